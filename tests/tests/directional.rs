//! A directional light (irradiance E along d̂) over a Lambertian plane of albedo ρ, with a black
//! square hovering above it: the radiance leaving the plane is ρ/π · E·cos θ where the square does
//! not shadow it, zero where it does, and zero on the square (nothing reflects back: the square
//! is black and the plane flat). Every pixel's mean is z-tested against that function averaged
//! over the pixel, for every unbiased integrator; the consistent ones (photon density estimation
//! blurs the shadow's edge) are t-tested on the image mean across seeds.
//!
//! False failures: ≤ 10⁻³ per test function (Šidák over configurations, pixels and channels);
//! seeds are fixed.

use glam::DVec3;
use lightlab_core::Vec2;
use lightlab_testkit::stats::{sidak, t_critical, z_critical};
use lightlab_tests::{across_seeds, render, scene};

const RHO: f64 = 0.5;
const IRRADIANCE: f64 = 2.0;
const DIRECTION: [f64; 3] = [-0.3, -1.0, 0.2];
/// The black square: y = 0.5, x and z in [−0.4, 0.4].
const SQUARE: (f64, f64) = (0.5, 0.4);

fn text() -> String {
    format!(
        "Scene(camera: Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 40, resolution: (24, 16)),
               materials: {{ \"plane\": Diffuse(albedo: ({RHO}, {RHO}, {RHO})),
                             \"black\": Diffuse(albedo: (0, 0, 0)) }},
               shapes: [
                   Shape(geometry: Quad(corner: (-4, 0, -4), edge1: (0, 0, 8), edge2: (8, 0, 0)), material: \"plane\"),
                   Shape(geometry: Quad(corner: (-{s}, {h}, -{s}), edge1: (0, 0, {w}), edge2: ({w}, 0, 0)), material: \"black\"),
               ],
               lights: [ Directional(direction: ({}, {}, {}), irradiance: ({IRRADIANCE}, {IRRADIANCE}, {IRRADIANCE})) ])",
        DIRECTION[0],
        DIRECTION[1],
        DIRECTION[2],
        h = SQUARE.0,
        s = SQUARE.1,
        w = 2.0 * SQUARE.1,
    )
}

/// Whether the ray o + t·d (t > 0) crosses the square.
fn hits_square(o: DVec3, d: DVec3) -> bool {
    let t = (SQUARE.0 - o.y) / d.y;
    let p = o + d * t;
    t > 0.0 && p.x.abs() <= SQUARE.1 && p.z.abs() <= SQUARE.1
}

/// The radiance seen through raster position `film` (render space is centred at `scene.origin`).
fn analytic(scene: &lightlab_scene::Scene, film: Vec2) -> f64 {
    let ray = scene.camera.generate_ray(film, Vec2::ZERO);
    let (o, d) = (ray.o.as_dvec3() + scene.origin, ray.d.as_dvec3());
    if d.y >= 0.0 || hits_square(o, d) {
        return 0.0;
    }
    let p = o + d * (-o.y / d.y);
    let to_light = -DVec3::from_array(DIRECTION).normalize();
    if p.x.abs() > 4.0 || p.z.abs() > 4.0 || hits_square(p, to_light) {
        return 0.0;
    }
    RHO / std::f64::consts::PI * IRRADIANCE * to_light.y
}

/// The analytic radiance averaged over each pixel (box filter, 16 × 16 points).
fn analytic_image(sc: &lightlab_scene::Scene) -> Vec<f64> {
    let (w, h) = (sc.camera.width, sc.camera.height);
    let n = 16;
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            (0..n * n)
                .map(|k| {
                    let u = ((k % n) as f32 + 0.5) / n as f32;
                    let v = ((k / n) as f32 + 0.5) / n as f32;
                    analytic(sc, Vec2::new(x + u, y + v))
                })
                .sum::<f64>()
                / (n * n) as f64
        })
        .collect()
}

#[test]
fn directional_light_over_a_plane_matches_the_analytic_image_per_pixel() {
    let sc = scene(&text());
    let want = analytic_image(&sc);
    // The image holds lit plane, shadow and the square.
    assert!(want.contains(&0.0) && want.iter().any(|&v| v > 0.1));
    // Light paths start on a disk bounding the whole plane, a tenth of which is in view: a pixel
    // receives about one light path per ten samples. Light tracing, and BDPT and VCM, whose
    // light-tracing strategy carries a few percent of each pixel, need enough samples for every
    // pixel to receive many light paths, or its variance estimate misses what they carry.
    let configs = [
        ("Path()", 64),
        ("Path(max_bounces: 1, strategy: LightOnly)", 64),
        ("Light()", 1024),
        ("Bdpt()", 1024),
        ("Vcm(variant: Vc)", 1024),
    ];
    let pixels = want.len() as u64;
    let crit = z_critical(sidak(1e-3, 3 * pixels * configs.len() as u64));
    for (config, spp) in configs {
        let out = render(&sc, config, spp, 3);
        assert_eq!(out.stats.non_finite_total(), 0, "{config}");
        for (i, &want) in want.iter().enumerate() {
            let (m, v) = (out.film.mean(i), out.film.variance_of_mean(i));
            for c in 0..3 {
                // A pixel with zero variance must be exact (fully shadowed or on the square).
                let z = if v[c] > 0.0 {
                    (m[c] - want) / v[c].sqrt()
                } else if (m[c] - want).abs() < 1e-6 {
                    0.0
                } else {
                    f64::INFINITY
                };
                assert!(
                    z.abs() < crit,
                    "{config}: pixel {i} channel {c}: {} ± {} vs {want}, z = {z:.2} > {crit:.2}",
                    m[c],
                    v[c].sqrt()
                );
            }
        }
    }
}

/// Photon mapping, SPPM and VCM's merges: the image mean across 8 seeds, t-tested and within
/// 2 % (the blur of the shadow's edge moves light across it, not out of the image).
#[test]
fn directional_light_photon_methods_match_the_analytic_mean() {
    let sc = scene(&text());
    let want_image = analytic_image(&sc);
    let want = want_image.iter().sum::<f64>() / want_image.len() as f64;
    let configs = [
        "Vcm(radius: Relative(0.01))",
        "Sppm(photons_per_pass: 20000)",
        "PhotonMap(photons: 100000, caustic_photons: 1000, indirect: Direct)",
    ];
    let crit = t_critical(sidak(1e-3, 3 * configs.len() as u64), 7.0);
    for config in configs {
        let (mean, se) = across_seeds(&sc, config, 16, 8)[0];
        for c in 0..3 {
            let t = (mean[c] - want) / se[c].max(1e-12);
            assert!(
                t.abs() < crit && (mean[c] / want - 1.0).abs() < 0.02,
                "{config}: {} ± {} vs {want}, t = {t:.2}",
                mean[c],
                se[c]
            );
        }
    }
}

/// Path tracing that never samples lights cannot see a delta direction, and says so.
#[test]
fn bsdf_only_path_tracing_refuses_the_directional_light() {
    let sc = scene(&text());
    let cfg = lightlab_integrators::IntegratorConfig::from_ron("Path(strategy: BsdfOnly)").unwrap();
    let integrator = cfg.build().unwrap();
    let e = integrator.check_scene(&sc).unwrap_err();
    assert!(e.contains("delta"), "{e}");
}
