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
