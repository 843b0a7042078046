//! Error of a rendered image against a reference, and the split of the error into bias and variance
//! across independent trials.
//!
//! With x a run's pixel value, r̂ the reference's pixel value and v_r the reference's own variance of
//! the mean (from its variance layer), E[(x − r̂)²] = E[(x − r)²] + v_r for an independent
//! reference, so v_r is subtracted from the squared errors: the reference's noise is not charged to
//! the method (it is reported, and a warning is due when it is not small next to the error).
//! That holds only where v_r is an unbiased estimate of the variance of the reference's mean — a
//! reference of independent samples.
//!
//! relMSE also divides by the noisy r̂² + ε. With D = r² + ε, e = x − r and b = E[e] the method's
//! bias, a Taylor expansion in r̂ − r gives, to first order in v_r,
//! E[((x − r̂)² − v_r) / (r̂² + ε)] = E[e²]/D · (1 + v_r (3r² − ε)/D²) + 4 r b v_r / D²:
//! a relative error between −v_r/ε (black pixels) and 9/16 · v_r/ε, plus a term in the method's
//! bias. `errors` subtracts both terms, estimated with r̂ for r, (x − r̂)² − v_r for e² and
//! x − r̂ for b (each unbiased to this order), leaving an error of order v_r². A reference rendered with a stratified or low-discrepancy
//! sampler, or by progressive photon mapping, has no such estimate; its image then carries no
//! variance and nothing is subtracted (the runner says so).

use serde::{Deserialize, Serialize};

/// Version of the errors' definitions, part of an experiment's identity (`runner`): 2 since relMSE
/// subtracts the first-order bias of dividing by the reference's noisy value.
pub const FORMAT: u32 = 2;

/// ε in relMSE = (x − r)² / (r² + ε), so that black pixels do not dominate (a common choice; the
/// value is part of the metric's definition and printed with the results).
pub const REL_EPSILON: f64 = 1e-2;

/// An image with its per-pixel variance of the mean, row-major RGB; `None` where the image has no
/// valid estimate of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<[f32; 3]>,
    pub variance: Option<Vec<[f32; 3]>>,
}

impl Image {
    /// The reference variance of pixel `i` (zero without a variance).
    #[inline]
    fn var(&self, i: usize) -> [f32; 3] {
        self.variance.as_ref().map_or([0.0; 3], |v| v[i])
    }

    /// `Err` naming how many values are unusable as a reference, and the first one: a mean that is
    /// not finite, or a variance that is not finite or is negative (errors against it would be NaN
    /// or infinite, and so would every statistic built on them).
    pub fn check_finite(&self) -> Result<(), String> {
        let bad_mean = |p: &[f32; 3]| p.iter().any(|x| !x.is_finite());
        let bad_var = |p: &[f32; 3]| p.iter().any(|x| !(x.is_finite() && *x >= 0.0));
        let first_and_count = |pixels: &[[f32; 3]], bad: &dyn Fn(&[f32; 3]) -> bool| {
            let count = pixels.iter().filter(|p| bad(p)).count();
            pixels.iter().position(bad).map(|i| (i, count))
        };
        let at = |i: usize| {
            (
                i % self.width.max(1) as usize,
                i / self.width.max(1) as usize,
            )
        };
        if let Some((i, n)) = first_and_count(&self.mean, &bad_mean) {
            return Err(format!(
                "{n} pixels are NaN or infinite (the first at {:?}: {:?})",
                at(i),
                self.mean[i]
            ));
        }
        if let Some(v) = &self.variance
            && let Some((i, n)) = first_and_count(v, &bad_var)
        {
            return Err(format!(
                "the variance of {n} pixels is NaN, infinite or negative (the first at {:?}: {:?})",
                at(i),
                v[i]
            ));
        }
        Ok(())
    }
}

/// Errors of one image against the reference, averaged over pixels and channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Errors {
    /// Mean squared error minus the reference's own variance contribution.
    pub mse: f64,
    /// Mean of (x − r)² / (r² + ε) minus the reference's contribution v_r / (r² + ε) and the
    /// first-order bias of dividing by the reference's noisy value (module docs).
    pub rel_mse: f64,
    /// Mean absolute error (not corrected for the reference's noise).
    pub mae: f64,
    /// Mean of the reference's variance of the mean: the part of the raw MSE due to the reference
    /// (0 when the reference has no valid variance; then nothing was subtracted).
    pub reference_variance: f64,
}

impl Errors {
    /// Whether every error is a finite number (a run is recorded only then).
    pub fn is_finite(&self) -> bool {
        [self.mse, self.rel_mse, self.mae, self.reference_variance]
            .iter()
            .all(|x| x.is_finite())
    }
}

/// Errors of `x` (pixel values) against `reference`; `None` when the sizes differ.
pub fn errors(x: &[[f32; 3]], reference: &Image) -> Option<Errors> {
    if x.len() != reference.mean.len() || x.is_empty() {
        return None;
    }
    let mut e = Errors::default();
    for (i, (p, r)) in x.iter().zip(&reference.mean).enumerate() {
        let v = reference.var(i);
        for c in 0..3 {
            let (p, r, v) = (p[c] as f64, r[c] as f64, v[c] as f64);
            let d2 = (p - r) * (p - r);
            e.mse += d2 - v;
            e.rel_mse += relative_error(d2, p - r, r, v);
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

/// relMSE's term of one pixel value x against the reference value `r` of variance `v`, from
/// (x − r)² (`squared`) and x − r (`difference`): ((x − r)² − v)/(r² + ε) less the noisy
/// denominator's first-order bias (module docs). Linear in the two, so their means over trials
/// give the mean over trials.
#[inline]
fn relative_error(squared: f64, difference: f64, r: f64, v: f64) -> f64 {
    let denominator = r * r + REL_EPSILON;
    let relative = (squared - v) / denominator;
    let from_denominator = (relative * (3.0 * r * r - REL_EPSILON) + 4.0 * r * difference) * v
        / (denominator * denominator);
    relative - from_denominator
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
            bias2 += (mean - r).powi(2) - s2 / t as f64 - reference.var(i)[c] as f64;
            variance += s2;
        }
    }
    let m = 3.0 * n as f64;
    Some(BiasVariance {
        bias2: bias2 / m,
        variance: variance / m,
    })
}

/// Leave-one-out jackknife standard errors of `bias_variance`'s two numbers (Efron & Stein 1981):
/// SE² = (T − 1)/T · Σᵢ (θ₍ᵢ₎ − θ̄₍·₎)² over the T estimates θ₍ᵢ₎ without trial i. Needs T ≥ 3
/// (each estimate needs two trials); trials must be independent, as distinct seeds make them. The
/// jackknife variance is conservative (Efron & Stein: never low on average); at T = 6 it came out
/// 15–19 % high in the test below, less with more trials.
pub fn bias_variance_se(trials: &[&[[f32; 3]]], reference: &Image) -> Option<BiasVariance> {
    let t = trials.len();
    if t < 3 {
        return None;
    }
    let leave_out: Vec<BiasVariance> = (0..t)
        .map(|i| {
            let rest: Vec<&[[f32; 3]]> = (0..t).filter(|&j| j != i).map(|j| trials[j]).collect();
            bias_variance(&rest, reference)
        })
        .collect::<Option<_>>()?;
    let se = |f: fn(&BiasVariance) -> f64| {
        let mean = leave_out.iter().map(f).sum::<f64>() / t as f64;
        let ss = leave_out.iter().map(|b| (f(b) - mean).powi(2)).sum::<f64>();
        ((t - 1) as f64 / t as f64 * ss).sqrt()
    };
    Some(BiasVariance {
        bias2: se(|b| b.bias2),
        variance: se(|b| b.variance),
    })
}

/// The standard error that the reference's own noise gives the errors of one setting (its T
/// trials), on top of the trials' spread.
///
/// Every run is measured against the same reference r̂ = r + δ, so the part of its error that δ
/// causes is common to all trials (and settings), and the trials' spread never sees it. Over the
/// reference's noise (independent pixels, δ of variance v_r), the mean MSE of trials with mean x̄
/// moves by (1/M) Σ [−2(x̄ − r)δ + δ² − v_r], of variance (1/M²) Σ [4(x̄ − r)² v_r + 2 v_r²] for
/// Gaussian δ; (x̄ − r̂)² − v_r estimates (x̄ − r)² without bias, so the estimate is
/// (1/M²) Σ [4(x̄ − r̂)² v_r − 2 v_r²]. In general, for a per-pixel error ḡ(r̂) (the mean over
/// trials), a second-order expansion gives Var ≈ ḡ′² v_r + ḡ″² v_r²/2, and ḡ′(r̂)² overestimates
/// ḡ′(r)² by ḡ″² v_r, so each pixel adds ḡ′(r̂)² v_r − ḡ″² v_r²/2 (the MSE's case: ḡ′ = −2(x̄ − r̂),
/// ḡ″ = 2). relMSE's ḡ, ((x − r̂)² − v_r)/(r̂² + ε) less its first-order correction, is
/// differentiated numerically (its correction scales ḡ′ by about 1 + v_r/ε at black pixels, so it is
/// kept). bias² moves by the MSE's amount (the variance
/// does not involve r̂). The offset is common to every setting measured against the reference, so
/// it cancels only where two settings have the same error per pixel: it moves ratios of errors,
/// which is why it is reported. `None` when the reference has no variance estimate. Pixels of a
/// reference that splats (light tracing, BDPT's light paths) are weakly correlated, which this
/// leaves out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReferenceSe {
    pub mse: f64,
    pub rel_mse: f64,
}

pub fn reference_se(trials: &[&[[f32; 3]]], reference: &Image) -> Option<ReferenceSe> {
    let variance = reference.variance.as_ref()?;
    let n = reference.mean.len();
    if trials.is_empty() || n == 0 || trials.iter().any(|x| x.len() != n) {
        return None;
    }
    let t = trials.len() as f64;
    let (mut mse, mut rel) = (0.0, 0.0);
    for (i, (r, v)) in reference.mean.iter().zip(variance).enumerate() {
        for c in 0..3 {
            let (r, v) = (r[c] as f64, v[c] as f64);
            let mean = trials.iter().map(|x| x[i][c] as f64).sum::<f64>() / t;
            let spread = trials
                .iter()
                .map(|x| (x[i][c] as f64 - mean).powi(2))
                .sum::<f64>()
                / t;
            let d = mean - r;
            mse += 4.0 * d * d * v - 2.0 * v * v;
            // relMSE's ḡ(ρ) for a reference value ρ, differentiated numerically at r̂ (central
            // differences; a step of 1 % of the reference's standard deviation, so that the
            // second-order term, of order v_r², keeps its size; it vanishes with v_r).
            let g = |rho: f64| relative_error(spread + (mean - rho).powi(2), mean - rho, rho, v);
            let h = (0.01 * v.sqrt()).max(1e-6 * (r.abs() + 1.0));
            let g1 = (g(r + h) - g(r - h)) / (2.0 * h);
            let g2 = (g(r + h) - 2.0 * g(r) + g(r - h)) / (h * h);
            rel += g1 * g1 * v - g2 * g2 * v * v / 2.0;
        }
    }
    let m = 3.0 * n as f64;
    Some(ReferenceSe {
        mse: (mse.max(0.0)).sqrt() / m,
        rel_mse: (rel.max(0.0)).sqrt() / m,
    })
}

/// Efficiency of a method at one setting, 1 / (error × time) (Veach 1997, §2.5.2: the inverse of
/// the variance × time product), from T independent trials, each with its error (MSE or relMSE)
/// and time.
///
/// It is the ratio of the means, 1 / (ē · t̄), not the mean of the per-trial 1 / (eᵢ tᵢ), which
/// Jensen's inequality biases far more (each eᵢ is noisier than ē) and which is undefined once an
/// eᵢ, with the reference's noise subtracted, is zero or negative. 1 / (ē · t̄) is consistent, but
/// still biased high for few trials: to second order, E[1/(ē t̄)] ≈ 1/(μ_e μ_t) · (1 + Var(ē)/μ_e² +
/// Var(t̄)/μ_t² + Cov(ē, t̄)/(μ_e μ_t)), which `relative_bias` estimates (about 10 % for an error
/// whose mean over the trials has a 30 % standard error). The standard error is the delta
/// method's, with the covariance of error and time: Var ≈ E² [Var(ē)/ē² + Var(t̄)/t̄² +
/// 2 Cov(ē, t̄)/(ē t̄)]; it rests on T − 1 degrees of freedom (`degrees_of_freedom`), and the
/// distribution of 1/ē is skewed to the right, so with few trials or a noisy ē read it as a
/// scale, not a symmetric interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Efficiency {
    /// 1 / (ē · t̄); `None` when ē ≤ 0.
    pub value: Option<f64>,
    pub se: Option<f64>,
    /// The second-order estimate of `value`'s relative bias (positive: too high); `None` with
    /// fewer than two trials or ē ≤ 0.
    pub relative_bias: Option<f64>,
    /// T − 1, the degrees of freedom of `se` and of the test of `error_significant`.
    pub degrees_of_freedom: usize,
    /// Whether ē is significantly above zero (one-sided Student t at 5 %, T − 1 degrees of
    /// freedom). When it is not, the error is within the reference's noise and the efficiency
    /// is a lower bound of little meaning.
    pub error_significant: bool,
}

pub fn efficiency(errors: &[f64], seconds: &[f64]) -> Efficiency {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let t = errors.len().min(seconds.len());
    let n = t as f64;
    let mean = |x: &[f64]| x[..t].iter().sum::<f64>() / n;
    let (e, s) = (mean(errors), mean(seconds));
    let value = (e > 0.0 && s > 0.0).then(|| 1.0 / (e * s));
    if t < 2 {
        return Efficiency {
            value,
            se: None,
            relative_bias: None,
            degrees_of_freedom: 0,
            error_significant: false,
        };
    }
    let cov = |a: &[f64], ma: f64, b: &[f64], mb: f64| {
        (0..t).map(|i| (a[i] - ma) * (b[i] - mb)).sum::<f64>() / (n - 1.0) / n
    };
    let (var_e, var_s, cov_es) = (
        cov(errors, e, errors, e),
        cov(seconds, s, seconds, s),
        cov(errors, e, seconds, s),
    );
    let se = value.map(|v| {
        let rel = var_e / (e * e) + var_s / (s * s) + 2.0 * cov_es / (e * s);
        v * rel.max(0.0).sqrt()
    });
    let relative_bias = value.map(|_| var_e / (e * e) + var_s / (s * s) + cov_es / (e * s));
    let critical = StudentsT::new(0.0, 1.0, n - 1.0)
        .map(|d| d.inverse_cdf(0.95))
        .unwrap_or(f64::INFINITY);
    Efficiency {
        value,
        se,
        relative_bias,
        degrees_of_freedom: t - 1,
        error_significant: e > critical * var_e.sqrt(),
    }
}

/// A power law y = e^a · x^b fitted to points (x, y ± se) on log–log axes: the convergence rate of
/// an error against samples or time.
///
/// Method: weighted least squares of ln y on ln x, with each point's standard error in log space
/// σᵢ = seᵢ/yᵢ (the delta method) — or, `pooled: Some(T)`, one σ² for all, the mean of the σᵢ²
/// (for few trials T per point, whose individual standard errors are too noisy to weight by). The
/// slope's standard error is √(1/Σwᵢ(ln xᵢ − x̄)²), multiplied by √(χ²/(n − 2)) when that exceeds
/// one (the points scatter more than their errors allow: the law does not hold exactly over the
/// range; Birge 1932, as the Particle Data Group scales). The interval is ±t₀.₉₇₅ of the unscaled
/// error on the pooled variance's n(T − 1) degrees of freedom (±1.96 with each point's own
/// standard error, taken as known), or ±t₀.₉₇₅(n − 2) of the scaled one: the scale is then
/// estimated from n − 2 residuals. Without
/// standard errors (one trial) it is ordinary least squares with a Student-t interval on n − 2
/// degrees of freedom. Points need independent errors: disjoint seeds at every x.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    pub intercept: f64,
    pub slope: f64,
    /// Half-width of the slope's 95 % confidence interval (infinite with only two points and no
    /// standard errors).
    pub slope_ci95: f64,
    /// Points used.
    pub points: usize,
    /// χ² per degree of freedom of the weighted fit (`None` without standard errors or with two
    /// points); well above 1 means the data are not one power law.
    pub chi2_per_dof: Option<f64>,
    /// x of the points left out because their y is not significantly positive — y ≤ 0 (an
    /// error at or below the reference's noise, after subtracting it) or, with a standard error,
    /// y ≤ 2 se, where ln y is dominated by noise and truncated from below (such points, kept,
    /// flattened the slope) — so that no point vanishes silently.
    pub excluded: Vec<f64>,
}

pub fn fit_power_law(points: &[(f64, f64, f64)], pooled: Option<u32>) -> Option<Fit> {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let mut excluded = Vec::new();
    let mut pts = Vec::new();
    for &(x, y, se) in points {
        if !(x > 0.0 && x.is_finite()) {
            continue;
        }
        if !(y > 0.0 && y.is_finite() && y > 2.0 * se) {
            excluded.push(x);
            continue;
        }
        pts.push((x.ln(), y.ln(), se / y));
    }
    let n = pts.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let weighted = pts.iter().all(|p| p.2 > 0.0 && p.2.is_finite());
    let pooled_var = pts.iter().map(|p| p.2 * p.2).sum::<f64>() / nf;
    let w: Vec<f64> = pts
        .iter()
        .map(|p| match (weighted, pooled) {
            (false, _) => 1.0,
            (true, Some(_)) => 1.0 / pooled_var,
            (true, None) => 1.0 / (p.2 * p.2),
        })
        .collect();
    let sw: f64 = w.iter().sum();
    let mx = pts.iter().zip(&w).map(|(p, w)| w * p.0).sum::<f64>() / sw;
    let my = pts.iter().zip(&w).map(|(p, w)| w * p.1).sum::<f64>() / sw;
    let sxx: f64 = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.0 - mx).powi(2))
        .sum();
    if !(sxx > 0.0) {
        return None;
    }
    let slope = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.0 - mx) * (p.1 - my))
        .sum::<f64>()
        / sxx;
    let intercept = my - slope * mx;
    let chi2: f64 = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    let t_975 = || StudentsT::new(0.0, 1.0, nf - 2.0).map(|t| t.inverse_cdf(0.975));
    let (slope_ci95, chi2_per_dof) = if weighted {
        let per_dof = (n > 2).then(|| chi2 / (nf - 2.0));
        match per_dof {
            // The residuals set the scale: an estimated variance on n − 2 degrees of freedom.
            Some(c) if c > 1.0 => (t_975().ok()? * (c / sxx).sqrt(), per_dof),
            // The pooled σ² is itself estimated, on n(T − 1) degrees of freedom.
            _ => {
                let critical = match pooled {
                    Some(t) if t >= 2 => StudentsT::new(0.0, 1.0, nf * (t - 1) as f64)
                        .map(|d| d.inverse_cdf(0.975))
                        .ok()?,
                    _ => 1.959_963_985,
                };
                (critical / sxx.sqrt(), per_dof)
            }
        }
    } else if n > 2 {
        (t_975().ok()? * (chi2 / (nf - 2.0) / sxx).sqrt(), None)
    } else {
        (f64::INFINITY, None)
    };
    Some(Fit {
        intercept,
        slope,
        slope_ci95,
        points: n,
        chi2_per_dof,
        excluded,
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
            variance: Some(vec![[variance; 3]; n]),
        }
    }

    /// Standard normal deviates: Box–Muller on a 64-bit LCG started at `seed`.
    fn gaussian(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            let mut u = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (u1, u2) = (u(), u());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
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

    /// relMSE against a noisy reference, simulated: 3·10⁶ pixel values x ~ N(r + b, σ²) against
    /// references r̂ ~ N(r, v_r), in a mid-grey pixel with a biased method and in a black one.
    /// Dividing by r̂² + ε biases the uncorrected mean by 6 % and −2 % of the true
    /// E[(x − r)²]/(r² + ε) (first order: 6.2 % and −2.0 %); the corrected relMSE must be within
    /// 0.4 % (second order: 0.3 % and 0.2 % by quadrature) plus 4 standard errors from the 10
    /// batches (≈ 0.1 % each; Student t₉, so false failures ≈ 3·10⁻³ for another seed).
    #[test]
    fn rel_mse_corrects_the_noisy_denominator() {
        let eps = REL_EPSILON;
        // (r, b, σ, v_r), with the first-order relative bias of the uncorrected mean.
        for (r, b, sigma, v, first_order) in [
            (0.2f64, 0.1, 0.1, 5e-4f64, 0.062),
            (0.0, 0.0, 0.05, 2e-4, -0.02),
        ] {
            let mut gauss = gaussian(4242);
            let truth = (b * b + sigma * sigma) / (r * r + eps);
            let n = 100_000;
            let (mut sum, mut sum2, mut raw) = (0.0, 0.0, 0.0);
            for _ in 0..10 {
                let reference = Image {
                    width: n as u32,
                    height: 1,
                    mean: (0..n)
                        .map(|_| [0; 3].map(|_| (r + v.sqrt() * gauss()) as f32))
                        .collect(),
                    variance: Some(vec![[v as f32; 3]; n]),
                };
                let x: Vec<[f32; 3]> = (0..n)
                    .map(|_| [0; 3].map(|_| (r + b + sigma * gauss()) as f32))
                    .collect();
                let e = errors(&x, &reference).unwrap();
                sum += e.rel_mse;
                sum2 += e.rel_mse * e.rel_mse;
                raw += x
                    .iter()
                    .zip(&reference.mean)
                    .flat_map(|(x, r)| (0..3).map(move |c| (x[c] as f64, r[c] as f64)))
                    .map(|(x, r)| ((x - r).powi(2) - v) / (r * r + eps))
                    .sum::<f64>()
                    / (3 * n) as f64;
            }
            let (mean, raw) = (sum / 10.0, raw / 10.0);
            let se = ((sum2 / 10.0 - mean * mean) / 9.0).sqrt();
            assert!(
                (raw / truth - 1.0 - first_order).abs() < 0.01,
                "r = {r}: uncorrected {raw} against {truth}, first order {first_order}"
            );
            assert!(
                (mean - truth).abs() < 0.004 * truth + 4.0 * se,
                "r = {r}: corrected relMSE {mean} ± {se} against {truth} (uncorrected {raw})"
            );
        }
    }

    /// The jackknife standard errors of bias² and variance against their spread over 300
    /// independent replications of T = 6 trials of 64 pixels (x = r + b + N(0, σ²), fixed seed):
    /// the jackknife overestimates on average (Efron–Stein inequality), so the mean SE must lie
    /// between 0.95 and 1.35 times the measured standard deviation (whose own relative SE from
    /// 300 replications is 4 %: a false failure needs a deviation of more than 5σ below).
    #[test]
    fn jackknife_standard_errors_match_the_spread_across_replications() {
        let (b, sigma, n, t) = (0.2f64, 0.5f64, 64, 6);
        let r = image(vec![[1.0; 3]; n], 0.0);
        let mut gauss = gaussian(777);
        let (mut estimates, mut ses) = (Vec::new(), Vec::new());
        for _ in 0..300 {
            let trials: Vec<Vec<[f32; 3]>> = (0..t)
                .map(|_| {
                    (0..n)
                        .map(|_| [(); 3].map(|_| (1.0 + b + sigma * gauss()) as f32))
                        .collect()
                })
                .collect();
            let refs: Vec<&[[f32; 3]]> = trials.iter().map(|t| t.as_slice()).collect();
            estimates.push(bias_variance(&refs, &r).unwrap());
            ses.push(bias_variance_se(&refs, &r).unwrap());
        }
        let check = |f: fn(&BiasVariance) -> f64, what: &str| {
            let m = estimates.iter().map(f).sum::<f64>() / 300.0;
            let sd = (estimates.iter().map(|e| (f(e) - m).powi(2)).sum::<f64>() / 299.0).sqrt();
            let se = ses.iter().map(f).sum::<f64>() / 300.0;
            // Measured 1.19 (bias²) and 1.15 (variance): conservative, as Efron–Stein says.
            assert!(
                (0.95..1.35).contains(&(se / sd)),
                "{what}: jackknife SE {se}, spread {sd}"
            );
        };
        check(|e| e.bias2, "bias²");
        check(|e| e.variance, "variance");
        let two: Vec<&[[f32; 3]]> = vec![&r.mean, &r.mean];
        assert!(
            bias_variance_se(&two, &r).is_none(),
            "T = 2 has no jackknife"
        );
    }

    /// Trials x = r + b + noise with known bias b and noise variance σ²: the estimates recover both
    /// (deterministic pseudo-noise, tolerance from the sampling error of 4096 pixels × 8 trials).
    #[test]
    fn bias_and_variance_of_synthetic_trials() {
        let (b, sigma) = (0.3f64, 0.5f64);
        let n = 4096;
        let r = image((0..n).map(|i| [(i % 7) as f32; 3]).collect(), 0.0);
        let mut gauss = gaussian(12345);
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
        // y = 7.4 x^−1 with small deterministic scatter, no standard errors: OLS with a t interval.
        let pts: Vec<(f64, f64, f64)> = (0..10)
            .map(|i| {
                let x = (i as f64).exp();
                (
                    x,
                    (2.0 - i as f64 + 0.01 * ((i * 7 % 5) as f64 - 2.0)).exp(),
                    0.0,
                )
            })
            .collect();
        let f = fit_power_law(&pts, None).unwrap();
        assert!(
            (f.slope + 1.0).abs() < f.slope_ci95 && f.slope_ci95 < 0.01,
            "{f:?}"
        );
        assert!(fit_power_law(&[(1.0, 1.0, 0.0)], None).is_none());
        assert!(
            fit_power_law(&[(1.0, 1.0, 0.0), (2.0, 3.0, 0.0)], None)
                .unwrap()
                .slope_ci95
                .is_infinite()
        );
        // Points not significantly positive (≤ 0, or within 2 standard errors of 0) are left out
        // and listed.
        let mut with_zero = pts.clone();
        with_zero.push((1e5, -1e-9, 1e-9));
        with_zero.push((2e5, 0.0, 1e-9));
        with_zero.push((4e5, 1.9e-9, 1e-9));
        let f = fit_power_law(&with_zero, None).unwrap();
        assert_eq!(
            (f.points, f.excluded.clone()),
            (10, vec![1e5, 2e5, 4e5]),
            "{f:?}"
        );
    }

    /// The reference's share of a setting's error spread, simulated: T = 4 fixed trials of a
    /// biased method (x = r + 0.1 + N(0, 0.01²)) over 1 500 pixels, a third each black, grey (0.2)
    /// and white, measured against 3 000 independent references r̂ = r + N(0, v_r). The spread of the
    /// setting's mean MSE and relMSE over the references must match `reference_se`'s estimate
    /// (averaged over them) within 6 %: the spread of 3 000 values has a relative standard error of
    /// 1.3 %, so a false failure needs 4.6σ (≈ 10⁻⁵ for another seed). Measured: 0.988 (MSE) and
    /// 0.996 (relMSE); leaving out relMSE's first-order correction made it 0.92. With one noisy reference the
    /// trials' own standard error would be 4× too small here.
    #[test]
    fn reference_se_matches_the_spread_over_references() {
        let (t, n, v, k) = (4, 1500, 4e-4f64, 3000);
        let truth: Vec<[f32; 3]> = (0..n).map(|i| [[0.0, 0.2, 1.0][i % 3] as f32; 3]).collect();
        let mut gauss = gaussian(99);
        let trials: Vec<Vec<[f32; 3]>> = (0..t)
            .map(|_| {
                truth
                    .iter()
                    .map(|p| p.map(|r| (r as f64 + 0.1 + 0.01 * gauss()) as f32))
                    .collect()
            })
            .collect();
        let slices: Vec<&[[f32; 3]]> = trials.iter().map(|x| x.as_slice()).collect();
        let (mut mse, mut rel, mut estimate) = (Vec::new(), Vec::new(), ReferenceSe::default());
        let mut trial_spread = 0.0;
        for _ in 0..k {
            let reference = Image {
                width: n as u32,
                height: 1,
                mean: truth
                    .iter()
                    .map(|p| p.map(|r| (r as f64 + v.sqrt() * gauss()) as f32))
                    .collect(),
                variance: Some(vec![[v as f32; 3]; n]),
            };
            let e: Vec<Errors> = slices
                .iter()
                .map(|x| errors(x, &reference).unwrap())
                .collect();
            mse.push(e.iter().map(|e| e.mse).sum::<f64>() / t as f64);
            rel.push(e.iter().map(|e| e.rel_mse).sum::<f64>() / t as f64);
            let m = mse.last().unwrap();
            trial_spread +=
                (e.iter().map(|e| (e.mse - m).powi(2)).sum::<f64>() / ((t - 1) * t) as f64).sqrt()
                    / k as f64;
            let r = reference_se(&slices, &reference).unwrap();
            estimate.mse += r.mse / k as f64;
            estimate.rel_mse += r.rel_mse / k as f64;
        }
        let sd = |x: &[f64]| {
            let m = x.iter().sum::<f64>() / x.len() as f64;
            (x.iter().map(|y| (y - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
        };
        for (what, spread, estimate) in [
            ("MSE", sd(&mse), estimate.mse),
            ("relMSE", sd(&rel), estimate.rel_mse),
        ] {
            assert!(
                (estimate / spread - 1.0).abs() < 0.06,
                "{what}: estimated {estimate}, spread over references {spread}"
            );
        }
        assert!(sd(&mse) > 3.0 * trial_spread, "{} {trial_spread}", sd(&mse));
        let none = Image {
            variance: None,
            ..image(truth.clone(), 0.0)
        };
        assert!(reference_se(&slices, &none).is_none());
    }

    /// The efficiency is the ratio of means with a delta-method error, not the mean of ratios.
    #[test]
    fn efficiency_is_a_ratio_of_means() {
        let (mse, time) = ([1.0, 3.0], [2.0, 2.0]);
        let e = efficiency(&mse, &time);
        // 1 / (2 · 2), where the mean of 1/(MSE·t) would be (1/2 + 1/6)/2 = 1/3.
        assert!((e.value.unwrap() - 0.25).abs() < 1e-12, "{e:?}");
        // Var(ē) = s²/T = 2/2 = 1; relative SE = 1/2, so SE = 0.125.
        assert!((e.se.unwrap() - 0.125).abs() < 1e-12, "{e:?}");
        assert!(!e.error_significant, "t₀.₉₅(1) = 6.3 > 2/1");
        // A mean error at or below zero has no efficiency, and is not significant.
        let e = efficiency(&[1e-3, -2e-3, 5e-4], &[1.0, 1.1, 0.9]);
        assert!(
            e.value.is_none() && e.se.is_none() && !e.error_significant,
            "{e:?}"
        );
        let e = efficiency(&[1.0, 1.1, 0.9, 1.05], &[1.0; 4]);
        assert!(e.error_significant && (e.value.unwrap() - 1.0 / 1.0125).abs() < 1e-12);
        assert_eq!(e.degrees_of_freedom, 3);
        // Var(ē)/ē² = 1/4 (above), no spread in time: the second-order bias is 25 %.
        let e = efficiency(&mse, &time);
        assert!((e.relative_bias.unwrap() - 0.25).abs() < 1e-12, "{e:?}");
    }

    /// The bias of 1/(ē t̄) with few trials, simulated: T = 4 trials of errors with a Gamma(3)
    /// distribution (each trial's error has a 58 % relative standard deviation), a constant time.
    /// Then ē is Gamma(12) and E[1/ē] = 12/11 exactly: 1/(ē t̄) is 9.1 % high on average.
    /// `relative_bias`, a second-order estimate from each setting's own trials, must average
    /// between 60 and 100 % of that (it measured 85 % in a 2·10⁵-replication simulation with
    /// another generator; the mean of 20 000 here has a standard error of 0.5 % of the bias'
    /// size, so a false failure would need a systematic change).
    #[test]
    fn efficiency_bias_with_few_trials() {
        let mut state = 2024u64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let n = 20_000;
        let (mut ratio, mut estimate) = (0.0, 0.0);
        for _ in 0..n {
            let errors: Vec<f64> = (0..4)
                .map(|_| (0..3).map(|_| -uniform().ln()).sum::<f64>() / 3.0)
                .collect();
            let e = efficiency(&errors, &[2.0; 4]);
            ratio += e.value.unwrap() * 2.0 / n as f64;
            estimate += e.relative_bias.unwrap() / n as f64;
        }
        let bias = ratio - 1.0;
        assert!((bias - 1.0 / 11.0).abs() < 0.01, "measured bias {bias}");
        assert!(
            (0.6..1.0).contains(&(estimate / bias)),
            "estimated {estimate}, measured {bias}"
        );
    }

    /// Weighted: exact points with 5 % standard errors give the exact slope, an interval of
    /// 1.96·0.05/√Sxx (χ² = 0 does not shrink it), and χ²/dof 0; a point far off its error
    /// inflates the interval by √(χ²/dof), with Student's t for 1.96.
    #[test]
    fn weighted_fit_uses_standard_errors() {
        let pts: Vec<(f64, f64, f64)> = (0..6)
            .map(|i| {
                let x = 2f64.powi(i);
                (x, 3.0 / x, 0.05 * 3.0 / x)
            })
            .collect();
        let f = fit_power_law(&pts, None).unwrap();
        let ln2 = 2f64.ln();
        let sxx: f64 = (0..6)
            .map(|i| ((i as f64 - 2.5) * ln2).powi(2))
            .sum::<f64>()
            / 0.0025;
        assert!((f.slope + 1.0).abs() < 1e-12, "{f:?}");
        assert!(
            (f.slope_ci95 - 1.96 / sxx.sqrt()).abs() < 1e-3 * f.slope_ci95,
            "{f:?}"
        );
        assert!(f.chi2_per_dof.unwrap() < 1e-20);
        // Pooled over 3 trials per point, the σ² is estimated on 6 · 2 = 12 degrees of freedom:
        // Student's t₀.₉₇₅(12) = 2.1788 for 1.96 (the same weights here, all σ being equal).
        let p = fit_power_law(&pts, Some(3)).unwrap();
        assert!(
            (p.slope_ci95 / f.slope_ci95 - 2.178_812_83 / 1.959_963_985).abs() < 1e-6,
            "{p:?}"
        );
        let mut off = pts.clone();
        // Twice the value with the same relative error: the weights, so Sxx, stay.
        off[5].1 *= 2.0;
        off[5].2 *= 2.0;
        let g = fit_power_law(&off, None).unwrap();
        // The scaled error's interval is Student's t on n − 2 = 4 degrees of freedom, not 1.96.
        let t4 = 2.776_445_105;
        let expected = t4 * (g.chi2_per_dof.unwrap() / sxx).sqrt();
        assert!(
            g.chi2_per_dof.unwrap() > 10.0 && (g.slope_ci95 - expected).abs() < 1e-6 * expected,
            "{g:?}, expected ±{expected}"
        );
    }
}
