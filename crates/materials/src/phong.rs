//! The modified Phong BRDF of Lafortune & Willems 1994 ("Using the Modified Phong Reflectance Model
//! for Physically Based Rendering"):
//!
//!   f(wo, wi) = kd/π + ks·(n+2)/(2π)·cosⁿα,  cos α = max(0, wi·r),  r = mirror direction of wo.
//!
//! The (n+2)/(2π) normalisation makes the specular albedo exactly ks at normal incidence and less
//! elsewhere, so kd + ks ≤ 1 conserves energy. wi·r(wo) = wo·r(wi), so f is reciprocal.
//!
//! Sampling picks the diffuse lobe with probability p_d = avg(kd)/(avg(kd) + avg(ks)) (cosine
//! hemisphere) or the specular one (cosⁿ lobe around r, density (n+1)/(2π)·cosⁿα); the pdf is the
//! mixture p_d·cos θi/π + p_s·(n+1)/(2π)·cosⁿα over the hemisphere of `wo`. Specular samples that
//! fall below the surface are lost. Two-sided, like Diffuse.

use crate::{BsdfEval, BsdfSample, LobeClass};
use lightlab_core::{Frame, INV_2PI, INV_PI, PI, Rgb, Vec2, Vec3};
use lightlab_samplers::warp::square_to_cosine_hemisphere;

pub(crate) struct Phong {
    kd: Rgb,
    ks: Rgb,
    exponent: f32,
    /// Probability of sampling the diffuse lobe; the specular one gets the rest.
    p_diffuse: f32,
}

/// Mirror direction of `w` about the normal +z.
#[inline]
fn mirror(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

impl Phong {
    /// `exponent` is expected to be ≥ 0; `kd`, `ks` non-negative with a positive sum, otherwise
    /// nothing is sampled.
    #[inline]
    pub(crate) fn new(kd: Rgb, ks: Rgb, exponent: f32) -> Phong {
        let (d, s) = (kd.average(), ks.average());
        Phong {
            kd,
            ks,
            exponent,
            p_diffuse: d / (d + s),
        }
    }

    /// cosⁿα for a reflection pair, 0 otherwise (also for n = 0, where 0⁰ = 1 would spread the
    /// lobe over directions its sampling never reaches, cos α ≤ 0); symmetric in its arguments.
    #[inline]
    fn cos_alpha_pow(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cos_alpha = mirror(wo).dot(wi);
        if cos_alpha > 0.0 {
            cos_alpha.powf(self.exponent)
        } else {
            0.0
        }
    }

    /// Mixture density of the sampling strategy for a reflection pair.
    #[inline]
    fn mixture_pdf(&self, wi: Vec3, cos_pow: f32) -> f32 {
        self.p_diffuse * wi.z.abs() * INV_PI
            + (1.0 - self.p_diffuse) * (self.exponent + 1.0) * INV_2PI * cos_pow
    }

    #[inline]
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> BsdfEval {
        if wo.z * wi.z <= 0.0 {
            return BsdfEval::ZERO;
        }
        let cos_pow = self.cos_alpha_pow(wo, wi);
        let (pdf_fwd, pdf_rev) = if self.p_diffuse.is_finite() {
            (self.mixture_pdf(wi, cos_pow), self.mixture_pdf(wo, cos_pow))
        } else {
            (0.0, 0.0)
        };
        BsdfEval {
            f: self.kd * INV_PI + self.ks * ((self.exponent + 2.0) * INV_2PI * cos_pow),
            pdf_fwd,
            pdf_rev,
        }
    }

    #[inline]
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 || !self.p_diffuse.is_finite() {
            return 0.0;
        }
        self.mixture_pdf(wi, self.cos_alpha_pow(wo, wi))
    }

    #[inline]
    pub(crate) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if !self.p_diffuse.is_finite() {
            return None;
        }
        let (wi, lobe) = if u_lobe < self.p_diffuse {
            let mut wi = square_to_cosine_hemisphere(u);
            wi.z = wi.z.copysign(wo.z);
            (wi, LobeClass::Diffuse)
        } else {
            // cos α = u₁^{1/(n+1)} has density (n+1)/(2π)·cosⁿα around r (Lafortune & Willems 1994).
            let cos_a = u.x.powf(1.0 / (self.exponent + 1.0));
            let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
            let phi = 2.0 * PI * u.y;
            let local = Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
            (Frame::from_z(mirror(wo)).to_world(local), LobeClass::Glossy)
        };
        if wi.z * wo.z <= 0.0 {
            return None;
        }
        let e = self.eval(wo, wi);
        Some(BsdfSample::new(wi, e.f, e.pdf_fwd, lobe, None))
    }
}
