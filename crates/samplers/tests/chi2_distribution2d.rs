//! Chi-square tests of `Distribution2D` against its own pdf on the unit square, and
//! deterministic tests of its pdf (normalisation, agreement with the value a sample reports) and
//! of its inverse.
//!
//! Every table's cell edges are also edges of the histogram (the histogram is an integer multiple
//! of the table), so the harness integrates a density that is constant inside each histogram
//! cell; the tables have zero rows, zero columns and isolated zero cells, where any sample is an
//! immediate failure.
//!
//! False failures: 4 chi-square tests (in 3 test functions) at the default
//! α = sidak(0.01, 300) = 3.35 × 10⁻⁵ each, together 1 − (1 − α)⁴ ≈ 0.013 % over the choice of
//! seed; the seeds are fixed. The other tests are deterministic.

use glam::Vec2;
use lightlab_samplers::Distribution2D;
use lightlab_testkit::{Chi2Test, Domain};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// A smooth bump times a ramp on a 16 × 12 grid, with column 5 and row 7 zero and a few zero
/// cells: a dynamic range of about 10³ among the positive cells.
fn bumpy_table() -> (Vec<f32>, usize, usize) {
    let (nu, nv) = (16, 12);
    let mut values = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (u, v) = ((i as f32 + 0.5) / nu as f32, (j as f32 + 0.5) / nv as f32);
            let bump = (-((u - 0.3).powi(2) + (v - 0.6).powi(2)) / 0.02).exp();
            let mut f = 1e-3 + bump * (0.2 + u);
            if i == 5 || j == 7 || (i + 3 * j) % 17 == 0 {
                f = 0.0;
            }
            values.push(f);
        }
    }
    (values, nu, nv)
}

/// Like an environment map in latitude–longitude: a sun (one bright cell, 10⁴ × the sky), a sky
/// weighted by sin θ, and a black ground (bottom half zero).
fn sky_table() -> (Vec<f32>, usize, usize) {
    let (nu, nv) = (32, 16);
    let mut values = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        let theta = std::f32::consts::PI * (j as f32 + 0.5) / nv as f32;
        for i in 0..nu {
            let f = if j >= nv / 2 {
                0.0
            } else if (i, j) == (20, 3) {
                1e4
            } else {
                (1.0 + 0.5 * (i as f32 * 0.4).sin()) * theta.sin()
            };
            values.push(f);
        }
    }
    (values, nu, nv)
}

/// Chi-square test of `values` on a histogram of `k` histogram cells per table cell along each axis.
fn chi2_table(name: &str, (values, nu, nv): (Vec<f32>, usize, usize), k: usize, seed: u64) {
    let d = Distribution2D::new(&values, nu, nv).unwrap();
    Chi2Test::new(Domain::Square)
        .resolution(k * nv, k * nu)
        .seed(seed)
        .run(
            name,
            |u: Vec2| {
                let (p, pdf) = d.sample(u);
                assert_eq!(pdf, d.pdf(p), "{name}: u {u} -> {p}");
                Some(p)
            },
            |p: Vec2| d.pdf(p),
        )
        .assert_ok();
}

#[test]
fn chi2_distribution2d_bumpy() {
    chi2_table("distribution2d_bumpy", bumpy_table(), 3, 31);
}

#[test]
fn chi2_distribution2d_sky() {
    chi2_table("distribution2d_sky", sky_table(), 2, 32);
}

#[test]
fn chi2_distribution2d_single_row_and_column() {
    // Degenerate shapes: one row (the marginal is trivial) and one column (each conditional is).
    let row: Vec<f32> = (0..10).map(|i| [0.0, 1.0, 5.0, 0.5, 2.0][i % 5]).collect();
    chi2_table("distribution2d_one_row", (row.clone(), 10, 1), 4, 33);
    chi2_table("distribution2d_one_column", (row, 1, 10), 4, 34);
}

/// pdf = value / mean value in every cell, and ∫ pdf = 1 (exact sum over the cells).
#[test]
fn distribution2d_pdf_is_the_normalised_table() {
    for (values, nu, nv) in [bumpy_table(), sky_table()] {
        let d = Distribution2D::new(&values, nu, nv).unwrap();
        assert_eq!(d.resolution(), (nu, nv));
        let mean = values.iter().map(|&v| v as f64).sum::<f64>() / (nu * nv) as f64;
        assert!((d.integral() - mean).abs() < 1e-12 * mean);
        let mut mass = 0.0f64;
        for j in 0..nv {
            for i in 0..nu {
                // The centre and the lower-left corner of the cell (edges belong to the cell above).
                for p in [
                    Vec2::new((i as f32 + 0.5) / nu as f32, (j as f32 + 0.5) / nv as f32),
                    Vec2::new(i as f32 / nu as f32, j as f32 / nv as f32),
                ] {
                    let want = (values[j * nu + i] as f64 / mean) as f32;
                    assert!(
                        (d.pdf(p) - want).abs() <= 1e-6 * want,
                        "cell ({i}, {j}) at {p}"
                    );
                }
                mass += d.pdf(Vec2::new(
                    (i as f32 + 0.5) / nu as f32,
                    (j as f32 + 0.5) / nv as f32,
                )) as f64
                    / (nu * nv) as f64;
            }
        }
        assert!((mass - 1.0).abs() < 1e-6, "∫ pdf = {mass}");
        // The top and right edges belong to the last cells; outside the square the pdf is zero.
        assert_eq!(d.pdf(Vec2::ONE), (values[nu * nv - 1] as f64 / mean) as f32);
        for p in [Vec2::new(-1e-6, 0.5), Vec2::new(0.5, 1.000_001), Vec2::NAN] {
            assert_eq!(d.pdf(p), 0.0, "{p}");
        }
    }
}

/// Samples land where the pdf is positive, even for u at the edges of [0, 1)² and at CDF steps,
/// and `invert` undoes `sample` (and `sample` undoes `invert`).
#[test]
fn distribution2d_invert_round_trips() {
    let below_one = 1.0 - f32::EPSILON / 2.0;
    for (values, nu, nv) in [bumpy_table(), sky_table()] {
        let d = Distribution2D::new(&values, nu, nv).unwrap();
        let mut rng = Pcg32::seed_from_u64(35);
        let edges = [0.0, 1e-7, 0.5, below_one];
        let us = edges
            .into_iter()
            .flat_map(|x| edges.map(|y| Vec2::new(x, y)))
            .chain((0..20_000).map(|_| Vec2::new(rng.random(), rng.random())));
        for u in us {
            let (p, pdf) = d.sample(u);
            assert!(pdf > 0.0 && p.cmpge(Vec2::ZERO).all() && p.cmplt(Vec2::ONE).all());
            let back = d.invert(p).expect("a sampled point has an inverse");
            // u.y (marginal) is recovered to f32 rounding of the CDF; u.x depends on the row.
            assert!(
                (back - u).abs().max_element() < 2e-5,
                "{u} -> {p} -> {back}"
            );
            let (again, _) = d.sample(back);
            assert!(
                (again - p).abs().max_element() < 1e-5,
                "{p} -> {back} -> {again}"
            );
        }
        // No inverse where nothing is sampled.
        let zero_cell = (0..nu * nv).find(|&c| values[c] == 0.0).unwrap();
        let centre = Vec2::new(
            ((zero_cell % nu) as f32 + 0.5) / nu as f32,
            ((zero_cell / nu) as f32 + 0.5) / nv as f32,
        );
        assert!(d.invert(centre).is_none());
        assert!(d.invert(Vec2::new(1.5, 0.5)).is_none());
    }
}

#[test]
fn distribution2d_rejects_bad_input() {
    assert!(Distribution2D::new(&[], 0, 3).is_none());
    assert!(Distribution2D::new(&[1.0; 6], 2, 2).is_none());
    assert!(Distribution2D::new(&[0.0; 6], 2, 3).is_none());
    assert!(Distribution2D::new(&[1.0, -1.0, 1.0, 1.0], 2, 2).is_none());
    assert!(Distribution2D::new(&[1.0, f32::INFINITY, 1.0, 1.0], 2, 2).is_none());
    // Tiny values are fine: the marginal is normalised before it is rounded to f32.
    let d = Distribution2D::new(&[1e-40, 0.0, 0.0, 3e-40], 2, 2).unwrap();
    let (p, pdf) = d.sample(Vec2::new(0.3, 0.8));
    assert!(pdf > 0.0 && p.x >= 0.5 && p.y >= 0.5, "{p} {pdf}");
}
