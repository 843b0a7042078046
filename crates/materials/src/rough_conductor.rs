//! Rough metal: the Torrance–Sparrow microfacet BRDF with GGX or Beckmann normals, height-correlated
//! Smith masking-shadowing and the conductor Fresnel term, sampled by visible normals (pbrt-v4
//! §9.6.5; Heitz 2018 for GGX, Heitz & d'Eon 2014 for Beckmann).
//!
//!   f(wo, wi) = D(h) G2(wo, wi) F(wo·h) / (4 |cos θo| |cos θi|),  h = normalize(wo + wi)
//!
//! (Walter et al. 2007, eq. 20, with h the half vector of their eq. 13). Sampling a visible normal m
//! from D_wo (Heitz 2018) and reflecting wo about it gives the density
//!
//!   p(wi) = D_wo(m) / (4 |wo·m|) = G1(wo) D(m) / (4 |cos θo|)
//!
//! (Walter et al. 2007, eq. 14 for the reflection Jacobian; Heitz 2018, eq. 17), so the sample
//! weight is F·G2/G1(wo) ≤ 1, for both distributions. Symmetric in wo and wi, hence the same in
//! both transport modes.
//! Two-sided: a `wo` below the surface is handled by mirroring both directions through the
//! tangent plane, which leaves D, Λ and the anisotropy axes unchanged.

use crate::microfacet::{Distribution, Microfacet};
use crate::{BsdfEval, BsdfSample, LobeClass, fresnel};
use lightlab_core::{Rgb, Vec2, Vec3};

pub(crate) struct RoughConductor {
    ggx: Microfacet,
    eta: Rgb,
    k: Rgb,
}

/// Mirrors `w` through the tangent plane.
#[inline]
fn flip_z(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// `(wo, wi, h, wo·h)` moved to the upper hemisphere, or `None` when they are not a reflection
/// pair. wo·h = wi·h = |wo + wi|/2 is computed from the length of the sum, so swapping wo and
/// wi changes no bit of the result (reciprocity survives rounding at grazing angles).
#[inline]
pub(crate) fn upper_half_vector(wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3, Vec3, f32)> {
    if wo.z * wi.z <= 0.0 {
        return None;
    }
    let (wo, wi) = if wo.z < 0.0 {
        (flip_z(wo), flip_z(wi))
    } else {
        (wo, wi)
    };
    let sum = wo + wi;
    let len = sum.length();
    if len == 0.0 {
        return None;
    }
    Some((wo, wi, sum / len, 0.5 * len))
}

impl RoughConductor {
    #[inline]
    pub(crate) fn new(distribution: Distribution, alpha: Vec2, eta: Rgb, k: Rgb) -> RoughConductor {
        RoughConductor {
            ggx: Microfacet::new(distribution, alpha),
            eta,
            k,
        }
    }

    #[inline]
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> BsdfEval {
        let Some((wo, wi, h, cos_h)) = upper_half_vector(wo, wi) else {
            return BsdfEval::ZERO;
        };
        let d = self.ggx.d(h);
        let fr = fresnel::conductor(cos_h, self.eta, self.k);
        BsdfEval {
            f: fr * (d * self.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z)),
            pdf_fwd: self.ggx.reflection_pdf(wo, h, cos_h),
            pdf_rev: self.ggx.reflection_pdf(wi, h, cos_h),
        }
    }

    #[inline]
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, _, h, cos_h)) = upper_half_vector(wo, wi) else {
            return 0.0;
        };
        self.ggx.reflection_pdf(wo, h, cos_h)
    }

    /// The value and pdf come from [`RoughConductor::eval`] at the sampled `wi`, so they are exactly
    /// what `eval` and `pdf` report.
    #[inline]
    pub(crate) fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let wo_up = if wo.z < 0.0 { flip_z(wo) } else { wo };
        let m = self.ggx.sample_normal(wo_up, u);
        let wi_up = fresnel::reflect(wo_up, m);
        if wi_up.z <= 0.0 {
            return None;
        }
        let wi = if wo.z < 0.0 { flip_z(wi_up) } else { wi_up };
        let e = self.eval(wo, wi);
        Some(BsdfSample::new(wi, e.f, e.pdf_fwd, LobeClass::Glossy, None))
    }
}
