//! Bidirectional path tracing against analytic solutions and the path tracer: the white furnace
//! term by term, a plane under a constant sky (ρ·L), the Cornell box (pinhole and thin lens, all
//! bounces and one Neumann term alone), the caustic sphere (specular paths), point and spot lights
//! over a plane, and bit-identical images on 1 and 2 threads.
//!
//! False-failure rate: each test's z-tests are Šidák-corrected to ≤ 1e-3 per test; fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{
    caustic_sphere, check_furnace_every_bounce, check_plane_under_sky, cornell, image_mean,
    regions, render, scene, z,
};

#[test]
fn furnace_every_bounce_count() {
    check_furnace_every_bounce("Bdpt", 128);
}

#[test]
fn plane_under_a_constant_sky() {
    check_plane_under_sky(&["Bdpt()"]);
}

/// Compares BDPT with path tracing region by region on each (scene text, settings) case.
fn agree_with_path_tracing(cases: &[(&str, String, &str, u32)], n: usize) {
    let crit = z_critical(sidak(1e-3, (cases.len() * n * n * 3) as u64));
    for (what, text, bounces, spp) in cases {
        let sc = scene(text);
        let pt = regions(&render(&sc, &format!("Path({bounces})"), spp * 4, 1), n);
        let bd = regions(&render(&sc, &format!("Bdpt({bounces})"), *spp, 2), n);
        for (k, (a, b)) in pt.iter().zip(&bd).enumerate() {
            for c in 0..3 {
                let z = z(b.0[c], b.1[c], a.0[c], a.1[c]);
                assert!(
                    z.abs() < crit,
                    "{what} ({bounces}), region {k}, channel {c}: bdpt {} ± {} vs path {} ± {}, z = {z:.2}",
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
fn cornell_box_agrees_with_path_tracing() {
    let pinhole = cornell(1.0, [0.0; 3], (32, 32));
    let thin_lens = pinhole.replace(
        "fov: 39.3077,",
        "fov: 39.3077, lens: ThinLens(aperture_radius: 0.15, focus_distance: 3.2),",
    );
    agree_with_path_tracing(
        &[
            ("pinhole", pinhole.clone(), "max_bounces: 5", 64),
            (
                "pinhole, second term only",
                pinhole,
                "min_bounces: 2, max_bounces: 2",
                64,
            ),
            ("thin lens", thin_lens, "max_bounces: 3", 64),
        ],
        4,
    );
}

#[test]
fn caustic_sphere_and_small_lights_agree_with_path_tracing() {
    let caustic = caustic_sphere((24, 24));
    let plane = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/point-over-plane.ron"
    ))
    .unwrap();
    let spot = plane.replace(
        "Point(position: (0, 1, 0), intensity: (10, 10, 10))",
        "Spot(position: (0, 1, 0), target: (0.3, 0, 0), intensity: (10, 10, 10), cone_angle: 40, falloff_start: 25)",
    );
    assert_ne!(spot, plane);
    agree_with_path_tracing(
        &[
            ("caustic sphere", caustic, "max_bounces: 5", 256),
            ("point light", plane, "", 64),
            ("spot light", spot, "", 64),
        ],
        2,
    );
}

#[test]
fn same_bits_on_one_and_two_threads() {
    let sc = scene(&cornell(1.0, [0.0; 3], (24, 20)));
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(&sc, "Bdpt(sampler: Sobol)", 8, 3))
            .film
    };
    assert_eq!(on(1), on(2));
}

/// Every weighting is unbiased: the power heuristic and uniform weights over all strategies, and
/// each single strategy alone on the paths of its length (here the first bounce, 1 scattering
/// vertex: emitter hit by the camera path (0, 3), light sampling (1, 2), light vertex splatted
/// through the lens (2, 1)).
#[test]
fn every_weighting_and_single_strategy_agrees_with_path_tracing() {
    let text = cornell(1.0, [0.0; 3], (24, 24));
    let cases: Vec<(String, String)> = vec![
        (
            "Path(max_bounces: 3)".into(),
            "Bdpt(max_bounces: 3, mis: Power)".into(),
        ),
        (
            "Path(max_bounces: 3)".into(),
            "Bdpt(max_bounces: 3, mis: Uniform)".into(),
        ),
        (
            "Path(min_bounces: 1, max_bounces: 1)".into(),
            "Bdpt(min_bounces: 1, max_bounces: 1, mis: Only(s: 0, t: 3))".into(),
        ),
        (
            "Path(min_bounces: 1, max_bounces: 1)".into(),
            "Bdpt(min_bounces: 1, max_bounces: 1, mis: Only(s: 1, t: 2))".into(),
        ),
        (
            "Path(min_bounces: 1, max_bounces: 1)".into(),
            "Bdpt(min_bounces: 1, max_bounces: 1, mis: Only(s: 2, t: 1))".into(),
        ),
    ];
    let sc = scene(&text);
    let crit = z_critical(sidak(1e-3, (cases.len() * 4 * 3) as u64));
    for (path, bdpt) in &cases {
        let a = regions(&render(&sc, path, 256, 1), 2);
        let b = regions(&render(&sc, bdpt, 256, 2), 2);
        for (k, (a, b)) in a.iter().zip(&b).enumerate() {
            for c in 0..3 {
                let z = z(b.0[c], b.1[c], a.0[c], a.1[c]);
                assert!(
                    z.abs() < crit,
                    "{bdpt} vs {path}, region {k}, channel {c}: {} ± {} vs {} ± {}, z = {z:.2}",
                    b.0[c],
                    b.1[c],
                    a.0[c],
                    a.1[c]
                );
            }
        }
    }
}

/// Per-strategy layers (the research view of pbrt-v4 and Tungsten): the MIS-weighted layers of all
/// strategies sum to the image, and each strategy's unweighted layer is an estimate of its own: on
/// the Cornell box, where every strategy can make every path, the three strategies of direct light
/// (s, t) = (0, 3) BSDF sampling, (1, 2) light sampling and (2, 1) light tracing agree in image mean
/// (z-tests Šidák-corrected to 1e-3 over 2 comparisons × 3 channels).
#[test]
fn strategy_layers_sum_to_the_image_and_each_estimates_its_paths() {
    let sc = scene(&cornell(1.0, [0.0; 3], (24, 24)));
    let out = render(&sc, "Bdpt(max_bounces: 2, strategy_layers: true)", 64, 8);
    let names: Vec<&str> = out.layers.iter().map(|(n, _)| n.as_str()).collect();
    for want in [
        "s0t2",
        "s1t1",
        "s0t3",
        "s1t2",
        "s2t1",
        "s0t4",
        "s1t3",
        "s2t2",
        "s3t1",
        "s2t1.unweighted",
    ] {
        assert!(names.contains(&want), "no layer {want} in {names:?}");
    }
    for i in 0..out.film.pixels.len() {
        let whole = out.film.mean(i);
        for c in 0..3 {
            let sum: f64 = out
                .layers
                .iter()
                .filter(|(n, _)| !n.ends_with(".unweighted"))
                .map(|(_, f)| f.mean(i)[c])
                .sum();
            assert!(
                (sum - whole[c]).abs() <= 1e-5 * whole[c].abs().max(1e-3),
                "pixel {i} channel {c}: strategies sum to {sum}, image {}",
                whole[c]
            );
        }
    }
    let layer = |name: &str| image_mean(&out.layers.iter().find(|(n, _)| n == name).unwrap().1);
    let crit = z_critical(sidak(1e-3, 6));
    let (nee, nee_se) = layer("s1t2.unweighted");
    for other in ["s0t3.unweighted", "s2t1.unweighted"] {
        let (m, se) = layer(other);
        for c in 0..3 {
            let zs = z(m[c], se[c], nee[c], nee_se[c]);
            assert!(
                zs.abs() < crit,
                "{other} channel {c}: {} ± {} vs light sampling {} ± {}",
                m[c],
                se[c],
                nee[c],
                nee_se[c]
            );
        }
    }
}

/// Outlier provenance: contributions far above their pixel's mean are logged with pixel, sample
/// index, strategy, class, densities and MIS weight; the statistics count them per strategy; and
/// each replays bit for bit from (seed, pixel, sample index) alone.
#[test]
fn outliers_are_logged_counted_and_replay_exactly() {
    use lightlab_integrators::IntegratorConfig;
    use lightlab_integrators::bdpt::Bdpt;
    let text = caustic_sphere((32, 24));
    let sc = scene(&text);
    // Uniform weights make fireflies of the caustic's hard strategies: something to log.
    let config = "Bdpt(max_bounces: 6, outliers: 20, mis: Uniform)";
    let (spp, seed) = (32, 4);
    let out = render(&sc, config, spp, seed);
    assert!(!out.outliers.is_empty(), "no outliers on the caustic scene");
    let counted: u64 = out.stats.outliers.iter().map(|(_, n)| n).sum();
    assert_eq!(counted, out.outliers.len() as u64);
    let IntegratorConfig::Bdpt(c) = IntegratorConfig::from_ron(config).unwrap() else {
        unreachable!()
    };
    let bdpt = Bdpt::new(c).unwrap();
    for o in &out.outliers {
        assert!(o.class.starts_with('L') && o.class.ends_with('E'));
        assert_eq!(o.pdf_fwd.len(), (o.s + o.t) as usize);
        let size = o.value.iter().fold(0f32, |a, &b| a.max(b)) as f64;
        let mean = o.pixel_mean.iter().fold(0f64, |a, &b| a.max(b));
        assert!(size > 20.0 * mean, "{o:?} is not an outlier");
        let replayed = bdpt.replay(&sc, seed, spp, (o.pixel[0], o.pixel[1]), o.sample);
        assert!(
            replayed.iter().any(|r| {
                let mut r = r.clone();
                r.pixel_mean = o.pixel_mean;
                &r == o
            }),
            "outlier {o:?} does not replay"
        );
    }
}
