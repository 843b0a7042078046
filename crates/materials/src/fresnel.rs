//! Fresnel equations for unpolarised light and the directions they go with: the mirror reflection
//! and Snell's-law refraction (pbrt-v4 §9.3).
//!
//! `eta` is always a *relative* index of refraction, η = η_inside / η_outside, with the outside on the
//! side the normal points into.

use glam::Vec3;
use lightlab_core::Rgb;
use std::ops::{Add, Div, Mul, Sub};

/// Reflectance of a smooth dielectric interface for unpolarised light (pbrt-v4 §9.3.5,
/// `FrDielectric`): the mean of the squared parallel and perpendicular amplitude coefficients.
/// `cos_i` is the cosine of the incident direction with the normal; a negative value means the
/// light arrives from inside, so η is inverted. Returns 1 under total internal reflection.
#[inline]
pub(crate) fn dielectric(cos_i: f32, eta: f32) -> f32 {
    let (cos_i, eta) = if cos_i < 0.0 {
        (-cos_i.max(-1.0), 1.0 / eta)
    } else {
        (cos_i.min(1.0), eta)
    };
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 || sin2_t.is_nan() {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r = 0.5 * (r_parl * r_parl + r_perp * r_perp);
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Hemispherical-average (cosine-weighted) reflectance of a smooth dielectric interface seen from
/// the side where the relative index is `eta`: F_dr(η) = 2 ∫₀¹ F(μ, η) μ dμ, the fraction of
/// diffuse (Lambertian) light the interface reflects back (Egan & Hilgeman 1973 and d'Eon & Irving
/// 2011 fit it; here it is integrated exactly). For η < 1 the rays beyond the critical angle are
/// totally reflected (μ < μ_c = √(1 − η²) contributes μ_c²) and the rest is integrated over cos θt,
/// where the integrand is smooth (μ dμ = η² t dt); Simpson's rule in f64, error below 10⁻⁹.
pub(crate) fn diffuse_reflectance(eta: f32) -> f32 {
    let eta = f64::from(eta);
    // Fresnel reflectance from the incident and transmitted cosines.
    let f = |ci: f64, ct: f64| {
        if ci + ct == 0.0 {
            return 1.0; // grazing incidence at a matched interface
        }
        let r_parl = (eta * ci - ct) / (eta * ci + ct);
        let r_perp = (ci - eta * ct) / (ci + eta * ct);
        0.5 * (r_parl * r_parl + r_perp * r_perp)
    };
    let simpson = |g: &dyn Fn(f64) -> f64| {
        const N: usize = 1024;
        let h = 1.0 / N as f64;
        let inner: f64 = (1..N)
            .map(|i| g(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (g(0.0) + g(1.0) + inner) * h / 3.0
    };
    let r = if eta >= 1.0 {
        2.0 * simpson(&|mu| {
            let ct = (1.0 - (1.0 - mu * mu) / (eta * eta)).sqrt();
            f(mu, ct) * mu
        })
    } else {
        let mu_c2 = 1.0 - eta * eta;
        mu_c2
            + 2.0
                * eta
                * eta
                * simpson(&|t| {
                    let mu = (mu_c2 + eta * eta * t * t).sqrt();
                    f(mu, t) * t
                })
    };
    r as f32
}

/// Reflectance of a conductor with complex relative index η + i·k, per channel (pbrt-v4 §9.3.6,
/// `FrComplex`): the dielectric formula evaluated in complex arithmetic. `cos_i` is clamped to [0, 1].
#[inline]
pub(crate) fn conductor(cos_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    Rgb::new(
        conductor_channel(cos_i, Complex::new(eta.r, k.r)),
        conductor_channel(cos_i, Complex::new(eta.g, k.g)),
        conductor_channel(cos_i, Complex::new(eta.b, k.b)),
    )
}

#[inline]
fn conductor_channel(cos_i: f32, eta: Complex) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_i = Complex::real(1.0 - cos_i * cos_i);
    let sin2_t = sin2_i / (eta * eta);
    let cos_t = (Complex::real(1.0) - sin2_t).sqrt();
    let ci = Complex::real(cos_i);
    let r_parl = (eta * ci - cos_t) / (eta * ci + cos_t);
    let r_perp = (ci - eta * cos_t) / (ci + eta * cos_t);
    let r = 0.5 * (r_parl.norm() + r_perp.norm());
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Mirror reflection of `w` about the unit normal `n` (pbrt-v4 §9.3, `Reflect`), both pointing away.
#[inline]
pub(crate) fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    -w + 2.0 * w.dot(n) * n
}

/// Refraction of `w` (pointing away from the surface) through the interface with normal `n` and
/// relative index `eta` (pbrt-v4 §9.3, `Refract`). When `w` is on the side opposite to `n`, the
/// normal is flipped and η inverted. Returns the transmitted direction and the relative index η′
/// crossed (η of the transmitted side over η of `w`'s side), or `None` under total internal
/// reflection.
#[inline]
pub(crate) fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let mut cos_i = n.dot(w);
    let (n, eta) = if cos_i < 0.0 {
        cos_i = -cos_i;
        (-n, 1.0 / eta)
    } else {
        (n, eta)
    };
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 || sin2_t.is_nan() {
        return None;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    Some((-w / eta + (cos_i / eta - cos_t) * n, eta))
}

/// Just enough complex arithmetic for [`conductor`].
#[derive(Clone, Copy, Debug)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    const fn new(re: f32, im: f32) -> Complex {
        Complex { re, im }
    }
    const fn real(re: f32) -> Complex {
        Complex { re, im: 0.0 }
    }
    /// |z|².
    fn norm(self) -> f32 {
        self.re * self.re + self.im * self.im
    }
    /// Principal square root (pbrt-v4 `pstd::sqrt(complex)`), which has a non-negative real part.
    fn sqrt(self) -> Complex {
        let n = self.re.hypot(self.im);
        if n == 0.0 {
            return Complex::real(0.0);
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Complex::new(t1, t2)
        } else {
            Complex::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

impl Add for Complex {
    type Output = Complex;
    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
}
impl Sub for Complex {
    type Output = Complex;
    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
}
impl Mul for Complex {
    type Output = Complex;
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}
impl Div for Complex {
    type Output = Complex;
    fn div(self, o: Complex) -> Complex {
        let scale = 1.0 / o.norm();
        Complex::new(
            scale * (self.re * o.re + self.im * o.im),
            scale * (self.im * o.re - self.re * o.im),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_fresnel_at_normal_incidence_is_schlick_f0() {
        for eta in [1.0001f32, 1.33, 1.5, 2.4, 4.0] {
            let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((dielectric(1.0, eta) - f0).abs() < 1e-6, "eta {eta}");
            // Arriving from inside at normal incidence reflects the same fraction.
            assert!(
                (dielectric(-1.0, eta) - f0).abs() < 1e-6,
                "eta {eta} inside"
            );
        }
    }

    #[test]
    fn dielectric_fresnel_is_one_under_total_internal_reflection_and_at_grazing() {
        let eta = 1.5f32;
        let cos_critical = (1.0 - 1.0 / (eta * eta)).sqrt();
        assert_eq!(dielectric(-(cos_critical - 1e-3), eta), 1.0);
        assert!(dielectric(-(cos_critical + 1e-3), eta) < 1.0);
        assert!((dielectric(0.0, eta) - 1.0).abs() < 1e-6);
    }

    /// Transmittance 1 − F is the same for the two directions of one refraction (Stokes relations).
    #[test]
    fn dielectric_fresnel_is_symmetric_under_reversal() {
        let eta = 1.5f32;
        for i in 1..50 {
            let cos_i = i as f32 / 50.0;
            let (wt, etap) = refract(
                Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i),
                Vec3::Z,
                eta,
            )
            .unwrap();
            assert_eq!(etap, eta);
            let back = dielectric(wt.z, eta);
            assert!(
                (dielectric(cos_i, eta) - back).abs() < 1e-5,
                "cos_i {cos_i}"
            );
        }
    }

    #[test]
    fn conductor_fresnel_at_normal_incidence_matches_closed_form() {
        let eta = Rgb::new(0.143, 0.374, 1.442);
        let k = Rgb::new(3.983, 2.385, 1.603);
        let f = conductor(1.0, eta, k);
        for c in 0..3 {
            let (n, k) = (eta[c], k[c]);
            let expect = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
            assert!(
                (f[c] - expect).abs() < 1e-5,
                "channel {c}: {} vs {expect}",
                f[c]
            );
        }
        assert!((conductor(0.0, eta, k).min_component() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn conductor_fresnel_reduces_to_dielectric_for_zero_k() {
        for i in 0..=20 {
            let cos_i = i as f32 / 20.0;
            for eta in [1.2f32, 1.5, 3.0] {
                let c = conductor(cos_i, Rgb::splat(eta), Rgb::BLACK);
                assert!(
                    (c.r - dielectric(cos_i, eta)).abs() < 1e-5,
                    "cos {cos_i} eta {eta}: {} vs {}",
                    c.r,
                    dielectric(cos_i, eta)
                );
            }
        }
    }

    #[test]
    fn refraction_obeys_snell_and_reverses() {
        for eta in [1.5f32, 1.0 / 1.5] {
            for i in 1..20 {
                let cos_i = i as f32 / 20.0;
                let w = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
                let Some((wt, etap)) = refract(w, Vec3::Z, eta) else {
                    assert!(eta < 1.0, "unexpected total internal reflection");
                    continue;
                };
                assert!((wt.length() - 1.0).abs() < 1e-5);
                assert!(wt.z < 0.0);
                let sin_i = w.x;
                let sin_t = (wt.x * wt.x + wt.y * wt.y).sqrt();
                assert!((sin_i - etap * sin_t).abs() < 1e-5, "Snell's law");
                let (back, etab) = refract(wt, Vec3::Z, eta).unwrap();
                assert!((back - w).length() < 1e-4);
                assert!((etab * etap - 1.0).abs() < 1e-6);
            }
        }
    }

    /// F_dr against the two published fits where their authors state them accurate (d'Eon & Irving
    /// 2011 for η > 1: 0.2 %; Egan & Hilgeman 1973 for η < 1 at glass-like indices: 0.6 %), zero for
    /// a vanishing interface, and the exact reciprocity of the interface:
    /// η² (1 − F_dr(1/η)) = 1 − F_dr(η) (the transmitted fractions in the two directions).
    #[test]
    fn diffuse_reflectance_matches_fits_and_reciprocity() {
        let d_eon = |eta: f32| {
            let x = 1.0 / eta;
            [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881]
                .iter()
                .rev()
                .fold(0.0, |acc, c| acc * x + c)
        };
        let egan = |eta: f32| 0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681;
        assert!(diffuse_reflectance(1.0).abs() < 1e-6);
        for eta in [1.1f32, 1.33, 1.5, 2.0, 3.0, 5.0] {
            let (ext, int) = (diffuse_reflectance(eta), diffuse_reflectance(1.0 / eta));
            assert!(
                (ext / d_eon(eta) - 1.0).abs() < 2e-3,
                "η = {eta}: {ext} vs {}",
                d_eon(eta)
            );
            if eta <= 2.0 {
                let e = egan(1.0 / eta);
                assert!((int / e - 1.0).abs() < 6e-3, "η = 1/{eta}: {int} vs {e}");
            }
            let (lhs, rhs) = (eta * eta * (1.0 - int), 1.0 - ext);
            assert!((lhs - rhs).abs() < 1e-5, "η = {eta}: {lhs} vs {rhs}");
        }
    }
}
