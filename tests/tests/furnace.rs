//! White furnace (pbrt-v4's integrator tests; Lightlab's analytic check): inside a closed diffuse
//! enclosure of albedo ρ emitting Lₑ, every camera path sees radiance Lₑ·Σ_{k=min}^{max} ρᵏ exactly.
//! Each render's image mean is compared with that by a z-test on the render's own variance, beyond
//! an allowance of 2⁻¹⁶ relative for f32 rounding (see `check`).
//!
//! False-failure rate: each file's tests use a two-sided critical value Šidák-corrected so that the
//! whole file fails by chance with probability ≤ 1e-3; seeds are fixed, so a pass is reproducible.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{furnace, furnace_box, image_mean, render, scene};

/// Number of z-tests in this file (each channel of each render counts once).
const TESTS: u64 = 3 * (10 + 4 + 9 + 4);

fn z_crit() -> f64 {
    z_critical(sidak(1e-3, TESTS))
}

fn expected(le: f64, rho: f64, min: u32, max: Option<u32>) -> f64 {
    match max {
        Some(k) => (min..=k).map(|i| le * rho.powi(i as i32)).sum(),
        None => le * rho.powi(min as i32) / (1.0 - rho),
    }
}

fn check(what: &str, text: &str, config: &str, spp: u32, want: f64) {
    let out = render(&scene(text), config, spp, 7);
    assert_eq!(
        out.stats.non_finite_total(),
        0,
        "{what}: non-finite samples"
    );
    let (mean, se) = image_mean(&out.film);
    for c in 0..3 {
        // Beyond the z-test, the rounding of the renderer's f32 arithmetic: a furnace's samples
        // vary so little (a relative standard error of 3·10⁻⁷ at 64 spp) that a few ulps per
        // vertex show (−1.4·10⁻⁶ relative on the sphere furnace at two bounces, with libm's and
        // with Lightlab's own sine alike). 2⁻¹⁶ relative is ten times that and still fails any
        // bias a method could have.
        let rounding = want * (1.0 / 65536.0);
        let excess = ((mean[c] - want).abs() - rounding).max(0.0);
        let z = excess.copysign(mean[c] - want) / se[c].max(1e-12 * want.max(1e-30));
        assert!(
            z.abs() < z_crit(),
            "{what} with {config}: channel {c} mean {} ± {} (1σ) vs analytic {want}, z = {z:.2} (critical {:.2})",
            mean[c],
            se[c],
            z_crit()
        );
    }
}

#[test]
fn furnace_sphere_path_every_max_bounces() {
    let (rho, le) = (0.7, 0.5);
    let text = furnace(rho as f32, le as f32, 1.0, (16, 12));
    for k in 0..=8 {
        check(
            "sphere furnace",
            &text,
            &format!("Path(max_bounces: {k})"),
            64,
            expected(le, rho, 0, Some(k)),
        );
    }
    check(
        "sphere furnace",
        &text,
        "Path()",
        64,
        expected(le, rho, 0, None),
    );
}

#[test]
fn furnace_every_strategy() {
    let (rho, le) = (0.6, 1.5);
    let text = furnace(rho as f32, le as f32, 3.0, (12, 12));
    for s in ["Mis", "BsdfOnly", "LightOnly", "Uniform"] {
        check(
            "sphere furnace",
            &text,
            &format!("Path(max_bounces: 5, strategy: {s})"),
            64,
            expected(le, rho, 0, Some(5)),
        );
    }
}

#[test]
fn furnace_min_bounces_isolate_neumann_terms() {
    let (rho, le) = (0.8, 1.0);
    let text = furnace(rho as f32, le as f32, 1.0, (8, 8));
    for k in 0..=8 {
        check(
            "sphere furnace",
            &text,
            &format!("Path(min_bounces: {k}, max_bounces: {k})"),
            64,
            expected(le, rho, k, Some(k)),
        );
    }
}

#[test]
fn furnace_mesh_enclosure() {
    let (rho, le) = (0.5, 2.0);
    let text = furnace_box(rho as f32, le as f32, (12, 8));
    for cfg in [
        "Path(max_bounces: 3)",
        "Path(max_bounces: 3, strategy: LightOnly)",
        "Path(max_bounces: 3, strategy: BsdfOnly)",
    ] {
        check("box furnace", &text, cfg, 64, expected(le, rho, 0, Some(3)));
    }
    check(
        "box furnace",
        &text,
        "Path()",
        64,
        expected(le, rho, 0, None),
    );
}
