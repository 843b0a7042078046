//! Bidirectional path tracing (Veach & Guibas 1994; Lafortune & Willems 1993; Veach 1997 ch. 10)
//! with every (s, t) strategy combined by multiple importance sampling (Veach 1997 ch. 9).
//!
//! Each pixel sample traces a camera subpath z₀…z_{t−1} and a light subpath y₀…y_{s−1} and forms
//! every full path y₀…y_{s−1} z_{t−1}…z₀ with s + t − 2 scattering vertices within the bounce
//! limits: s = 0 (the camera path hits an emitter), s = 1 (a point sampled on a light, next-event
//! estimation), t = 1 (a light vertex connected to a point on the lens and splatted into the pixel it
//! lands on, as in light tracing — for s = 1 the light's own point, an emitter seen directly) and
//! s, t ≥ 2 (a deterministic connection of the two subpaths). An emitter seen directly (s + t = 2)
//! thus has two strategies, the camera ray hitting it (s = 0) and its point splatted through the lens
//! (s = 1): the second is what renders an emitter smaller than a pixel's footprint.
//!
//! MIS: the balance heuristic, computed by Veach's walk over ratios of the area-measure densities
//! with which neighbouring strategies would have produced the same path (Veach 1997 §10.2;
//! pbrt-v4 §16.3.4): each vertex stores `pdf_fwd` (density of its generation along its own subpath)
//! and `pdf_rev` (density of its generation from the other side), and the weight of (s, t) is
//! 1 / Σᵢ (pᵢ / p_s). Strategies that cannot produce a path (a delta vertex at a connection) are left
//! out of the sum. At a specular vertex the two directions' densities are the lobe's selection
//! probability times η²|cos θ| (`delta_densities`: the Dirac delta written in the throughput
//! measure, which refraction preserves, cancels from the ratios), unlike pbrt's
//! zero-then-remap-to-one, which loses the cos/d² conversions beside specular chains and the
//! solid-angle compression of a refraction.
//!
//! Research views: `strategy_layers` writes every strategy as a layer, weighted and unweighted;
//! `outliers` logs large contributions with their provenance, and [`Bdpt::replay`] recomputes any
//! pixel sample from (seed, pixel, sample index). Russian roulette decides how long subpaths are, not the densities in the weights,
//! so the weights of all strategies of a path still sum to one.
//!
//! Sample dimensions per pixel sample: pixel (2), lens (2), then the camera subpath (per vertex:
//! lobe 1, direction 2, roulette 1), then the light subpath (light 1, position 2, direction 2, per
//! vertex lobe 1, direction 2, roulette 1) and the connection samples (per camera vertex: light 1,
//! light point 2, lens 2). Light subpath values come from a second stream keyed by the pixel sample,
//! so the camera dimensions keep the layout stratified samplers expect.

use crate::config::{ConfigError, Validate, check_common, default_rr, invalid};
use crate::film::Film;
use crate::passes::{PassSpec, Schedule, run_passes};
use crate::paths::{Layers, PathClass, Router};
use crate::render::{Counters, PixelVariance};
use crate::roulette::survives;
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::{Vec2, Vec3};
use lightlab_core::{Progress, Ray, Rgb, TransportMode};
use lightlab_geometry::{NO_LIGHT, spawn_ray, spawn_ray_to, spawn_ray_to_point};
use lightlab_materials::SurfaceBsdf;
use lightlab_samplers::{Independent, Sampler, SamplerConfig, SamplerVisitor};
use lightlab_scene::{Light, Scene};
use serde::{Deserialize, Serialize};

/// Settings of bidirectional path tracing: `Bdpt(max_bounces: 8, mis: Balance)`; every field
/// optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, rename = "Bdpt")]
pub struct BdptConfig {
    /// Largest number of scattering vertices of a full path; `None` for no limit. Default `None`.
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    pub min_bounces: u32,
    /// Russian roulette on both subpaths from this many vertices on; `None` turns it off.
    /// Default `Some(3)`.
    pub russian_roulette: Option<u32>,
    /// Sampler of the camera subpaths (the light subpaths use independent samples). Default
    /// `Independent`.
    pub sampler: SamplerConfig,
    /// Strategy weights: `Balance`, `Power`, `Uniform` or `Only(s: S, t: T)`. Default `Balance`.
    pub mis: Mis,
    /// Also write every strategy (s, t) as layers `s{s}t{t}` (MIS-weighted; they sum to the image)
    /// and `s{s}t{t}.unweighted` (the strategy's own estimate of its paths). Needs `max_bounces`.
    /// Default false.
    pub strategy_layers: bool,
    /// Log every contribution larger (in its largest channel) than this multiple of its pixel's
    /// mean, with its provenance (pixel, sample index, strategy, path class, densities, MIS
    /// weight), for replay with `lightlab replay`. Non-finite contributions are always logged.
    /// Default `None` (only non-finite ones).
    pub outliers: Option<f32>,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    pub layers: Layers,
}

impl Default for BdptConfig {
    fn default() -> Self {
        BdptConfig {
            max_bounces: None,
            min_bounces: 0,
            russian_roulette: default_rr(),
            sampler: SamplerConfig::Independent,
            mis: Mis::Balance,
            strategy_layers: false,
            outliers: None,
            paths: None,
            layers: Layers::Off,
        }
    }
}

impl Validate for BdptConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_common(
            self.max_bounces,
            self.min_bounces,
            self.russian_roulette,
            self.paths.as_deref(),
            &self.layers,
        )?;
        if let Mis::Only { s, t } = self.mis
            && t == 0
        {
            return invalid(format!(
                "Only(s: {s}, t: 0) is not a strategy: paths must reach the camera, so t ≥ 1"
            ));
        }
        if let Some(f) = self.outliers
            && !(f > 1.0 && f.is_finite())
        {
            return invalid(format!(
                "outliers is a multiple of the pixel's mean and must be finite and > 1, got {f}"
            ));
        }
        if self.strategy_layers && self.max_bounces.is_none() {
            return invalid(
                "strategy_layers needs max_bounces (it bounds the number of strategies)",
            );
        }
        Ok(())
    }
}

/// How bidirectional path tracing weights its strategies (Veach 1997, ch. 9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mis {
    /// wᵢ = pᵢ / Σⱼ pⱼ (Veach's balance heuristic).
    #[default]
    Balance,
    /// wᵢ = pᵢ² / Σⱼ pⱼ² (the power heuristic with β = 2).
    Power,
    /// wᵢ = 1 / (number of strategies that can produce the path): unweighted averaging.
    Uniform,
    /// No MIS: only strategy (s, t), with weight 1 — the paths of s + t − 2 bounces that this one
    /// strategy samples, for looking at one technique alone.
    Only { s: u32, t: u32 },
}

impl Mis {
    /// Whether strategy (s, t) is left out entirely.
    pub fn excludes(&self, s: usize, t: usize) -> bool {
        matches!(*self, Mis::Only { s: os, t: ot } if (os as usize, ot as usize) != (s, t))
    }
}

/// Technique numbers for the non-finite counters.
const CONNECTION: usize = 0;
const SPLAT: usize = 1;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Camera,
    /// A light's origin vertex, or a point sampled on light `light`.
    Light {
        light: u32,
    },
    Surface,
}

/// One vertex of a subpath (pbrt-v4 §16.3.1).
#[derive(Clone, Copy, Debug)]
struct Vertex {
    kind: Kind,
    p: Vec3,
    p_error: Vec3,
    /// Geometric normal (zero for point lights and the camera; the direction of travel for an
    /// infinite light).
    ng: Vec3,
    /// Shading normal (= ng where there is no shading frame).
    ns: Vec3,
    sb: Option<SurfaceBsdf>,
    /// Light id of an emissive surface hit, `NO_LIGHT` otherwise.
    emitter: u32,
    beta: Rgb,
    pdf_fwd: f32,
    pdf_rev: f32,
    delta: bool,
    /// An emitter at infinity (environment): `ng` is the direction the light travels.
    infinite: bool,
    /// Scattering vertices of the subpath from its origin up to and including this one.
    class: PathClass,
}

impl Vertex {
    fn new(kind: Kind, p: Vec3, beta: Rgb) -> Vertex {
        Vertex {
            kind,
            p,
            p_error: Vec3::ZERO,
            ng: Vec3::ZERO,
            ns: Vec3::ZERO,
            sb: None,
            emitter: NO_LIGHT,
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            infinite: false,
            class: PathClass::EMPTY,
        }
    }

    fn on_surface(&self) -> bool {
        self.ng != Vec3::ZERO && !self.infinite
    }

    /// The light this vertex emits as, if any.
    fn light(&self) -> Option<u32> {
        match self.kind {
            Kind::Light { light } => Some(light),
            Kind::Surface if self.emitter != NO_LIGHT => Some(self.emitter),
            _ => None,
        }
    }

    fn connectible(&self, scene: &Scene) -> bool {
        match self.kind {
            Kind::Camera => true,
            Kind::Light { light } => {
                !self.infinite || !matches!(scene.lights[light as usize], Light::Environment { .. })
            }
            Kind::Surface => !self.delta,
        }
    }

    /// f toward `next` for arrival from `prev` (surface vertices), in `mode`.
    fn f(&self, prev: &Vertex, next: &Vertex, mode: TransportMode) -> Rgb {
        match &self.sb {
            Some(sb) => {
                sb.eval(
                    (prev.p - self.p).normalize(),
                    (next.p - self.p).normalize(),
                    mode,
                )
                .f
            }
            None => Rgb::BLACK,
        }
    }

    /// Radiance this vertex emits toward `to`.
    fn le(&self, scene: &Scene, to: &Vertex) -> Rgb {
        let Some(light) = self.light() else {
            return Rgb::BLACK;
        };
        match scene.lights[light as usize] {
            Light::Area {
                radiance,
                two_sided,
                ..
            } => Light::area_le(radiance, two_sided, self.ng, (to.p - self.p).normalize()),
            Light::Environment { radiance } if self.infinite => radiance,
            _ => Rgb::BLACK,
        }
    }

    /// Converts a solid-angle density of the direction from `self` to `next` into an area density at
    /// `next` (solid angle kept for an infinite `next`).
    fn convert_density(&self, pdf_w: f32, next: &Vertex) -> f32 {
        if next.infinite {
            return pdf_w;
        }
        let w = next.p - self.p;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let mut pdf = pdf_w / d2;
        if next.on_surface() {
            pdf *= next.ng.dot(w / d2.sqrt()).abs();
        }
        pdf
    }

    /// Area density at `next` of sampling the direction self → next, having arrived from `prev`.
    fn pdf(&self, scene: &Scene, prev: Option<&Vertex>, next: &Vertex) -> f32 {
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
    fn pdf_light(&self, scene: &Scene, v: &Vertex) -> f32 {
        let Some(light) = self.light() else {
            return 0.0;
        };
        let l = &scene.lights[light as usize];
        if self.infinite {
            // Rays from infinity start on a disk of the scene radius: area density 1/(πR²),
            // converted by the cosine at `v`.
            let (pdf_pos, _) = l.pdf_le(scene.shapes(), scene.radius, Vec3::ZERO, self.ng);
            return if v.on_surface() {
                pdf_pos * v.ng.dot(self.ng).abs()
            } else {
                pdf_pos
            };
        }
        let w = v.p - self.p;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let w = w / d2.sqrt();
        let (_, pdf_dir) = l.pdf_le(scene.shapes(), scene.radius, self.ng, w);
        let mut pdf = pdf_dir / d2;
        if v.on_surface() {
            pdf *= v.ng.dot(w).abs();
        }
        pdf
    }

    /// Density of this vertex as the origin of a light subpath: light choice × area density
    /// (pbrt-v4 `PdfLightOrigin`); for an infinite light, the directional density.
    fn pdf_light_origin(&self, scene: &Scene) -> f32 {
        let Some(light) = self.light() else {
            return 0.0;
        };
        let pmf = scene.light_pmf(light);
        if self.infinite {
            return pmf * lightlab_core::INV_4PI;
        }
        let (pdf_pos, _) =
            scene.lights[light as usize].pdf_le(scene.shapes(), scene.radius, self.ng, self.ng);
        pmf * pdf_pos
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
fn delta_densities(s: &lightlab_materials::BsdfSample, wo: Vec3, ns: Vec3) -> (f32, f32) {
    let eta2 = if s.transmission { s.eta * s.eta } else { 1.0 };
    (s.pdf * eta2 * s.wi.dot(ns).abs(), s.pdf * wo.dot(ns).abs())
}

fn direction(from: &Vertex, to: &Vertex) -> Vec3 {
    if to.infinite {
        -to.ng
    } else {
        (to.p - from.p).normalize()
    }
}

pub struct Bdpt {
    config: BdptConfig,
    router: Router,
    /// With `strategy_layers`: every strategy (s, t), in layer order.
    strategies: Vec<(usize, usize)>,
}

impl Bdpt {
    /// BDPT with `config` (checked).
    pub fn new(config: BdptConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let router = Router::new(config.paths.as_deref(), &config.layers, config.max_bounces)
            .map_err(ConfigError::Invalid)?;
        let strategies = match (config.strategy_layers, config.max_bounces) {
            (true, Some(max)) => (2..=max as usize + 2)
                .flat_map(|n| (0..n).map(move |s| (s, n - s)))
                .filter(|&st| st.1 >= 1)
                .collect(),
            _ => Vec::new(),
        };
        Ok(Bdpt {
            config,
            router,
            strategies,
        })
    }

    /// Slot of the weighted layer of strategy (s, t) (the unweighted one follows it), counted from
    /// the first strategy layer.
    fn strategy_slot(&self, s: usize, t: usize) -> Option<usize> {
        self.strategies
            .iter()
            .position(|&x| x == (s, t))
            .map(|i| 2 * i)
    }

    /// Extends `path` by a random walk from `ray` (pbrt-v4 `RandomWalk`), at most `max_vertices`
    /// new vertices. `pdf_w` is the solid-angle density of `ray`'s direction.
    #[allow(clippy::too_many_arguments)]
    fn random_walk<S: Sampler>(
        &self,
        scene: &Scene,
        mut ray: Ray,
        mut beta: Rgb,
        pdf_w: f32,
        max_vertices: u32,
        mode: TransportMode,
        sampler: &mut S,
        path: &mut Vec<Vertex>,
        counters: &mut Counters,
    ) {
        let mut pdf_fwd_w = pdf_w;
        let mut added = 0u32;
        // Russian roulette scores the throughput relative to the walk's start — light subpaths
        // start with the emitted flux, in units of power, which no absolute threshold can judge —
        // and, on camera paths, with the η² of refractions divided out (pbrt-v4 §13.4.4).
        let beta_start = beta.max_component();
        let mut eta_scale = 1.0f32;
        while added < max_vertices {
            counters.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                // Camera paths that escape end on the environment, if there is one.
                if mode == TransportMode::Radiance
                    && let Some(env) = scene.environment_light()
                {
                    let mut v = Vertex::new(Kind::Light { light: env }, ray.o + ray.d, beta);
                    v.class = path.last().expect("a walk starts from a vertex").class;
                    v.infinite = true;
                    v.ng = ray.d.normalize();
                    v.pdf_fwd = pdf_fwd_w;
                    path.push(v);
                }
                break;
            };
            let bsdf = scene.materials[hit.material as usize];
            let sb = SurfaceBsdf::new(hit.ns, hit.dpdu, hit.ng, bsdf);
            let mut v = Vertex::new(Kind::Surface, hit.p, beta);
            v.p_error = hit.p_error;
            v.ng = hit.ng;
            v.ns = sb.frame.n;
            v.sb = Some(sb);
            v.emitter = hit.light;
            let prev = *path.last().expect("a walk starts from a vertex");
            v.class = prev.class.push(bsdf.lobe_class());
            v.pdf_fwd = prev.convert_density(pdf_fwd_w, &v);
            path.push(v);
            added += 1;
            let (u_lobe, u_dir, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
            if added >= max_vertices {
                break;
            }
            let wo = -ray.d.normalize();
            let Some(s) = sb.sample(wo, u_lobe, u_dir, mode) else {
                break;
            };
            if s.weight.is_black() {
                break;
            }
            beta *= s.weight;
            let mut pdf_rev_w = sb.pdf(s.wi, wo);
            pdf_fwd_w = s.pdf;
            let n = path.len();
            if s.delta {
                path[n - 1].delta = true;
                (pdf_fwd_w, pdf_rev_w) = delta_densities(&s, wo, sb.frame.n);
            }
            let this = path[n - 1];
            path[n - 2].pdf_rev = this.convert_density(pdf_rev_w, &path[n - 2]);
            if s.transmission && mode == TransportMode::Radiance {
                eta_scale *= s.eta * s.eta;
            }
            let score = beta.max_component() / beta_start * eta_scale;
            if !survives(self.config.russian_roulette, added, score, u_rr, &mut beta) {
                break;
            }
            ray = spawn_ray(hit.p, hit.p_error, hit.ng, s.wi);
        }
    }

    /// The camera subpath through raster position `film`.
    fn camera_subpath<S: Sampler>(
        &self,
        scene: &Scene,
        film: Vec2,
        sampler: &mut S,
        max_vertices: u32,
        path: &mut Vec<Vertex>,
        counters: &mut Counters,
    ) {
        let ray = scene.camera.generate_ray(film, sampler.next_2d());
        path.push(Vertex::new(Kind::Camera, ray.o, Rgb::WHITE));
        let pdf_dir = scene.camera.pdf_we_dir(ray.o, ray.d);
        self.random_walk(
            scene,
            ray,
            Rgb::WHITE,
            pdf_dir,
            max_vertices - 1,
            TransportMode::Radiance,
            sampler,
            path,
            counters,
        );
    }

    /// The light subpath (pbrt-v4 `GenerateLightSubpath`).
    fn light_subpath<S: Sampler>(
        &self,
        scene: &Scene,
        sampler: &mut S,
        max_vertices: u32,
        path: &mut Vec<Vertex>,
        counters: &mut Counters,
    ) {
        let (u_light, u_pos, u_dir) = (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
        if max_vertices == 0 {
            return;
        }
        let Some((light, pmf)) = scene.sample_light(u_light) else {
            return;
        };
        let l = &scene.lights[light as usize];
        let Some(em) = l.sample_le(scene.shapes(), scene.center, scene.radius, u_pos, u_dir) else {
            return;
        };
        let infinite = matches!(l, Light::Environment { .. });
        let mut v = Vertex::new(Kind::Light { light }, em.p, em.le / (pmf * em.pdf_pos));
        v.p_error = em.p_error;
        if infinite {
            v.infinite = true;
            v.ng = em.dir;
            // The origin's density is directional for an infinite light (pbrt-v4 §16.3.2).
            v.pdf_fwd = pmf * lightlab_core::INV_4PI;
        } else {
            v.pdf_fwd = pmf * em.pdf_pos;
            if !em.delta_pos {
                v.ng = em.n;
                v.ns = em.n;
            }
        }
        path.push(v);
        let cos = if em.delta_pos || infinite {
            1.0
        } else {
            em.n.dot(em.dir).abs()
        };
        let beta = em.le * (cos / (pmf * em.pdf_pos * em.pdf_dir));
        let ray = if em.delta_pos || infinite {
            Ray::new(em.p, em.dir)
        } else {
            spawn_ray(em.p, em.p_error, em.n, em.dir)
        };
        self.random_walk(
            scene,
            ray,
            beta,
            em.pdf_dir,
            max_vertices - 1,
            TransportMode::Importance,
            sampler,
            path,
            counters,
        );
        if infinite && path.len() > 1 {
            // A ray from infinity starts on the disk: its first hit has the disk's area density.
            let first = &mut path[1];
            first.pdf_fwd = em.pdf_pos
                * if first.on_surface() {
                    first.ng.dot(em.dir).abs()
                } else {
                    1.0
                };
        }
    }

    fn visible(scene: &Scene, a: &Vertex, b: &Vertex) -> bool {
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
        !scene.occluded(&ray)
    }

    /// G(a, b) = |cos θ_a| |cos θ_b| / d² with shading normals where there are any.
    fn g(a: &Vertex, b: &Vertex) -> f32 {
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
        let ca = if a.ns != Vec3::ZERO {
            a.ns.dot(w).abs()
        } else {
            1.0
        };
        let cb = if b.ns != Vec3::ZERO {
            b.ns.dot(w).abs()
        } else {
            1.0
        };
        ca * cb / d2
    }

    /// The MIS weight of strategy (s, t) (pbrt-v4 `MISWeight`, balance heuristic). `sampled` replaces
    /// the endpoint that strategy sampled anew (the light point for s = 1, the lens point for t = 1).
    fn mis_weight(
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        sampled: Option<Vertex>,
        s: usize,
        t: usize,
        heuristic: Mis,
    ) -> f32 {
        if matches!(heuristic, Mis::Only { .. }) {
            return 1.0;
        }
        let mut lv: Vec<Vertex> = light[..s].to_vec();
        let mut cv: Vec<Vertex> = camera[..t].to_vec();
        // t = 1 samples the lens point (for s = t = 1 too, whose light vertex is the subpath's
        // origin); s = 1 with t ≥ 2 samples a point on a light.
        if t == 1 {
            cv[0] = sampled.expect("t = 1 samples the camera vertex");
        } else if s == 1 {
            lv[0] = sampled.expect("s = 1 samples the light vertex");
        }
        // The connection vertices are never delta for the connection itself.
        if t > 0 {
            cv[t - 1].delta = false;
        }
        if s > 0 {
            lv[s - 1].delta = false;
        }
        // Densities of the connection vertices and their predecessors from the other side.
        if t > 0 {
            let pt = cv[t - 1];
            cv[t - 1].pdf_rev = if s > 0 {
                let qs_minus = if s > 1 { Some(lv[s - 2]) } else { None };
                lv[s - 1].pdf(scene, qs_minus.as_ref(), &pt)
            } else {
                pt.pdf_light_origin(scene)
            };
        }
        if t > 1 {
            let (pt, pt_minus) = (cv[t - 1], cv[t - 2]);
            cv[t - 2].pdf_rev = if s > 0 {
                pt.pdf(scene, Some(&lv[s - 1]), &pt_minus)
            } else {
                pt.pdf_light(scene, &pt_minus)
            };
        }
        if s > 0 {
            let qs = lv[s - 1];
            let pt_minus = if t > 1 { Some(cv[t - 2]) } else { None };
            lv[s - 1].pdf_rev = cv[t - 1].pdf(scene, pt_minus.as_ref(), &qs);
        }
        if s > 1 {
            let (qs, qs_minus) = (lv[s - 1], lv[s - 2]);
            lv[s - 2].pdf_rev = qs.pdf(scene, Some(&cv[t - 1]), &qs_minus);
        }
        let remap = |p: f32| if p != 0.0 { p } else { 1.0 };
        // Each other strategy i enters with rᵢ = pᵢ / p_s: the balance heuristic sums rᵢ, the power
        // heuristic (β = 2) rᵢ², uniform weights count the strategies (Veach 1997, §9.2).
        let term = |r: f32| match heuristic {
            Mis::Balance => r,
            Mis::Power => r * r,
            Mis::Uniform => 1.0,
            Mis::Only { .. } => 0.0,
        };
        let mut sum = 0.0f32;
        let mut ri = 1.0f32;
        for i in (1..t).rev() {
            ri *= remap(cv[i].pdf_rev) / remap(cv[i].pdf_fwd);
            if !cv[i].delta && !cv[i - 1].delta {
                sum += term(ri);
            }
        }
        ri = 1.0;
        for i in (0..s).rev() {
            ri *= remap(lv[i].pdf_rev) / remap(lv[i].pdf_fwd);
            let delta_before = if i > 0 {
                lv[i - 1].delta
            } else {
                lv[0]
                    .light()
                    .is_some_and(|l| scene.lights[l as usize].is_delta())
            };
            if !lv[i].delta && !delta_before {
                sum += term(ri);
            }
        }
        1.0 / (1.0 + sum)
    }

    /// Unweighted contribution of strategy (s, t), its MIS weight, and where it goes: the pixel
    /// (`None`) or, for t = 1, a splat position.
    #[allow(clippy::too_many_arguments)]
    fn connect(
        &self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
        u_light: f32,
        u_point: Vec2,
        u_lens: Vec2,
        counters: &mut Counters,
    ) -> Option<(Rgb, f32, Option<Vec2>)> {
        // An escaped camera path can only be completed by s = 0.
        if t > 1 && s != 0 && camera[t - 1].infinite {
            return None;
        }
        let mut sampled = None;
        let mut raster = None;
        let l = if s == 0 {
            let pt = &camera[t - 1];
            pt.light()?;
            pt.beta * pt.le(scene, &camera[t - 2])
        } else if t == 1 {
            let qs = &light[s - 1];
            if !qs.connectible(scene) || qs.infinite {
                return None;
            }
            let cs = scene.camera.sample_wi(qs.p, u_lens)?;
            if !(cs.pdf_w > 0.0) {
                return None;
            }
            let v = Vertex::new(Kind::Camera, cs.p_lens, Rgb::splat(cs.we / cs.pdf_w));
            raster = Some(cs.raster);
            let value = if s == 1 {
                // s = t = 1: the point on the light seen directly through the lens (light
                // tracing's emission connection); a point or spot light has no area to be seen.
                if !qs.on_surface() || !(qs.pdf_fwd > 0.0) {
                    return None;
                }
                qs.le(scene, &v) / qs.pdf_fwd
            } else {
                qs.beta * qs.f(&light[s - 2], &v, TransportMode::Importance)
            };
            let cos = qs.ns.dot(cs.wi).abs();
            let l = value * v.beta * cos;
            sampled = Some(v);
            if l.is_black() {
                return None;
            }
            counters.rays += 1;
            if !Self::visible(scene, qs, &v) {
                return None;
            }
            l
        } else if s == 1 {
            let pt = &camera[t - 1];
            if !pt.connectible(scene) {
                return None;
            }
            let (light_index, pmf) = scene.sample_light(u_light)?;
            let lt = &scene.lights[light_index as usize];
            let ls = lt.sample_li(scene.shapes(), pt.p, u_point)?;
            if !(ls.pdf_w > 0.0) || ls.li.is_black() {
                return None;
            }
            let mut v = Vertex::new(
                Kind::Light { light: light_index },
                ls.p,
                ls.li / (ls.pdf_w * pmf),
            );
            v.p_error = ls.p_error;
            if ls.infinite {
                v.infinite = true;
                v.ng = -ls.wi;
            } else if !ls.delta {
                v.ng = ls.n;
                v.ns = ls.n;
            }
            v.pdf_fwd = v.pdf_light_origin(scene);
            let f = pt.f(&camera[t - 2], &v, TransportMode::Radiance);
            let l = pt.beta * f * v.beta * pt.ns.dot(ls.wi).abs();
            sampled = Some(v);
            if l.is_black() {
                return None;
            }
            counters.rays += 1;
            if !Self::visible(scene, pt, &v) {
                return None;
            }
            l
        } else {
            let (qs, pt) = (&light[s - 1], &camera[t - 1]);
            if !qs.connectible(scene) || !pt.connectible(scene) || qs.infinite {
                return None;
            }
            // s ≥ 2: qs is a surface vertex.
            let fq = qs.f(&light[s - 2], pt, TransportMode::Importance);
            let l = qs.beta * fq * pt.f(&camera[t - 2], qs, TransportMode::Radiance) * pt.beta;
            if l.is_black() {
                return None;
            }
            let l = l * Self::g(qs, pt);
            if l.is_black() {
                return None;
            }
            counters.rays += 1;
            if !Self::visible(scene, qs, pt) {
                return None;
            }
            l
        };
        let w = Self::mis_weight(scene, light, camera, sampled, s, t, self.config.mis);
        Some((l, w, raster))
    }
}

/// Seed offset of the light subpaths' random-number stream.
const LIGHT_STREAM: u64 = 0x6c69_6768_7470_6174;

/// Pixel samples before which no contribution is called an outlier (the running mean is too
/// uncertain before).
const OUTLIER_MIN_SAMPLES: u64 = 8;

/// A logged contribution: where it came from (pixel, sample index: with the seed, enough to
/// replay it), which strategy and path, its value and MIS weight, and the area-measure densities
/// of the full path's vertices y₀ … y_{s−1} z_{t−1} … z₀ along the light and camera subpaths.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Outlier {
    pub pixel: [u32; 2],
    pub sample: u64,
    pub s: u32,
    pub t: u32,
    pub class: String,
    /// Weighted contribution (what the image receives).
    pub value: [f32; 3],
    pub unweighted: [f32; 3],
    pub mis_weight: f32,
    /// Raster position of a t = 1 splat.
    pub raster: Option<[f32; 2]>,
    /// The pixel's running mean before this sample.
    pub pixel_mean: [f64; 3],
    pub pdf_fwd: Vec<f32>,
    pub pdf_rev: Vec<f32>,
}

impl Outlier {
    fn new(
        pixel: (u32, u32),
        sample: u64,
        c: &Contribution,
        pixel_mean: [f64; 3],
        light: &[Vertex],
        camera: &[Vertex],
    ) -> Outlier {
        let path = light.iter().chain(camera.iter().rev());
        let v = c.unweighted * c.weight;
        Outlier {
            pixel: [pixel.0, pixel.1],
            sample,
            s: c.s as u32,
            t: c.t as u32,
            class: joined_class(light, camera, c.s, c.t).to_heckbert(),
            value: [v.r, v.g, v.b],
            unweighted: [c.unweighted.r, c.unweighted.g, c.unweighted.b],
            mis_weight: c.weight,
            raster: c.raster.map(|r| [r.x, r.y]),
            pixel_mean,
            pdf_fwd: path.clone().map(|v| v.pdf_fwd).collect(),
            pdf_rev: path.map(|v| v.pdf_rev).collect(),
        }
    }
}

/// A splat, and the pixel sample and strategy it came from, to replay it if it turns out an
/// outlier.
#[derive(Clone, Copy, Debug)]
struct SplatSource {
    /// The pixel it lands in, and its value.
    target: u32,
    value: Rgb,
    pixel: (u32, u32),
    sample: u64,
    s: u16,
    t: u16,
}

/// The class of the path strategy (s, t) joins, light first (for s = 0 the last camera vertex is
/// the emitter, not a scattering vertex).
fn joined_class(light: &[Vertex], camera: &[Vertex], s: usize, t: usize) -> PathClass {
    match s {
        0 if t >= 2 => camera[t - 2].class.reversed(),
        0 => PathClass::EMPTY,
        _ => light[s - 1].class.then(camera[t - 1].class.reversed()),
    }
}

/// One strategy's contribution to one pixel sample.
#[derive(Clone, Copy, Debug)]
pub struct Contribution {
    pub s: usize,
    pub t: usize,
    /// Its layer (see `Router::route`).
    pub layer: usize,
    /// The strategy's own estimate, before the MIS weight.
    pub unweighted: Rgb,
    pub weight: f32,
    /// Where a t = 1 contribution lands; `None` for the sample's own pixel.
    pub raster: Option<Vec2>,
}

impl Bdpt {
    /// Traces pixel sample `index` of `pixel` and calls `visit(contribution, light subpath, camera
    /// subpath)` for every strategy that contributes, in the order the renderer adds them. Rendering
    /// and [`Bdpt::replay`] both go through here, so a replay reproduces a render's sample exactly.
    #[allow(clippy::too_many_arguments)]
    fn pixel_sample<S: Sampler>(
        &self,
        scene: &Scene,
        seed: u64,
        (x, y): (u32, u32),
        index: u64,
        sampler: &mut S,
        light_sampler: &mut Independent,
        (camera, light): (&mut Vec<Vertex>, &mut Vec<Vertex>),
        counters: &mut Counters,
        mut visit: impl FnMut(&Contribution, &[Vertex], &[Vertex]),
    ) {
        let cfg = &self.config;
        let max_bounces = cfg.max_bounces.unwrap_or(u32::MAX - 2);
        let pixel = y as u64 * scene.camera.width as u64 + x as u64;
        sampler.start_pixel_sample(seed, pixel, index);
        light_sampler.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, index);
        let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
        camera.clear();
        light.clear();
        self.camera_subpath(
            scene,
            film,
            sampler,
            max_bounces.saturating_add(2),
            camera,
            counters,
        );
        self.light_subpath(
            scene,
            light_sampler,
            max_bounces.saturating_add(1),
            light,
            counters,
        );
        for t in 1..=camera.len() {
            let (u_light, u_point, u_lens) = (
                light_sampler.next_1d(),
                light_sampler.next_2d(),
                light_sampler.next_2d(),
            );
            for s in 0..=light.len() {
                let depth = (s + t) as i64 - 2;
                if depth < cfg.min_bounces as i64
                    || depth > max_bounces as i64
                    || cfg.mis.excludes(s, t)
                {
                    continue;
                }
                // Only a router that filters or splits needs the joined path's class (outliers
                // rebuild it).
                let class = if self.router.is_trivial() {
                    PathClass::EMPTY
                } else {
                    joined_class(light, camera, s, t)
                };
                let Some(layer) = self.router.route(&class) else {
                    continue;
                };
                let Some((unweighted, weight, raster)) = self.connect(
                    scene, light, camera, s, t, u_light, u_point, u_lens, counters,
                ) else {
                    continue;
                };
                let c = Contribution {
                    s,
                    t,
                    layer,
                    unweighted,
                    weight,
                    raster,
                };
                visit(&c, &light[..s.min(light.len())], &camera[..t]);
            }
        }
    }

    /// The splats larger (largest channel) than `factor` times the final mean of the pixel they
    /// land in, replayed for their provenance.
    fn splat_outliers(
        &self,
        scene: &Scene,
        seed: u64,
        spp: u32,
        items: &[WorkItem],
        film: &Film,
        factor: f32,
    ) -> Vec<Outlier> {
        let mut out = Vec::new();
        for r in items {
            for src in &r.splat_sources {
                let value = src.value;
                let mean = film.mean(src.target as usize);
                let scale = mean[0].max(mean[1]).max(mean[2]);
                if (value.max_component() as f64) <= factor as f64 * scale.max(f64::MIN_POSITIVE) {
                    continue;
                }
                let replayed = self.replay(scene, seed, spp, src.pixel, src.sample);
                if let Some(mut o) = replayed.into_iter().find(|o| {
                    (o.s, o.t) == (src.s as u32, src.t as u32)
                        && o.value == [value.r, value.g, value.b]
                }) {
                    o.pixel_mean = mean;
                    out.push(o);
                }
            }
        }
        out
    }

    /// Every contribution of pixel sample `index` of `pixel` (x, y), recomputed from (seed, pixel,
    /// sample index) alone: the deterministic replay of a logged outlier.
    /// `spp` is the render's samples per pixel (stratified samplers depend on it).
    pub fn replay(
        &self,
        scene: &Scene,
        seed: u64,
        spp: u32,
        pixel: (u32, u32),
        index: u64,
    ) -> Vec<Outlier> {
        struct Replay<'a> {
            bdpt: &'a Bdpt,
            scene: &'a Scene,
            seed: u64,
            pixel: (u32, u32),
            index: u64,
        }
        impl SamplerVisitor for Replay<'_> {
            type Output = Vec<Outlier>;
            fn visit<S: Sampler + Clone + Send + Sync + 'static>(
                self,
                mut sampler: S,
            ) -> Vec<Outlier> {
                let mut out = Vec::new();
                let (mut camera, mut light) = (Vec::new(), Vec::new());
                self.bdpt.pixel_sample(
                    self.scene,
                    self.seed,
                    self.pixel,
                    self.index,
                    &mut sampler,
                    &mut Independent::new(),
                    (&mut camera, &mut light),
                    &mut Counters::default(),
                    |c, light, camera| {
                        out.push(Outlier::new(
                            self.pixel, self.index, c, [0.0; 3], light, camera,
                        ))
                    },
                );
                out
            }
        }
        self.config.sampler.dispatch(
            spp,
            Replay {
                bdpt: self,
                scene,
                seed,
                pixel,
                index,
            },
        )
    }
}

impl Integrator for Bdpt {
    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let spp = match *budget {
            Budget::Samples(n) => n,
            Budget::Seconds(_) => 1,
        };
        self.config.sampler.dispatch(
            spp,
            RenderWith {
                bdpt: self,
                scene,
                budget,
                seed,
                progress,
                on_pass,
            },
        )
    }

    fn needs_sample_count(&self) -> bool {
        self.config.sampler.needs_sample_count()
    }

    fn best_sample_count(&self, n: u32) -> u32 {
        self.config.sampler.best_count_up_to(n)
    }
}

struct RenderWith<'a, 'b> {
    bdpt: &'a Bdpt,
    scene: &'a Scene,
    budget: &'a Budget,
    seed: u64,
    progress: &'a dyn Progress,
    on_pass: &'b mut dyn FnMut(u32, &Film) -> bool,
}

/// What one work item keeps besides its contributions: the subpath buffers it reuses, and the
/// outliers and splat provenance it logged.
#[derive(Default)]
struct WorkItem {
    camera: Vec<Vertex>,
    light: Vec<Vertex>,
    outliers: Vec<Outlier>,
    /// Where each splat of the full image came from (only with `outliers`).
    splat_sources: Vec<SplatSource>,
}

impl SamplerVisitor for RenderWith<'_, '_> {
    type Output = RenderOutput;

    fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, prototype: S) -> RenderOutput {
        let RenderWith {
            bdpt,
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = self;
        let cfg = &bdpt.config;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let router = &bdpt.router;
        // Per pixel: the full image, the class or bounce layers, then two per strategy.
        let first_strategy = 1 + router.layer_count();
        let spec = PassSpec {
            width,
            height,
            slots: first_strategy + 2 * bdpt.strategies.len(),
            splats: true,
            groups: 0,
            independent: cfg.sampler.independent(),
        };
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        let out = run_passes(
            &spec,
            router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, item: &mut WorkItem| {
                let mut sampler = prototype.clone();
                let mut light_sampler = Independent::new();
                // Non-finite counts of this sample (the sample holds `counters`).
                let mut non_finite = [0u64; 2];
                let (running_mean, running_count) = sink.running_mean();
                let scale = running_mean[0].max(running_mean[1]).max(running_mean[2]);
                let WorkItem {
                    camera,
                    light,
                    outliers,
                    splat_sources,
                } = item;
                bdpt.pixel_sample(
                    scene,
                    seed,
                    (x, y),
                    index,
                    &mut sampler,
                    &mut light_sampler,
                    (camera, light),
                    counters,
                    |c, light, camera| {
                        let value = c.unweighted * c.weight;
                        let finite = value.is_finite();
                        if !finite {
                            non_finite[if c.raster.is_some() {
                                SPLAT
                            } else {
                                CONNECTION
                            }] += 1;
                        }
                        // Camera-side contributions are compared with their pixel's mean over
                        // the passes before this one; splats (t = 1), which land in other
                        // pixels, with their pixel's final mean after the render (see
                        // `splat_outliers`).
                        let outlier = match cfg.outliers {
                            Some(factor) if c.raster.is_none() => {
                                running_count >= OUTLIER_MIN_SAMPLES
                                    && value.max_component() as f64
                                        > factor as f64 * scale.max(f64::MIN_POSITIVE)
                            }
                            _ => false,
                        };
                        if !finite || outlier {
                            outliers.push(Outlier::new(
                                (x, y),
                                index,
                                c,
                                running_mean,
                                light,
                                camera,
                            ));
                        }
                        if !finite {
                            return;
                        }
                        let strategy = bdpt
                            .strategy_slot(c.s, c.t)
                            .filter(|_| c.unweighted.is_finite());
                        match c.raster {
                            Some(r) => {
                                let pixel = sink.pixel_at(r);
                                sink.splat_routed(pixel, c.layer, value);
                                if let Some(k) = strategy {
                                    sink.splat_slot(pixel, first_strategy + k, value);
                                    sink.splat_slot(pixel, first_strategy + k + 1, c.unweighted);
                                }
                                if cfg.outliers.is_some() {
                                    splat_sources.push(SplatSource {
                                        target: pixel,
                                        value,
                                        pixel: (x, y),
                                        sample: index,
                                        s: c.s as u16,
                                        t: c.t as u16,
                                    });
                                }
                            }
                            None => {
                                sink.add_routed(c.layer, value);
                                if let Some(k) = strategy {
                                    sink.add_slot(first_strategy + k, value);
                                    sink.add_slot(first_strategy + k + 1, c.unweighted);
                                }
                            }
                        }
                    },
                );
                for (k, n) in non_finite.iter().enumerate() {
                    counters.non_finite[k] += *n;
                }
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let pixels = width as u64 * height as u64;
        let mut stats = RenderStats::new(
            "Bdpt",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            pixels * out.spp as u64,
            &out.counters,
            &["connection", "splat"],
            if spec.independent {
                PixelVariance::Independent
            } else {
                PixelVariance::NotAnEstimate(format!(
                    "the {} sampler's camera subpaths are correlated (s²/n overestimates the \
                     variance of the mean)",
                    cfg.sampler.name()
                ))
            },
        );
        let mut outliers: Vec<Outlier> = out
            .extras
            .iter()
            .flat_map(|r| r.outliers.iter().cloned())
            .collect();
        if let Some(factor) = cfg.outliers {
            outliers.extend(bdpt.splat_outliers(scene, seed, out.spp, &out.extras, &film, factor));
        }
        let mut per_strategy: std::collections::BTreeMap<(u32, u32), u64> = Default::default();
        for o in &outliers {
            *per_strategy.entry((o.s, o.t)).or_default() += 1;
        }
        stats.outliers = per_strategy
            .into_iter()
            .map(|((s, t), n)| (format!("s{s}t{t}"), n))
            .collect();
        let names = router.layer_names().into_iter().chain(
            bdpt.strategies
                .iter()
                .flat_map(|(s, t)| [format!("s{s}t{t}"), format!("s{s}t{t}.unweighted")]),
        );
        RenderOutput {
            film,
            layers: names.zip(films).collect(),
            outliers,
            stats,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(name: &str) -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes")
            .join(name);
        lightlab_scene::load_scene(&path).unwrap()
    }

    /// The vertices of a full path x₀ (on a light) … x_{n−1} (the camera) split as s light and
    /// t = n − s camera vertices, with every density recomputed from the geometry, as both subpath
    /// generators would have stored them.
    fn split(scene: &Scene, z: &[Vertex], s: usize) -> (Vec<Vertex>, Vec<Vertex>) {
        let n = z.len();
        let t = n - s;
        let mut camera: Vec<Vertex> = z[..t].to_vec();
        let mut light: Vec<Vertex> = z[t..].iter().rev().copied().collect();
        if let Some(y0) = light.first_mut() {
            y0.kind = Kind::Light { light: y0.emitter };
            y0.sb = None;
            y0.delta = false;
        }
        for i in 1..camera.len() {
            let prev = if i >= 2 { Some(camera[i - 2]) } else { None };
            camera[i].pdf_fwd = camera[i - 1].pdf(scene, prev.as_ref(), &camera[i]);
        }
        if !light.is_empty() {
            light[0].pdf_fwd = light[0].pdf_light_origin(scene);
        }
        for i in 1..light.len() {
            let prev = if i >= 2 { Some(light[i - 2]) } else { None };
            light[i].pdf_fwd = light[i - 1].pdf(scene, prev.as_ref(), &light[i]);
        }
        // Reverse densities of the interior vertices (the last two of each side are set by
        // `mis_weight` itself).
        for i in 0..camera.len().saturating_sub(2) {
            let next2 = camera[i + 2];
            camera[i].pdf_rev = camera[i + 1].pdf(scene, Some(&next2), &camera[i]);
        }
        for i in 0..light.len().saturating_sub(2) {
            let next2 = light[i + 2];
            light[i].pdf_rev = light[i + 1].pdf(scene, Some(&next2), &light[i]);
        }
        (light, camera)
    }

    /// Veach's condition for unbiased MIS: the weights of all strategies that can produce a path sum
    /// to one, for the balance and power heuristics and uniform weights. Checked on camera paths that end on the light, in the Cornell box (all diffuse) and
    /// the caustic scene (delta vertices, whose connections are impossible strategies).
    #[test]
    fn weights_of_all_strategies_sum_to_one() {
        for name in ["cornell-box.ron", "caustic-sphere.ron"] {
            let scene = scene(name);
            let bdpt = Bdpt::new(BdptConfig {
                max_bounces: Some(6),
                russian_roulette: None,
                ..BdptConfig::default()
            })
            .unwrap();
            let mut counters = Counters::default();
            let mut checked = 0;
            for pixel in 0..200_000u64 {
                let mut sampler = Independent::new();
                sampler.start_pixel_sample(7, pixel, 0);
                let film = Vec2::new(
                    (pixel % 256) as f32 + 0.5,
                    ((pixel / 256) % 256) as f32 + 0.5,
                );
                let mut z = Vec::new();
                bdpt.camera_subpath(&scene, film, &mut sampler, 8, &mut z, &mut counters);
                let Some(last) = z.last() else { continue };
                if z.len() < 3
                    || last.emitter == NO_LIGHT
                    || last.le(&scene, &z[z.len() - 2]).is_black()
                {
                    continue;
                }
                let n = z.len();
                for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                    let mut sum = 0.0f64;
                    for s in 0..n {
                        let t = n - s;
                        let (light, camera) = split(&scene, &z, s);
                        let connection_delta = s > 0 && (light[s - 1].delta || camera[t - 1].delta);
                        if connection_delta {
                            continue;
                        }
                        let sampled = if t == 1 {
                            Some(camera[0])
                        } else if s == 1 {
                            Some(light[0])
                        } else {
                            None
                        };
                        sum += Bdpt::mis_weight(&scene, &light, &camera, sampled, s, t, heuristic)
                            as f64;
                    }
                    assert!(
                        (sum - 1.0).abs() < 1e-3,
                        "{name}, {heuristic:?}: a path of {n} vertices has weights summing to {sum}"
                    );
                }
                checked += 1;
                if checked == 300 {
                    break;
                }
            }
            assert!(
                checked >= 50,
                "{name}: only {checked} paths reached the light"
            );
        }
    }

    /// A sampler that replays `values` in order (then ½): drives a production walk along a path
    /// chosen in advance.
    struct Script {
        values: Vec<f32>,
        next: usize,
    }

    impl Sampler for Script {
        fn start_pixel_sample(&mut self, _: u64, _: u64, _: u64) {}
        fn next_1d(&mut self) -> f32 {
            self.next += 1;
            self.values.get(self.next - 1).copied().unwrap_or(0.5)
        }
        fn next_2d(&mut self) -> Vec2 {
            Vec2::new(self.next_1d(), self.next_1d())
        }
    }

    fn bdpt(max_bounces: u32) -> Bdpt {
        Bdpt::new(BdptConfig {
            max_bounces: Some(max_bounces),
            russian_roulette: None,
            ..BdptConfig::default()
        })
        .unwrap()
    }

    /// The camera subpath that `camera_subpath` traces back through the vertices of the light
    /// subpath `light` (x₀ on the light … x_{n−1}) when its samples are chosen to: the camera ray
    /// through x_{n−1}'s raster position, at every diffuse vertex the inverse of the cosine warp
    /// toward the next vertex, at every delta vertex the lobe the light path took. `None` unless
    /// the walk retraces every vertex.
    fn camera_through(bdpt: &Bdpt, scene: &Scene, light: &[Vertex]) -> Option<Vec<Vertex>> {
        use lightlab_samplers::warp::cosine_hemisphere_to_square;
        let n = light.len();
        let raster = scene
            .camera
            .sample_wi(light[n - 1].p, Vec2::splat(0.5))?
            .raster;
        let mut values = vec![0.5, 0.5];
        for j in (1..n).rev() {
            let (here, next) = (&light[j], &light[j - 1]);
            let sb = here.sb?;
            let wi = (next.p - here.p).normalize();
            let (u_lobe, u_dir) = if here.delta {
                let prev = if j + 1 < n {
                    light[j + 1].p
                } else {
                    scene.camera.eye
                };
                let through = (prev - here.p).dot(here.ng) * (next.p - here.p).dot(here.ng) < 0.0;
                (if through { 1.0 - 1e-6 } else { 0.0 }, Vec2::splat(0.5))
            } else {
                let mut local = sb.frame.to_local(wi);
                local.z = local.z.abs();
                (0.5, cosine_hemisphere_to_square(local))
            };
            values.extend([u_lobe, u_dir.x, u_dir.y, 0.5]);
        }
        let mut sampler = Script { values, next: 0 };
        let mut camera = Vec::new();
        let film = raster;
        bdpt.camera_subpath(
            scene,
            film,
            &mut sampler,
            n as u32 + 1,
            &mut camera,
            &mut Counters::default(),
        );
        let retraced = camera.len() == n + 1
            && (1..=n).all(|j| camera[j].p.distance(light[n - j].p) < 1e-3)
            && camera[n].emitter != NO_LIGHT;
        retraced.then_some(camera)
    }

    /// Σ over the strategies that can make the path `light` + camera of their MIS weights, from
    /// the densities the two production walks stored.
    fn weight_sum(scene: &Scene, light: &[Vertex], camera: &[Vertex], heuristic: Mis) -> f64 {
        let m = light.len();
        (0..=m)
            .filter(|&s| s == 0 || !(light[s - 1].delta || camera[m - s].delta))
            .map(|s| {
                let t = m + 1 - s;
                let sampled = match (s, t) {
                    (_, 1) => Some(camera[0]),
                    (1, _) => Some(light[0]),
                    _ => None,
                };
                Bdpt::mis_weight(scene, light, camera, sampled, s, t, heuristic) as f64
            })
            .sum()
    }

    /// Light subpaths of `scene` traced by production code (seeds 0, 1, …) whose last vertex the
    /// camera sees and which `keep` accepts, each with the camera subpath retracing it.
    fn production_paths(
        scene: &Scene,
        bdpt: &Bdpt,
        vertices: u32,
        keep: impl Fn(&[Vertex]) -> bool,
        want: usize,
    ) -> Vec<(Vec<Vertex>, Vec<Vertex>)> {
        let mut out = Vec::new();
        for seed in 0..400_000u64 {
            let mut sampler = Independent::new();
            sampler.start_pixel_sample(seed, 0, 0);
            let mut light = Vec::new();
            bdpt.light_subpath(
                scene,
                &mut sampler,
                vertices,
                &mut light,
                &mut Counters::default(),
            );
            let Some(last) = light.last() else { continue };
            if last.delta || !keep(&light) {
                continue;
            }
            let visible = scene
                .camera
                .sample_wi(last.p, Vec2::splat(0.5))
                .is_some_and(|cs| {
                    Bdpt::visible(
                        scene,
                        last,
                        &Vertex::new(Kind::Camera, cs.p_lens, Rgb::WHITE),
                    )
                });
            if !visible {
                continue;
            }
            if let Some(camera) = camera_through(bdpt, scene, &light) {
                out.push((light, camera));
                if out.len() == want {
                    break;
                }
            }
        }
        out
    }

    /// One refractive interface: a light under a diffuse ceiling above a flat glass surface
    /// (η = 1.5 below it), a diffuse floor in the glass and the camera in the glass too — the
    /// path `L D S D E` crosses the interface once.
    fn flat_interface(material: &str) -> Scene {
        let text = format!(
            "Scene(camera: Camera(eye: (0, -0.4, 1.6), target: (0, -1, 0), fov: 50, resolution: (32, 32)),
               materials: {{ \"white\": Diffuse(albedo: (0.8, 0.8, 0.8)), \"black\": Diffuse(albedo: (0, 0, 0)),
                             \"interface\": {material} }},
               shapes: [
                 Shape(geometry: Quad(corner: (-10, 0, -10), edge1: (0, 0, 20), edge2: (20, 0, 0)), material: \"interface\"),
                 Shape(geometry: Quad(corner: (-3, -1, -3), edge1: (0, 0, 6), edge2: (6, 0, 0)), material: \"white\"),
                 Shape(geometry: Quad(corner: (-3, 1, -3), edge1: (6, 0, 0), edge2: (0, 0, 6)), material: \"white\"),
                 Shape(geometry: Quad(corner: (-0.3, 0.5, -0.3), edge1: (0, 0, 0.6), edge2: (0.6, 0, 0)), material: \"black\",
                       emission: (radiance: (5, 5, 5))),
               ])"
        );
        lightlab_scene::parse_scene(&text, std::path::Path::new("flat-interface.ron")).unwrap()
    }

    /// The weights of all strategies sum to one with the densities the walks themselves store —
    /// through a mirror, one flat refractive interface, the glass sphere (two interfaces), and for
    /// an emitter seen directly —
    /// for the balance and power heuristics and uniform weights. (It fails when the two walks
    /// disagree on a delta vertex's ratio of densities.)
    #[test]
    fn production_weights_sum_to_one_through_specular_vertices() {
        let with_delta = |p: &[Vertex]| p.iter().any(|v| v.delta);
        let mirror_floor = {
            let text = std::fs::read_to_string(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../../scenes/caustic-sphere.ron"),
            )
            .unwrap()
            .replace(
                "\"glass\": Dielectric(ior: 1.5)",
                "\"glass\": Mirror(reflectance: (0.9, 0.9, 0.9))",
            );
            lightlab_scene::parse_scene(&text, std::path::Path::new("mirror-sphere.ron")).unwrap()
        };
        let directly = |p: &[Vertex]| p.len() == 1;
        for (name, scene, keep, vertices) in [
            (
                "mirror sphere",
                mirror_floor,
                &with_delta as &dyn Fn(&[Vertex]) -> bool,
                6,
            ),
            (
                "flat interface",
                flat_interface("Dielectric(ior: 1.5)"),
                &with_delta,
                6,
            ),
            (
                "glass sphere",
                super::tests::scene("caustic-sphere.ron"),
                &with_delta,
                6,
            ),
            // An emitter seen directly: s = 0 (the camera ray hits it) and s = t = 1.
            (
                "emitter seen directly",
                super::tests::scene("cornell-box.ron"),
                &directly,
                1,
            ),
        ] {
            let bdpt = bdpt(6);
            let paths = production_paths(&scene, &bdpt, vertices, keep, 40);
            assert!(paths.len() >= 20, "{name}: only {} paths", paths.len());
            for (light, camera) in &paths {
                for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                    let sum = weight_sum(&scene, light, camera, heuristic);
                    assert!(
                        (sum - 1.0).abs() < 2e-3,
                        "{name}, {heuristic:?}: a path of {} light vertices has weights summing to {sum}",
                        light.len()
                    );
                }
            }
        }
    }

    /// On `L D S D E` through one flat interface the balance weights are the true ones: the ratio
    /// of the light-tracing strategy (s = 4) to next-event estimation (s = 1) equals the ratio of
    /// their path densities computed independently, with the solid-angle Jacobians through the
    /// refraction taken by finite differences in f64 (Snell's law, the landing point's area per
    /// steradian). Keeping the lobe probability alone at the delta vertex was off by the
    /// compression (η_i/η_t)² cos θ_i / cos θ_t — a factor 0.3–0.5 here.
    #[test]
    fn weights_through_one_refraction_match_finite_difference_densities() {
        use glam::DVec3;
        let scene = flat_interface("Dielectric(ior: 1.5)");
        let eta = 1.5f64;
        let bdpt = bdpt(3);
        let shape = |p: &[Vertex]| {
            p.len() == 4 && !p[1].delta && p[2].delta && p[1].p.y > 0.9 && p[3].p.y < -0.9
        };
        let paths = production_paths(&scene, &bdpt, 4, shape, 10);
        assert!(paths.len() >= 5, "only {} L D S D paths", paths.len());
        // Refracts d at the plane y = 0 and returns where it lands on the plane y = `to`.
        let land = |origin: DVec3, d: DVec3, to: f64| -> DVec3 {
            let at = origin + d * (-origin.y / d.y);
            let (eta_i, eta_t) = if d.y < 0.0 { (1.0, eta) } else { (eta, 1.0) };
            let n = DVec3::new(0.0, -d.y.signum(), 0.0);
            let cos_i = -d.dot(n);
            let r = eta_i / eta_t;
            let t = d * r + n * (r * cos_i - (1.0 - r * r * (1.0 - cos_i * cos_i)).sqrt());
            at + t * ((to - at.y) / t.y)
        };
        // Steradians per unit area of the landing point on the plane y = `to`, for directions
        // around d from `origin`.
        let jacobian = |origin: DVec3, d: DVec3, to: f64| -> f64 {
            let (t1, t2) = {
                let a = if d.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
                let t1 = d.cross(a).normalize();
                (t1, d.cross(t1))
            };
            let h = 1e-6;
            let at = |a: f64, b: f64| land(origin, (d + t1 * a + t2 * b).normalize(), to);
            let da = (at(h, 0.0) - at(-h, 0.0)) / (2.0 * h);
            let db = (at(0.0, h) - at(0.0, -h)) / (2.0 * h);
            1.0 / da.cross(db).length()
        };
        for (light, camera) in &paths {
            let x: Vec<DVec3> = light.iter().map(|v| v.p.as_dvec3()).collect();
            let eye = scene.camera.eye.as_dvec3();
            let cos_up = |a: DVec3, b: DVec3| (b - a).normalize().y.abs();
            // s = 4: the light emits x₀ → x₁ (cosine), x₁ scatters toward x₂ (cosine), which
            // refracts to x₃; the camera vertex is the pinhole for every strategy.
            let d01 = x[1] - x[0];
            let p_41 = cos_up(x[0], x[1]) / std::f64::consts::PI * cos_up(x[0], x[1])
                / d01.length_squared()
                * cos_up(x[1], x[2])
                / std::f64::consts::PI
                * jacobian(x[1], (x[2] - x[1]).normalize(), -1.0);
            // s = 1: the camera samples x₃ (its directional density times cos/d²), x₃ scatters
            // toward x₂ (cosine), which refracts to x₁; the light point x₀ is sampled alike.
            let d3 = x[3] - eye;
            let p_cam = scene
                .camera
                .pdf_we_dir(scene.camera.eye, d3.normalize().as_vec3())
                as f64
                * cos_up(eye, x[3])
                / d3.length_squared();
            let p_14 = p_cam * cos_up(x[3], x[2]) / std::f64::consts::PI
                * jacobian(x[3], (x[2] - x[3]).normalize(), 1.0);
            let w = |s: usize| {
                let t = 5 - s;
                let sampled = match (s, t) {
                    (_, 1) => Some(camera[0]),
                    (1, _) => Some(light[0]),
                    _ => None,
                };
                Bdpt::mis_weight(&scene, light, camera, sampled, s, t, Mis::Balance) as f64
            };
            let (production, exact) = (w(4) / w(1), p_41 / p_14);
            assert!(
                (production / exact - 1.0).abs() < 2e-3,
                "w(4,1)/w(1,4) = {production:.5}, the densities' ratio {exact:.5}"
            );
        }
    }
}
