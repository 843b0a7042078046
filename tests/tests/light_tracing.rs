//! Light tracing against analytic solutions and against the path tracer: the white furnace term by
//! term, a Lambertian plane under a constant sky (the environment as an emitter: radiance ρ·L
//! everywhere), the Cornell box through a pinhole and through a thin lens (region means compared
//! with path tracing), and bit-identical images on 1 and 2 threads.
//!
//! False-failure rate: each test's z-tests are Šidák-corrected to ≤ 1e-3 per test; fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{cornell, furnace, regions, render, scene, z};

#[test]
fn furnace_every_bounce_count() {
    let (rho, le) = (0.7f64, 0.5f64);
    let sc = scene(&furnace(rho as f32, le as f32, 1.0, (12, 8)));
    let configs: Vec<(String, f64)> = (0..=4)
        .map(|k| {
            (
                format!("Light(max_bounces: {k})"),
                (0..=k).map(|i| le * rho.powi(i)).sum(),
            )
        })
        .chain([
            (
                "Light(min_bounces: 2, max_bounces: 2)".to_string(),
                le * rho * rho,
            ),
            ("Light()".to_string(), le / (1.0 - rho)),
        ])
        .collect();
    let crit = z_critical(sidak(1e-3, configs.len() as u64 * 3));
    for (config, want) in configs {
        let out = render(&sc, &config, 256, 11);
        assert_eq!(out.stats.non_finite_total(), 0);
        let (mean, se) = out.film.average();
        for c in 0..3 {
            let z = z(mean[c], se[c], want, 0.0);
            assert!(
                z.abs() < crit,
                "{config}: {} ± {} vs {want}, z = {z:.2}",
                mean[c],
                se[c]
            );
        }
    }
}

#[test]
fn plane_under_a_constant_sky() {
    // Radiance leaving a Lambertian plane under a uniform sky L: ρ/π · πL = ρL.
    let text = "Scene(camera: Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 30, resolution: (16, 16)),
        materials: { \"plane\": Diffuse(albedo: (0.6, 0.5, 0.4)) },
        shapes: [ Shape(geometry: Quad(corner: (-5, 0, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"plane\") ],
        lights: [ Environment(radiance: (2, 2, 2)) ])";
    let sc = scene(text);
    let want = [1.2, 1.0, 0.8];
    let crit = z_critical(sidak(1e-3, 2 * 3));
    for config in ["Light()", "Path()"] {
        let out = render(&sc, config, 256, 5);
        let (mean, se) = out.film.average();
        for c in 0..3 {
            let z = z(mean[c], se[c], want[c], 0.0);
            assert!(
                z.abs() < crit,
                "{config}: channel {c}: {} ± {} vs {}, z = {z:.2}",
                mean[c],
                se[c],
                want[c]
            );
        }
    }
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
