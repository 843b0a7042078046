//! Vertex connection and merging against analytic answers, path tracing and BDPT: the white
//! furnace term by term for every variant, a plane under a constant sky, the Cornell box and the
//! caustic sphere; `Vc` (connections only) against BDPT; the merges' bias shrinking with passes.
//!
//! Merges make every pixel of a pass depend on the same light paths, and their radius shrinks
//! from pass to pass, so for `Vcm` and `Bpm` noise is measured across independent seeds (Student's
//! t with seeds − 1 degrees of freedom) or, region by region, from the film's spread of per-pass
//! estimates with an allowance for the blur of density estimation. False-failure rate: each
//! test's statistical checks are Šidák-corrected to ≤ 1e-3, except that region z-tests take
//! VCM's standard error from independent pixels, which measured up to 1.15× too small in variance
//! (`lightlab_tests::regions`): up to 4·10⁻³ for those tests; fixed seeds.

use lightlab_core::NoProgress;
use lightlab_integrators::{Budget, IntegratorConfig};
use lightlab_testkit::stats::{sidak, t_critical};
use lightlab_tests::{
    across_seeds, caustic_sphere, check_plane_under_sky, cornell, furnace, image_mean,
    pass_regions, regions, render, scene, z,
};

/// The variants, and VCM with three light paths per pixel and pass.
const VARIANTS: [&str; 5] = [
    "variant: Vcm",
    "variant: Vc",
    "variant: Bpm",
    "variant: Vcm, light_paths: 3",
    "variant: Vc, light_paths: 3",
];

/// White furnace (ρ = 0.7, Lₑ = 0.5): every variant (and VCM and VC with three light paths per
/// pixel), with merges that carry a good part of the
/// image (η = π r² N ≈ 0.4), gives Lₑ·Σρᵏ for max_bounces 1 and 3, the second term alone and the
/// whole series — 8 seeds each (t-test, 7 degrees of freedom) and within 1.5 %. A sphere's area
/// within chord distance r is exactly πr² (Archimedes), so density estimation is unbiased here;
/// what remains is VCM's own approximation, the merge weights evaluated with the light vertex
/// standing for the camera vertex, which vanishes with the radius (measured, second term, `Bpm`,
/// 16 seeds × 1024 passes at a fixed radius: +0.58 % ± 0.06 % at r = 0.1, −0.01 % ± 0.01 % at
/// r = 0.02).
#[test]
fn furnace_every_variant_every_bounce_limit() {
    let (rho, le) = (0.7f64, 0.5f64);
    let sc = scene(&furnace(rho as f32, le as f32, 1.0, (8, 6)));
    let limits: [(&str, f64); 4] = [
        ("max_bounces: 1", le * (1.0 + rho)),
        ("max_bounces: 3", (0..=3).map(|i| le * rho.powi(i)).sum()),
        ("min_bounces: 2, max_bounces: 2", le * rho * rho),
        ("russian_roulette: Some(2)", le / (1.0 - rho)),
    ];
    let seeds = 8;
    let crit = t_critical(sidak(1e-3, (VARIANTS.len() * limits.len() * 3) as u64), 7.0);
    for variant in VARIANTS {
        for (limit, want) in limits {
            let config = format!("Vcm({variant}, {limit}, radius: Relative(0.05))");
            let (mean, se) = across_seeds(&sc, &config, 32, seeds)[0];
            for c in 0..3 {
                let t = z(mean[c], se[c], want, 0.0);
                assert!(
                    t.abs() < crit && (mean[c] / want - 1.0).abs() < 0.015,
                    "{config}: {} ± {} vs {want}, t = {t:.2}",
                    mean[c],
                    se[c]
                );
            }
        }
    }
}

/// A Lambertian plane under a uniform sky leaves ρL: connections and merges find the environment
/// light as BDPT does (`Vc` z-tested on its own standard error, `Vcm` and `Bpm` across seeds).
#[test]
fn plane_under_a_constant_sky() {
    check_plane_under_sky(&["Vcm(variant: Vc)"]);
    let text = "Scene(camera: Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 30, resolution: (16, 16)),
        materials: { \"plane\": Diffuse(albedo: (0.6, 0.5, 0.4)) },
        shapes: [ Shape(geometry: Quad(corner: (-5, 0, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"plane\") ],
        lights: [ Environment(radiance: (2, 2, 2)) ])";
    let sc = scene(text);
    let want = [1.2, 1.0, 0.8];
    let crit = t_critical(sidak(1e-3, 2 * 3), 7.0);
    for config in [
        "Vcm(radius: Relative(0.05))",
        "Vcm(variant: Bpm, radius: Relative(0.05))",
    ] {
        let (mean, se) = across_seeds(&sc, config, 16, 8)[0];
        for c in 0..3 {
            let t = z(mean[c], se[c], want[c], 0.0);
            assert!(
                t.abs() < crit,
                "{config}: channel {c}: {} ± {} vs {}, t = {t:.2}",
                mean[c],
                se[c],
                want[c]
            );
        }
    }
}

/// `Vc` is BDPT with one light path per camera path: on the Cornell box and the caustic sphere
/// its image agrees with `Bdpt`'s region by region (4 × 4 regions, z-test on both films'
/// variances) — also with three light paths per pixel, all splatted.
#[test]
fn vc_agrees_with_bdpt() {
    let cases = [
        ("cornell box", cornell(1.0, [0.0; 3], (32, 32))),
        ("caustic sphere", caustic_sphere((32, 32))),
    ];
    let vcs = [
        "Vcm(variant: Vc, max_bounces: 6)",
        "Vcm(variant: Vc, max_bounces: 6, light_paths: 3)",
    ];
    // Vc's errors have 127 degrees of freedom (pass_regions), BDPT's far more: Welch's ν is at
    // least 127, so t(127) is a conservative critical value.
    let crit = t_critical(
        sidak(1e-3, (cases.len() * vcs.len() * 16 * 3) as u64),
        127.0,
    );
    for ((what, text), config) in cases.iter().flat_map(|c| vcs.iter().map(move |v| (c, v))) {
        let sc = scene(text);
        let bdpt = regions(&render(&sc, "Bdpt(max_bounces: 6)", 128, 1), 4);
        let vc = pass_regions(&sc, config, 128, 2, 4);
        for (k, (a, b)) in vc.iter().zip(&bdpt).enumerate() {
            for c in 0..3 {
                let z = z(a.0[c], a.1[c], b.0[c], b.1[c]);
                assert!(
                    z.abs() < crit,
                    "{what}, {config}, region {k}, channel {c}: vc {} ± {} vs bdpt {} ± {}, z = {z:.2}",
                    a.0[c],
                    a.1[c],
                    b.0[c],
                    b.1[c]
                );
            }
        }
    }
}

/// On the Cornell box and the caustic sphere `Vcm` and `Bpm` agree with path tracing (the
/// caustic sphere: BDPT, which finds `L S+ D E` far better) region by region within noise plus
/// an allowance for the blur of merging at a radius that shrinks from 2 % of the scene: 1 %
/// for `Vcm`, whose weights leave merges little of these paths, 3 % for `Bpm`, which merges
/// everything. Their noise is the spread of each region's per-pass estimates (`pass_regions`:
/// passes at a shrinking radius are not identically distributed, which makes it conservative).
/// Leaving out merges in `Bpm` (only emission seen directly remains) must fail the check.
#[test]
fn vcm_and_bpm_agree_with_path_tracing() {
    let cases = [
        (
            "cornell box",
            cornell(1.0, [0.0; 3], (24, 24)),
            "Path(max_bounces: 6)",
        ),
        (
            "caustic sphere",
            caustic_sphere((24, 24)),
            "Bdpt(max_bounces: 6)",
        ),
    ];
    let crit = t_critical(sidak(1e-3, (cases.len() * 2 * 16 * 3) as u64), 127.0);
    for (what, text, reference) in cases {
        let sc = scene(&text);
        let want = regions(&render(&sc, reference, 2048, 1), 4);
        let worst = |config: &str| {
            let got = pass_regions(&sc, config, 128, 2, 4);
            let mut worst = 0.0f64;
            for (g, w) in got.iter().zip(&want) {
                for c in 0..3 {
                    let sigma = (g.1[c] * g.1[c] + w.1[c] * w.1[c]).sqrt();
                    worst = worst.max(((g.0[c] - w.0[c]).abs() - crit * sigma) / w.0[c]);
                }
            }
            worst
        };
        for (variant, allowance) in [("Vcm", 0.01), ("Bpm", 0.03)] {
            let config = format!("Vcm(variant: {variant}, max_bounces: 6, radius: Relative(0.02))");
            let w = worst(&config);
            assert!(
                w < allowance,
                "{what}, {config}: worst relative excess {w:.4}"
            );
        }
        let none = worst("Vcm(variant: Bpm, max_bounces: 0)");
        assert!(
            none > 0.1,
            "{what}: the check cannot see missing light ({none})"
        );
    }
}

/// The merges' bias shrinks as the radius does: on the caustic sphere's paths of 2–4 bounces,
/// `Bpm` (merges only) from a large first radius. The squared bias of the image after i passes —
/// ‖mean over 24 seeds − reference‖² less the seeds' and the reference's variance — falls from 16
/// to 256 passes to at most half (r_i⁴ ∝ i^(2(α−1)) predicts a quarter at α = 0.75), while at
/// α = 1 (a fixed radius) it stays within a factor 2 and after 256 passes is at least 3 times
/// the shrinking radius's. With 8 seeds the estimate was too noisy for these bounds: other seed
/// sets failed them before and after the parallelogram light sampling changed the light paths
/// (α = 1 drifting 3.5·10⁻⁵ → 1.2·10⁻⁵); with 24 it passes at three seed sets (900, 1900, 2900).
#[test]
fn merge_bias_shrinks_with_passes() {
    let sc = scene(&caustic_sphere((16, 16)));
    let reference = render(&sc, "Bdpt(min_bounces: 2, max_bounces: 4)", 16384, 77);
    let pixels = reference.film.pixels.len();
    let marks = [16u32, 256];
    let squared_bias = |alpha: f32| -> [f64; 2] {
        let config = IntegratorConfig::from_ron(&format!(
            "Vcm(variant: Bpm, min_bounces: 2, max_bounces: 4, radius: Relative(0.1), alpha: {alpha})"
        ))
        .unwrap()
        .build()
        .unwrap();
        let seeds = 24;
        // Per mark and pixel channel: Σ over seeds and Σ of squares.
        let mut sums = vec![[0.0f64; 2]; 2 * 3 * pixels];
        for seed in 0..seeds {
            config.render_passes(
                &sc,
                &Budget::Samples(256),
                900 + seed,
                &NoProgress,
                &mut |i, film| {
                    if let Some(k) = marks.iter().position(|&m| m == i) {
                        for j in 0..pixels {
                            let m = film.mean(j);
                            for c in 0..3 {
                                let s = &mut sums[(k * pixels + j) * 3 + c];
                                s[0] += m[c];
                                s[1] += m[c] * m[c];
                            }
                        }
                    }
                    true
                },
            );
        }
        let n = seeds as f64;
        [0, 1].map(|k| {
            let mut b = 0.0;
            for j in 0..pixels {
                let (r, v) = (reference.film.mean(j), reference.film.variance_of_mean(j));
                for c in 0..3 {
                    let [sum, sq] = sums[(k * pixels + j) * 3 + c];
                    let mean = sum / n;
                    let var = (sq / n - mean * mean) * n / (n - 1.0);
                    b += (mean - r[c]).powi(2) - var / n - v[c];
                }
            }
            b / (3 * pixels) as f64
        })
    };
    let [early, late] = squared_bias(0.75);
    let [fixed_early, fixed_late] = squared_bias(1.0);
    println!(
        "bias² α = 0.75: {early:.3e} → {late:.3e}; α = 1: {fixed_early:.3e} → {fixed_late:.3e}"
    );
    assert!(late < early / 2.0, "bias² {early:.3e} → {late:.3e}");
    assert!(
        fixed_late > fixed_early / 2.0 && fixed_late < 2.0 * fixed_early,
        "a fixed radius keeps its bias: {fixed_early:.3e} → {fixed_late:.3e}"
    );
    assert!(
        fixed_late > 3.0 * late,
        "after 256 passes: fixed radius {fixed_late:.3e}, shrinking {late:.3e}"
    );
}

/// `Vc` has independent, identically distributed passes: its image carries a standard error.
#[test]
fn vc_reports_a_standard_error_and_vcm_does_not_pretend_to() {
    let sc = scene(&cornell(1.0, [0.0; 3], (8, 8)));
    let vc = render(&sc, "Vcm(variant: Vc)", 4, 1);
    assert!(image_mean(&vc.film).1.iter().all(|&s| s > 0.0));
    let vcm = render(&sc, "Vcm()", 4, 1);
    assert!(vcm.film.image_se.is_none());
}

/// `strategy_layers` writes every connection `s{S}t{T}` and merge `m{T}` weighted (they sum to
/// the image, pixel by pixel, to rounding) and unweighted; on the caustic sphere the caustic seen
/// directly (`L S S D E`, mostly) comes from light tracing's strategies (s{S}t1) and merges,
/// camera paths hitting the light through the glass (s0t{T}) carrying almost none of it.
#[test]
fn technique_layers_sum_to_the_image() {
    let sc = scene(&caustic_sphere((16, 16)));
    let out = render(
        &sc,
        r#"Vcm(max_bounces: 4, strategy_layers: true, radius: Relative(0.02), paths: "LS+DE")"#,
        32,
        3,
    );
    let names: Vec<&str> = out.layers.iter().map(|(n, _)| n.as_str()).collect();
    for want in ["s0t2", "s1t1", "s2t1", "s3t2", "m2", "m3.unweighted", "m5"] {
        assert!(names.contains(&want), "no layer {want} in {names:?}");
    }
    let weighted: Vec<_> = out
        .layers
        .iter()
        .filter(|(n, _)| !n.ends_with(".unweighted"))
        .collect();
    for i in 0..out.film.pixels.len() {
        let whole = out.film.mean(i);
        for c in 0..3 {
            let sum: f64 = weighted.iter().map(|(_, f)| f.mean(i)[c]).sum();
            assert!(
                (sum - whole[c]).abs() <= 1e-5 * whole[c].abs().max(1e-3),
                "pixel {i} channel {c}: layers {sum} vs image {}",
                whole[c]
            );
        }
    }
    // Σ of the weighted layers whose names `pick` accepts.
    let total = |pick: &dyn Fn(&str) -> bool| -> f64 {
        weighted
            .iter()
            .filter(|(n, _)| pick(n))
            .map(|(_, f)| f.average().iter().sum::<f64>())
            .sum()
    };
    let all = out.film.average().iter().sum::<f64>();
    let light_tracing = total(&|n| n.ends_with("t1"));
    let merges = total(&|n| n.starts_with('m'));
    let camera_hits = total(&|n| n.starts_with("s0"));
    assert!(
        light_tracing + merges > 0.95 * all && camera_hits < 0.01 * all,
        "light tracing {light_tracing:.3e} + merges {merges:.3e} of {all:.3e}; camera paths \
         hitting the light {camera_hits:.3e}"
    );
}

/// Every kind of light, camera, sampler and material: a point and a spot light over a plane, the
/// Cornell box through a thin lens and with the Sobol' sampler, a rough glass sphere (glossy
/// transmission) and a Phong floor — `Vcm` against path tracing region by region (2 × 2), within
/// noise (the film's spread of passes, an approximation) plus 1 % for merging's blur.
#[test]
fn every_light_camera_sampler_and_material_agrees_with_path_tracing() {
    let plane = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/point-over-plane.ron"
    ))
    .unwrap();
    let spot = plane.replace(
        "Point(position: (0, 1, 0), intensity: (10, 10, 10))",
        "Spot(position: (0, 1, 0), target: (0.3, 0, 0), intensity: (10, 10, 10), cone_angle: 40, falloff_start: 25)",
    );
    let pinhole = cornell(1.0, [0.0; 3], (24, 24));
    let thin_lens = pinhole.replace(
        "fov: 39.3077,",
        "fov: 39.3077, lens: ThinLens(aperture_radius: 0.15, focus_distance: 3.2),",
    );
    let rough = caustic_sphere((24, 24))
        .replace(
            "Dielectric(ior: 1.5)",
            "RoughDielectric(roughness: Isotropic(0.1), ior: 1.5)",
        )
        .replace(
            "\"white\": Diffuse(albedo: (0.725, 0.71, 0.68))",
            "\"white\": Phong(kd: (0.4, 0.4, 0.4), ks: (0.3, 0.3, 0.3), exponent: 30)",
        );
    let cases = [
        ("point light", plane.clone(), "", 64),
        ("spot light", spot, "", 64),
        ("thin lens", thin_lens, "max_bounces: 3", 64),
        (
            "Sobol sampler",
            pinhole,
            "max_bounces: 3, sampler: Sobol",
            64,
        ),
        ("rough glass, Phong", rough, "max_bounces: 5", 128),
    ];
    assert!(cases[1].1 != plane && cases[4].1.contains("Phong") && cases[4].1.contains("Rough"));
    // VCM's errors have spp − 1 ≥ 63 degrees of freedom (pass_regions); t(63) is conservative.
    let crit = t_critical(sidak(1e-3, (cases.len() * 4 * 3) as u64), 63.0);
    for (what, text, settings, spp) in cases {
        let sc = scene(&text);
        let sep = if settings.is_empty() { "" } else { ", " };
        let pt = regions(&render(&sc, &format!("Path({settings})"), spp * 8, 1), 2);
        let config = format!("Vcm({settings}{sep}radius: Relative(0.01))");
        let vcm = pass_regions(&sc, &config, spp, 2, 2);
        for (k, (a, b)) in vcm.iter().zip(&pt).enumerate() {
            for c in 0..3 {
                let sigma = (a.1[c] * a.1[c] + b.1[c] * b.1[c]).sqrt();
                let excess = (a.0[c] - b.0[c]).abs() - crit * sigma;
                assert!(
                    excess < 0.01 * b.0[c],
                    "{what} ({config}), region {k}, channel {c}: vcm {} ± {} vs path {} ± {}",
                    a.0[c],
                    a.1[c],
                    b.0[c],
                    b.1[c]
                );
            }
        }
    }
}

/// Outliers are logged with their provenance (here above 5× their pixel's mean), counted per technique, and
/// every one — splats found after the render included — replays exactly from (seed, pixel, pass).
#[test]
fn outliers_are_logged_counted_and_replay_exactly() {
    use lightlab_integrators::Vcm;
    let sc = scene(&caustic_sphere((32, 24)));
    // A small radius makes merges noisy: something to log.
    let config = "Vcm(max_bounces: 6, outliers: 5, radius: Relative(0.002))";
    let (spp, seed) = (32, 4);
    let out = render(&sc, config, spp, seed);
    assert!(!out.outliers.is_empty(), "no outliers on the caustic scene");
    let counted: u64 = out.stats.outliers.iter().map(|(_, n)| n).sum();
    assert_eq!(counted, out.outliers.len() as u64);
    println!("{:?}", out.stats.outliers);
    let IntegratorConfig::Vcm(c) = IntegratorConfig::from_ron(config).unwrap() else {
        unreachable!()
    };
    let vcm = Vcm::new(c).unwrap();
    for o in &out.outliers {
        assert!(o.class.starts_with('L') && o.class.ends_with('E'));
        let vertices = (o.s + o.t) as usize - o.merge as usize;
        assert_eq!(o.pdf_fwd.len(), vertices, "{o:?}");
        let size = o.value.iter().fold(0f32, |a, &b| a.max(b)) as f64;
        let mean = o.pixel_mean.iter().fold(0f64, |a, &b| a.max(b));
        assert!(
            size > 5.0 * mean || !size.is_finite(),
            "{o:?} is not an outlier"
        );
        let replayed = vcm.replay(&sc, seed, spp, (o.pixel[0], o.pixel[1]), o.sample);
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
