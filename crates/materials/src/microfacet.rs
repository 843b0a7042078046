//! Microfacet normal distributions with Smith masking: the anisotropic Trowbridge–Reitz (GGX) and
//! Beckmann distributions, their normal distribution D, Λ, the masking term G1, height-correlated
//! masking-shadowing G2, and the sampling of the microfacet normals visible from a direction (Heitz
//! 2018 for GGX, Heitz & d'Eon 2014 for Beckmann).
//!
//! Everything is in the local shading frame (normal on +z); αx scales slopes along +x (the frame's
//! `s`, i.e. `dpdu`), αy along +y. Microfacet normals `m` live in the upper hemisphere.
//!
//! Numerics: α is clamped to at least [`ALPHA_MIN`]. GGX's D is written in the form of Heitz 2018,
//! eq. 1, `1 / (π αx αy (x²/αx² + y²/αy² + z²)²)`, whose denominator is ≥ π αx αy · min(1, 1/α²)² for
//! any unit `m`, so D stays finite (≤ 1/(π·10⁻⁸) ≈ 3.2·10⁷ at α = 10⁻⁴) with no tan θ to overflow;
//! Beckmann's D is zero once its exponent passes 100 (e⁻¹⁰⁰ ≈ 4·10⁻⁴⁴). GGX's Λ is written without
//! the cancellation of `(−1 + √(1 + a))/2`, Beckmann's with erfc; both are +∞ (G1 = G2 = 0) exactly
//! at the horizon.

use glam::{Vec2, Vec3};
use lightlab_core::PI;

/// Smallest roughness used: smaller α (including 0) is raised to this. At α = 10⁻⁴ a lobe is
/// ~0.01° wide, indistinguishable from a mirror in any scene we render, while D, the pdfs and f
/// stay far from f32 overflow even at grazing angles. Use `Bsdf::Mirror` / `Bsdf::Dielectric` for
/// truly smooth surfaces.
pub const ALPHA_MIN: f32 = 1e-4;

/// The distribution of microfacet normals of a rough surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Distribution {
    /// Trowbridge–Reitz / GGX (Walter et al. 2007, eq. 33): long tails; sampled by visible normals
    /// (Heitz 2018).
    #[default]
    Ggx,
    /// Beckmann (Walter et al. 2007, eq. 25): Gaussian slopes; sampled by visible normals (Heitz &
    /// d'Eon 2014).
    Beckmann,
}

/// A microfacet distribution with roughness (αx, αy), both ≥ [`ALPHA_MIN`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Microfacet {
    kind: Distribution,
    ax: f32,
    ay: f32,
}

impl Microfacet {
    /// Clamps α to [`ALPHA_MIN`] (a NaN component also becomes `ALPHA_MIN`).
    #[inline]
    pub(crate) fn new(kind: Distribution, alpha: Vec2) -> Microfacet {
        Microfacet {
            kind,
            ax: alpha.x.max(ALPHA_MIN),
            ay: alpha.y.max(ALPHA_MIN),
        }
    }

    /// Normal distribution D(m). Zero for `m` at or below the horizon.
    ///
    /// GGX: Walter et al. 2007, eq. 33, anisotropic form of Heitz 2018, eq. 1. Beckmann: Walter et
    /// al. 2007, eq. 25, D = exp(−(x²/αx² + y²/αy²)/z²) / (π αx αy z⁴).
    #[inline]
    pub(crate) fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (sx, sy) = (m.x / self.ax, m.y / self.ay);
        match self.kind {
            Distribution::Ggx => {
                let e = sx * sx + sy * sy + m.z * m.z;
                1.0 / (PI * self.ax * self.ay * e * e)
            }
            Distribution::Beckmann => {
                let z2 = m.z * m.z;
                let e = (sx * sx + sy * sy) / z2;
                if !(e < 100.0) {
                    return 0.0;
                }
                (-e).exp() / (PI * self.ax * self.ay * z2 * z2)
            }
        }
    }

    /// Smith's Λ(w) (Heitz 2014, "Understanding the Masking-Shadowing Function", §5.3; anisotropic
    /// form as Heitz 2018, eq. 2), with α²tan²θ = (αx²x² + αy²y²) / z². Depends only on |z|; +∞
    /// at the horizon.
    ///
    /// GGX: Λ = (−1 + √(1 + α²tan²θ)) / 2, evaluated as a / (2(1 + √(1 + a))) to avoid
    /// cancellation. Beckmann: with a = 1/(α tan θ), Λ = (e^(−a²)/(a√π) − erfc(a)) / 2 (Heitz 2014,
    /// eq. 72 with erf − 1 = −erfc), in f64.
    #[inline]
    pub(crate) fn lambda(&self, w: Vec3) -> f32 {
        let (x, y) = (self.ax * w.x, self.ay * w.y);
        let a2 = (x * x + y * y) / (w.z * w.z);
        if !a2.is_finite() {
            return f32::INFINITY;
        }
        match self.kind {
            Distribution::Ggx => a2 / (2.0 * (1.0 + (1.0 + a2).sqrt())),
            Distribution::Beckmann => {
                if a2 == 0.0 {
                    return 0.0;
                }
                let a = 1.0 / (a2 as f64).sqrt();
                let l = ((-a * a).exp() / (a * std::f64::consts::PI.sqrt()) - libm::erfc(a)) / 2.0;
                l.max(0.0) as f32
            }
        }
    }

    /// Smith masking G1(w) = 1 / (1 + Λ(w)) (Heitz 2014), for microfacets facing `w`.
    #[inline]
    pub(crate) fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated Smith masking-shadowing G2 = 1 / (1 + Λ(wo) + Λ(wi)) (Heitz 2014, the
    /// height-correlated form). Used for reflection and, as pbrt-v4 does (§9.6.3, §9.7), for
    /// transmission too, where Heitz's exact height-correlated form is a Beta function of the two
    /// Λ; this one is symmetric in its arguments and ≤ G1(wo), so reciprocity and energy hold.
    #[inline]
    pub(crate) fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        // Λ(wo) + Λ(wi) first: addition commutes exactly, so G2(wo, wi) and G2(wi, wo) are the same bits.
        1.0 / (1.0 + (self.lambda(wo) + self.lambda(wi)))
    }

    /// Density of visible normals D_w(m) = G1(w) |w·m| D(m) / |w.z| (Heitz 2018, eq. 3, written for
    /// both sides of the surface as pbrt-v4 §9.6.4 does). Callers discard microfacets that face away
    /// from `w`; for them this is not a density.
    #[inline]
    pub(crate) fn d_visible(&self, w: Vec3, m: Vec3) -> f32 {
        self.g1(w) / w.z.abs() * self.d(m) * w.dot(m).abs()
    }

    /// Samples a microfacet normal visible from the direction `w` (upper hemisphere); its
    /// solid-angle density is [`Microfacet::normal_pdf`], D_w(m). A reflection about it has weight
    /// F·G2/G1(w) ≤ 1, however grazing `w` is.
    #[inline]
    pub(crate) fn sample_normal(&self, w: Vec3, u: Vec2) -> Vec3 {
        match self.kind {
            Distribution::Ggx => self.sample_visible(w, u),
            Distribution::Beckmann => self.sample_visible_beckmann(w, u),
        }
    }

    /// Solid-angle density with which reflecting `wo` about a sampled normal gives `wi`, for the half
    /// vector `h` of the pair (Walter et al. 2007, eq. 14, with visible normals: Heitz 2018, eq. 17):
    /// G1(wo) D(h) / (4 cos θo), written without wo·h so that it is the same bits however h was
    /// found.
    #[inline]
    pub(crate) fn reflection_pdf(&self, wo: Vec3, h: Vec3, _cos_h: f32) -> f32 {
        self.g1(wo) * self.d(h) / (4.0 * wo.z)
    }

    /// Solid-angle density of [`Microfacet::sample_normal`] at `m`, among the normals that face `w`.
    #[inline]
    pub(crate) fn normal_pdf(&self, w: Vec3, m: Vec3) -> f32 {
        self.d_visible(w, m)
    }

    /// Samples a microfacet normal from the Beckmann distribution of normals visible from `w`
    /// (Heitz & d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using the Distribution of
    /// Visible Normals", §4): stretch `w` to the configuration α = 1, sample the visible slopes
    /// there for its polar angle, rotate them to its azimuth and unstretch. A `w` below the surface
    /// is replaced by −w, as for GGX.
    fn sample_visible_beckmann(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        let wh = Vec3::new(self.ax * w.x, self.ay * w.y, w.z).normalize();
        let r = (wh.x * wh.x + wh.y * wh.y).sqrt();
        let (cos_phi, sin_phi) = if r > 0.0 {
            (wh.x / r, wh.y / r)
        } else {
            (1.0, 0.0)
        };
        let (x, y) = beckmann_visible_slopes(f64::from(wh.z.clamp(0.0, 1.0)), u);
        let (sx, sy) = (cos_phi * x - sin_phi * y, sin_phi * x + cos_phi * y);
        let m = Vec3::new(-self.ax * sx, -self.ay * sy, 1.0).normalize();
        if m.is_finite() { m } else { Vec3::Z }
    }

    /// Samples a microfacet normal from the GGX distribution of normals visible from `w` (Heitz
    /// 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), Listing 1). A `w` below
    /// the surface is replaced by −w first (pbrt-v4 `Sample_wm`), so the result, always in the upper
    /// hemisphere, faces −w; its density is still [`Microfacet::d_visible`].
    #[inline]
    fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        // §3.2: stretch the view direction into the configuration where α = 1 (a hemisphere).
        let vh = Vec3::new(self.ax * w.x, self.ay * w.y, w.z).normalize();
        // §4.1: orthonormal basis around vh (any T1 when vh is the pole).
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        // §4.2: uniform point on the projected hemisphere (disk with a warped far half).
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        // §4.3: reproject onto the hemisphere.
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        // §3.4: unstretch back to the ellipsoid configuration.
        Vec3::new(self.ax * nh.x, self.ay * nh.y, nh.z.max(0.0)).normalize()
    }
}

/// Slopes (x̃, ỹ) of a Beckmann normal (α = 1) visible from the direction at polar angle θ with
/// cos θ = `cos` and azimuth 0 (Heitz & d'Eon 2014, §4 and Appendix): the slope density is
/// P22(x̃, ỹ)·max(0, cos θ − x̃ sin θ) / (cos θ (1 + Λ)), Gaussian in ỹ and, in x̃ ≤ cot θ, of CDF
///
///   F(x̃) = k·(1 + erf x̃ + tan θ e^(−x̃²)/√π),  F′(x̃) = k·(2/√π) e^(−x̃²)(1 − x̃ tan θ),
///
/// k normalising F(cot θ) to 1. F(x̃) = u is solved by Newton's method safeguarded with bisection,
/// from Jakob's (2014, "An Improved Visible Normal Sampling Routine for the Beckmann
/// Distribution") fitted initial guess, in f64 to |F − u| < 10⁻⁷.
fn beckmann_visible_slopes(cos: f64, u: Vec2) -> (f32, f32) {
    use statrs::function::erf::erf_inv;
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    let (u1, u2) = (
        f64::from(u.x).clamp(1e-9, 1.0 - 1e-9),
        f64::from(u.y).clamp(1e-9, 1.0 - 1e-9),
    );
    let y = erf_inv(2.0 * u2 - 1.0) as f32;
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    if sin < 1e-7 {
        return (erf_inv(2.0 * u1 - 1.0) as f32, y);
    }
    let (tan, cot) = (sin / cos, cos / sin);
    let top = libm::erf(cot);
    let k = 1.0 / (1.0 + top + tan * INV_SQRT_PI * (-cot * cot).exp());
    let theta = cos.acos();
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    // erf x̃ = −1 + 10⁻¹⁶ at x̃ = −5.9: no sample lies below.
    let (mut lo, mut hi) = (-6.0f64, cot);
    let mut x = erf_inv(top - (1.0 + top) * (1.0 - u1).powf(fit));
    for _ in 0..32 {
        if !(x > lo && x < hi) {
            x = 0.5 * (lo + hi);
        }
        let g = (-x * x).exp();
        let value = k * (1.0 + libm::erf(x) + tan * INV_SQRT_PI * g) - u1;
        if value.abs() < 1e-7 {
            break;
        }
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        x -= value / (k * 2.0 * INV_SQRT_PI * g * (1.0 - x * tan));
    }
    (x.clamp(lo, hi) as f32, y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Midpoint quadrature over the upper hemisphere in (θ, φ) with `n_theta` × 4·`n_theta` cells.
    fn integrate_hemisphere(n_theta: usize, f: impl Fn(Vec3) -> f64) -> f64 {
        let n_phi = 4 * n_theta;
        let (d_theta, d_phi) = (
            std::f64::consts::FRAC_PI_2 / n_theta as f64,
            2.0 * std::f64::consts::PI / n_phi as f64,
        );
        let mut sum = 0.0;
        for i in 0..n_theta {
            let theta = (i as f64 + 0.5) * d_theta;
            let (st, ct) = theta.sin_cos();
            for j in 0..n_phi {
                let phi = (j as f64 + 0.5) * d_phi;
                let (sp, cp) = phi.sin_cos();
                let m = Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32);
                sum += f(m) * st * d_theta * d_phi;
            }
        }
        sum
    }

    const ALPHAS: [Vec2; 4] = [
        Vec2::new(0.1, 0.1),
        Vec2::new(0.3, 0.3),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.1, 0.6),
    ];

    const KINDS: [Distribution; 2] = [Distribution::Ggx, Distribution::Beckmann];

    /// Every distribution at every test roughness.
    fn all() -> impl Iterator<Item = (Vec2, Microfacet)> {
        KINDS
            .into_iter()
            .flat_map(|k| ALPHAS.into_iter().map(move |a| (a, Microfacet::new(k, a))))
    }

    /// ∫ D(m) cos θm dωm = 1: the microsurface projects onto unit macro area (Heitz 2014).
    #[test]
    fn projected_area_is_one() {
        for (alpha, ggx) in all() {
            let area = integrate_hemisphere(1500, |m| ggx.d(m) as f64 * m.z as f64);
            assert!((area - 1.0).abs() < 2e-3, "alpha {alpha}: {area}");
        }
    }

    /// ∫ G1(v) max(0, v·m) D(m) dωm = v.z: the visible-normal density integrates to one (Heitz 2014,
    /// projected-area constraint with Smith's G1). This pins Λ down, including its anisotropic form.
    #[test]
    fn visible_normal_density_is_normalised() {
        for (alpha, ggx) in all() {
            for (theta, phi) in [(0.0f32, 0.0f32), (0.8, 0.3), (1.3, 2.0), (1.5, 4.0)] {
                let v = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let total = integrate_hemisphere(1500, |m| {
                    if v.dot(m) > 0.0 {
                        ggx.d_visible(v, m) as f64
                    } else {
                        0.0
                    }
                });
                assert!(
                    (total - 1.0).abs() < 3e-3,
                    "alpha {alpha}, theta {theta}, phi {phi}: {total}"
                );
            }
        }
    }

    #[test]
    fn masking_is_one_at_normal_incidence_and_zero_at_the_horizon() {
        for (_, ggx) in all() {
            assert_eq!(ggx.g1(Vec3::Z), 1.0);
            assert_eq!(ggx.g1(Vec3::X), 0.0);
            assert_eq!(ggx.g2(Vec3::X, Vec3::Z), 0.0);
            // Grazing enough (tan θ = 7) that even Beckmann at α = 0.1 masks a little.
            let g = ggx.g1(Vec3::new(0.99, 0.0, 0.1414).normalize());
            assert!(g > 0.0 && g < 1.0);
        }
    }

    #[test]
    fn extreme_roughness_stays_finite() {
        for kind in KINDS {
            extreme_roughness_stays_finite_for(kind);
        }
    }

    fn extreme_roughness_stays_finite_for(kind: Distribution) {
        let ggx = Microfacet::new(kind, Vec2::ZERO);
        assert!(ggx.d(Vec3::Z).is_finite());
        assert!(ggx.d(Vec3::new(1.0, 0.0, 1e-30).normalize()).is_finite());
        let w = Vec3::new(1.0, 0.0, 1e-20).normalize();
        assert!(ggx.lambda(w).is_finite() || ggx.g1(w) == 0.0);
        for u in [
            Vec2::ZERO,
            Vec2::new(0.999_999_9, 0.5),
            Vec2::new(0.5, 0.999_999_9),
        ] {
            for w in [Vec3::Z, w, Vec3::new(0.0, -1.0, 1e-7).normalize()] {
                let m = ggx.sample_normal(w, u);
                assert!(m.is_finite() && m.z >= 0.0, "w {w} u {u}: {m}");
            }
        }
    }
}
