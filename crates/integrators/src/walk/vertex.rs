//! The vertex every path is built of (Veach 1997 §10.2; pbrt-v4 §16.3.1): where it is, how it
//! scatters, the throughput that reached it, and the area-measure densities with which it was
//! generated from either side — what bidirectional methods need to weight their strategies, and
//! what unidirectional ones read a subset of.

use crate::paths::PathClass;
use glam::Vec3;
use lightlab_core::{Ray, Rgb, TransportMode};
use lightlab_geometry::{NO_LIGHT, spawn_ray, spawn_ray_to, spawn_ray_to_point};
use lightlab_materials::{BsdfSample, SurfaceBsdf};
use lightlab_scene::{Light, Scene};

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Kind {
    /// A point on the lens (the eye for a pinhole).
    Camera,
    /// A light subpath's origin, or a point sampled on light `light`.
    Light { light: u32 },
    /// A surface hit.
    Surface,
}

/// One vertex of a path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathVertex {
    pub kind: Kind,
    pub p: Vec3,
    pub p_error: Vec3,
    /// Geometric normal (zero for point lights and the camera; the direction light travels for
    /// an emitter at infinity).
    pub ng: Vec3,
    /// Shading normal (= `ng` where there is no shading frame; zero where there is no surface).
    pub ns: Vec3,
    /// Unit direction back toward the previous vertex (ωo); zero at a subpath's origin.
    pub wo: Vec3,
    pub sb: Option<SurfaceBsdf>,
    /// Light id of an emissive surface hit, `NO_LIGHT` otherwise.
    pub emitter: u32,
    /// Shape of a surface hit (for the density with which light sampling finds an emitter).
    pub shape: u32,
    /// Throughput from the subpath's origin: We·Π f|cos|/p on the camera side, Le·Π f|cos|/p
    /// (flux) on the light side.
    pub beta: Rgb,
    /// Area density of this vertex as its subpath generated it (solid angle for a vertex at
    /// infinity).
    pub pdf_fwd: f32,
    /// Area density of this vertex had the other subpath generated it (set once the next vertex
    /// exists; bidirectional methods only).
    pub pdf_rev: f32,
    /// The walk left this vertex by a Dirac-delta lobe (mirror, smooth dielectric, plastic's
    /// coating) — per path, for a BSDF that mixes delta and non-delta lobes; before the walk
    /// samples here, whether every lobe is a delta. Whether the vertex can be connected to or
    /// merged at is the BSDF's business ([`PathVertex::connectible`]).
    pub delta: bool,
    /// An emitter at infinity (environment): `ng` is the direction its light travels.
    pub infinite: bool,
    /// Scattering vertices from the subpath's origin up to and including this one (0 at the
    /// origin).
    pub depth: u32,
    /// Their classes, origin first.
    pub class: PathClass,
    /// The instant of the path (within the shutter): every ray from this vertex is traced then.
    pub time: f32,
}

impl PathVertex {
    /// A vertex of `kind` at `p` at instant `time` with throughput `beta` and nothing else known.
    pub fn new(kind: Kind, p: Vec3, time: f32, beta: Rgb) -> PathVertex {
        PathVertex {
            kind,
            p,
            p_error: Vec3::ZERO,
            ng: Vec3::ZERO,
            ns: Vec3::ZERO,
            wo: Vec3::ZERO,
            sb: None,
            emitter: NO_LIGHT,
            shape: 0,
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            infinite: false,
            depth: 0,
            class: PathClass::EMPTY,
            time,
        }
    }

    /// The classes of the scattering vertices before this one as the walk left them (plastic's
    /// coating an `S` where it left by the coating, which `class` records only from the next
    /// vertex on): the class of a path that ends here on an emitter, or merges here.
    pub fn arrival_class(&self) -> PathClass {
        match self.kind {
            Kind::Surface => self.class.without_last(),
            // A light's origin has none; an escaped camera subpath's end records its arrival.
            Kind::Camera | Kind::Light { .. } => self.class,
        }
    }

    pub fn on_surface(&self) -> bool {
        self.ng != Vec3::ZERO && !self.infinite
    }

    /// The light this vertex emits as, if any.
    pub fn light(&self) -> Option<u32> {
        match self.kind {
            Kind::Light { light } => Some(light),
            Kind::Surface if self.emitter != NO_LIGHT => Some(self.emitter),
            _ => None,
        }
    }

    /// Whether a deterministic connection to this vertex can carry light (not through a delta
    /// BSDF, not to the origin of a light at infinity: an environment's or a directional light's
    /// direction is reached only by sampling it).
    pub fn connectible(&self) -> bool {
        match self.kind {
            Kind::Camera => true,
            Kind::Light { .. } => !self.infinite,
            Kind::Surface => self.sb.is_some_and(|sb| !sb.bsdf.is_delta()),
        }
    }

    /// f toward `next` for arrival from `prev` (surface vertices), in `mode`.
    pub fn f(&self, prev: &PathVertex, next: &PathVertex, mode: TransportMode) -> Rgb {
        match &self.sb {
            Some(sb) => {
                sb.eval(direction(self, prev), direction(self, next), mode)
                    .f
            }
            None => Rgb::BLACK,
        }
    }

    /// Radiance this vertex emits toward `to`.
    pub fn le(&self, scene: &Scene, to: &PathVertex) -> Rgb {
        // At infinity `ng` is exactly the direction the light travels (the difference of
        // positions would round it, as path tracing's escaped ray does not).
        let w = if self.infinite {
            self.ng
        } else {
            (to.p - self.p).normalize()
        };
        self.le_toward(scene, w)
    }

    /// Radiance this vertex emits in direction `w` (black unless it is on an emitter).
    #[inline]
    pub fn le_toward(&self, scene: &Scene, w: Vec3) -> Rgb {
        let Some(light) = self.light() else {
            return Rgb::BLACK;
        };
        match &scene.lights[light as usize] {
            &Light::Area {
                radiance,
                two_sided,
                ..
            } => Light::area_le(radiance, two_sided, self.ng, w),
            // Emitted toward the scene along w: it arrives from −w.
            l @ Light::Environment { .. } if self.infinite => l.environment_le(-w),
            _ => Rgb::BLACK,
        }
    }

    /// Converts a density `pdf` of the step from `self` to `next` into an area density at `next`:
    /// a solid-angle density times |cos θ_next| / d²; from a vertex at infinity, the area density
    /// of the ray's origin on the scene's disk times |cos θ_next|. A vertex at infinity keeps the
    /// solid-angle density.
    #[inline]
    pub fn convert_density(&self, pdf: f32, next: &PathVertex) -> f32 {
        if next.infinite {
            return pdf;
        }
        if self.infinite {
            return if next.on_surface() {
                pdf * next.ng.dot(self.ng).abs()
            } else {
                pdf
            };
        }
        let w = next.p - self.p;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let mut pdf = pdf / d2;
        if next.on_surface() {
            pdf *= next.ng.dot(w / d2.sqrt()).abs();
        }
        pdf
    }

    /// Area density at `next` of sampling the direction self → next, having arrived from `prev`.
    pub fn pdf(&self, scene: &Scene, prev: Option<&PathVertex>, next: &PathVertex) -> f32 {
        if matches!(self.kind, Kind::Light { .. }) {
            return self.pdf_light(scene, next);
        }
        let w_next = direction(self, next);
        let pdf_w = match self.kind {
            Kind::Camera => scene.camera.pdf_we_dir(self.p, w_next),
            _ => match (&self.sb, prev) {
                (Some(sb), Some(prev)) => sb.pdf(direction(self, prev), w_next),
                _ => 0.0,
            },
        };
        self.convert_density(pdf_w, next)
    }

    /// Area density at `v` of this emitter sending light toward `v` (pbrt-v4 `PdfLight`).
    pub fn pdf_light(&self, scene: &Scene, v: &PathVertex) -> f32 {
        let Some(light) = self.light() else {
            return 0.0;
        };
        let l = &scene.lights[light as usize];
        if self.infinite {
            // Rays from infinity start on a disk of the scene radius: area density 1/(πR²),
            // converted by the cosine at `v`.
            let (pdf_pos, _) = l.pdf_le(scene.shapes(), scene.radius, Vec3::ZERO, self.ng);
            return self.convert_density(pdf_pos, v);
        }
        let w = v.p - self.p;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let (_, pdf_dir) = l.pdf_le(scene.shapes(), scene.radius, self.ng, w / d2.sqrt());
        self.convert_density(pdf_dir, v)
    }

    /// Density of this vertex as the origin of a light subpath: light choice × area density
    /// (pbrt-v4 `PdfLightOrigin`); for an infinite light, the directional density.
    pub fn pdf_light_origin(&self, scene: &Scene) -> f32 {
        let Some(light) = self.light() else {
            return 0.0;
        };
        let pmf = scene.light_pmf(light);
        let (pdf_pos, pdf_dir) =
            scene.lights[light as usize].pdf_le(scene.shapes(), scene.radius, self.ng, self.ng);
        // At infinity `ng` is the direction the light travels in.
        pmf * if self.infinite { pdf_dir } else { pdf_pos }
    }

    /// The solid-angle densities of the step this vertex took into `s` and of the reverse step
    /// (from `s.wi` back toward `wo`), delta lobes written as [`delta_densities`] does.
    #[inline]
    pub fn step_densities(&self, s: &BsdfSample) -> (f32, f32) {
        if s.delta {
            delta_densities(s, self.wo, self.ns)
        } else {
            let rev = self.sb.as_ref().map_or(0.0, |sb| sb.pdf(s.wi, self.wo));
            (s.pdf, rev)
        }
    }
}

/// The densities a delta vertex stores for its two directions: the sampled `s.wi` (forward) and
/// the arrival direction `wo` (reverse, what the other subpath would sample), as the lobe's
/// selection probability P times η²·|cos θ| — η the refractive index of the direction's side
/// relative to the arrival side (`s.eta` for a refraction, 1 for a reflection), θ its angle to
/// the shading normal `ns`.
///
/// Why. A delta BSDF's direction density is P times a Dirac delta, and MIS compares strategies
/// that generate the vertex after it from either side, so the two deltas must be written in one
/// measure for their ratio to be defined. Refraction preserves the throughput measure
/// η² |cos θ| dω (étendue; Veach 1997 §5.2.2, Nicodemus 1963): a Dirac delta in that measure is the
/// same on both sides of the interface and cancels from every ratio, leaving P·η²|cos θ| per
/// direction. Their ratio is the solid-angle compression (η_i/η_t)² cos θ_i / cos θ_t that one
/// refraction brings into the path density; it cancels for a symmetric pair of interfaces
/// (entering and leaving a sphere) but not at one flat interface. Only each vertex's ratio enters
/// the weights, so the common scale (the arrival side's η) does not matter; the Fresnel selection
/// probability is the same from either side, so P serves both directions.
#[inline]
pub(crate) fn delta_densities(s: &BsdfSample, wo: Vec3, ns: Vec3) -> (f32, f32) {
    let eta2 = if s.transmission { s.eta * s.eta } else { 1.0 };
    (s.pdf * eta2 * s.wi.dot(ns).abs(), s.pdf * wo.dot(ns).abs())
}

/// Unit direction from `from` toward `to` (the reverse of its travel for a vertex at infinity).
#[inline]
pub(crate) fn direction(from: &PathVertex, to: &PathVertex) -> Vec3 {
    if to.infinite {
        -to.ng
    } else {
        (to.p - from.p).normalize()
    }
}

/// Whether nothing blocks the segment between `a` and `b` (offset off the surfaces they lie on).
#[inline]
pub(crate) fn unoccluded(scene: &Scene, a: &PathVertex, b: &PathVertex) -> bool {
    debug_assert_eq!(
        a.time, b.time,
        "a connection joins two paths of one instant"
    );
    let ray = if b.infinite {
        let mut r = spawn_ray(a.p, a.p_error, a.ng, -b.ng);
        r.t_max = f32::INFINITY;
        r
    } else if a.on_surface() && b.on_surface() {
        spawn_ray_to(a.p, a.p_error, a.ng, b.p, b.p_error, b.ng)
    } else if a.on_surface() {
        spawn_ray_to_point(a.p, a.p_error, a.ng, b.p)
    } else if b.on_surface() {
        spawn_ray_to_point(b.p, b.p_error, b.ng, a.p)
    } else {
        Ray::segment(a.p, b.p - a.p, 1.0 - 1e-4)
    };
    !scene.occluded(&ray.at_time(a.time))
}

/// G(a, b) = |cos θ_a| |cos θ_b| / d² with shading normals where there are any.
pub(crate) fn geometry_term(a: &PathVertex, b: &PathVertex) -> f32 {
    if b.infinite {
        return if a.ns != Vec3::ZERO {
            a.ns.dot(b.ng).abs()
        } else {
            1.0
        };
    }
    let d = b.p - a.p;
    let d2 = d.length_squared();
    if !(d2 > 0.0) {
        return 0.0;
    }
    let w = d / d2.sqrt();
    let cos = |n: Vec3| if n != Vec3::ZERO { n.dot(w).abs() } else { 1.0 };
    cos(a.ns) * cos(b.ns) / d2
}
