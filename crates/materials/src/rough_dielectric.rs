//! Rough glass: the microfacet BSDF of Walter et al. 2007 ("Microfacet Models for Refraction through
//! Rough Surfaces") with GGX or Beckmann normals, following pbrt-v4's `DielectricBxDF` (§9.7).
//!
//! With η_o and η_i the indices on the sides of `wo` and `wi` (outside = 1, inside = `eta`), the
//! generalised half vector is m ∝ η_o·wo + η_i·wi, flipped to the upper hemisphere (Walter eq. 13
//! for reflection, where η_o = η_i, and eq. 16 for transmission). Then
//!
//!   f_r = D(m) G2 F / (4 |cos θo| |cos θi|)                                   (Walter eq. 20)
//!   f_t = η_o² · S,  S = D(m) G2 (1 − F) |wi·m| |wo·m| / (|cos θo| |cos θi| (η_i wi·m + η_o wo·m)²)
//!                                                                              (Walter eq. 21)
//!
//! in radiance mode; S is symmetric in (wo, η_o) ↔ (wi, η_i), so the adjoint used in importance mode
//! is f_t* = η_i² · S — pbrt-v4's "divide by η′² only for radiance" (§9.5.2), and the generalised
//! reciprocity f(wo, wi)/η_o² = f(wi, wo)/η_i² of Veach 1997, eq. 5.14. F = F(wo·m) is the exact
//! dielectric Fresnel term. The half vector, S and F are computed so that they are the same bits for
//! (wo, wi) and (wi, wo): absolute indices in m and S, and F from a cosine both orders share (see
//! `Configuration::fresnel`).
//!
//! Sampling: a normal m visible from wo, D_wo (Heitz 2018; Heitz & d'Eon 2014 for Beckmann), then
//! reflection with probability F and
//! refraction with probability 1 − F. The density is that of m times the Jacobian of the map m → wi,
//! 1/(4|wo·m|) for reflection (Walter eq. 14) and η_i²|wi·m| / (η_i wi·m + η_o wo·m)² for refraction
//! (Walter eq. 17), times the Fresnel selection probability. Microfacets that face away from either
//! direction are discarded (pbrt-v4 §9.7), so these are the exact densities of `sample`.

use crate::microfacet::{Distribution, Microfacet};
use crate::{BsdfEval, BsdfSample, LobeClass, fresnel};
use lightlab_core::{Rgb, TransportMode, Vec2, Vec3};

pub(crate) struct RoughDielectric {
    ggx: Microfacet,
    eta: f32,
}

/// A pair (wo, wi) seen through the microfacet that connects them.
struct Configuration {
    /// Generalised half vector, upper hemisphere.
    m: Vec3,
    /// Index of refraction on `wo`'s and `wi`'s side (both 1 for reflection).
    eta_o: f32,
    eta_i: f32,
    reflect: bool,
    /// Fresnel reflectance at m, computed so that it is the same bits for (wo, wi) and (wi, wo).
    fresnel: f32,
}

impl Configuration {
    /// The same configuration seen from the other end.
    #[inline]
    fn reversed(&self) -> Configuration {
        Configuration {
            m: self.m,
            eta_o: self.eta_i,
            eta_i: self.eta_o,
            reflect: self.reflect,
            fresnel: self.fresnel,
        }
    }
}

impl RoughDielectric {
    #[inline]
    pub(crate) fn new(distribution: Distribution, alpha: Vec2, eta: f32) -> RoughDielectric {
        RoughDielectric {
            ggx: Microfacet::new(distribution, alpha),
            eta,
        }
    }

    /// The half vector and indices of (wo, wi), or `None` when a direction is on the horizon, the
    /// half vector is undefined, or the microfacet faces away from either direction.
    #[inline]
    fn configuration(&self, wo: Vec3, wi: Vec3) -> Option<Configuration> {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0 || cos_i == 0.0 {
            return None;
        }
        let reflect = cos_o * cos_i > 0.0;
        let side_eta = |cos: f32| if cos > 0.0 { 1.0 } else { self.eta };
        let (eta_o, eta_i) = if reflect {
            (1.0, 1.0)
        } else {
            (side_eta(cos_o), side_eta(cos_i))
        };
        let sum = wo * eta_o + wi * eta_i;
        let len = sum.length();
        if len == 0.0 {
            return None;
        }
        let m = if sum.z < 0.0 { -sum / len } else { sum / len };
        if m.dot(wi) * cos_i <= 0.0 || m.dot(wo) * cos_o <= 0.0 {
            return None;
        }
        // F(wo·m) = F(wi·m) mathematically. Evaluate it from a quantity both orders share: for
        // reflection wo·m = ±|wo + wi|/2; for refraction the cosine on the outside, which also
        // avoids the ill-conditioned inside evaluation near the critical angle.
        let cos_fresnel = if reflect {
            (0.5 * len).copysign(cos_o)
        } else if cos_o > 0.0 {
            wo.dot(m)
        } else {
            wi.dot(m)
        };
        Some(Configuration {
            m,
            eta_o,
            eta_i,
            reflect,
            fresnel: fresnel::dielectric(cos_fresnel, self.eta),
        })
    }

    /// Solid-angle density with which `sample(wo)` yields `wi` in configuration `c`.
    #[inline]
    fn pdf_in(&self, c: &Configuration, wo: Vec3, wi: Vec3) -> f32 {
        let fr = c.fresnel;
        let d_wo = self.ggx.normal_pdf(wo, c.m);
        if c.reflect {
            d_wo / (4.0 * wo.dot(c.m).abs()) * fr
        } else {
            let denom = c.eta_i * wi.dot(c.m) + c.eta_o * wo.dot(c.m);
            let dm_dwi = c.eta_i * c.eta_i * wi.dot(c.m).abs() / (denom * denom);
            d_wo * dm_dwi * (1.0 - fr)
        }
    }

    #[inline]
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        let Some(c) = self.configuration(wo, wi) else {
            return BsdfEval::ZERO;
        };
        let fr = c.fresnel;
        let dg = self.ggx.d(c.m) * self.ggx.g2(wo, wi);
        let f = if c.reflect {
            dg * fr / (4.0 * (wo.z * wi.z).abs())
        } else {
            let (wo_m, wi_m) = (wo.dot(c.m), wi.dot(c.m));
            let denom = c.eta_i * wi_m + c.eta_o * wo_m;
            let s = dg * (1.0 - fr) * (wi_m * wo_m).abs() / ((wo.z * wi.z).abs() * denom * denom);
            let eta_scale = match mode {
                TransportMode::Radiance => c.eta_o,
                TransportMode::Importance => c.eta_i,
            };
            eta_scale * eta_scale * s
        };
        BsdfEval {
            f: Rgb::splat(f),
            pdf_fwd: self.pdf_in(&c, wo, wi),
            pdf_rev: self.pdf_in(&c.reversed(), wi, wo),
        }
    }

    #[inline]
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.configuration(wo, wi)
            .map_or(0.0, |c| self.pdf_in(&c, wo, wi))
    }

    /// The value and pdf come from [`RoughDielectric::eval`] at the sampled `wi`, so they are
    /// exactly what `eval` and `pdf` report.
    #[inline]
    pub(crate) fn sample(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let m = self.ggx.sample_normal(wo, u);
        // A normal facing away from wo (only by rounding at grazing angles: sampled normals are
        // visible) is discarded, as `configuration` does: lost mass, so the density stays exact.
        if wo.dot(m) * wo.z <= 0.0 {
            return None;
        }
        let fr = fresnel::dielectric(wo.dot(m), self.eta);
        let (wi, transmitted_eta) = if u_lobe < fr {
            let wi = fresnel::reflect(wo, m);
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            (wi, None)
        } else {
            let (wi, etap) = fresnel::refract(wo, m, self.eta)?;
            if wi.z * wo.z >= 0.0 {
                return None;
            }
            (wi, Some(etap))
        };
        let e = self.eval(wo, wi, mode);
        Some(BsdfSample::new(
            wi,
            e.f,
            e.pdf_fwd,
            LobeClass::Glossy,
            transmitted_eta,
        ))
    }
}
