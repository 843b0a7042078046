//! The anisotropic Trowbridge–Reitz (GGX) microfacet distribution with Smith masking: normal
//! distribution D, Λ, the masking term G1, height-correlated masking-shadowing G2, and sampling of the
//! distribution of visible normals.
//!
//! Everything is in the local shading frame (normal on +z); αx scales slopes along +x (the frame's
//! `s`, i.e. `dpdu`), αy along +y. Microfacet normals `m` live in the upper hemisphere.
//!
//! Numerics: α is clamped to at least [`ALPHA_MIN`]. D is written in the form of Heitz 2018, eq. 1,
//! `1 / (π αx αy (x²/αx² + y²/αy² + z²)²)`, whose denominator is ≥ π αx αy · min(1, 1/α²)² for any
//! unit `m`, so D stays finite (≤ 1/(π·10⁻⁸) ≈ 3.2·10⁷ at α = 10⁻⁴) with no tan θ to overflow. Λ is
//! written without the cancellation of `(−1 + √(1 + a))/2`, and is +∞ (G1 = G2 = 0) exactly at the
//! horizon.

use glam::{Vec2, Vec3};
use lightlab_core::PI;

/// Smallest roughness used: smaller α (including 0) is raised to this. At α = 10⁻⁴ a lobe is
/// ~0.01° wide, indistinguishable from a mirror in any scene we render, while D, the pdfs and f
/// stay far from f32 overflow even at grazing angles. Use `Bsdf::Mirror` / `Bsdf::Dielectric` for
/// truly smooth surfaces.
pub const ALPHA_MIN: f32 = 1e-4;

/// GGX with roughness (αx, αy), both ≥ [`ALPHA_MIN`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ggx {
    ax: f32,
    ay: f32,
}

impl Ggx {
    /// Clamps α to [`ALPHA_MIN`] (a NaN component also becomes `ALPHA_MIN`).
    #[inline]
    pub(crate) fn new(alpha: Vec2) -> Ggx {
        Ggx {
            ax: alpha.x.max(ALPHA_MIN),
            ay: alpha.y.max(ALPHA_MIN),
        }
    }

    /// Normal distribution D(m) (Walter et al. 2007, eq. 33; anisotropic form of Heitz 2018, eq. 1).
    /// Zero for `m` at or below the horizon.
    #[inline]
    pub(crate) fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (sx, sy) = (m.x / self.ax, m.y / self.ay);
        let e = sx * sx + sy * sy + m.z * m.z;
        1.0 / (PI * self.ax * self.ay * e * e)
    }

    /// Smith's Λ(w) for GGX (Heitz 2014, "Understanding the Masking-Shadowing Function"; anisotropic
    /// form as Heitz 2018, eq. 2): Λ = (−1 + √(1 + α²tan²θ)) / 2 with
    /// α²tan²θ = (αx²x² + αy²y²) / z², evaluated as
    /// a / (2(1 + √(1 + a))) to avoid cancellation. Depends only on |z|; +∞ at the horizon.
    #[inline]
    pub(crate) fn lambda(&self, w: Vec3) -> f32 {
        let (x, y) = (self.ax * w.x, self.ay * w.y);
        let a = (x * x + y * y) / (w.z * w.z);
        if !a.is_finite() {
            return f32::INFINITY;
        }
        a / (2.0 * (1.0 + (1.0 + a).sqrt()))
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
    /// both sides of the surface as pbrt-v4 §9.6.4 does): the solid-angle density
    /// of the normal returned by [`Ggx::sample_visible`]. Callers discard microfacets that face away
    /// from `w`; for them this is not a density.
    #[inline]
    pub(crate) fn d_visible(&self, w: Vec3, m: Vec3) -> f32 {
        self.g1(w) / w.z.abs() * self.d(m) * w.dot(m).abs()
    }

    /// Samples a microfacet normal from the distribution of normals visible from `w` (Heitz 2018,
    /// "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), Listing 1). A `w` below the
    /// surface is replaced by −w first (pbrt-v4 `Sample_wm`), so the result, always in the upper
    /// hemisphere, faces −w; its density is still [`Ggx::d_visible`].
    #[inline]
    pub(crate) fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
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

    /// ∫ D(m) cos θm dωm = 1: the microsurface projects onto unit macro area (Heitz 2014).
    #[test]
    fn ggx_projected_area_is_one() {
        for alpha in ALPHAS {
            let ggx = Ggx::new(alpha);
            let area = integrate_hemisphere(1500, |m| ggx.d(m) as f64 * m.z as f64);
            assert!((area - 1.0).abs() < 2e-3, "alpha {alpha}: {area}");
        }
    }

    /// ∫ G1(v) max(0, v·m) D(m) dωm = v.z: the visible-normal density integrates to one (Heitz 2014,
    /// projected-area constraint with Smith's G1). This pins Λ down, including its anisotropic form.
    #[test]
    fn visible_normal_density_is_normalised() {
        for alpha in ALPHAS {
            let ggx = Ggx::new(alpha);
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
        for alpha in ALPHAS {
            let ggx = Ggx::new(alpha);
            assert_eq!(ggx.g1(Vec3::Z), 1.0);
            assert_eq!(ggx.g1(Vec3::X), 0.0);
            assert_eq!(ggx.g2(Vec3::X, Vec3::Z), 0.0);
            let g = ggx.g1(Vec3::new(0.6, 0.0, 0.8));
            assert!(g > 0.0 && g < 1.0);
        }
    }

    #[test]
    fn extreme_roughness_stays_finite() {
        let ggx = Ggx::new(Vec2::ZERO);
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
                let m = ggx.sample_visible(w, u);
                assert!(m.is_finite() && m.z >= 0.0, "w {w} u {u}: {m}");
            }
        }
    }
}
