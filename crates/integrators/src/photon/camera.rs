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
use crate::nee::{Competition, emission_found, environment_found, sample_direct};
use crate::paths::PathClass;
use crate::render::{Counters, Technique};
use crate::sink::Sink;
use crate::walk::{
    Arrival, Directions, Lobes, PathVertex, RoulettePolicy, Visitor, Walk, from_camera,
};
use glam::Vec2;
use lightlab_core::{Ray, Rgb, TransportMode};
use lightlab_materials::LobeClass;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;

/// Settings of the camera walk.
#[derive(Clone, Copy, Debug)]
pub struct CameraWalk {
    /// Most scattering vertices of a full path (the integrator's `max_bounces`).
    pub max_bounces: u32,
    /// Fewest scattering vertices of a contribution.
    pub min_bounces: u32,
    /// The camera paths' Russian roulette.
    pub roulette: RoulettePolicy,
    /// Continue through glossy surfaces instead of gathering there.
    pub trace_glossy: bool,
    /// Next-event estimation at glossy vertices and at the visible point.
    pub direct: bool,
}

/// Where the camera path stopped to gather photons.
#[derive(Clone, Copy, Debug)]
pub struct VisiblePoint {
    /// What a density estimate needs of the point.
    pub gather: GatherPoint,
    /// The surface vertex itself (depth d, throughput `beta`).
    pub(crate) vertex: PathVertex,
    /// Camera-path throughput up to the point (We·Π f·|cos|/p, We/p = 1 for the pinhole).
    pub beta: Rgb,
    /// Scattering vertices from the camera, the visible point included (d ≥ 1): photons of k
    /// bounces gathered here make paths of k + d − 1 scattering vertices.
    pub depth: u32,
    /// Classes of the camera path's scattering vertices before the visible point, camera first.
    pub eye: PathClass,
}

impl VisiblePoint {
    /// The visible point at surface vertex `v`, reached as `arrival` says.
    #[inline]
    pub(crate) fn at(v: &PathVertex, arrival: &Arrival) -> VisiblePoint {
        let sb = v.sb.expect("a visible point is on a surface");
        VisiblePoint {
            gather: GatherPoint {
                p: v.p,
                wo: v.wo,
                bsdf: sb,
            },
            vertex: *v,
            beta: v.beta,
            depth: v.depth,
            eye: arrival.class,
        }
    }

    /// The visible point to make at surface vertex `v` — or `None` where the path goes on
    /// through a delta lobe. A BSDF that mixes a delta lobe into a non-delta one (plastic) has
    /// its lobe chosen here, with one sample from `sampler`: with the delta probability P the
    /// path goes on (the walk must then sample [`Lobes::Delta`], whose weight divides by P);
    /// otherwise the point gathers the non-delta part with throughput β/(1 − P).
    #[inline]
    pub(crate) fn at_or_delta<S: Sampler>(
        v: &PathVertex,
        arrival: &Arrival,
        sampler: &mut S,
    ) -> Option<VisiblePoint> {
        let mut vp = VisiblePoint::at(v, arrival);
        if vp.gather.bsdf.bsdf.mixes_delta() {
            let p = vp.gather.bsdf.delta_probability(v.wo);
            if sampler.next_1d() < p {
                return None;
            }
            vp.beta /= 1.0 - p;
        }
        Some(vp)
    }

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

/// Seed offset of the next-event-estimation stream (independent of the camera path's stream).
const LIGHT_STREAM: u64 = 0x5851_f42d_4c95_7f2d;

/// The camera walk of a sample of pixel (x, y) of an image `width` wide at instant `time`: the
/// path's random numbers from stream (seed, pixel, `camera_index`), next-event estimation's from
/// an independent stream at `light_index`. Returns the visible point, if any, and the path's
/// sampler, which a final gather continues with.
#[allow(clippy::too_many_arguments)]
pub fn trace_pixel(
    scene: &Scene,
    cfg: &CameraWalk,
    (seed, time): (u64, f32),
    (x, y, width): (u32, u32, u32),
    camera_index: u64,
    light_index: u64,
    l: &mut Sink,
    counters: &mut Counters,
) -> (Option<VisiblePoint>, Independent) {
    let pixel = y as u64 * width as u64 + x as u64;
    let mut sampler = Independent::new();
    sampler.start_pixel_sample(seed, pixel, camera_index);
    let mut lights = Independent::new();
    lights.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, light_index);
    let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
    let vp = walk(
        scene,
        cfg,
        (film, time),
        &mut sampler,
        &mut lights,
        l,
        counters,
    );
    (vp, sampler)
}

/// Traces the camera ray through raster position `film` at instant `time`, adds the radiance it estimates on the
/// way (emission and direct light) to `l`, by path class, and returns the visible point, if
/// the path reached one. `sampler` drives the path (lens, BSDF and roulette choices); `lights`
/// drives next-event estimation, so that progressive photon mapping can keep a path fixed while
/// its light samples change.
pub fn walk<S: Sampler, T: Sampler>(
    scene: &Scene,
    cfg: &CameraWalk,
    (film, time): (Vec2, f32),
    sampler: &mut S,
    lights: &mut T,
    l: &mut Sink,
    counters: &mut Counters,
) -> Option<VisiblePoint> {
    // Emission is found at the vertex after the last one a path may scatter at.
    let walk = Walk {
        mode: TransportMode::Radiance,
        max_depth: cfg.max_bounces.saturating_add(1),
        roulette: cfg.roulette,
        directions: Directions::Bsdf,
    };
    let mut visitor = ToVisiblePoint {
        scene,
        cfg,
        lights,
        l,
        competition: if cfg.direct {
            Competition::Power
        } else {
            Competition::None
        },
        found: None,
        delta_only: false,
    };
    from_camera(scene, &walk, film, time, sampler, &mut visitor, counters);
    visitor.found
}

/// The camera walk's visitor: emission and next-event estimation on the way, and the visible
/// point where it stops.
struct ToVisiblePoint<'a, 'r, T> {
    scene: &'a Scene,
    cfg: &'a CameraWalk,
    lights: &'a mut T,
    l: &'a mut Sink<'r>,
    /// Emission after a glossy vertex competes with next-event estimation there.
    competition: Competition,
    found: Option<VisiblePoint>,
    /// The path chose a delta lobe at the vertex last visited, where it did not stop.
    delta_only: bool,
}

impl<T: Sampler> Visitor for ToVisiblePoint<'_, '_, T> {
    #[inline]
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        arrival: &Arrival,
        sampler: &mut S,
        counters: &mut Counters,
    ) -> bool {
        let (scene, cfg) = (self.scene, self.cfg);
        if arrival.class.len() >= cfg.min_bounces {
            let c = emission_found(scene, v, arrival, self.competition);
            if !c.is_black() {
                self.l
                    .add_eye_or_count(&arrival.class, c, Technique::Camera, counters);
            }
        }
        if v.depth > cfg.max_bounces {
            return false;
        }
        let Some(sb) = v.sb else {
            return false;
        };
        let class_here = sb.bsdf.lobe_class();
        let gathers = match class_here {
            LobeClass::Specular => false,
            LobeClass::Glossy => !cfg.trace_glossy,
            LobeClass::Diffuse => true,
        };
        let (u_light, u_point) = (self.lights.next_1d(), self.lights.next_2d());
        if cfg.direct
            && class_here != LobeClass::Specular
            && v.depth >= cfg.min_bounces
            && let Some(d) = sample_direct(scene, v, &sb, v.wo, u_light, u_point, true, counters)
        {
            // At the visible point light sampling is the only strategy for direct light.
            let w = if gathers {
                1.0
            } else {
                self.competition.direct_weight(&d)
            };
            self.l
                .add_eye_or_count(&v.class, v.beta * d.value * w, Technique::Camera, counters);
        }
        if gathers {
            self.found = VisiblePoint::at_or_delta(v, arrival, sampler);
            self.delta_only = self.found.is_none();
            return self.delta_only;
        }
        true
    }

    #[inline]
    fn lobes(&mut self, _v: &PathVertex) -> Lobes {
        if std::mem::take(&mut self.delta_only) {
            Lobes::Delta
        } else {
            Lobes::All
        }
    }

    #[inline]
    fn escaped(&mut self, ray: &Ray, beta: Rgb, arrival: &Arrival, counters: &mut Counters) {
        if arrival.class.len() >= self.cfg.min_bounces {
            let d = ray.d.normalize();
            let c = environment_found(self.scene, beta, d, arrival, self.competition);
            if !c.is_black() {
                self.l
                    .add_eye_or_count(&arrival.class, c, Technique::Camera, counters);
            }
        }
    }
}
