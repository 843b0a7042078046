//! Scattering at surfaces: the [`Bsdf`] enum, evaluated and sampled in the local shading frame, and
//! the world-space [`SurfaceBsdf`] wrapper that converts frames and rejects bad configurations once
//! (pbrt-v4's `BSDF` class).
//!
//! ```
//! use lightlab_core::{Rgb, TransportMode, Vec2, Vec3};
//! use lightlab_materials::{Bsdf, Distribution, SurfaceBsdf};
//!
//! let bsdf = Bsdf::RoughConductor {
//!     alpha: Vec2::splat(0.2),
//!     eta: Rgb::new(0.143, 0.374, 1.442), // gold
//!     k: Rgb::new(3.983, 2.385, 1.603),
//!     distribution: Distribution::Ggx,
//! };
//! let surface = SurfaceBsdf::new(Vec3::Z, Vec3::X, Vec3::Z, bsdf);
//! let wo = Vec3::new(0.6, 0.0, 0.8);
//! let s = surface.sample(wo, 0.5, Vec2::new(0.3, 0.7), TransportMode::Radiance).unwrap();
//! // The throughput update of a path: beta *= s.weight (= f·|cos θi| / pdf).
//! let e = surface.eval(wo, s.wi, TransportMode::Radiance);
//! assert!((e.pdf_fwd / s.pdf - 1.0).abs() < 1e-3);
//! ```
//!
//! # Conventions (design.md)
//!
//! - `wo` points toward the previous vertex of the path being built (toward the camera on camera
//!   paths, toward the light on light paths); `wi` is the other, sampled direction. Both point away
//!   from the surface and are unit vectors. In the local frame the shading normal is +z, so
//!   cos θ = `w.z`.
//! - [`TransportMode::Radiance`] evaluates f(wo, wi) with light arriving from `wi`;
//!   [`TransportMode::Importance`] evaluates the adjoint f*(wo, wi) = f(wi, wo) (Veach 1997, ch. 3
//!   and §5.1). The two differ only for refraction: the radiance-mode BTDF carries the factor 1/η′²,
//!   η′ = η(wi's side)/η(wo's side) (Veach 1997, §5.2; pbrt-v4 §9.5.2); the importance-mode one
//!   does not. Shading-normal corrections are the business of [`SurfaceBsdf`].
//! - `f` never includes the cosine. Pdfs are per unit solid angle and include the probability of
//!   choosing the lobe.
//! - Delta lobes (Mirror, Conductor, ThinDielectric, smooth Dielectric) are invisible to `eval`/`pdf` (both zero). Their samples
//!   follow pbrt: `f` is the delta coefficient divided by |cos θi| and `pdf` is the discrete
//!   probability of choosing the lobe, so `weight = f·|cos θi| / pdf` holds for every sample.
//! - Nothing here returns NaN or ±∞: `eval` gives zero and `sample` gives `None` instead.

mod diffuse;
mod fresnel;
mod microfacet;
mod phong;
mod plastic;
mod rough_conductor;
mod rough_dielectric;
mod rough_plastic;
mod specular;
mod surface;
mod texture;

pub use microfacet::{ALPHA_MIN, Distribution};
pub use plastic::Plastic;
pub use rough_plastic::{Coating, RoughPlastic};
pub use surface::{Material, SurfaceBsdf};
pub use texture::{Bitmap, Filter, Pattern, Texture, TextureSlots, Wrap};

use lightlab_core::{Rgb, TransportMode, Vec2, Vec3};
use phong::Phong;
use rough_conductor::RoughConductor;
use rough_dielectric::RoughDielectric;

/// Which kind of scattering a lobe does, for Heckbert path classes: D, G, S.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LobeClass {
    Diffuse,
    Glossy,
    Specular,
}

/// The value and densities of a BSDF for a given pair of directions.
#[derive(Clone, Copy, Debug)]
pub struct BsdfEval {
    /// f(wo, wi) in the requested mode, without the cosine.
    pub f: Rgb,
    /// Solid-angle pdf with which `sample(wo)` yields `wi`.
    pub pdf_fwd: f32,
    /// Solid-angle pdf with which `sample(wi)` yields `wo`.
    pub pdf_rev: f32,
}

impl BsdfEval {
    pub const ZERO: BsdfEval = BsdfEval {
        f: Rgb::BLACK,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
    };

    /// `self` if every field is finite, otherwise zero.
    #[inline]
    fn finite_or_zero(self) -> BsdfEval {
        if self.f.is_finite() && self.pdf_fwd.is_finite() && self.pdf_rev.is_finite() {
            self
        } else {
            BsdfEval::ZERO
        }
    }
}

/// A sampled direction with everything a path needs to continue.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction (local frame from [`Bsdf::sample`], world from [`SurfaceBsdf::sample`]).
    pub wi: Vec3,
    /// f(wo, wi) in the requested mode, summed over all lobes (delta samples: see the crate docs).
    pub f: Rgb,
    /// Solid-angle pdf of `wi` over all lobes (delta samples: the lobe's selection probability).
    pub pdf: f32,
    /// f·|cos θi| / pdf: the factor a path throughput is multiplied by.
    pub weight: Rgb,
    /// The class of the lobe that was sampled.
    pub lobe: LobeClass,
    /// Whether `wi` is on the other side of the surface from `wo`.
    pub transmission: bool,
    /// Relative index crossed: η of `wi`'s side over η of `wo`'s side (pbrt-v4's `etap`); 1 for
    /// reflection.
    pub eta: f32,
    /// Whether the sampled lobe is a Dirac delta (then `f` and `pdf` follow the delta convention).
    pub delta: bool,
}

impl BsdfSample {
    /// A sample in the local frame; `transmitted_eta` is `Some(η′)` for refraction. `weight` is
    /// derived here so that every variant obeys `weight = f·|cos θi| / pdf`.
    #[inline]
    pub(crate) fn new(
        wi: Vec3,
        f: Rgb,
        pdf: f32,
        lobe: LobeClass,
        transmitted_eta: Option<f32>,
    ) -> BsdfSample {
        BsdfSample {
            wi,
            f,
            pdf,
            weight: f * (wi.z.abs() / pdf),
            lobe,
            transmission: transmitted_eta.is_some(),
            eta: transmitted_eta.unwrap_or(1.0),
            delta: lobe == LobeClass::Specular,
        }
    }

    #[inline]
    fn is_finite_and_positive(&self) -> bool {
        self.pdf > 0.0
            && self.pdf.is_finite()
            && self.f.is_finite()
            && self.weight.is_finite()
            && self.wi.is_finite()
            && self.eta.is_finite()
    }
}

/// A BSDF in the local shading frame (normal = +z). `Copy`, at most 48 bytes (design.md).
///
/// | variant | parameter | meaning |
/// | --- | --- | --- |
/// | `Diffuse` | `albedo` | Lambertian reflectance; two-sided (reflects on whichever side `wo` is) |
/// | `Mirror` | `reflectance` | perfect specular reflection, two-sided |
/// | `Conductor` | `eta`, `k` | smooth metal: specular reflection weighted by the conductor Fresnel term for complex IOR η + ik per channel; two-sided |
/// | `ThinDielectric` | `eta` | a thin sheet of glass: reflection 2R/(1 + R) (inter-reflections summed), the rest transmitted straight through; two-sided |
/// | `Dielectric` | `eta` | smooth glass, η = IOR inside / IOR outside, outside = +z side; exact unpolarised Fresnel |
/// | `RoughConductor` | `alpha`, `eta`, `k`, `distribution` | GGX or Beckmann, anisotropic α (x along the frame's `s`, y along `t`), height-correlated Smith G2, conductor Fresnel with complex IOR η + ik per channel, VNDF sampling; two-sided |
/// | `RoughDielectric` | `alpha`, `eta`, `distribution` | Walter et al. 2007 rough glass with GGX or Beckmann (VNDF sampling), Fresnel choice of reflection or refraction. η = 1 makes the interface invisible and this model degenerate: it then transmits nothing (pbrt-v4 switches to a pass-through; use no surface instead) |
/// | `Phong` | `kd`, `ks`, `exponent` | modified Phong (Lafortune & Willems 1994), energy-conserving when kd + ks ≤ 1; two-sided |
/// | `Plastic` | [`Plastic`]: `kd`, `ks`, `eta`, `nonlinear` | a Lambertian base under a smooth dielectric coating (Mitsuba 3's `plastic`): a delta reflection ks·F plus the base seen through the coating; two-sided |
/// | `RoughPlastic` | [`RoughPlastic`]: `kd`, `ks`, `nonlinear`, [`Coating`] (distribution, isotropic α, `eta`) | the base under a rough dielectric coating (Mitsuba 3's `roughplastic`): microfacet reflection ks·F·D·G2 plus the base seen through the coating's tabulated transmittance; two-sided |
///
/// Roughness below [`ALPHA_MIN`] is raised to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse {
        albedo: Rgb,
    },
    Mirror {
        reflectance: Rgb,
    },
    Conductor {
        eta: Rgb,
        k: Rgb,
    },
    ThinDielectric {
        eta: f32,
    },
    Dielectric {
        eta: f32,
    },
    RoughConductor {
        alpha: Vec2,
        eta: Rgb,
        k: Rgb,
        distribution: Distribution,
    },
    RoughDielectric {
        alpha: Vec2,
        eta: f32,
        distribution: Distribution,
    },
    Phong {
        kd: Rgb,
        ks: Rgb,
        exponent: f32,
    },
    Plastic(Plastic),
    RoughPlastic(RoughPlastic),
}

impl Bsdf {
    /// f(wo, wi) (without the cosine) and both pdfs, local frame. Delta lobes contribute zero.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        let e = match *self {
            Bsdf::Diffuse { albedo } => diffuse::eval(albedo, wo, wi),
            Bsdf::Mirror { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Dielectric { .. } => BsdfEval::ZERO,
            Bsdf::RoughConductor {
                alpha,
                eta,
                k,
                distribution,
            } => RoughConductor::new(distribution, alpha, eta, k).eval(wo, wi),
            Bsdf::RoughDielectric {
                alpha,
                eta,
                distribution,
            } => RoughDielectric::new(distribution, alpha, eta).eval(wo, wi, mode),
            Bsdf::Phong { kd, ks, exponent } => Phong::new(kd, ks, exponent).eval(wo, wi),
            Bsdf::Plastic(p) => p.eval(wo, wi),
            Bsdf::RoughPlastic(p) => p.eval(wo, wi),
        };
        e.finite_or_zero()
    }

    /// Samples `wi` given `wo` (local frame): `u_lobe` chooses among lobes, `u` the direction.
    /// `None` when `wo.z == 0`, when the sample is lost (e.g. reflected below the surface), or when
    /// its pdf is zero or any result is not finite.
    #[inline]
    pub fn sample(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        let s = match *self {
            Bsdf::Diffuse { albedo } => Some(diffuse::sample(albedo, wo, u)),
            Bsdf::Mirror { reflectance } => Some(specular::sample_mirror(reflectance, wo)),
            Bsdf::Conductor { eta, k } => Some(specular::sample_conductor(eta, k, wo)),
            Bsdf::ThinDielectric { eta } => Some(specular::sample_thin_dielectric(eta, wo, u_lobe)),
            Bsdf::Dielectric { eta } => specular::sample_dielectric(eta, wo, u_lobe, mode),
            Bsdf::RoughConductor {
                alpha,
                eta,
                k,
                distribution,
            } => RoughConductor::new(distribution, alpha, eta, k).sample(wo, u),
            Bsdf::RoughDielectric {
                alpha,
                eta,
                distribution,
            } => RoughDielectric::new(distribution, alpha, eta).sample(wo, u_lobe, u, mode),
            Bsdf::Phong { kd, ks, exponent } => Phong::new(kd, ks, exponent).sample(wo, u_lobe, u),
            Bsdf::Plastic(p) => Some(p.sample(wo, u_lobe, u)),
            Bsdf::RoughPlastic(p) => p.sample(wo, u_lobe, u),
        }?;
        s.is_finite_and_positive().then_some(s)
    }

    /// Solid-angle pdf with which `sample(wo)` yields `wi`; equals `eval(wo, wi, _).pdf_fwd`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let pdf = match *self {
            Bsdf::Diffuse { .. } => diffuse::pdf(wo, wi),
            Bsdf::Mirror { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Dielectric { .. } => 0.0,
            Bsdf::RoughConductor {
                alpha,
                eta,
                k,
                distribution,
            } => RoughConductor::new(distribution, alpha, eta, k).pdf(wo, wi),
            Bsdf::RoughDielectric {
                alpha,
                eta,
                distribution,
            } => RoughDielectric::new(distribution, alpha, eta).pdf(wo, wi),
            Bsdf::Phong { kd, ks, exponent } => Phong::new(kd, ks, exponent).pdf(wo, wi),
            Bsdf::Plastic(p) => p.pdf(wo, wi),
            Bsdf::RoughPlastic(p) => p.pdf(wo, wi),
        };
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    /// Probability that [`Bsdf::sample`] takes a Dirac-delta lobe for `wo` (local frame): 1 when
    /// [`Bsdf::is_delta`], 0 without delta lobes, in between for a BSDF mixing both (`Plastic`).
    /// `sample` picks a delta lobe exactly when `u_lobe` is below it.
    #[inline]
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        match self {
            Bsdf::Plastic(p) => p.specular_probability(wo),
            _ if self.is_delta() => 1.0,
            _ => 0.0,
        }
    }

    /// Whether some lobes are Dirac deltas and others not, so that a vertex's delta flag depends
    /// on the sample drawn there.
    #[inline]
    pub fn mixes_delta(&self) -> bool {
        matches!(self, Bsdf::Plastic(_))
    }

    /// Whether every lobe is a Dirac delta, so that `eval` and `pdf` are always zero.
    #[inline]
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Bsdf::Mirror { .. }
                | Bsdf::Conductor { .. }
                | Bsdf::ThinDielectric { .. }
                | Bsdf::Dielectric { .. }
        )
    }

    /// Heckbert class of the material as a whole — of what `eval` sees, for a BSDF that mixes
    /// delta lobes in (`Plastic` is `D`; a path leaving it by its delta lobe records `S` there);
    /// `RoughPlastic` is its coating's class, as `Phong` is `G` (a diffuse base under a glossy
    /// coating scatters glossily as a whole):
    /// `Diffuse` and microfacet surfaces at least as rough as [`DIFFUSE_ALPHA`] are `D`, `Mirror`, `Conductor`, `ThinDielectric` and smooth `Dielectric` are `S`, smoother
    /// microfacet surfaces and `Phong` are `G`. A Phong sample still reports
    /// [`LobeClass::Diffuse`] in [`BsdfSample::lobe`] when its diffuse lobe was chosen.
    #[inline]
    pub fn lobe_class(&self) -> LobeClass {
        match self {
            Bsdf::Diffuse { .. } | Bsdf::Plastic(_) => LobeClass::Diffuse,
            Bsdf::Mirror { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Dielectric { .. } => LobeClass::Specular,
            Bsdf::RoughConductor { alpha, .. } | Bsdf::RoughDielectric { alpha, .. } => {
                if alpha.min_element() >= DIFFUSE_ALPHA {
                    LobeClass::Diffuse
                } else {
                    LobeClass::Glossy
                }
            }
            Bsdf::RoughPlastic(p) => {
                if p.coating.alpha >= DIFFUSE_ALPHA {
                    LobeClass::Diffuse
                } else {
                    LobeClass::Glossy
                }
            }
            Bsdf::Phong { .. } => LobeClass::Glossy,
        }
    }
}

/// GGX roughness from which a microfacet surface counts as diffuse (`D`) in path classes: at
/// α = 0.5 the lobe's half-width exceeds 25°, and its reflection no longer images its
/// surroundings.
pub const DIFFUSE_ALPHA: f32 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bsdf_fits_in_48_bytes() {
        assert!(
            std::mem::size_of::<Bsdf>() <= 48,
            "size_of::<Bsdf>() = {}",
            std::mem::size_of::<Bsdf>()
        );
    }

    #[test]
    fn lobe_classes_and_delta_flags_follow_heckbert() {
        let rough = Vec2::splat(0.2);
        let cases = [
            (
                Bsdf::Diffuse { albedo: Rgb::WHITE },
                LobeClass::Diffuse,
                false,
            ),
            (
                Bsdf::Mirror {
                    reflectance: Rgb::WHITE,
                },
                LobeClass::Specular,
                true,
            ),
            (Bsdf::Dielectric { eta: 1.5 }, LobeClass::Specular, true),
            (
                Bsdf::RoughConductor {
                    alpha: rough,
                    eta: Rgb::WHITE,
                    k: Rgb::WHITE,
                    distribution: Distribution::Ggx,
                },
                LobeClass::Glossy,
                false,
            ),
            (
                Bsdf::RoughDielectric {
                    alpha: rough,
                    eta: 1.5,
                    distribution: Distribution::Beckmann,
                },
                LobeClass::Glossy,
                false,
            ),
            (
                Bsdf::RoughConductor {
                    alpha: Vec2::new(0.5, 0.7),
                    eta: Rgb::WHITE,
                    k: Rgb::WHITE,
                    distribution: Distribution::Ggx,
                },
                LobeClass::Diffuse,
                false,
            ),
            (
                Bsdf::Phong {
                    kd: Rgb::splat(0.5),
                    ks: Rgb::splat(0.5),
                    exponent: 10.0,
                },
                LobeClass::Glossy,
                false,
            ),
            (
                Bsdf::RoughPlastic(RoughPlastic::new(
                    Rgb::splat(0.5),
                    Rgb::WHITE,
                    Distribution::Ggx,
                    0.2,
                    1.5,
                    false,
                )),
                LobeClass::Glossy,
                false,
            ),
            (
                Bsdf::RoughPlastic(RoughPlastic::new(
                    Rgb::splat(0.5),
                    Rgb::WHITE,
                    Distribution::Beckmann,
                    0.5,
                    1.5,
                    false,
                )),
                LobeClass::Diffuse,
                false,
            ),
        ];
        for (bsdf, class, delta) in cases {
            assert_eq!(bsdf.lobe_class(), class, "{bsdf:?}");
            assert_eq!(bsdf.is_delta(), delta, "{bsdf:?}");
            let s = bsdf
                .sample(
                    Vec3::new(0.0, 0.6, 0.8),
                    0.99,
                    Vec2::new(0.3, 0.6),
                    TransportMode::Radiance,
                )
                .unwrap();
            assert_eq!(s.delta, delta, "{bsdf:?}");
            if bsdf.is_delta() {
                assert_eq!(s.lobe, LobeClass::Specular);
            }
        }
    }
}
