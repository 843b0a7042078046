//! Measured convergence of the samplers (`lightlab convergence`): Monte Carlo estimates of the
//! integrals over [0, 1]² of analytic test functions with known values (after pbrt-v4's `function`
//! integrator), for every sampler at 1…N samples over independent seeds; the MSE per sample count
//! and the fitted log–log slope with its 95 % confidence interval.
//!
//! Every sample count gets its own seeds (disjoint from every other count's), so the points of a
//! curve have independent errors, and the fit weights each point by its own standard error
//! ([`fit_power_law`]); `coverage` checks that the resulting interval holds a known rate as often
//! as it claims.
//!
//! Expected rates (Mitchell 1996; Owen 1997): independent samples −1; jittered (stratified) −2 on
//! smooth integrands and −1.5 on integrands with edges; scrambled Sobol' at least as fast as jittered.

use crate::metrics::{Fit, fit_power_law};
use crate::plot::{LinePlot, Series};
use lightlab_samplers::{Sampler, SamplerConfig, SamplerVisitor};
use serde::Serialize;

/// A test integrand on [0, 1]² and its exact integral.
#[derive(Clone, Copy, Debug)]
pub struct TestFunction {
    pub name: &'static str,
    /// Whether the integrand is smooth (no discontinuities) — decides the expected jittered rate.
    pub smooth: bool,
    pub f: fn(f64, f64) -> f64,
    pub integral: fn() -> f64,
}

const SIGMA: f64 = 0.2;

/// The five integrands: a smooth Gaussian bump, a disk, an axis-aligned step, an oblique edge and
/// a 10 × 10 checkerboard (10 so its cells never align with power-of-two strata).
pub const FUNCTIONS: [TestFunction; 5] = [
    TestFunction {
        name: "gaussian",
        smooth: true,
        f: |x, y| (-((x - 0.5).powi(2) + (y - 0.5).powi(2)) / (2.0 * SIGMA * SIGMA)).exp(),
        // ∫₀¹ exp(−(x − ½)²/2σ²) dx = σ√(2π)·erf(1 / (2√2 σ)), squared for the separable 2D bump.
        integral: || {
            let one = SIGMA
                * (2.0 * std::f64::consts::PI).sqrt()
                * statrs::function::erf::erf(0.5 / (SIGMA * 2f64.sqrt()));
            one * one
        },
    },
    TestFunction {
        name: "disk",
        smooth: false,
        f: |x, y| {
            if (x - 0.5).powi(2) + (y - 0.5).powi(2) < 0.16 {
                1.0
            } else {
                0.0
            }
        },
        integral: || std::f64::consts::PI * 0.16,
    },
    TestFunction {
        name: "step",
        smooth: false,
        f: |x, _| if x < 1.0 / 3.0 { 1.0 } else { 0.0 },
        integral: || 1.0 / 3.0,
    },
    TestFunction {
        name: "diagonal-edge",
        smooth: false,
        // Below the line y = 0.8 − 0.6x: ∫₀¹ (0.8 − 0.6x) dx = 0.5.
        f: |x, y| if y < 0.8 - 0.6 * x { 1.0 } else { 0.0 },
        integral: || 0.5,
    },
    TestFunction {
        name: "checkerboard",
        smooth: false,
        f: |x, y| (((10.0 * x).floor() + (10.0 * y).floor()) as i64 % 2) as f64,
        integral: || 0.5,
    },
];

/// MSE of one sampler on one function at one sample count.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub function: String,
    pub sampler: String,
    pub spp: u32,
    pub mse: f64,
    /// Standard error of the MSE over the replicates.
    pub mse_se: f64,
}

/// Fitted rate of one sampler on one function.
#[derive(Clone, Debug, Serialize)]
pub struct Rate {
    pub function: String,
    pub sampler: String,
    pub fit: Fit,
}

/// Settings of a convergence study.
#[derive(Clone, Copy, Debug)]
pub struct Study {
    /// Largest sample count; counts are 1, 2, 4, … up to it.
    pub max_spp: u32,
    /// Independent replicates (seeds) per sample count; each count has its own.
    pub seeds: u32,
    /// Smallest sample count used in the fit (the rate is asymptotic).
    pub fit_from: u32,
}

struct Estimate<'a> {
    f: &'a TestFunction,
    spp: u32,
    seed: u64,
}

impl SamplerVisitor for Estimate<'_> {
    type Output = f64;
    fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, mut sampler: S) -> f64 {
        let mut sum = 0.0;
        for i in 0..self.spp {
            sampler.start_pixel_sample(self.seed, 0, i as u64);
            let u = sampler.next_2d();
            sum += (self.f.f)(u.x as f64, u.y as f64);
        }
        sum / self.spp as f64
    }
}

/// Runs the study: every function × sampler × sample count, replicates in parallel.
pub fn run(study: &Study, progress: &dyn lightlab_core::Progress) -> (Vec<Point>, Vec<Rate>) {
    let counts: Vec<u32> = (0..32)
        .map(|k| 1u32 << k)
        .take_while(|&n| n <= study.max_spp)
        .collect();
    progress.start((FUNCTIONS.len() * SamplerConfig::ALL.len()) as u64);
    let mut points = Vec::new();
    let mut rates = Vec::new();
    for f in &FUNCTIONS {
        for sampler in SamplerConfig::ALL {
            let mut pts = Vec::new();
            for (c, &spp) in counts.iter().enumerate() {
                let (mse, mse_se) = mse_over_seeds(f, sampler, spp, study.seeds, c as u64);
                pts.push(Point {
                    function: f.name.into(),
                    sampler: sampler.name().into(),
                    spp,
                    mse,
                    mse_se,
                });
            }
            let fit_pts: Vec<(f64, f64, f64)> = pts
                .iter()
                .filter(|p| p.spp >= study.fit_from)
                .map(|p| (p.spp as f64, p.mse, p.mse_se))
                .collect();
            if let Some(fit) = fit_power_law(&fit_pts, None) {
                rates.push(Rate {
                    function: f.name.into(),
                    sampler: sampler.name().into(),
                    fit,
                });
            }
            points.extend(pts);
            progress.advance(1);
        }
    }
    (points, rates)
}

/// MSE of `sampler`'s estimate of `f` at `spp` samples over `seeds` replicates, and its standard
/// error. Replicate s of curve point `point` uses seed (point, s): no two points share a seed.
pub fn mse_over_seeds(
    f: &TestFunction,
    sampler: SamplerConfig,
    spp: u32,
    seeds: u32,
    point: u64,
) -> (f64, f64) {
    use rayon::prelude::*;
    let exact = (f.integral)();
    let errors: Vec<f64> = (0..seeds as u64)
        .into_par_iter()
        .map(|s| {
            let seed = point << 32 | s;
            (sampler.dispatch(spp, Estimate { f, spp, seed }) - exact).powi(2)
        })
        .collect();
    let n = errors.len() as f64;
    let mse = errors.iter().sum::<f64>() / n;
    let var = errors.iter().map(|e| (e - mse).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mse, (var / n).sqrt())
}

/// Coverage of the fitted slope's 95 % interval: `studies` repetitions of a whole convergence
/// study of `f` with `sampler` (sample counts `counts`, `seeds` each, disjoint seeds throughout),
/// returning the fraction whose interval contains `true_slope`.
pub fn coverage(
    f: &TestFunction,
    sampler: SamplerConfig,
    counts: &[u32],
    seeds: u32,
    studies: u32,
    true_slope: f64,
) -> f64 {
    let mut covered = 0;
    for study in 0..studies as u64 {
        let pts: Vec<(f64, f64, f64)> = counts
            .iter()
            .enumerate()
            .map(|(c, &spp)| {
                let point = study * counts.len() as u64 + c as u64;
                let (mse, se) = mse_over_seeds(f, sampler, spp, seeds, point);
                (spp as f64, mse, se)
            })
            .collect();
        if let Some(fit) = fit_power_law(&pts, None)
            && (fit.slope - true_slope).abs() <= fit.slope_ci95
        {
            covered += 1;
        }
    }
    covered as f64 / studies as f64
}

/// The MSE-against-samples plot of one function, one series per sampler with its fitted slope.
pub fn plot(function: &str, points: &[Point], rates: &[Rate]) -> LinePlot {
    let series = SamplerConfig::ALL
        .iter()
        .map(|s| {
            let rate = rates
                .iter()
                .find(|r| r.function == function && r.sampler == s.name());
            Series {
                label: match rate {
                    Some(r) => format!(
                        "{}: slope {:.2} ± {:.2}",
                        s.name(),
                        r.fit.slope,
                        r.fit.slope_ci95
                    ),
                    None => s.name().into(),
                },
                points: points
                    .iter()
                    .filter(|p| p.function == function && p.sampler == s.name())
                    .map(|p| (p.spp as f64, p.mse, p.mse_se))
                    .collect(),
            }
        })
        .collect();
    LinePlot {
        title: format!("{function}: MSE of the integral against samples"),
        x_label: "samples".into(),
        y_label: "MSE over seeds (± 1 s.e.)".into(),
        log_x: true,
        log_y: true,
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form integrals against a fine midpoint rule (1000² cells; the edges' error is
    /// O(1/1000)).
    #[test]
    fn integrals_are_right() {
        let n = 1000;
        for f in &FUNCTIONS {
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    sum += (f.f)((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                }
            }
            let numeric = sum / (n * n) as f64;
            assert!(
                (numeric - (f.integral)()).abs() < 2e-3,
                "{}: {numeric} vs {}",
                f.name,
                (f.integral)()
            );
        }
    }
}
