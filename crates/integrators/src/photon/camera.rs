//! The camera side of photon mapping: a camera path traced through specular (and, if asked,
//! glossy) surfaces to the first surface where photons are gathered — the *visible point* of
//! Hachisuka & Jensen 2009, the first diffuse hit of Jensen's two-pass method (Jensen 2001, §9.1).
//!
//! Along the way it collects what photons do not: emission seen through the specular chain
//! (`L S* E`), and next-event estimation at every glossy vertex it passes and at the visible point
//! (`L X S* E`). At glossy vertices emission found by BSDF sampling and by light sampling are
//! combined by the power heuristic (Veach 1997, §9.2), as in the path tracer; at the visible point
//! light sampling is the only strategy for direct light, so it has weight 1 there.

use super::map::GatherPoint;
use crate::nee::{emitted, environment_light_pdf, light_pdf_of_hit, sample_direct};
use crate::paths::PathClass;
use crate::render::Counters;
use crate::roulette::survives;
use crate::sink::Sink;
use glam::Vec2;
use lightlab_core::{Rgb, TransportMode};
use lightlab_geometry::{Hit, NO_LIGHT, spawn_ray};
use lightlab_materials::{LobeClass, SurfaceBsdf};
use lightlab_samplers::Sampler;
use lightlab_samplers::mis::power_heuristic;
use lightlab_scene::Scene;

/// Technique number of non-finite camera-side contributions (emission and direct lighting).
pub const CAMERA: usize = 0;

/// Settings of the camera walk.
#[derive(Clone, Copy, Debug)]
pub struct Walk {
    pub max_bounces: u32,
    pub min_bounces: u32,
    pub russian_roulette: Option<u32>,
    /// Continue through glossy surfaces instead of gathering there.
    pub trace_glossy: bool,
    /// Next-event estimation at glossy vertices and at the visible point.
    pub direct: bool,
}

/// Where the camera path stopped to gather photons.
#[derive(Clone, Copy, Debug)]
pub struct VisiblePoint {
    pub gather: GatherPoint,
    pub hit: Hit,
    /// Camera-path throughput up to the point (We·Π f·|cos|/p, We/p = 1 for the pinhole).
    pub beta: Rgb,
    /// Scattering vertices from the camera, the visible point included (d ≥ 1): photons of k
    /// bounces gathered here make paths of k + d − 1 scattering vertices.
    pub depth: u32,
    /// Classes of the camera path's scattering vertices before the visible point, camera first.
    pub eye: PathClass,
}

impl VisiblePoint {
    /// Range of photon bounce counts k whose paths through this point have between `min` and `max`
    /// scattering vertices.
    #[inline]
    pub fn photon_bounces(&self, min: u32, max: u32) -> (u32, u32) {
        (
            (min + 1).saturating_sub(self.depth).max(1),
            max.saturating_add(1).saturating_sub(self.depth),
        )
    }
}

impl VisiblePoint {
    /// The class of a photon's path completed through this point to the camera, light first.
    #[inline]
    pub fn class_with(&self, photon: &PathClass) -> PathClass {
        photon.then(self.eye.reversed())
    }
}

/// Traces the camera ray through raster position `film`, adds the radiance it estimates on the
/// way (emission and direct light) to `l`, by path class, and returns the visible point, if
/// the path reached one. `sampler` drives the path (lens, BSDF and roulette choices); `lights`
/// drives next-event estimation, so that progressive photon mapping can keep a path fixed while
/// its light samples change.
pub fn walk<S: Sampler, T: Sampler>(
    scene: &Scene,
    cfg: &Walk,
    film: Vec2,
    sampler: &mut S,
    lights: &mut T,
    l: &mut Sink,
    counters: &mut Counters,
) -> Option<VisiblePoint> {
    let mut ray = scene.camera.generate_ray(film, sampler.next_2d());
    // Scattering vertices so far, camera first.
    let mut class = PathClass::EMPTY;
    let mut beta = Rgb::WHITE;
    let mut eta_scale = 1.0f32;
    let mut depth = 0u32;
    // Whether emission reached from the previous vertex competes with light sampling there, and
    // the BSDF pdf it was reached with.
    let mut prev_nee: Option<f32> = None;
    let mut prev_p = ray.o;
    loop {
        counters.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            let le = scene.environment_le();
            if depth >= cfg.min_bounces && !le.is_black() {
                let w = prev_nee.map_or(1.0, |bsdf_pdf| {
                    power_heuristic(1.0, bsdf_pdf, 1.0, environment_light_pdf(scene))
                });
                add(l, &class, beta * le * w, counters);
            }
            return None;
        };
        let wo = -ray.d.normalize();
        if hit.light != NO_LIGHT && depth >= cfg.min_bounces {
            let le = emitted(scene, &hit, wo);
            if !le.is_black() {
                let w = prev_nee.map_or(1.0, |bsdf_pdf| {
                    power_heuristic(1.0, bsdf_pdf, 1.0, light_pdf_of_hit(scene, prev_p, &hit))
                });
                add(l, &class, beta * le * w, counters);
            }
        }
        if depth >= cfg.max_bounces {
            return None;
        }
        let bsdf = scene.materials[hit.material as usize];
        let sb = SurfaceBsdf::new(hit.ns, hit.dpdu, hit.ng, bsdf);
        let class_here = bsdf.lobe_class();
        let gathers = match class_here {
            LobeClass::Specular => false,
            LobeClass::Glossy => !cfg.trace_glossy,
            LobeClass::Diffuse => true,
        };
        let (u_light, u_point) = (lights.next_1d(), lights.next_2d());
        if cfg.direct
            && class_here != LobeClass::Specular
            && depth + 1 >= cfg.min_bounces
            && let Some(d) = sample_direct(scene, &hit, &sb, wo, u_light, u_point, true, counters)
        {
            let w = if gathers || d.delta {
                1.0
            } else {
                power_heuristic(1.0, d.light_pdf, 1.0, d.bsdf_pdf)
            };
            add(l, &class.push(class_here), beta * d.value * w, counters);
        }
        if gathers {
            return Some(VisiblePoint {
                gather: GatherPoint {
                    p: hit.p,
                    wo,
                    bsdf: sb,
                },
                hit,
                beta,
                depth: depth + 1,
                eye: class,
            });
        }
        class = class.push(class_here);
        let (u_lobe, u_dir, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
        let s = sb.sample(wo, u_lobe, u_dir, TransportMode::Radiance)?;
        beta *= s.weight;
        if s.transmission {
            eta_scale *= s.eta * s.eta;
        }
        prev_nee = (cfg.direct && !s.delta).then_some(s.pdf);
        prev_p = hit.p;
        depth += 1;
        let score = beta.max_component() * eta_scale;
        if !survives(cfg.russian_roulette, depth, score, u_rr, &mut beta) {
            return None;
        }
        ray = spawn_ray(hit.p, hit.p_error, hit.ng, s.wi);
    }
}

/// Adds a contribution of the camera-first class `eye` unless it is not finite (counted).
#[inline]
fn add(l: &mut Sink, eye: &PathClass, c: Rgb, counters: &mut Counters) {
    if c.is_finite() {
        l.add_eye(eye, c);
    } else {
        counters.non_finite[CAMERA] += 1;
    }
}
