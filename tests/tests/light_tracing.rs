//! Light tracing against analytic solutions and against the path tracer: the white furnace term by
//! term, a Lambertian plane under a constant sky (the environment as an emitter: radiance ρ·L
//! everywhere), the Cornell box through a pinhole and through a thin lens (region means compared
//! with path tracing), and bit-identical images on 1 and 2 threads.
//!
//! False-failure rate: each test's z-tests are Šidák-corrected to ≤ 1e-3 per test; fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{
    check_furnace_every_bounce, check_plane_under_sky, cornell, regions, render, scene, z,
};

#[test]
fn furnace_every_bounce_count() {
    check_furnace_every_bounce("Light", 256);
}

#[test]
fn plane_under_a_constant_sky() {
    check_plane_under_sky(&["Light()", "Path()"]);
}

#[test]
fn cornell_box_agrees_with_path_tracing_pinhole_and_thin_lens() {
    let pinhole = cornell(1.0, [0.0; 3], (32, 32));
    let thin_lens = pinhole.replace(
        "fov: 39.3077,",
        "fov: 39.3077, lens: ThinLens(aperture_radius: 0.15, focus_distance: 3.2),",
    );
    assert_ne!(pinhole, thin_lens);
    let crit = z_critical(sidak(1e-3, 2 * 16 * 3));
    for (what, text) in [("pinhole", pinhole), ("thin lens", thin_lens)] {
        let sc = scene(&text);
        let pt = regions(&render(&sc, "Path(max_bounces: 4)", 256, 1), 4);
        let lt = regions(&render(&sc, "Light(max_bounces: 4)", 64, 2), 4);
        for (k, (a, b)) in pt.iter().zip(&lt).enumerate() {
            for c in 0..3 {
                let z = z(b.0[c], b.1[c], a.0[c], a.1[c]);
                assert!(
                    z.abs() < crit,
                    "{what}, region {k}, channel {c}: light {} ± {} vs path {} ± {}, z = {z:.2}",
                    b.0[c],
                    b.1[c],
                    a.0[c],
                    a.1[c]
                );
            }
        }
    }
}

#[test]
fn same_bits_on_one_and_two_threads() {
    let sc = scene(&cornell(1.0, [0.0; 3], (24, 20)));
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(&sc, "Light()", 16, 3)).film
    };
    assert_eq!(on(1), on(2));
}
