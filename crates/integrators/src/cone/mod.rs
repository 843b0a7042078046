//! Cone tracing (Amanatides 1984): one cone per pixel instead of many rays. The cone leaves the
//! pinhole along the pixel centre's direction with the pixel's solid angle (a circular footprint
//! of the pixel's area on the image plane's sphere of directions); every sphere and triangle it
//! meets is intersected analytically — the fraction f of the cone's cross-section it covers
//! (`regions`) — and the surfaces are composited front to back, L = Σᵢ fᵢ Lᵢ Πⱼ<ᵢ (1 − fⱼ), each
//! shaded once (`shading`: emission plus direct light from area lights with a shadow cone).
//!
//! What it approximates, against the box-filtered pixel integral a path tracer estimates:
//! (1) the pixel's footprint is a disk, not a square (a different anti-aliasing filter);
//! (2) partial coverages composite as if independent (Amanatides' §3), exact when one surface lies
//! wholly behind another's edge, wrong where two partial surfaces overlap in the cone; the
//! triangles of one shape count as one surface, correct for planar and convex shapes;
//! (3) each surface's radiance is taken at one point (near the middle of its covered part);
//! (4) a sphere's outline is taken as a disk in the cone's plane (exact for a sphere on the axis);
//! (5) a shadow is the fraction of the light's solid angle the shadow cone finds blocked, not the
//! cosine-weighted visible irradiance (see `shading`). The irradiance itself is exact, so fully
//! lit or fully shadowed pixels inside one surface are right up to (3).
//! Only emission and direct light (`LE`, `LDE`): no reflection or refraction cones, so the
//! method renders what `Path(max_bounces: 1)` does.

mod regions;
mod shading;

use crate::config::{ConfigError, Settings, Validate, invalid};
use crate::film::{Film, PixelSums};
use crate::paths::{Layers, PathClass, Router};
use crate::render::{Counters, PixelLimit, PixelVariance, named};
use crate::shutter::pass_time;
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::{Vec2, Vec3};
use lightlab_core::{Progress, Rgb};
use lightlab_materials::{Bsdf, LobeClass};
use lightlab_scene::desc::Lens;
use lightlab_scene::{Light, Scene};
use rayon::prelude::*;
use regions::{Projection, Region, cap_fraction};
use serde::{Deserialize, Serialize};
use shading::{Emitter, Solid, direct};
use std::time::Instant;

/// Settings of cone tracing: `Cone(shadows: false)`; every field optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, rename = "Cone")]
pub struct ConeConfig {
    /// 0 (emitters seen directly) or 1 (and direct light). Default 1.
    pub max_bounces: u32,
    /// 0 or 1, at most `max_bounces`. Default 0.
    pub min_bounces: u32,
    /// Shadow cones toward the lights; `false` lights every point fully. Default true.
    pub shadows: bool,
    /// Render only the paths (`LE`, `LDE`) this expression matches. Default `None`.
    pub paths: Option<String>,
    /// Image layers besides the full image. Default `Off`.
    pub layers: Layers,
}

impl Default for ConeConfig {
    fn default() -> Self {
        ConeConfig {
            max_bounces: 1,
            min_bounces: 0,
            shadows: true,
            paths: None,
            layers: Layers::Off,
        }
    }
}

impl Validate for ConeConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        if self.max_bounces > 1 {
            return invalid(format!(
                "cone tracing renders emission and direct light only: max_bounces must be 0 or 1, \
                 got {}",
                self.max_bounces
            ));
        }
        if self.min_bounces > self.max_bounces {
            return invalid(format!(
                "min_bounces ({}) exceeds max_bounces ({})",
                self.min_bounces, self.max_bounces
            ));
        }
        Router::check(
            self.paths.as_deref(),
            &self.layers,
            self.min_bounces,
            Some(self.max_bounces),
        )
        .map_err(ConfigError::Invalid)
    }
}

impl Settings for ConeConfig {
    fn paths_and_layers(&mut self) -> (&mut Option<String>, &mut Layers) {
        (&mut self.paths, &mut self.layers)
    }
}

/// Cone tracing, built from checked [`ConeConfig`] settings.
pub struct Cone {
    config: ConeConfig,
    router: Router,
}

impl Cone {
    /// A cone tracer with `config` (checked).
    pub fn new(config: ConeConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let router = Router::new(
            config.paths.as_deref(),
            &config.layers,
            Some(config.max_bounces),
        )
        .map_err(ConfigError::Invalid)?;
        Ok(Cone { config, router })
    }
}

/// One surface a cone meets: where, how much of the cross-section, and what it sends back
/// (per image slot).
struct Layer {
    depth: f32,
    coverage: f32,
    radiance: Vec<Rgb>,
}

/// The scene as the cone tracer reads it.
struct View<'a> {
    scene: &'a Scene,
    solids: Vec<Solid>,
    emitters: Vec<Emitter>,
    /// The light (index into `emitters`) each shape carries, if any.
    emitter_of: Vec<Option<usize>>,
    /// Image slot of `LE` and of `LDE` (`None`: not rendered).
    slots: [Vec<usize>; 2],
    shadows: bool,
}

impl View<'_> {
    /// Emission and direct light leaving `x` (normal `n`, on the viewer's side; `front`: that side
    /// is the geometric front) of shape `shape` toward the viewer, per slot.
    fn shade(&self, shape: usize, x: Vec3, n: Vec3, front: bool, slot_count: usize) -> Vec<Rgb> {
        let mut out = vec![Rgb::BLACK; slot_count];
        if let Some(e) = self.emitter_of[shape].map(|i| &self.emitters[i])
            && (front || e.two_sided)
        {
            for &s in &self.slots[0] {
                out[s] += e.radiance;
            }
        }
        if self.slots[1].is_empty() {
            return out;
        }
        let s = &self.scene.shapes()[shape];
        let Bsdf::Diffuse { albedo } = self.scene.materials[s.material as usize].bsdf else {
            return out;
        };
        if albedo.is_black() {
            return out;
        }
        let mut e = Rgb::BLACK;
        for emitter in self.emitters.iter().filter(|e| e.shape != shape) {
            e += direct(
                &self.solids,
                emitter,
                x,
                n,
                shape,
                self.shadows,
                self.scene.radius,
            );
        }
        let l = albedo * e * (1.0 / std::f32::consts::PI);
        for &slot in &self.slots[1] {
            out[slot] += l;
        }
        out
    }

    /// The surfaces the cone from the eye about `axis` with cross-section radius `r` meets.
    fn layers(&self, pr: &Projection, r: f32, slot_count: usize) -> Vec<Layer> {
        let cone = Region::Disk {
            centre: Vec2::ZERO,
            radius: r,
        };
        let cone_area = cone.area();
        let near = 1e-6 * self.scene.radius;
        let mut layers = Vec::new();
        for (shape, solid) in self.solids.iter().enumerate() {
            match solid {
                &Solid::Sphere { centre, radius } => {
                    let (f, d) = match pr.sphere(centre, radius) {
                        Some(disk) => {
                            let Region::Disk {
                                centre: c,
                                radius: rd,
                            } = disk
                            else {
                                unreachable!()
                            };
                            // The middle of the covered chord along the line of centres.
                            let e = c.normalize_or(Vec2::X);
                            let (s0, s1) = ((c.length() - rd).max(-r), (c.length() + rd).min(r));
                            (
                                cone.overlap(&disk) / cone_area,
                                pr.direction(e * (0.5 * (s0 + s1))),
                            )
                        }
                        // Too close for the projection plane: coverage in angle, shaded along
                        // the axis (or toward the sphere when the axis misses it).
                        None => {
                            let f = cap_fraction(r.atan(), pr.apex, pr.axis(), centre, radius);
                            (f, pr.axis())
                        }
                    };
                    let f = f.min(1.0);
                    if !(f > 0.0) {
                        continue;
                    }
                    let p = sphere_point(pr.apex, d, centre, radius);
                    let n = (p - centre).normalize();
                    layers.push(Layer {
                        depth: (p - pr.apex).length(),
                        coverage: f,
                        radiance: self.shade(shape, p, n, true, slot_count),
                    });
                }
                Solid::Mesh(tris) => {
                    // The triangles facing the eye, or (a planar shape seen from behind) those
                    // facing away: (coverage, depth, radiance) of each.
                    let mut sets: [Vec<(f32, f32, Vec<Rgb>)>; 2] = [Vec::new(), Vec::new()];
                    for (v, ng) in tris {
                        let Some(region) = pr.polygon(v, near, f32::INFINITY) else {
                            continue;
                        };
                        let f = cone.overlap(&region) / cone_area;
                        if !(f > 0.0) {
                            continue;
                        }
                        let Region::Polygon(poly) = &region else {
                            unreachable!()
                        };
                        let d = pr.direction(covered_middle(poly, r));
                        let t = ng.dot(v[0] - pr.apex) / ng.dot(d);
                        let p = pr.apex + d * t;
                        let front = ng.dot(pr.apex - v[0]) > 0.0;
                        let n = if front { *ng } else { -*ng };
                        let radiance = self.shade(shape, p, n, front, slot_count);
                        sets[usize::from(!front)].push((f, t, radiance));
                    }
                    let set = if sets[0].is_empty() {
                        &sets[1]
                    } else {
                        &sets[0]
                    };
                    let total: f32 = set.iter().map(|s| s.0).sum();
                    if !(total > 0.0) {
                        continue;
                    }
                    let mut radiance = vec![Rgb::BLACK; slot_count];
                    for (f, _, l) in set {
                        for (acc, v) in radiance.iter_mut().zip(l) {
                            *acc += *v * (f / total);
                        }
                    }
                    layers.push(Layer {
                        depth: set.iter().map(|s| s.0 * s.1).sum::<f32>() / total,
                        coverage: total.min(1.0),
                        radiance,
                    });
                }
            }
        }
        layers.sort_by(|a, b| a.depth.total_cmp(&b.depth));
        layers
    }
}

/// A point of the convex polygon `poly` inside the disk of radius `r` about the origin, near the
/// middle of their intersection: the origin if the polygon holds it, else the middle of the chord
/// from the polygon's nearest point to the disk's edge (that point itself if the middle falls
/// outside the polygon).
fn covered_middle(poly: &[Vec2], r: f32) -> Vec2 {
    let inside = |p: Vec2| {
        (0..poly.len()).all(|i| (poly[(i + 1) % poly.len()] - poly[i]).perp_dot(p - poly[i]) >= 0.0)
    };
    if inside(Vec2::ZERO) {
        return Vec2::ZERO;
    }
    let nearest = (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let t = (-a).dot(b - a) / (b - a).length_squared().max(f32::MIN_POSITIVE);
            a + (b - a) * t.clamp(0.0, 1.0)
        })
        .min_by(|p, q| p.length_squared().total_cmp(&q.length_squared()))
        .unwrap_or(Vec2::ZERO);
    let d = nearest.length();
    let middle = nearest * ((d + r) * 0.5 / d.max(f32::MIN_POSITIVE));
    if inside(middle) { middle } else { nearest }
}

/// Where the ray from `o` along unit `d` meets the sphere, or, missing it by rounding at the
/// outline, the sphere's point nearest the ray.
fn sphere_point(o: Vec3, d: Vec3, centre: Vec3, radius: f32) -> Vec3 {
    let oc = o - centre;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - radius * radius);
    if disc >= 0.0 {
        return o + d * (-b - disc.sqrt());
    }
    let closest = o + d * (-b);
    centre + (closest - centre).normalize_or(d) * radius
}

/// Solid angle of the spherical triangle of unit vectors a, b, c (Van Oosterom & Strackee 1983).
fn triangle_solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// Why `scene` is beyond cone tracing, if it is.
fn check(scene: &Scene) -> Result<(), String> {
    if !matches!(scene.camera.lens, Lens::Pinhole) {
        return Err(
            "cone tracing starts its cones at a pinhole: the scene's camera has a thin lens".into(),
        );
    }
    if let Some(light) = scene
        .lights
        .iter()
        .find(|l| !matches!(l, Light::Area { .. }))
    {
        let kind = light.kind();
        return Err(format!(
            "cone tracing casts shadow cones toward lights with area (spheres and polygons); the \
             scene has {kind}"
        ));
    }
    let solids = Solid::of(scene);
    for e in Emitter::of(scene) {
        if lights_itself(&solids[e.shape], &e, scene.camera.eye, scene.radius) {
            return Err(format!(
                "cone tracing lights a surface by the other lights only, and the light on shape \
                 {} can light itself: a concave or two-sided closed mesh, or a sphere the camera \
                 is inside; render it with Path(max_bounces: 1)",
                e.shape
            ));
        }
    }
    for (shape, i) in scene.shapes().iter().zip(0..) {
        let material = &scene.materials[shape.material as usize];
        let name = &scene.material_names[shape.material as usize];
        if !matches!(material.bsdf, Bsdf::Diffuse { .. }) || !material.textures.is_empty() {
            return Err(format!(
                "cone tracing shades Lambertian surfaces of constant albedo (no reflection or \
                 refraction cones): material '{name}' (shape {i}) is not"
            ));
        }
    }
    Ok(())
}

/// Whether emitter `e` can light its own shape `solid`, which the shading leaves out: a vertex of
/// the shape in front of one of its emitting triangles (beyond `1e-5 · scale`; never for a plane or
/// a closed convex mesh facing out), or a sphere whose inside the camera at `eye` sees.
fn lights_itself(solid: &Solid, e: &Emitter, eye: Vec3, scale: f32) -> bool {
    match solid {
        Solid::Mesh(tris) => tris.iter().any(|(a, n)| {
            tris.iter().flat_map(|(v, _)| v).any(|&p| {
                let height = n.dot(p - a[0]);
                height > 1e-5 * scale || (e.two_sided && height < -1e-5 * scale)
            })
        }),
        &Solid::Sphere { centre, radius } => eye.distance(centre) < radius,
    }
}

impl Integrator for Cone {
    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        check(scene)
    }

    /// A film per slot, and an instant's rows: a value per pixel and slot.
    fn memory_bytes(&self, scene: &Scene) -> u64 {
        let cells = scene.camera.width as u64
            * scene.camera.height as u64
            * (1 + self.router.layer_count()) as u64;
        cells.saturating_mul((size_of::<PixelSums>() + size_of::<Rgb>()) as u64)
    }

    /// One cone per pixel, whatever the budget (the image is deterministic: more samples would
    /// repeat it); `spp` in the statistics is 1. With motion blur (shapes moving while the shutter
    /// is open) the image averages instants instead (the accumulation buffer, Haeberli & Akeley
    /// 1990): the budget's samples are instants, each one cone per pixel in the scene frozen then,
    /// at the passes' stratified times (`shutter`); the spread over instants is its variance.
    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let start = Instant::now();
        let cam = &scene.camera;
        let (width, height) = (cam.width, cam.height);
        let slot_count = 1 + self.router.layer_count();
        let blur = scene.motion_blur();
        let instants = if blur { budget.samples_or(u32::MAX) } else { 1 };
        progress.start(height as u64 * if blur { budget.samples_or(1) } else { 1 } as u64);
        let mut films: Vec<Film> = (0..slot_count).map(|_| Film::new(width, height)).collect();
        let mut counters = Counters::default();
        let mut taken = 0;
        while taken < instants {
            let rows = if blur {
                let frozen = scene.at_instant(pass_time(cam, seed, taken as u64));
                self.instant(&frozen, slot_count, progress)
            } else if scene.has_motion() {
                // A closed shutter over moving shapes: the one instant, where they are then.
                self.instant(&scene.at_instant(cam.shutter.0), slot_count, progress)
            } else {
                self.instant(scene, slot_count, progress)
            };
            for (y, row) in rows.iter().enumerate() {
                for (x, value) in row.iter().enumerate() {
                    let i = y * width as usize + x;
                    for (film, v) in films.iter_mut().zip(value) {
                        if v.is_finite() {
                            film.pixels[i].add(v.to_array().map(f64::from));
                        } else {
                            counters.count_non_finite(crate::render::Technique::Camera);
                            film.pixels[i].add([0.0; 3]);
                        }
                    }
                }
            }
            counters.rays += width as u64 * height as u64;
            taken += 1;
            let stop = !on_pass(taken, &films[0]);
            if stop || matches!(budget, Budget::Seconds(s) if start.elapsed().as_secs_f64() >= *s) {
                break;
            }
        }
        let film = films.remove(0);
        let mut stats = RenderStats::new(
            "Cone",
            &film,
            taken,
            seed,
            start.elapsed().as_secs_f64(),
            width as u64 * height as u64 * taken as u64,
            &counters,
            &[crate::render::Technique::Camera],
            if blur {
                crate::shutter::instants_variance()
            } else {
                PixelVariance::NotAnEstimate(
                    "deterministic: one cone per pixel, no samples to take a variance over".into(),
                )
            },
        );
        stats.pixel_limit = PixelLimit::ConeFootprint;
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(self.router.layer_names(), films),
            stats,
        }
    }
}

impl Cone {
    /// The cone-traced image of `scene` (at rest), per pixel a value per output slot.
    fn instant(
        &self,
        scene: &Scene,
        slot_count: usize,
        progress: &dyn Progress,
    ) -> Vec<Vec<Vec<Rgb>>> {
        let cam = &scene.camera;
        let (width, height) = (cam.width, cam.height);
        let mut slots = [Vec::new(), Vec::new()];
        let mut class = PathClass::EMPTY;
        for (k, slot) in slots.iter_mut().enumerate() {
            if k > 0 {
                class = class.push(LobeClass::Diffuse);
            }
            if (self.config.min_bounces as usize..=self.config.max_bounces as usize).contains(&k)
                && let Some(layer) = self.router.route(&class)
            {
                slot.push(0);
                if slot_count > 1 {
                    slot.push(1 + layer);
                }
            }
        }
        let emitters = Emitter::of(scene);
        let mut emitter_of = vec![None; scene.shapes().len()];
        for (i, e) in emitters.iter().enumerate() {
            emitter_of[e.shape] = Some(i);
        }
        let view = View {
            scene,
            solids: Solid::of(scene),
            emitters,
            emitter_of,
            slots,
            shadows: self.config.shadows,
        };
        (0..height)
            .into_par_iter()
            .map(|y| {
                let row = (0..width)
                    .map(|x| {
                        let corner = |dx: f32, dy: f32| {
                            cam.generate_ray(Vec2::new(x as f32 + dx, y as f32 + dy), Vec2::ZERO)
                                .d
                        };
                        let (a, b, c, d) = (
                            corner(0.0, 0.0),
                            corner(1.0, 0.0),
                            corner(1.0, 1.0),
                            corner(0.0, 1.0),
                        );
                        let solid_angle =
                            triangle_solid_angle(a, b, c) + triangle_solid_angle(a, c, d);
                        // The cone of that solid angle: 2π(1 − cos α) = Ω.
                        let cos_alpha = 1.0 - solid_angle / (2.0 * std::f32::consts::PI);
                        let r = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt() / cos_alpha;
                        let axis = corner(0.5, 0.5);
                        let pr = Projection::new(cam.eye, axis);
                        let mut value = vec![Rgb::BLACK; slot_count];
                        let mut covered = 0.0f32;
                        for layer in view.layers(&pr, r, slot_count) {
                            let w = (1.0 - covered) * layer.coverage;
                            for (v, l) in value.iter_mut().zip(&layer.radiance) {
                                *v += *l * w;
                            }
                            covered += w;
                            if covered >= 1.0 {
                                break;
                            }
                        }
                        value
                    })
                    .collect();
                progress.advance(1);
                row
            })
            .collect()
    }
}
