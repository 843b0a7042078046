//! Chi-square tests of the uniform cone warp on a gnomonic window around its axis, where the
//! cone's edge falls inside the cells (the `Domain::Cap` tests of `chi2_warps.rs` fit the cap to
//! the cone exactly, so they never ask the pdf about directions near its edge).
//!
//! Tiny cones: near z = 1 the rounded z has a spacing of 6·10⁻⁸, and for a half-angle of 10⁻³ rad
//! 1 − cos θmax = 4.8·10⁻⁷ is only 8 such steps. A pdf that tested membership by `z ≥ cos θmax`
//! saw a jagged edge and integrated to 1.06 over the window (this test failed with X² ≈ 45 000);
//! `square_to_uniform_cone_pdf` now tests (x² + y²)/(1 + z) ≤ 1 − cos θmax. The last test checks
//! the warp against an independent f64 membership test (`precise_cone_pdf`).
//!
//! False failures: 3 chi-square tests at the default
//! α = sidak(0.01, 300) = 3.35 × 10⁻⁵ each, together 1 − (1 − α)³ ≈ 0.010 %; the seeds are fixed.

use glam::{DVec3, Vec2, Vec3};
use lightlab_samplers::warp::{square_to_uniform_cone, square_to_uniform_cone_pdf};
use lightlab_testkit::{Chi2Test, DirectionWindow, Domain};

/// The cone's pdf with membership decided from 1 − cos θ computed without cancellation.
fn precise_cone_pdf(v: Vec3, cos_theta_max: f32) -> f32 {
    let one_minus_cos = if v.z > 0.0 {
        (v.x * v.x + v.y * v.y) / (1.0 + v.z)
    } else {
        1.0 - v.z
    };
    if one_minus_cos <= 1.0 - cos_theta_max {
        1.0 / (2.0 * std::f32::consts::PI * (1.0 - cos_theta_max))
    } else {
        0.0
    }
}

/// Uniform cone of half-angle `theta` on a window 1.2 times as wide, tested against `pdf`.
fn chi2_cone(name: &str, theta: f32, seed: u64, pdf: impl Fn(Vec3, f32) -> f32) {
    let cos_theta_max = theta.cos();
    let half = 1.2 * (theta as f64).tan();
    let window = DirectionWindow::new(DVec3::Z, DVec3::X, (half, half));
    let result = Chi2Test::new(Domain::Square).seed(seed).run(
        name,
        |u: Vec2| window.to_square(square_to_uniform_cone(u, cos_theta_max)),
        |p: Vec2| window.density(p, |w| pdf(w, cos_theta_max)),
    );
    result.assert_ok();
    assert_eq!(
        result.accepted, result.samples,
        "{name}: samples outside the window"
    );
}

#[test]
fn chi2_uniform_cone_narrow_window() {
    chi2_cone(
        "uniform_cone_0.05rad_window",
        0.05,
        41,
        square_to_uniform_cone_pdf,
    );
}

#[test]
fn chi2_uniform_cone_tiny_window_precise_membership() {
    chi2_cone(
        "uniform_cone_1e-3rad_window_precise",
        1e-3,
        42,
        precise_cone_pdf,
    );
}

#[test]
fn chi2_uniform_cone_tiny_window() {
    chi2_cone(
        "uniform_cone_1e-3rad_window",
        1e-3,
        42,
        square_to_uniform_cone_pdf,
    );
}
