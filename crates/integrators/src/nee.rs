//! Next-event estimation (direct lighting by sampling the lights; Shirley et al. 1996, pbrt-v4
//! §13.4): one light chosen by power, one point or direction on it, one shadow ray.

use crate::render::Counters;
use glam::Vec2;
use glam::Vec3;
use lightlab_core::{INV_4PI, Rgb, TransportMode};
use lightlab_geometry::{Hit, spawn_ray, spawn_ray_to, spawn_ray_to_point};
use lightlab_materials::SurfaceBsdf;
use lightlab_scene::{Light, LightSample, Scene};

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

/// Samples direct lighting at `hit` toward `wo` with one light sample (`u_light`, `u_point`).
/// With `shadows` false visibility is not tested (unshadowed direct lighting). `None` when the
/// sample carries nothing or is occluded.
pub(crate) fn sample_direct(
    scene: &Scene,
    hit: &Hit,
    sb: &SurfaceBsdf,
    wo: Vec3,
    u_light: f32,
    u_point: Vec2,
    shadows: bool,
    counters: &mut Counters,
) -> Option<DirectSample> {
    let (li_index, pmf) = scene.sample_light(u_light)?;
    let ls = scene.lights[li_index as usize].sample_li(scene.shapes(), hit.p, u_point)?;
    let e = sb.eval(wo, ls.wi, TransportMode::Radiance);
    if ls.li.is_black() || e.f.is_black() {
        return None;
    }
    counters.rays += shadows as u64;
    if shadows && shadowed(scene, hit, &ls) {
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

/// Radiance the surface at `hit` emits toward `wo` (black unless it is an area light).
#[inline]
pub(crate) fn emitted(scene: &Scene, hit: &Hit, wo: Vec3) -> Rgb {
    match scene.lights.get(hit.light as usize) {
        Some(&Light::Area {
            radiance,
            two_sided,
            ..
        }) => Light::area_le(radiance, two_sided, hit.ng, wo),
        _ => Rgb::BLACK,
    }
}

/// Solid-angle density, light choice included, with which next-event estimation from `from`
/// would have sampled the emitting point `hit` — the other strategy in the MIS weight of emission
/// found by BSDF sampling.
#[inline]
pub(crate) fn light_pdf_of_hit(scene: &Scene, from: Vec3, hit: &Hit) -> f32 {
    scene.light_pmf(hit.light)
        * scene.shapes()[hit.shape as usize].pdf_solid_angle(from, hit.p, hit.ng)
}

/// The same for a ray that escapes to the (constant) environment light.
#[inline]
pub(crate) fn environment_light_pdf(scene: &Scene) -> f32 {
    scene
        .environment_light()
        .map_or(0.0, |i| scene.light_pmf(i) * INV_4PI)
}

/// Whether the segment from `hit` to the light sample is blocked.
fn shadowed(scene: &Scene, hit: &Hit, ls: &LightSample) -> bool {
    let ray = if ls.infinite {
        let mut r = spawn_ray(hit.p, hit.p_error, hit.ng, ls.wi);
        r.t_max = f32::INFINITY;
        r
    } else if ls.delta {
        spawn_ray_to_point(hit.p, hit.p_error, hit.ng, ls.p)
    } else {
        spawn_ray_to(hit.p, hit.p_error, hit.ng, ls.p, ls.p_error, ls.n)
    };
    scene.occluded(&ray)
}
