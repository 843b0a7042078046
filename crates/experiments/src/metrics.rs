//! Error of a rendered image against a reference, and the split of the error into bias and variance
//! across independent trials.
//!
//! With x a run's pixel value, r̂ the reference's pixel value and v_r the reference's own variance of
//! the mean (from its variance layer), E[(x − r̂)²] = E[(x − r)²] + v_r for an independent
//! reference, so v_r is subtracted from the squared errors: the reference's noise is not charged to
//! the method (it is reported, and a warning is due when it is not small next to the error).

use serde::{Deserialize, Serialize};

/// ε in relMSE = (x − r)² / (r² + ε), so that black pixels do not dominate (a common choice; the
/// value is part of the metric's definition and printed with the results).
pub const REL_EPSILON: f64 = 1e-2;

/// An image with its per-pixel variance of the mean, row-major RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<[f32; 3]>,
    pub variance: Vec<[f32; 3]>,
}

/// Errors of one image against the reference, averaged over pixels and channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Errors {
    /// Mean squared error minus the reference's own variance contribution.
    pub mse: f64,
    /// Mean of (x − r)² / (r² + ε) minus the reference's contribution v_r / (r² + ε).
    pub rel_mse: f64,
    /// Mean absolute error (not corrected for the reference's noise).
    pub mae: f64,
    /// Mean of the reference's variance of the mean: the part of the raw MSE due to the reference.
    pub reference_variance: f64,
}

/// Errors of `x` (pixel values) against `reference`; `None` when the sizes differ.
pub fn errors(x: &[[f32; 3]], reference: &Image) -> Option<Errors> {
    if x.len() != reference.mean.len() || x.is_empty() {
        return None;
    }
    let mut e = Errors::default();
    for ((p, r), v) in x.iter().zip(&reference.mean).zip(&reference.variance) {
        for c in 0..3 {
            let (p, r, v) = (p[c] as f64, r[c] as f64, v[c] as f64);
            let d2 = (p - r) * (p - r);
            e.mse += d2 - v;
            e.rel_mse += (d2 - v) / (r * r + REL_EPSILON);
            e.mae += (p - r).abs();
            e.reference_variance += v;
        }
    }
    let n = 3.0 * x.len() as f64;
    Some(Errors {
        mse: e.mse / n,
        rel_mse: e.rel_mse / n,
        mae: e.mae / n,
        reference_variance: e.reference_variance / n,
    })
}

/// Bias and variance of a method at one setting, from T ≥ 2 independent trials (images `trials`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BiasVariance {
    /// Mean over pixels of the squared bias: (x̄ − r)² corrected for the noise of the trial mean
    /// (variance / T) and of the reference (v_r). Can come out slightly negative for an unbiased method.
    pub bias2: f64,
    /// Mean over pixels of the unbiased sample variance of one trial's pixel value.
    pub variance: f64,
}

pub fn bias_variance(trials: &[&[[f32; 3]]], reference: &Image) -> Option<BiasVariance> {
    let t = trials.len();
    let n = reference.mean.len();
    if t < 2 || n == 0 || trials.iter().any(|x| x.len() != n) {
        return None;
    }
    let (mut bias2, mut variance) = (0.0, 0.0);
    for i in 0..n {
        for c in 0..3 {
            let mean = trials.iter().map(|x| x[i][c] as f64).sum::<f64>() / t as f64;
            let s2 = trials
                .iter()
                .map(|x| (x[i][c] as f64 - mean).powi(2))
                .sum::<f64>()
                / (t - 1) as f64;
            let r = reference.mean[i][c] as f64;
            bias2 += (mean - r).powi(2) - s2 / t as f64 - reference.variance[i][c] as f64;
            variance += s2;
        }
    }
    let m = 3.0 * n as f64;
    Some(BiasVariance {
        bias2: bias2 / m,
        variance: variance / m,
    })
}

/// Least-squares line y = a + b·x with the 95 % confidence interval of the slope (Student t with
/// n − 2 degrees of freedom). Used on (log spp, log MSE) for convergence rates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    pub intercept: f64,
    pub slope: f64,
    /// Half-width of the slope's 95 % confidence interval (infinite with only two points).
    pub slope_ci95: f64,
    pub points: usize,
}

pub fn fit_line(points: &[(f64, f64)]) -> Option<Fit> {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let pts: Vec<_> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let n = pts.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / nf;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / nf;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if !(sxx > 0.0) {
        return None;
    }
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    let intercept = my - slope * mx;
    let slope_ci95 = if n > 2 {
        let rss: f64 = pts
            .iter()
            .map(|p| (p.1 - intercept - slope * p.0).powi(2))
            .sum();
        let se = (rss / (nf - 2.0) / sxx).sqrt();
        let t = StudentsT::new(0.0, 1.0, nf - 2.0).ok()?.inverse_cdf(0.975);
        t * se
    } else {
        f64::INFINITY
    };
    Some(Fit {
        intercept,
        slope,
        slope_ci95,
        points: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(mean: Vec<[f32; 3]>, variance: f32) -> Image {
        let n = mean.len();
        Image {
            width: n as u32,
            height: 1,
            mean,
            variance: vec![[variance; 3]; n],
        }
    }

    #[test]
    fn errors_of_known_differences() {
        let r = image(vec![[1.0; 3], [0.0; 3]], 0.0);
        let e = errors(&[[1.5; 3], [-1.0; 3]], &r).unwrap();
        assert!((e.mse - (0.25 + 1.0) / 2.0).abs() < 1e-12);
        assert!((e.mae - 0.75).abs() < 1e-12);
        assert!((e.rel_mse - (0.25 / 1.01 + 1.0 / 0.01) / 2.0).abs() < 1e-9);
        // The reference's own variance is subtracted.
        let noisy = image(vec![[1.0; 3], [0.0; 3]], 0.05);
        let e2 = errors(&[[1.5; 3], [-1.0; 3]], &noisy).unwrap();
        assert!(
            (e.mse - e2.mse - 0.05).abs() < 1e-9 && (e2.reference_variance - 0.05).abs() < 1e-9
        );
        assert!(errors(&[[0.0; 3]], &r).is_none());
    }

    /// Trials x = r + b + noise with known bias b and noise variance σ²: the estimates recover both
    /// (deterministic pseudo-noise, tolerance from the sampling error of 4096 pixels × 8 trials).
    #[test]
    fn bias_and_variance_of_synthetic_trials() {
        let (b, sigma) = (0.3f64, 0.5f64);
        let n = 4096;
        let r = image((0..n).map(|i| [(i % 7) as f32; 3]).collect(), 0.0);
        let mut state = 12345u64;
        let mut gauss = || {
            // Box–Muller on a 64-bit LCG.
            let mut u = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (u1, u2) = (u(), u());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        };
        let trials: Vec<Vec<[f32; 3]>> = (0..8)
            .map(|_| {
                r.mean
                    .iter()
                    .map(|p| p.map(|v| (v as f64 + b + sigma * gauss()) as f32))
                    .collect()
            })
            .collect();
        let refs: Vec<&[[f32; 3]]> = trials.iter().map(|t| t.as_slice()).collect();
        let bv = bias_variance(&refs, &r).unwrap();
        assert!((bv.variance - sigma * sigma).abs() < 0.02, "{bv:?}");
        assert!((bv.bias2 - b * b).abs() < 0.01, "{bv:?}");
        // An unbiased method: bias² ≈ 0 within the same tolerance.
        let unbiased: Vec<Vec<[f32; 3]>> = trials
            .iter()
            .map(|t| t.iter().map(|p| p.map(|v| v - b as f32)).collect())
            .collect();
        let refs: Vec<&[[f32; 3]]> = unbiased.iter().map(|t| t.as_slice()).collect();
        assert!(bias_variance(&refs, &r).unwrap().bias2.abs() < 0.01);
    }

    #[test]
    fn fit_recovers_slope_and_interval_covers_it() {
        let pts: Vec<(f64, f64)> = (0..10)
            .map(|i| {
                (
                    i as f64,
                    2.0 - 1.0 * i as f64 + 0.01 * ((i * 7 % 5) as f64 - 2.0),
                )
            })
            .collect();
        let f = fit_line(&pts).unwrap();
        assert!(
            (f.slope + 1.0).abs() < f.slope_ci95 && f.slope_ci95 < 0.01,
            "{f:?}"
        );
        assert!(fit_line(&[(1.0, 1.0)]).is_none());
        assert!(
            fit_line(&[(1.0, 1.0), (2.0, 3.0)])
                .unwrap()
                .slope_ci95
                .is_infinite()
        );
    }
}
