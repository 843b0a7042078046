//! Chi-square goodness-of-fit tests of every warp in `lightlab_samplers::warp` against its own
//! pdf, with the testkit harness (after Mitsuba 3's `chi2.py`): 10⁶ samples per test, cells
//! expected below 5 pooled, immediate failure for a sample where the pdf is zero.
//!
//! False failures: each test runs at the default α = sidak(0.01, 300) = 3.35 × 10⁻⁵, so a
//! correct warp fails with that probability over the choice of seed, and the 10 chi-square tests
//! of this file together with probability 1 − (1 − α)¹⁰ ≈ 0.03 %. The seeds are fixed, so a
//! passing run keeps passing until a warp's code changes.

use lightlab_samplers::warp::*;
use lightlab_testkit::{Chi2Test, Domain};

#[test]
fn chi2_cosine_hemisphere() {
    Chi2Test::new(Domain::Hemisphere)
        .seed(1)
        .run(
            "cosine_hemisphere",
            |u| Some(square_to_cosine_hemisphere(u)),
            square_to_cosine_hemisphere_pdf,
        )
        .assert_ok();
}

#[test]
fn chi2_uniform_hemisphere() {
    Chi2Test::new(Domain::Hemisphere)
        .seed(2)
        .run(
            "uniform_hemisphere",
            |u| Some(square_to_uniform_hemisphere(u)),
            square_to_uniform_hemisphere_pdf,
        )
        .assert_ok();
}

#[test]
fn chi2_uniform_sphere() {
    Chi2Test::new(Domain::Sphere)
        .seed(3)
        .run(
            "uniform_sphere",
            |u| Some(square_to_uniform_sphere(u)),
            square_to_uniform_sphere_pdf,
        )
        .assert_ok();
}

/// A cone tested over the whole sphere: checks that no sample leaves the cone and that the pdf's
/// mass is where the samples are. The default 41 rows put the cone's edge inside a row (for
/// cos θmax = 0.9 at 5 % of row 2), where the harness integrates adaptively.
fn cone_on_sphere(name: &str, cos_theta_max: f32, seed: u64) {
    Chi2Test::new(Domain::Sphere)
        .seed(seed)
        .run(
            name,
            |u| Some(square_to_uniform_cone(u, cos_theta_max)),
            |v| square_to_uniform_cone_pdf(v, cos_theta_max),
        )
        .assert_ok();
}

/// A cone tested on its own cap, parameterised by 1 − cos θ computed from x² + y² so that even a
/// cone of 10⁻⁶ sr keeps 41 × 80 resolvable cells (on the sphere it would fill part of one cell).
fn cone_on_cap(name: &str, cos_theta_max: f32, seed: u64) {
    Chi2Test::new(Domain::Cap { cos_theta_max })
        .seed(seed)
        .run(
            name,
            |u| Some(square_to_uniform_cone(u, cos_theta_max)),
            |v| square_to_uniform_cone_pdf(v, cos_theta_max),
        )
        .assert_ok();
}

#[test]
fn chi2_uniform_cone_narrow() {
    cone_on_sphere("uniform_cone_0.9_sphere", 0.9, 4);
    cone_on_cap("uniform_cone_0.9_cap", 0.9, 5);
}

#[test]
fn chi2_uniform_cone_hemisphere_and_wider() {
    cone_on_sphere("uniform_cone_0.0_sphere", 0.0, 6);
    cone_on_sphere("uniform_cone_-0.5_sphere", -0.5, 7);
}

#[test]
fn chi2_uniform_cone_tiny() {
    // 1 − 10⁻⁶ in f32 is 0.99999899: a cone of half-angle 0.0816°, like the sun seen from far off.
    cone_on_cap("uniform_cone_tiny_cap", 1.0 - 1e-6, 8);
}

#[test]
fn chi2_concentric_disk() {
    Chi2Test::new(Domain::Disk)
        .seed(9)
        .run(
            "concentric_disk",
            |u| Some(square_to_concentric_disk(u)),
            square_to_concentric_disk_pdf,
        )
        .assert_ok();
}

#[test]
fn chi2_uniform_triangle() {
    // Barycentrics (b1, b2) on the unit square: density 2 on the lower-left triangle b1 + b2 ≤ 1,
    // zero above it. The diagonal cuts cells of the default 41 × 40 grid at generic positions.
    Chi2Test::new(Domain::Square)
        .seed(10)
        .run(
            "uniform_triangle",
            |u| Some(square_to_uniform_triangle(u)),
            square_to_uniform_triangle_pdf,
        )
        .assert_ok();
}
