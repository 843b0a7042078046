//! Statistical asserts for Monte Carlo estimates: multiple-test corrections, z-tests of a mean and
//! of whole images (Mitsuba 3's `test_renders.py` compares renders with references that carry
//! variance images the same way), approximate equality in glam's test-macro style, and a
//! least-squares line with a confidence interval for convergence rates on log–log axes.
//!
//! Every z-test assumes the estimate is approximately normal with a well-estimated standard error:
//! a mean of many (≳ 30) independent samples, by the central limit theorem.

use glam::{Vec2, Vec3, Vec3A};
use lightlab_core::Rgb;
use statrs::distribution::{ContinuousCDF, Normal, StudentsT};
use statrs::statistics::Statistics;
use std::fmt;

/// Suite-wide false-failure rate the defaults are designed for.
pub const SUITE_ALPHA: f64 = 0.01;
/// Number of statistical tests the defaults budget [`SUITE_ALPHA`] over.
pub const SUITE_TESTS: u64 = 300;

/// The default per-test significance: `sidak(SUITE_ALPHA, SUITE_TESTS)` = 3.35 × 10⁻⁵, i.e. a
/// two-sided z-test critical value of 4.148 σ. A suite of at most 300 tests at this level fails
/// spuriously in at most 1 % of runs (the project runs 286 chi-square tests at it: 280 counted on
/// 2026-12-06 by logging every run of `cargo test --workspace`, and Phong's exponent 0 since).
pub fn default_alpha() -> f64 {
    sidak(SUITE_ALPHA, SUITE_TESTS)
}

/// Šidák's correction: the per-test level 1 − (1 − α)^(1/n) at which n independent tests together
/// reject a true hypothesis with probability α. Computed as −expm1(ln1p(−α)/n) to stay accurate for
/// tiny levels.
pub fn sidak(alpha: f64, n: u64) -> f64 {
    assert!(
        alpha > 0.0 && alpha < 1.0 && n >= 1,
        "sidak needs α in (0, 1) and n ≥ 1"
    );
    -((-alpha).ln_1p() / n as f64).exp_m1()
}

/// The two-sided critical value z such that P(|Z| > z) = `alpha` for a standard normal Z.
pub fn z_critical(alpha: f64) -> f64 {
    assert!(
        alpha > 0.0 && alpha < 1.0,
        "z_critical needs α in (0, 1), got {alpha}"
    );
    // Φ⁻¹(α/2) rather than Φ⁻¹(1 − α/2): the lower tail keeps its precision for tiny α.
    -Normal::standard().inverse_cdf(alpha / 2.0)
}

/// The two-sided critical value t such that P(|T| > t) = `alpha` for Student's t with `dof`
/// degrees of freedom (for means whose standard error is estimated from few samples).
pub fn t_critical(alpha: f64, dof: f64) -> f64 {
    assert!(
        alpha > 0.0 && alpha < 1.0 && dof > 0.0,
        "t_critical needs α in (0, 1) and dof > 0"
    );
    -statrs::distribution::StudentsT::new(0.0, 1.0, dof)
        .expect("valid Student t")
        .inverse_cdf(alpha / 2.0)
}

/// Mean and standard error s/√n (s with n − 1 in the denominator) of independent samples.
pub fn mean_and_std_error(samples: &[f64]) -> (f64, f64) {
    assert!(
        samples.len() >= 2,
        "a standard error needs at least 2 samples, got {}",
        samples.len()
    );
    let mean = samples.iter().mean();
    let std_dev = samples.iter().std_dev();
    (mean, std_dev / (samples.len() as f64).sqrt())
}

/// A z-test of an estimated mean against its expected value.
#[derive(Clone, Copy, Debug)]
pub struct ZTest {
    pub estimate: f64,
    pub expected: f64,
    pub std_error: f64,
    /// (estimate − expected) / std_error; ±∞ for a zero std error and a nonzero difference.
    pub z: f64,
    pub z_crit: f64,
}

/// Tests `mean` (with standard error `std_error`) against `expected`; passes when |z| ≤ `z_crit`
/// (e.g. `z_critical(default_alpha())`).
pub fn z_test_mean(mean: f64, expected: f64, std_error: f64, z_crit: f64) -> ZTest {
    ZTest {
        estimate: mean,
        expected,
        std_error,
        z: z_score(mean - expected, std_error),
        z_crit,
    }
}

/// diff / std_error, defined as 0 for 0/0.
fn z_score(diff: f64, std_error: f64) -> f64 {
    if diff == 0.0 { 0.0 } else { diff / std_error }
}

impl ZTest {
    /// |z| ≤ z_crit (false for NaN).
    pub fn passed(&self) -> bool {
        self.z.abs() <= self.z_crit
    }

    /// Panics with the report unless the test passed.
    #[track_caller]
    pub fn assert_ok(&self) {
        if !self.passed() {
            panic!("{self}");
        }
    }
}

impl fmt::Display for ZTest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verdict = if self.passed() { "passed" } else { "FAILED" };
        write!(
            f,
            "z-test {verdict}: estimate {} vs expected {} (difference {:.4e}, std error {:.4e}): \
             z = {:.3}, critical |z| = {:.3}",
            self.estimate,
            self.expected,
            self.estimate - self.expected,
            self.std_error,
            self.z,
            self.z_crit
        )
    }
}

/// Per-pixel means and standard errors of an image estimate, row-major, `channels` values per
/// pixel interleaved.
#[derive(Clone, Copy, Debug)]
pub struct ImageEstimate<'a> {
    pub width: usize,
    pub channels: usize,
    pub mean: &'a [f64],
    pub std_error: &'a [f64],
}

/// What an image estimate is compared with, in the same layout.
#[derive(Clone, Copy, Debug)]
pub enum Reference<'a> {
    /// Known values (an analytic solution).
    Exact(&'a [f64]),
    /// Another estimate with its own standard errors, independent of the first: the z-score of
    /// the difference uses √(se₁² + se₂²).
    Estimate {
        mean: &'a [f64],
        std_error: &'a [f64],
    },
}

/// One value of an image z-test.
#[derive(Clone, Copy, Debug)]
pub struct PixelZ {
    pub x: usize,
    pub y: usize,
    pub channel: usize,
    pub value: f64,
    pub expected: f64,
    /// Standard error of the difference.
    pub std_error: f64,
    pub z: f64,
}

/// The outcome of [`image_z_test`].
#[derive(Clone, Debug)]
pub struct ImageZTest {
    /// Values (pixel channels) compared.
    pub values: usize,
    /// Values tested: all but those with zero standard error whose difference is within rounding.
    pub tested: usize,
    /// Family-wise significance level over all tested values.
    pub alpha: f64,
    /// Critical |z| per value: `z_critical(sidak(alpha, tested))`.
    pub z_crit: f64,
    /// Values whose |z| exceeds `z_crit` (or is NaN).
    pub exceeding: usize,
    /// The value with the largest |z| (NaN counts as largest).
    pub worst: Option<PixelZ>,
}

/// Relative difference below which two values with zero standard error count as equal: per-sample
/// values are f32 (relative rounding 6 × 10⁻⁸), accumulated in f64.
const ZERO_VARIANCE_REL_TOL: f64 = 1e-5;

/// Per-pixel z-test of an image estimate against a reference: each channel of each pixel is one
/// test of z = (value − expected)/se, and the image passes when no |z| exceeds the Šidák-corrected
/// critical value for the number of values tested, so the whole image is one test at level
/// `alpha` (e.g. [`default_alpha`]). The level holds even though the channels of a pixel are
/// correlated: for jointly normal values Šidák's inequality bounds the family-wise rate by α under
/// any correlation. Values with zero standard error (on both sides) are skipped when equal up to
/// f32 rounding and fail otherwise.
pub fn image_z_test(estimate: &ImageEstimate, reference: &Reference, alpha: f64) -> ImageZTest {
    let n = estimate.mean.len();
    assert!(
        estimate.width >= 1 && estimate.channels >= 1,
        "image_z_test needs width and channels ≥ 1"
    );
    assert_eq!(
        estimate.std_error.len(),
        n,
        "one standard error per image value"
    );
    let (expected, reference_se) = match *reference {
        Reference::Exact(values) => (values, None),
        Reference::Estimate { mean, std_error } => (mean, Some(std_error)),
    };
    assert_eq!(expected.len(), n, "reference and estimate differ in size");
    if let Some(se) = reference_se {
        assert_eq!(se.len(), n, "one reference standard error per value");
    }

    let scores: Vec<Option<PixelZ>> = (0..n)
        .map(|i| {
            let (value, exp) = (estimate.mean[i], expected[i]);
            let se_ref = reference_se.map_or(0.0, |se| se[i]);
            let std_error = estimate.std_error[i].hypot(se_ref);
            let diff = value - exp;
            if std_error == 0.0 && diff.abs() <= ZERO_VARIANCE_REL_TOL * value.abs().max(exp.abs())
            {
                return None;
            }
            let pixel = i / estimate.channels;
            Some(PixelZ {
                x: pixel % estimate.width,
                y: pixel / estimate.width,
                channel: i % estimate.channels,
                value,
                expected: exp,
                std_error,
                z: z_score(diff, std_error),
            })
        })
        .collect();
    let tested = scores.iter().flatten().count();
    let z_crit = if tested == 0 {
        f64::INFINITY
    } else {
        z_critical(sidak(alpha, tested as u64))
    };
    let magnitude = |p: &PixelZ| {
        if p.z.is_nan() {
            f64::INFINITY
        } else {
            p.z.abs()
        }
    };
    let exceeding = scores
        .iter()
        .flatten()
        .filter(|p| p.z.is_nan() || p.z.abs() > z_crit)
        .count();
    let worst = scores
        .into_iter()
        .flatten()
        .max_by(|a, b| magnitude(a).total_cmp(&magnitude(b)));
    ImageZTest {
        values: n,
        tested,
        alpha,
        z_crit,
        exceeding,
        worst,
    }
}

impl ImageZTest {
    /// No tested value exceeds the critical |z|.
    pub fn passed(&self) -> bool {
        self.exceeding == 0
    }

    /// Panics with the report unless the test passed.
    #[track_caller]
    pub fn assert_ok(&self) {
        if !self.passed() {
            panic!("{self}");
        }
    }
}

impl fmt::Display for ImageZTest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verdict = if self.passed() { "passed" } else { "FAILED" };
        write!(
            f,
            "image z-test {verdict}: {} of {} tested values (of {}) exceed |z| = {:.3} \
             (family-wise α = {:.3e})",
            self.exceeding, self.tested, self.values, self.z_crit, self.alpha
        )?;
        if let Some(w) = &self.worst {
            write!(
                f,
                "; worst at pixel ({}, {}) channel {}: {} vs expected {} (std error {:.4e}), \
                 z = {:.3}",
                w.x, w.y, w.channel, w.value, w.expected, w.std_error, w.z
            )?;
        }
        Ok(())
    }
}

/// Values [`approx_eq`] and [`assert_close!`](crate::assert_close) compare component by component.
pub trait Approx: Copy + fmt::Debug {
    /// The components, widened to f64.
    fn components(self) -> Vec<f64>;
}

impl Approx for f32 {
    fn components(self) -> Vec<f64> {
        vec![self as f64]
    }
}

impl Approx for f64 {
    fn components(self) -> Vec<f64> {
        vec![self]
    }
}

impl Approx for Vec2 {
    fn components(self) -> Vec<f64> {
        self.to_array().map(f64::from).to_vec()
    }
}

impl Approx for Vec3 {
    fn components(self) -> Vec<f64> {
        self.to_array().map(f64::from).to_vec()
    }
}

impl Approx for Vec3A {
    fn components(self) -> Vec<f64> {
        self.to_array().map(f64::from).to_vec()
    }
}

impl Approx for Rgb {
    fn components(self) -> Vec<f64> {
        [self.r, self.g, self.b].map(f64::from).to_vec()
    }
}

/// The component with the largest |a − b| beyond its tolerance max(abs, rel · max(|a|, |b|)), as
/// (index, a, b, tolerance); None when all are within. NaN is never close; equal infinities are.
fn worst_violation<T: Approx>(a: T, b: T, rel: f64, abs: f64) -> Option<(usize, f64, f64, f64)> {
    a.components()
        .into_iter()
        .zip(b.components())
        .enumerate()
        .filter_map(|(k, (x, y))| {
            let tol = abs.max(rel * x.abs().max(y.abs()));
            let diff = (x - y).abs();
            (x != y && (diff.is_nan() || diff > tol)).then_some((k, x, y, tol))
        })
        .max_by(|p, q| {
            let excess = |&(_, x, y, tol): &(usize, f64, f64, f64)| {
                let d = (x - y).abs() - tol;
                if d.is_nan() { f64::INFINITY } else { d }
            };
            excess(p).total_cmp(&excess(q))
        })
}

/// Whether every component satisfies |a − b| ≤ max(abs, rel · max(|a|, |b|)).
pub fn approx_eq<T: Approx>(a: T, b: T, rel: f64, abs: f64) -> bool {
    worst_violation(a, b, rel, abs).is_none()
}

/// Implementation of [`assert_close!`](crate::assert_close).
#[doc(hidden)]
#[track_caller]
pub fn assert_close_impl<T: Approx>(
    a: T,
    b: T,
    rel: f64,
    abs: f64,
    left: &str,
    right: &str,
    context: Option<fmt::Arguments>,
) {
    if let Some((k, x, y, tol)) = worst_violation(a, b, rel, abs) {
        let context = context.map_or(String::new(), |c| format!(": {c}"));
        panic!(
            "assertion failed: `{left} ≈ {right}`{context}\n  \
             left: {a:?}\n right: {b:?}\n  diff: {:e} in component {k} ({x} vs {y})\n   \
             tol: {tol:e} (rel {rel:e}, abs {abs:e})",
            (x - y).abs()
        );
    }
}

/// Asserts that two values ([`Approx`]: f32, f64, Vec2, Vec3, Vec3A, Rgb) agree component by
/// component within max(abs, rel · max(|a|, |b|)); on failure prints both values, the worst
/// difference and the tolerance. An optional format string adds context.
///
/// ```
/// use lightlab_testkit::assert_close;
/// assert_close!(0.1f32 + 0.2, 0.3, rel = 1e-6, abs = 0.0);
/// let (x, y) = (glam::Vec3::X, glam::Vec3::new(1.0, 1e-9, 0.0));
/// assert_close!(x, y, rel = 0.0, abs = 1e-6, "axis {}", 0);
/// ```
#[macro_export]
macro_rules! assert_close {
    ($left:expr, $right:expr, rel = $rel:expr, abs = $abs:expr $(,)?) => {
        $crate::stats::assert_close_impl(
            $left,
            $right,
            $rel,
            $abs,
            stringify!($left),
            stringify!($right),
            ::core::option::Option::None,
        )
    };
    ($left:expr, $right:expr, rel = $rel:expr, abs = $abs:expr, $($context:tt)+) => {
        $crate::stats::assert_close_impl(
            $left,
            $right,
            $rel,
            $abs,
            stringify!($left),
            stringify!($right),
            ::core::option::Option::Some(format_args!($($context)+)),
        )
    };
}

/// A least-squares line y = intercept + slope · x.
#[derive(Clone, Copy, Debug)]
pub struct Fit {
    pub slope: f64,
    pub intercept: f64,
    /// Standard error of the slope, √(RSS/(n − 2) / Σ(x − x̄)²).
    pub slope_std_error: f64,
    /// Half-width of the 95 % confidence interval of the slope: t₀.₉₇₅,ₙ₋₂ · slope_std_error.
    pub slope_ci95: f64,
}

impl Fit {
    /// Whether `slope` lies in the 95 % confidence interval.
    pub fn slope_consistent_with(&self, slope: f64) -> bool {
        (self.slope - slope).abs() <= self.slope_ci95
    }
}

/// Ordinary least squares of `ys` on `xs` with the slope's 95 % confidence interval from Student's
/// t with n − 2 degrees of freedom (normal, independent residuals of equal variance). For an
/// error-vs-samples convergence rate, pass log N and log error: the MSE of plain Monte Carlo has
/// slope −1.
pub fn fit_line(xs: &[f64], ys: &[f64]) -> Fit {
    let n = xs.len();
    assert_eq!(n, ys.len(), "fit_line needs as many ys as xs");
    assert!(
        n >= 3,
        "fit_line needs at least 3 points for a confidence interval"
    );
    let (x_mean, y_mean) = (xs.iter().mean(), ys.iter().mean());
    let sxx: f64 = xs.iter().map(|x| (x - x_mean).powi(2)).sum();
    assert!(sxx > 0.0, "fit_line needs at least two distinct xs");
    let sxy: f64 = xs
        .iter()
        .zip(ys)
        .map(|(x, y)| (x - x_mean) * (y - y_mean))
        .sum();
    let slope = sxy / sxx;
    let intercept = y_mean - slope * x_mean;
    let rss: f64 = xs
        .iter()
        .zip(ys)
        .map(|(x, y)| (y - intercept - slope * x).powi(2))
        .sum();
    let slope_std_error = (rss / (n - 2) as f64 / sxx).sqrt();
    let t = StudentsT::new(0.0, 1.0, (n - 2) as f64)
        .expect("n − 2 ≥ 1 degrees of freedom")
        .inverse_cdf(0.975);
    Fit {
        slope,
        intercept,
        slope_std_error,
        slope_ci95: t * slope_std_error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    #[test]
    fn sidak_and_critical_values() {
        assert!((sidak(0.05, 1) - 0.05).abs() < 1e-15);
        // Reference values from Python's statistics.NormalDist and math.erfc.
        assert!(
            (default_alpha() - 3.350056e-5).abs() < 1e-10,
            "{}",
            default_alpha()
        );
        assert!((z_critical(0.05) - 1.959964).abs() < 1e-6);
        assert!((z_critical(default_alpha()) - 4.148264).abs() < 1e-5);
        // Tiny levels keep their precision: P(|Z| > 8.5) = erfc(8.5/√2) = 1.8959e-17.
        assert!(
            (z_critical(1.8959e-17) - 8.5).abs() < 1e-4,
            "{}",
            z_critical(1.8959e-17)
        );
    }

    /// Monte Carlo estimate of ∫₀¹ x² dx = 1/3 from n uniform samples, plus an offset.
    fn estimate(seed: u64, n: usize, offset: f64) -> (f64, f64) {
        let mut rng = Pcg32::seed_from_u64(seed);
        let xs: Vec<f64> = (0..n)
            .map(|_| rng.random::<f64>().powi(2) + offset)
            .collect();
        mean_and_std_error(&xs)
    }

    #[test]
    fn z_test_accepts_correct_and_rejects_ten_sigma_off() {
        let z_crit = z_critical(default_alpha());
        let (mean, se) = estimate(1, 10_000, 0.0);
        // Standard error of x² for uniform x: √(1/5 − 1/9)/√n = 0.298/100.
        assert!((se - 0.00298).abs() < 1e-4, "{se}");
        z_test_mean(mean, 1.0 / 3.0, se, z_crit).assert_ok();
        let off = z_test_mean(mean + 10.0 * se, 1.0 / 3.0, se, z_crit);
        assert!(!off.passed() && (off.z - 10.0).abs() < z_crit, "{off}");
        assert!(!z_test_mean(f64::NAN, 1.0, 1.0, z_crit).passed());
        assert!(z_test_mean(1.0, 1.0, 0.0, z_crit).passed());
        assert!(!z_test_mean(1.0, 1.1, 0.0, z_crit).passed());
    }

    /// A 12 × 8 RGB image whose values estimate ∫ x² = 1/3 (plus `offset` at pixel (5, 3), green).
    fn image(seed: u64, offset: f64) -> (Vec<f64>, Vec<f64>) {
        (0..12 * 8 * 3)
            .map(|i| {
                estimate(
                    seed * 1000 + i as u64,
                    400,
                    if i == (3 * 12 + 5) * 3 + 1 {
                        offset
                    } else {
                        0.0
                    },
                )
            })
            .unzip()
    }

    #[test]
    fn image_z_test_accepts_correct_and_rejects_ten_sigma_off() {
        let alpha = default_alpha();
        let (mean, se) = image(1, 0.0);
        let estimate = ImageEstimate {
            width: 12,
            channels: 3,
            mean: &mean,
            std_error: &se,
        };
        let exact = vec![1.0 / 3.0; mean.len()];
        image_z_test(&estimate, &Reference::Exact(&exact), alpha).assert_ok();
        let (ref_mean, ref_se) = image(2, 0.0);
        let other = Reference::Estimate {
            mean: &ref_mean,
            std_error: &ref_se,
        };
        let result = image_z_test(&estimate, &other, alpha);
        result.assert_ok();
        assert_eq!(result.tested, 12 * 8 * 3);

        // One value 10 σ off (σ ≈ 0.015 per value) is found and located.
        let (bad_mean, bad_se) = image(1, 0.15);
        let bad = ImageEstimate {
            width: 12,
            channels: 3,
            mean: &bad_mean,
            std_error: &bad_se,
        };
        let result = image_z_test(&bad, &Reference::Exact(&exact), alpha);
        assert_eq!(result.exceeding, 1, "{result}");
        let worst = result.worst.unwrap();
        assert_eq!((worst.x, worst.y, worst.channel), (5, 3, 1), "{result}");
        let message = std::panic::catch_unwind(|| result.assert_ok()).unwrap_err();
        assert!(
            message
                .downcast_ref::<String>()
                .unwrap()
                .contains("pixel (5, 3) channel 1")
        );
    }

    #[test]
    fn image_z_test_skips_equal_zero_variance_values() {
        let mean = [0.0, 2.0, 0.5, 0.5];
        let se = [0.0, 0.0, 0.1, 0.1];
        let estimate = ImageEstimate {
            width: 2,
            channels: 1,
            mean: &mean,
            std_error: &se,
        };
        let result = image_z_test(
            &estimate,
            &Reference::Exact(&[0.0, 2.0 + 1e-9, 0.5, 0.5]),
            0.01,
        );
        assert_eq!((result.tested, result.exceeding), (2, 0), "{result}");
        let result = image_z_test(&estimate, &Reference::Exact(&[0.0, 2.1, 0.5, 0.5]), 0.01);
        assert_eq!((result.tested, result.exceeding), (3, 1), "{result}");
    }

    #[test]
    fn image_z_test_combines_standard_errors_of_two_estimates() {
        let estimate = ImageEstimate {
            width: 1,
            channels: 1,
            mean: &[1.0],
            std_error: &[0.3],
        };
        let reference = Reference::Estimate {
            mean: &[0.0],
            std_error: &[0.4],
        };
        let worst = image_z_test(&estimate, &reference, 0.01).worst.unwrap();
        assert!(
            (worst.std_error - 0.5).abs() < 1e-12 && (worst.z - 2.0).abs() < 1e-12,
            "{worst:?}"
        );
    }

    #[test]
    fn approx_eq_and_assert_close() {
        assert!(approx_eq(1.0f64, 1.0 + 1e-10, 1e-9, 0.0));
        assert!(!approx_eq(1.0f64, 1.0 + 1e-8, 1e-9, 0.0));
        assert!(approx_eq(0.0f64, 1e-12, 0.0, 1e-9));
        assert!(!approx_eq(f64::NAN, f64::NAN, 1.0, 1.0));
        assert!(approx_eq(f64::INFINITY, f64::INFINITY, 0.0, 0.0));
        assert!(approx_eq(
            Rgb::new(1.0, 2.0, 3.0),
            Rgb::new(1.0, 2.0, 3.000001),
            1e-6,
            0.0
        ));
        crate::assert_close!(Vec3::X, Vec3::new(1.0, 1e-9, 0.0), rel = 0.0, abs = 1e-6);
        let panic = std::panic::catch_unwind(|| {
            crate::assert_close!(
                Vec3::X,
                Vec3::new(1.0, 0.5, 0.0),
                rel = 1e-6,
                abs = 1e-7,
                "bounce {}",
                2
            )
        })
        .unwrap_err();
        let message = panic.downcast_ref::<String>().unwrap();
        for part in [
            "Vec3::X ≈",
            ": bounce 2",
            "left: Vec3(1.0, 0.0, 0.0)",
            "right: Vec3(1.0, 0.5, 0.0)",
            "diff: 5e-1 in component 1",
            "tol: 5e-7 (rel 1e-6, abs 1e-7)",
        ] {
            assert!(message.contains(part), "{part:?} missing from\n{message}");
        }
    }

    #[test]
    fn fit_line_recovers_a_known_slope() {
        // MSE ∝ N^-1 with noise: log-log slope −1.
        let mut rng = Pcg32::seed_from_u64(7);
        let xs: Vec<f64> = (0..20).map(|i| (10.0 + i as f64).ln()).collect();
        let ys: Vec<f64> = xs
            .iter()
            .map(|x| 0.3 - x + 0.01 * (rng.random::<f64>() - 0.5))
            .collect();
        let fit = fit_line(&xs, &ys);
        assert!(fit.slope_consistent_with(-1.0), "{fit:?}");
        assert!(!fit.slope_consistent_with(-0.95), "{fit:?}");
        assert!((fit.intercept - 0.3).abs() < 0.02, "{fit:?}");
        // Exact data: zero-width interval; t₀.₉₇₅,₂ = 4.303.
        let exact = fit_line(&[0.0, 1.0, 2.0, 3.0], &[1.0, 3.0, 5.0, 7.0]);
        assert_eq!(
            (exact.slope, exact.intercept, exact.slope_ci95),
            (2.0, 1.0, 0.0)
        );
        let noisy = fit_line(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 1.0, 3.0]);
        assert!(
            (noisy.slope_ci95 / noisy.slope_std_error - 4.3027).abs() < 1e-3,
            "{noisy:?}"
        );
    }
}
