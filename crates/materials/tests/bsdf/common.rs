//! Shared test fixtures: parameter sets for every variant, awkward directions, random helpers.

use lightlab_core::{Rgb, TransportMode, Vec2, Vec3};
use lightlab_materials::{Bsdf, Distribution, Plastic, RoughPlastic};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

pub const MODES: [TransportMode; 2] = [TransportMode::Radiance, TransportMode::Importance];

/// Roughness sets the brief asks for: near-specular, glossy, rough, very rough, anisotropic.
pub const ALPHAS: [Vec2; 5] = [
    Vec2::new(1e-3, 1e-3),
    Vec2::new(0.05, 0.05),
    Vec2::new(0.3, 0.3),
    Vec2::new(1.0, 1.0),
    Vec2::new(0.1, 0.6),
];

/// Relative indices: glass seen from outside, and the same interface with the sides swapped.
pub const ETAS: [f32; 2] = [1.5, 1.0 / 1.5];

pub const PHONG_EXPONENTS: [f32; 3] = [1.0, 20.0, 1000.0];

/// Gold (pbrt-v4 "metal-Au" at roughly 650/550/450 nm).
pub const GOLD_ETA: Rgb = Rgb::new(0.143, 0.374, 1.442);
pub const GOLD_K: Rgb = Rgb::new(3.983, 2.385, 1.603);

pub fn diffuse() -> Bsdf {
    Bsdf::Diffuse {
        albedo: Rgb::new(0.8, 0.5, 0.2),
    }
}

pub fn mirror() -> Bsdf {
    Bsdf::Mirror {
        reflectance: Rgb::new(0.9, 0.6, 0.3),
    }
}

/// Both microfacet distributions.
pub const DISTRIBUTIONS: [Distribution; 2] = [Distribution::Ggx, Distribution::Beckmann];

pub fn rough_conductor(alpha: Vec2) -> Bsdf {
    Bsdf::RoughConductor {
        alpha,
        eta: GOLD_ETA,
        k: GOLD_K,
        distribution: Distribution::Ggx,
    }
}

pub fn phong(exponent: f32) -> Bsdf {
    Bsdf::Phong {
        kd: Rgb::new(0.5, 0.3, 0.2),
        ks: Rgb::new(0.4, 0.5, 0.3),
        exponent,
    }
}

/// Gold at every test roughness, with GGX and with Beckmann normals.
pub fn rough_conductors() -> Vec<Bsdf> {
    DISTRIBUTIONS
        .iter()
        .flat_map(|&distribution| {
            ALPHAS.iter().map(move |&alpha| Bsdf::RoughConductor {
                alpha,
                eta: GOLD_ETA,
                k: GOLD_K,
                distribution,
            })
        })
        .collect()
}

/// Glass at every test roughness and both relative indices, with GGX and with Beckmann normals.
pub fn rough_dielectrics() -> Vec<Bsdf> {
    DISTRIBUTIONS
        .iter()
        .flat_map(|&distribution| {
            ALPHAS.iter().flat_map(move |&alpha| {
                ETAS.iter().map(move |&eta| Bsdf::RoughDielectric {
                    alpha,
                    eta,
                    distribution,
                })
            })
        })
        .collect()
}

/// Smooth plastic with a coloured base and coating factor, linear and nonlinear, on glass-like
/// coating (η = 1.5) and on a coating less dense than the outside (η = 1/1.5, total internal
/// reflection beyond 42°).
pub fn plastics() -> Vec<Bsdf> {
    ETAS.iter()
        .flat_map(|&eta| {
            [false, true].map(|nonlinear| {
                Bsdf::Plastic(Plastic::new(
                    Rgb::new(0.7, 0.4, 0.2),
                    Rgb::new(1.0, 0.8, 0.9),
                    eta,
                    nonlinear,
                ))
            })
        })
        .collect()
}

/// Rough plastic with the same base and coating factor: near-specular GGX (α = 0.05) and fully
/// rough GGX (α = 1) on glass, GGX α = 0.3 on the inverted interface η = 1/1.5, Beckmann α = 0.3;
/// linear and nonlinear.
pub fn rough_plastics() -> Vec<Bsdf> {
    [
        (Distribution::Ggx, 0.05, 1.5, false),
        (Distribution::Ggx, 0.3, 1.0 / 1.5, true),
        (Distribution::Beckmann, 0.3, 1.5, true),
        (Distribution::Ggx, 1.0, 1.5, false),
    ]
    .map(|(distribution, alpha, eta, nonlinear)| {
        Bsdf::RoughPlastic(RoughPlastic::new(
            Rgb::new(0.7, 0.4, 0.2),
            Rgb::new(1.0, 0.8, 0.9),
            distribution,
            alpha,
            eta,
            nonlinear,
        ))
    })
    .to_vec()
}

pub fn phongs() -> Vec<Bsdf> {
    PHONG_EXPONENTS.iter().map(|&n| phong(n)).collect()
}

pub fn dielectrics() -> Vec<Bsdf> {
    ETAS.iter().map(|&eta| Bsdf::Dielectric { eta }).collect()
}

/// Direction at polar angle `theta` from +z and azimuth `phi`.
pub fn dir(theta: f32, phi: f32) -> Vec3 {
    let (s, c) = theta.sin_cos();
    Vec3::new(s * phi.cos(), s * phi.sin(), c)
}

pub const GRAZING: f32 = std::f32::consts::FRAC_PI_2 - 1e-3;

/// Normal incidence, 45°, and grazing (10⁻³ rad above the horizon), at azimuths that are not
/// aligned with the anisotropy axes.
pub fn wos_upper() -> Vec<Vec3> {
    vec![
        Vec3::Z,
        dir(std::f32::consts::FRAC_PI_4, 0.7),
        dir(GRAZING, 2.3),
    ]
}

/// The same three incidences on both sides of the surface (two-sided materials, and dielectrics
/// seen from inside).
pub fn wos_both_sides() -> Vec<Vec3> {
    wos_upper()
        .into_iter()
        .flat_map(|w| [w, Vec3::new(w.x, w.y, -w.z)])
        .collect()
}

pub fn rng(seed: u64) -> Pcg32 {
    Pcg32::seed_from_u64(seed)
}

pub fn uniform2(rng: &mut Pcg32) -> Vec2 {
    Vec2::new(rng.random::<f32>(), rng.random::<f32>())
}

/// Uniform direction on the unit sphere (pdf 1/4π).
pub fn uniform_sphere(rng: &mut Pcg32) -> Vec3 {
    lightlab_samplers::warp::square_to_uniform_sphere(uniform2(rng))
}

/// |a − b| ≤ rel·max(|a|, |b|), with a clear message.
pub fn assert_rel(a: f32, b: f32, rel: f32, what: &dyn Fn() -> String) {
    let scale = a.abs().max(b.abs());
    assert!(
        (a - b).abs() <= rel * scale,
        "{}: {a} vs {b} (relative difference {}, tolerance {rel})",
        what(),
        (a - b).abs() / scale
    );
}

pub fn assert_rgb_rel(a: Rgb, b: Rgb, rel: f32, what: &dyn Fn() -> String) {
    for c in 0..3 {
        assert_rel(a[c], b[c], rel, &|| format!("{} (channel {c})", what()));
    }
}

/// Mean and standard error of the mean of a sample, per channel, accumulated in f64.
#[derive(Default)]
pub struct MeanEstimate {
    n: u64,
    sum: [f64; 3],
    sum_sq: [f64; 3],
}

impl MeanEstimate {
    pub fn add(&mut self, x: Rgb) {
        self.n += 1;
        for c in 0..3 {
            let v = x[c] as f64;
            self.sum[c] += v;
            self.sum_sq[c] += v * v;
        }
    }
    pub fn add_scalar(&mut self, x: f32) {
        self.add(Rgb::splat(x));
    }
    pub fn mean(&self, c: usize) -> f64 {
        self.sum[c] / self.n as f64
    }
    /// Standard error of the mean.
    pub fn sigma(&self, c: usize) -> f64 {
        let n = self.n as f64;
        let mean = self.mean(c);
        ((self.sum_sq[c] / n - mean * mean).max(0.0) / (n - 1.0)).sqrt()
    }
}
