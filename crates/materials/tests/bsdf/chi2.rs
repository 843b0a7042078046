//! Chi-square goodness-of-fit tests that `sample()` draws directions with density `pdf()`, in the
//! manner of Mitsuba 3's `chi2.py`: histogram 500 000 samples over a 40 × 80 grid in (cos θ, φ)
//! (equal-area in solid angle), compute each cell's expected count by integrating pdf() over the cell
//! (adaptive 2D quadrature), pool cells expected below 5, and reject when the p-value is below 10⁻⁴.
//! That is the false-failure probability per (BSDF, wo) case for a random seed; seeds are fixed, so
//! results are deterministic.
//!
//! The test compares shapes: expected counts are scaled to the number of samples that `sample()`
//! returned. Whether ∫pdf equals the probability that a sample is returned at all is checked by
//! `normalisation::pdf_integrates_to_the_probability_that_sampling_succeeds`; folding it in here
//! would make the (often nearly empty) cell of lost samples collect the quadrature's summed bias.

use crate::common::*;
use lightlab_core::{TransportMode, Vec2, Vec3};
use lightlab_materials::Bsdf;
use rand::RngExt;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::PI;

const N_COS: usize = 40;
const N_PHI: usize = 80;
const SAMPLES: usize = 500_000;
const MIN_EXPECTED: f64 = 5.0;
const P_THRESHOLD: f64 = 1e-4;

fn direction(cos_theta: f64, phi: f64) -> Vec3 {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(
        (sin_theta * phi.cos()) as f32,
        (sin_theta * phi.sin()) as f32,
        cos_theta as f32,
    )
}

fn cell_of(w: Vec3) -> usize {
    let i = (((w.z as f64 + 1.0) * 0.5 * N_COS as f64) as usize).min(N_COS - 1);
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let j = ((phi / (2.0 * PI) * N_PHI as f64) as usize).min(N_PHI - 1);
    i * N_PHI + j
}

/// An integrand over a rectangle of parameter space.
type Integrand<'a> = &'a dyn Fn(f64, f64) -> f64;

/// The 4 × 4 midpoint rule and the 5 × 5 trapezoid rule over [x0, x1] × [y0, y1]. For smooth
/// integrands they agree to O(h²); the trapezoid rule also sees the edges, so a discontinuity near an
/// edge makes them disagree even when it is too thin for the midpoints to see.
fn rules(f: Integrand, x: (f64, f64), y: (f64, f64)) -> (f64, f64) {
    let (dx, dy) = ((x.1 - x.0) / 4.0, (y.1 - y.0) / 4.0);
    let (mut midpoint, mut trapezoid) = (0.0, 0.0);
    for a in 0..5 {
        for b in 0..5 {
            let (s, t) = (a as f64, b as f64);
            if a < 4 && b < 4 {
                midpoint += f(x.0 + (s + 0.5) * dx, y.0 + (t + 0.5) * dy);
            }
            let weight = if a % 4 == 0 { 0.5 } else { 1.0 } * if b % 4 == 0 { 0.5 } else { 1.0 };
            trapezoid += weight * f(x.0 + s * dx, y.0 + t * dy);
        }
    }
    (midpoint * dx * dy, trapezoid * dx * dy)
}

/// Integral over a rectangle. Where the two rules agree to a small fraction of the expected count's
/// Poisson standard deviation, returns (2·midpoint + trapezoid)/3, which cancels their leading
/// O(h²) error terms (Simpson's rule in 1D); elsewhere recurses into quarters (up to `depth` times).
fn integrate(f: Integrand, x: (f64, f64), y: (f64, f64), depth: u32) -> f64 {
    let (midpoint, trapezoid) = rules(f, x, y);
    let n = SAMPLES as f64;
    let tolerance = 0.05 * (n * midpoint).max(1.0).sqrt() / n;
    if depth == 0 || (midpoint - trapezoid).abs() <= tolerance {
        return (2.0 * midpoint + trapezoid) / 3.0;
    }
    let (xm, ym) = (0.5 * (x.0 + x.1), 0.5 * (y.0 + y.1));
    [
        ((x.0, xm), (y.0, ym)),
        ((x.0, xm), (ym, y.1)),
        ((xm, x.1), (y.0, ym)),
        ((xm, x.1), (ym, y.1)),
    ]
    .iter()
    .map(|&(x, y)| integrate(f, x, y, depth - 1))
    .sum()
}

/// ∫ pdf over cell (i, j), in (cos θ, φ) where dω = d cos θ dφ. The two rows that touch the horizon
/// are integrated in t ∈ [0, 1] with |cos θ| = h·t⁴ (h the row height), which crowds the quadrature
/// points toward cos θ = 0: at grazing incidence, rough glass refracts into a sliver of directions
/// within ~10⁻³ of the horizon that a uniform rule never sees.
fn cell_integral(pdf: &dyn Fn(Vec3) -> f32, i: usize, j: usize) -> f64 {
    let h = 2.0 / N_COS as f64;
    let phi = (
        2.0 * PI * j as f64 / N_PHI as f64,
        2.0 * PI * (j + 1) as f64 / N_PHI as f64,
    );
    if i == N_COS / 2 - 1 || i == N_COS / 2 {
        let side = if i == N_COS / 2 { 1.0 } else { -1.0 };
        let f = |t: f64, phi: f64| {
            pdf(direction(side * h * t.powi(4), phi)) as f64 * h * 4.0 * t.powi(3)
        };
        integrate(&f, (0.0, 1.0), phi, 7)
    } else {
        let f = |c: f64, phi: f64| pdf(direction(c, phi)) as f64;
        integrate(&f, (-1.0 + h * i as f64, -1.0 + h * (i + 1) as f64), phi, 7)
    }
}

/// Runs the test for one (bsdf, wo) and panics with the worst cells when it fails.
fn chi2_test(bsdf: Bsdf, wo: Vec3, seed: u64) {
    let mut observed = vec![0u64; N_COS * N_PHI];
    let mut rng = rng(seed);
    for _ in 0..SAMPLES {
        if let Some(s) = bsdf.sample(
            wo,
            rng.random(),
            uniform2(&mut rng),
            TransportMode::Radiance,
        ) {
            observed[cell_of(s.wi)] += 1;
        }
    }
    let found: u64 = observed.iter().sum();

    let pdf = |w: Vec3| bsdf.pdf(wo, w);
    let mut expected: Vec<f64> = (0..N_COS * N_PHI)
        .map(|k| cell_integral(&pdf, k / N_PHI, k % N_PHI))
        .collect();
    let integral: f64 = expected.iter().sum();
    for e in &mut expected {
        *e *= found as f64 / integral;
    }

    // Pool the cells expected below MIN_EXPECTED; a pool that is itself too small joins the
    // smallest regular cell.
    let mut cells: Vec<(usize, f64, f64)> = (0..expected.len())
        .map(|k| (k, observed[k] as f64, expected[k]))
        .collect();
    cells.sort_by(|a, b| a.2.total_cmp(&b.2));
    let split = cells.partition_point(|c| c.2 < MIN_EXPECTED);
    let pool = cells[..split]
        .iter()
        .fold((usize::MAX, 0.0, 0.0), |acc, c| {
            (acc.0, acc.1 + c.1, acc.2 + c.2)
        });
    let mut bins: Vec<(usize, f64, f64)> = cells[split..].to_vec();
    if pool.2 >= MIN_EXPECTED {
        bins.push(pool);
    } else if let Some(first) = bins.first_mut() {
        first.1 += pool.1;
        first.2 += pool.2;
    }
    assert!(bins.len() > 1, "{bsdf:?}, wo {wo}: nothing to test");

    let statistic: f64 = bins.iter().map(|&(_, o, e)| (o - e) * (o - e) / e).sum();
    let dof = (bins.len() - 1) as f64;
    let p_value = ChiSquared::new(dof).unwrap().sf(statistic);
    if p_value < P_THRESHOLD {
        let mut worst = bins.clone();
        worst.sort_by(|a, b| {
            let d = |&(_, o, e): &(usize, f64, f64)| (o - e) * (o - e) / e;
            d(b).total_cmp(&d(a))
        });
        let describe = |k: usize| match k {
            usize::MAX => "pool".to_string(),
            k => format!("cos-bin {:2}, phi-bin {:2}", k / N_PHI, k % N_PHI),
        };
        let table: Vec<String> = worst
            .iter()
            .take(10)
            .map(|&(k, o, e)| format!("  {}: observed {o}, expected {e:.1}", describe(k)))
            .collect();
        panic!(
            "{bsdf:?}, wo {wo}: chi² = {statistic:.1} with {dof} dof, p = {p_value:.2e} < {P_THRESHOLD}\n\
             ∫pdf = {integral:.5}, {found} of {SAMPLES} samples found\nworst cells:\n{}",
            table.join("\n")
        );
    }
}

#[test]
fn chi2_diffuse() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(diffuse(), wo, 4100 + k as u64);
    }
}

#[test]
fn chi2_rough_conductor_alpha_0_05() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(rough_conductor(Vec2::splat(0.05)), wo, 4200 + k as u64);
    }
}

#[test]
fn chi2_rough_conductor_alpha_0_3() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(rough_conductor(Vec2::splat(0.3)), wo, 4300 + k as u64);
    }
}

#[test]
fn chi2_rough_conductor_anisotropic() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(rough_conductor(Vec2::new(0.1, 0.6)), wo, 4400 + k as u64);
    }
}

#[test]
fn chi2_rough_dielectric_alpha_0_3() {
    for eta in ETAS {
        for (k, wo) in wos_both_sides().into_iter().enumerate() {
            chi2_test(
                Bsdf::RoughDielectric {
                    alpha: Vec2::splat(0.3),
                    eta,
                },
                wo,
                4500 + k as u64,
            );
        }
    }
}

#[test]
fn chi2_rough_dielectric_anisotropic() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(
            Bsdf::RoughDielectric {
                alpha: Vec2::new(0.1, 0.6),
                eta: 1.5,
            },
            wo,
            4600 + k as u64,
        );
    }
}

#[test]
fn chi2_phong_exponent_20() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(phong(20.0), wo, 4700 + k as u64);
    }
}

#[test]
fn chi2_phong_exponent_1() {
    for (k, wo) in wos_upper().into_iter().enumerate() {
        chi2_test(phong(1.0), wo, 4800 + k as u64);
    }
}

#[test]
fn chi2_phong_exponent_1000() {
    for (k, wo) in wos_upper().into_iter().enumerate() {
        chi2_test(phong(1000.0), wo, 4900 + k as u64);
    }
}

#[test]
fn chi2_rough_dielectric_alpha_0_05() {
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        chi2_test(
            Bsdf::RoughDielectric {
                alpha: Vec2::splat(0.05),
                eta: 1.5,
            },
            wo,
            5000 + k as u64,
        );
    }
}

#[test]
fn chi2_rough_conductor_alpha_1() {
    for (k, wo) in wos_upper().into_iter().enumerate() {
        chi2_test(rough_conductor(Vec2::splat(1.0)), wo, 5100 + k as u64);
    }
}
