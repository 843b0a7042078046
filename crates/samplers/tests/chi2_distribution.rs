//! Chi-square tests of `Distribution1D`: the items it picks follow the weights it was built from,
//! and the remapped uniform it returns is uniform and independent of the item (pbrt-v4 §A.4.2
//! reuses it for a continuous choice).
//!
//! False failures: 2 tests at the default α = sidak(0.01, 300) = 3.35 × 10⁻⁵ each, together
//! 1 − (1 − α)² ≈ 0.007 % over the choice of seed; the seeds are fixed.

use glam::Vec2;
use lightlab_samplers::Distribution1D;
use lightlab_testkit::{Chi2Test, Domain, chi2_discrete, default_alpha};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// Zeros (first, inner, last), a dynamic range of 10⁶ and items expected below 5 in 10⁶ draws.
const WEIGHTS: [f32; 12] = [
    0.0, 1.0, 3.0, 1e-3, 0.0, 7.5, 2.0, 0.25, 12.0, 1e-5, 4.0, 0.0,
];

#[test]
fn chi2_distribution1d_items() {
    let d = Distribution1D::new(&WEIGHTS).unwrap();
    let mut rng = Pcg32::seed_from_u64(11);
    let mut counts = [0u64; WEIGHTS.len()];
    for _ in 0..1_000_000 {
        let (i, pmf, _) = d.sample(rng.random());
        assert_eq!(pmf, d.pmf(i));
        counts[i] += 1;
    }
    // Expected from the weights themselves, not from `pmf`, so a wrong normalisation shows.
    let total: f64 = WEIGHTS.iter().map(|&w| w as f64).sum();
    let probabilities = WEIGHTS.map(|w| w as f64 / total);
    chi2_discrete(
        "distribution1d_items",
        &counts,
        &probabilities,
        default_alpha(),
    )
    .assert_ok();
}

#[test]
fn chi2_distribution1d_remapped_uniform() {
    // Item i and remapped u as the point (u, (i + ½)/n) of the unit square: row i then has density
    // n · pmf(i), uniform across its columns.
    let d = Distribution1D::new(&WEIGHTS).unwrap();
    let n = WEIGHTS.len();
    Chi2Test::new(Domain::Square)
        .resolution(n, 20)
        .seed(12)
        .run(
            "distribution1d_remapped",
            |u: Vec2| {
                let (i, _, remapped) = d.sample(u.x);
                Some(Vec2::new(remapped, (i as f32 + 0.5) / n as f32))
            },
            |p: Vec2| d.pmf(((p.y * n as f32) as usize).min(n - 1)) * n as f32,
        )
        .assert_ok();
}
