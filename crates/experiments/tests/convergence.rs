//! The samplers converge at the rates theory predicts (Mitchell 1996; Owen 1997), measured by the
//! convergence study on analytic integrands: independent −1; jittered −2 on the smooth Gaussian and
//! −1.5 on integrands with edges; scrambled Sobol' at least as fast as jittered.
//!
//! Tolerance: the fit's own 95 % interval plus 0.1 for the pre-asymptotic bend of the curves over
//! 16…4096 samples. Fixed seeds, so the outcome is reproducible; each slope would leave its interval
//! by chance with probability 5 %, which the 0.1 margin covers (the margin is 1–2.5 interval widths).

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
