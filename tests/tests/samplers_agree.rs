//! Every sampler renders the same image: the Cornell box with each of Stratified, LatinHypercube,
//! Halton and Sobol against Independent at four times the samples, compared region by region (4×4
//! regions per image) by a two-sample z-test per channel.
//!
//! The per-pixel variance estimate s²/n is exact for independent samples and, on average,
//! overestimates the variance of stratified and low-discrepancy estimates wherever they beat
//! independent samples (their samples are then negatively correlated), as they do on the Cornell box
//! (relMSE per sample 0.5–0.6× Independent's, BENCHMARKS.md "Samplers' cost"), so the test is
//! conservative for them. False-failure rate ≤ 1e-3 for the file (Šidák over all
//! comparisons), fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{cornell, independent_pixels_mean, regions, render, scene};

#[test]
fn all_samplers_agree_on_the_cornell_box() {
    let sc = scene(&cornell(1.0, [0.0; 3], (32, 32)));
    let base = regions(&render(&sc, "Path(max_bounces: 4)", 256, 21), 4);
    let samplers = ["Stratified", "LatinHypercube", "Halton", "Sobol"];
    let crit = z_critical(sidak(1e-3, (samplers.len() * 16 * 3) as u64));
    for s in samplers {
        let out = render(&sc, &format!("Path(max_bounces: 4, sampler: {s})"), 64, 22);
        assert_eq!(out.stats.non_finite_total(), 0);
        for (k, (a, b)) in base.iter().zip(regions(&out, 4)).enumerate() {
            for c in 0..3 {
                let se = (a.1[c] * a.1[c] + b.1[c] * b.1[c]).sqrt();
                let z = (b.0[c] - a.0[c]) / se.max(1e-12);
                assert!(
                    z.abs() < crit,
                    "{s}: region {k} channel {c}: {} vs {} (Independent), z = {z:.2} (critical {crit:.2})",
                    b.0[c],
                    a.0[c]
                );
            }
        }
    }
}

/// The furnace's exact answer with every sampler (a sampler that skews its values would miss it).
#[test]
fn all_samplers_hit_the_furnace_value() {
    let text = lightlab_tests::furnace(0.7, 0.5, 1.0, (8, 8));
    let sc = scene(&text);
    let want = 0.5 * (1.0 + 0.7 + 0.49);
    let crit = z_critical(sidak(1e-3, 5 * 3));
    for s in [
        "Independent",
        "Stratified",
        "LatinHypercube",
        "Halton",
        "Sobol",
    ] {
        let out = render(
            &sc,
            &format!("Path(max_bounces: 2, strategy: Uniform, sampler: {s})"),
            64,
            3,
        );
        let (mean, se) = independent_pixels_mean(&out.film);
        for c in 0..3 {
            // Uniform hemisphere sampling keeps some variance (cos θ varies); the floor covers f32
            // rounding (relative 1e-6) should a sampler make the estimate nearly exact.
            let z = (mean[c] - want) / se[c].max(1e-6 * want);
            assert!(z.abs() < crit, "{s}: {} vs {want}, z = {z:.2}", mean[c]);
        }
    }
}
