//! Lambertian reflection, two-sided: f = albedo / π on whichever side `wo` lies, sampled by the
//! cosine-weighted hemisphere on that side (pbrt-v4 §9.2).

use crate::{BsdfEval, BsdfSample, LobeClass};
use lightlab_core::{INV_PI, Rgb, Vec2, Vec3};
use lightlab_samplers::warp::square_to_cosine_hemisphere;

#[inline]
pub(crate) fn eval(albedo: Rgb, wo: Vec3, wi: Vec3) -> BsdfEval {
    if wo.z * wi.z <= 0.0 {
        return BsdfEval::ZERO;
    }
    BsdfEval {
        f: albedo * INV_PI,
        pdf_fwd: wi.z.abs() * INV_PI,
        pdf_rev: wo.z.abs() * INV_PI,
    }
}

#[inline]
pub(crate) fn pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z * wi.z <= 0.0 {
        return 0.0;
    }
    wi.z.abs() * INV_PI
}

#[inline]
pub(crate) fn sample(albedo: Rgb, wo: Vec3, u: Vec2) -> BsdfSample {
    let mut wi = square_to_cosine_hemisphere(u);
    wi.z = wi.z.copysign(wo.z);
    let pdf = pdf(wo, wi);
    BsdfSample::new(wi, albedo * INV_PI, pdf, LobeClass::Diffuse, None)
}
