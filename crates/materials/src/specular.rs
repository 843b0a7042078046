//! Perfectly smooth surfaces: the mirror, the smooth conductor and the smooth dielectric interface
//! (pbrt-v4 §9.3, §9.4 and §9.5). Every lobe is a Dirac delta, so there is nothing to evaluate; samples follow the delta
//! convention of the crate docs (f = coefficient / |cos θi|, pdf = lobe-selection probability).

use crate::{BsdfSample, LobeClass, fresnel};
use lightlab_core::{Rgb, TransportMode, Vec3};

/// Perfect mirror, two-sided: wi = (−wo.x, −wo.y, wo.z), weight = reflectance.
#[inline]
pub(crate) fn sample_mirror(reflectance: Rgb, wo: Vec3) -> BsdfSample {
    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
    BsdfSample::new(wi, reflectance / wi.z.abs(), 1.0, LobeClass::Specular, None)
}

/// Smooth conductor, two-sided: the mirror direction with weight F(|cos θo|), the conductor Fresnel
/// reflectance for complex relative index η + i·k (pbrt-v4 §9.3.6, `ConductorBxDF` specular case).
#[inline]
pub(crate) fn sample_conductor(eta: Rgb, k: Rgb, wo: Vec3) -> BsdfSample {
    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
    let f = fresnel::conductor(wo.z.abs(), eta, k);
    BsdfSample::new(wi, f / wi.z.abs(), 1.0, LobeClass::Specular, None)
}

/// Thin dielectric sheet (a window pane), two-sided: the slab's two parallel interfaces reflect
/// R′ = R + T²R/(1 − R²) + … = 2R/(1 + R) in total, R = F(|cos θo|) (the geometric series of
/// inter-reflections inside the slab; Mitsuba 3's `thindielectric`), and transmit T′ = 1 − R′ along
/// −wo (the two refractions cancel). Each lobe is chosen with its probability, so both weights are
/// 1; the medium is the same on both sides, so there is no η′² factor.
#[inline]
pub(crate) fn sample_thin_dielectric(eta: f32, wo: Vec3, u_lobe: f32) -> BsdfSample {
    let r = fresnel::dielectric(wo.z.abs(), eta);
    let r = 2.0 * r / (1.0 + r);
    if u_lobe < r {
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        BsdfSample::new(wi, Rgb::splat(r / wi.z.abs()), r, LobeClass::Specular, None)
    } else {
        let (wi, t) = (-wo, 1.0 - r);
        BsdfSample::new(
            wi,
            Rgb::splat(t / wi.z.abs()),
            t,
            LobeClass::Specular,
            Some(1.0),
        )
    }
}

/// Smooth dielectric (pbrt-v4 `DielectricBxDF`, specular case): reflection with probability
/// R = F(cos θo) and coefficient R, refraction with probability T = 1 − R and coefficient T, scaled
/// by 1/η′² in radiance mode (pbrt-v4 §9.5.2) where η′ is the relative index crossed. So the weight
/// is 1 for reflection, and 1/η′² (radiance) or 1 (importance) for refraction.
#[inline]
pub(crate) fn sample_dielectric(
    eta: f32,
    wo: Vec3,
    u_lobe: f32,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let r = fresnel::dielectric(wo.z, eta);
    let t = 1.0 - r;
    if u_lobe < r {
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        Some(BsdfSample::new(
            wi,
            Rgb::splat(r / wi.z.abs()),
            r,
            LobeClass::Specular,
            None,
        ))
    } else {
        let (wi, etap) = fresnel::refract(wo, Vec3::Z, eta)?;
        let mut ft = t / wi.z.abs();
        if mode == TransportMode::Radiance {
            ft /= etap * etap;
        }
        Some(BsdfSample::new(
            wi,
            Rgb::splat(ft),
            t,
            LobeClass::Specular,
            Some(etap),
        ))
    }
}
