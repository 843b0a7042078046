//! The samplers converge at the rates theory predicts (Mitchell 1996; Owen 1997), measured by the
//! convergence study on analytic integrands: independent −1; jittered −2 on the smooth Gaussian and
//! −1.5 on integrands with edges; scrambled Sobol' at least as fast as jittered.
//!
//! Tolerance: the fit's own 95 % interval plus 0.1 for the pre-asymptotic bend of the curves over
//! 16…4096 samples. Fixed seeds, so the outcome is reproducible; each slope would leave its interval
//! by chance with probability 5 %, which the 0.1 margin covers (the margin is 1–2.5 interval widths,
//! so the tolerance is at least 5.9 standard errors of the slope: a false-failure rate below 10⁻⁸
//! per slope for normal fit errors, were the curves' bend none; the bend uses up part of it).

use lightlab_core::NoProgress;
use lightlab_experiments::convergence::{Rate, Study, run};

fn slope(rates: &[Rate], function: &str, sampler: &str) -> (f64, f64) {
    let r = rates
        .iter()
        .find(|r| r.function == function && r.sampler == sampler)
        .unwrap();
    (r.fit.slope, r.fit.slope_ci95)
}

#[test]
fn samplers_converge_at_their_theoretical_rates() {
    let (_, rates) = run(
        &Study {
            max_spp: 4096,
            seeds: 256,
            fit_from: 16,
        },
        &NoProgress,
    );
    let check = |function: &str, sampler: &str, want: f64| {
        let (s, ci) = slope(&rates, function, sampler);
        assert!(
            (s - want).abs() < ci + 0.1,
            "{sampler} on {function}: slope {s:.3} ± {ci:.3}, expected {want}"
        );
    };
    for f in ["gaussian", "disk", "step", "diagonal-edge", "checkerboard"] {
        check(f, "Independent", -1.0);
        // Sobol' is at least as good as jittered: its slope is no shallower, within both intervals.
        let (sobol, ci_s) = slope(&rates, f, "Sobol");
        let (jittered, ci_j) = slope(&rates, f, "Stratified");
        assert!(
            sobol <= jittered + ci_s + ci_j,
            "{f}: Sobol {sobol:.2} ± {ci_s:.2} vs Stratified {jittered:.2} ± {ci_j:.2}"
        );
    }
    check("gaussian", "Stratified", -2.0);
    for f in ["disk", "diagonal-edge"] {
        check(f, "Stratified", -1.5);
    }
}

/// The slope interval means what it says: over 400 repeated studies of a known rate (independent
/// sampling of the disk, a Bernoulli integrand whose MSE is exactly p(1 − p)/N, slope −1), the
/// 95 % interval holds −1 in about 95 % of them. Fixed seeds; the band [0.92, 0.98] is ±3 binomial
/// standard deviations of 400 studies at 95 % (false-failure rate ≈ 0.3 %). Reusing one set of
/// seeds at every count, or ignoring the points' standard errors, fails it.
#[test]
fn slope_intervals_cover_the_true_rate() {
    use lightlab_experiments::convergence::{FUNCTIONS, coverage};
    use lightlab_samplers::SamplerConfig;
    let disk = FUNCTIONS.iter().find(|f| f.name == "disk").unwrap();
    let counts: Vec<u32> = (4..=10).map(|k| 1 << k).collect();
    let c = coverage(disk, SamplerConfig::Independent, &counts, 64, 400, -1.0);
    assert!((0.92..=0.98).contains(&c), "coverage {c}");
}
