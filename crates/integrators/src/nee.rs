//! Next-event estimation (direct lighting by sampling the lights; Shirley et al. 1996, pbrt-v4
//! §13.4): one light chosen by power, one point or direction on it, one shadow ray.

use crate::render::Counters;
use crate::walk::{Arrival, PathVertex};
use glam::Vec2;
use glam::Vec3;
use lightlab_core::{Rgb, TransportMode};
use lightlab_geometry::{NO_LIGHT, spawn_ray, spawn_ray_to, spawn_ray_to_point};
use lightlab_materials::SurfaceBsdf;
use lightlab_samplers::mis::power_heuristic;
use lightlab_scene::{LightSample, Scene};

/// An unoccluded light sample at a surface point, before any MIS weight.
pub(crate) struct DirectSample {
    /// f(ωo, ωi) · Lᵢ · |ωi·n_s| / (pmf · p_ω): the single-sample estimate of direct lighting.
    pub value: Rgb,
    /// pmf · p_ω of the light sample (solid angle; 1·pmf for delta lights).
    pub light_pdf: f32,
    /// Solid-angle pdf with which BSDF sampling at the point would choose ωi.
    pub bsdf_pdf: f32,
    /// The light is a delta light (point, spot): no other strategy can find it.
    pub delta: bool,
}

/// Samples direct lighting at surface vertex `v` toward `wo` with one light sample (`u_light`, `u_point`).
/// With `shadows` false visibility is not tested (unshadowed direct lighting). `None` when the
/// sample carries nothing or is occluded.
pub(crate) fn sample_direct(
    scene: &Scene,
    v: &PathVertex,
    sb: &SurfaceBsdf,
    wo: Vec3,
    u_light: f32,
    u_point: Vec2,
    shadows: bool,
    counters: &mut Counters,
) -> Option<DirectSample> {
    let (li_index, pmf) = scene.sample_light(u_light)?;
    let ls = scene.lights[li_index as usize].sample_li(scene.shapes(), v.p, u_point)?;
    // A point behind a one-sided light sends nothing: no BSDF evaluation for it.
    if ls.li.is_black() {
        return None;
    }
    let e = sb.eval(wo, ls.wi, TransportMode::Radiance);
    if e.f.is_black() {
        return None;
    }
    counters.rays += shadows as u64;
    if shadows && shadowed(scene, v, &ls) {
        return None;
    }
    let light_pdf = pmf * ls.pdf_w;
    let cos = ls.wi.dot(sb.frame.n).abs();
    Some(DirectSample {
        value: e.f * ls.li * (cos / light_pdf),
        light_pdf,
        bsdf_pdf: e.pdf_fwd,
        delta: ls.delta,
    })
}

/// How emission that a BSDF-sampled ray finds is weighted against next-event estimation at the
/// vertex the ray left (Veach 1997, §9.2). After the camera or a specular vertex, where lights
/// cannot be sampled, the weight is always 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Competition {
    /// Lights are not sampled: BSDF sampling alone finds emission (weight 1).
    None,
    /// Next-event estimation alone counts light reached after a non-specular vertex (weight 0).
    LightsOnly,
    /// Both strategies count, combined by the power heuristic.
    Power,
}

impl Competition {
    /// The weight of a next-event sample `d` (1 for a delta light, which BSDF sampling cannot
    /// find).
    #[inline]
    pub(crate) fn direct_weight(self, d: &DirectSample) -> f32 {
        match self {
            Competition::Power if !d.delta => power_heuristic(1.0, d.light_pdf, 1.0, d.bsdf_pdf),
            _ => 1.0,
        }
    }

    #[inline]
    fn weight(self, arrival: &Arrival, light_pdf: impl FnOnce() -> f32) -> f32 {
        match self {
            _ if arrival.delta => 1.0,
            Competition::None => 1.0,
            Competition::LightsOnly => 0.0,
            Competition::Power => power_heuristic(1.0, arrival.pdf_w, 1.0, light_pdf()),
        }
    }
}

/// The weighted emission β·Lₑ·w a camera-side walk finds at surface vertex `v`, reached as
/// `arrival` says (black where `v` does not emit).
#[inline]
pub(crate) fn emission_found(
    scene: &Scene,
    v: &PathVertex,
    arrival: &Arrival,
    competition: Competition,
) -> Rgb {
    if v.emitter == NO_LIGHT {
        return Rgb::BLACK;
    }
    let le = v.le_toward(scene, v.wo);
    if le.is_black() {
        return le;
    }
    v.beta * le * competition.weight(arrival, || light_pdf_of_hit(scene, arrival.from, v))
}

/// The same for a walk that escaped with throughput `beta` along the unit direction `d` to the
/// environment.
#[inline]
pub(crate) fn environment_found(
    scene: &Scene,
    beta: Rgb,
    d: Vec3,
    arrival: &Arrival,
    competition: Competition,
) -> Rgb {
    let le = scene.environment_le(d);
    if le.is_black() {
        return le;
    }
    beta * le * competition.weight(arrival, || environment_light_pdf(scene, d))
}

/// Solid-angle density, light choice included, with which next-event estimation from `from`
/// would have sampled the emitting surface vertex `v` — the other strategy in the MIS weight of
/// emission found by BSDF sampling.
#[inline]
fn light_pdf_of_hit(scene: &Scene, from: Vec3, v: &PathVertex) -> f32 {
    scene.light_pmf(v.emitter) * scene.shapes()[v.shape as usize].pdf_solid_angle(from, v.p, v.ng)
}

/// The same for a ray that escapes along `d` to the environment light.
#[inline]
fn environment_light_pdf(scene: &Scene, d: Vec3) -> f32 {
    scene.environment_light().map_or(0.0, |i| {
        scene.light_pmf(i) * scene.lights[i as usize].environment_pdf(d)
    })
}

/// Whether the segment from `v` to the light sample is blocked.
fn shadowed(scene: &Scene, v: &PathVertex, ls: &LightSample) -> bool {
    let ray = if ls.infinite {
        let mut r = spawn_ray(v.p, v.p_error, v.ng, ls.wi);
        r.t_max = f32::INFINITY;
        r
    } else if ls.delta {
        spawn_ray_to_point(v.p, v.p_error, v.ng, ls.p)
    } else {
        spawn_ray_to(v.p, v.p_error, v.ng, ls.p, ls.p_error, ls.n)
    };
    scene.occluded(&ray.at_time(v.time))
}
