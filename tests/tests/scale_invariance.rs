//! Robustness at the extremes of scale and distance (design.md: error-bounded offsets, no fixed
//! epsilon; positions handled in f64 until the scene is centred): the Cornell box scaled by 10⁻⁴ …
//! 10⁴ about the origin (radiance unchanged), or moved 10⁵ and 10⁷ away from it, renders the same
//! image with every integrator.
//!
//! False-failure rate ≤ 1e-3 for the file (Šidák over every comparison), fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{cornell, regions, render, scene, z};

/// The variants of the box compared with the box itself: (what, scale, translation).
const VARIANTS: [(&str, f32, [f64; 3]); 7] = [
    ("scaled 1e-4", 1e-4, [0.0; 3]),
    ("scaled 1e-2", 1e-2, [0.0; 3]),
    ("scaled 1e2", 1e2, [0.0; 3]),
    ("scaled 1e4", 1e4, [0.0; 3]),
    ("moved to 1e5", 1.0, [1e5, 1e5, 1e5]),
    ("moved to 1e7", 1.0, [1e7, -1e7, 1e7]),
    ("scaled 1e-3 and moved 1e3 sizes", 1e-3, [1.0, -2.0, 0.5]),
];

/// Path tracing region by region (4 × 4 regions of a 48 × 48 image, two-sample z-tests).
#[test]
fn cornell_box_far_away_tiny_and_huge_renders_the_same() {
    let res = (48, 48);
    let config = "Path(max_bounces: 4)";
    let spp = 48;
    let base = regions(
        &render(&scene(&cornell(1.0, [0.0; 3], res)), config, spp, 11),
        4,
    );
    let crit = z_critical(sidak(1e-3, (VARIANTS.len() * 16 * 3) as u64));
    for (what, s, t) in VARIANTS {
        let out = render(&scene(&cornell(s, t, res)), config, spp, 12);
        assert_eq!(
            out.stats.non_finite_total(),
            0,
            "{what}: non-finite samples"
        );
        for (k, (a, b)) in base.iter().zip(regions(&out, 4)).enumerate() {
            for c in 0..3 {
                let se = (a.1[c] * a.1[c] + b.1[c] * b.1[c]).sqrt();
                let z = (b.0[c] - a.0[c]) / se.max(1e-12);
                assert!(
                    z.abs() < crit,
                    "{what}: region {k} channel {c}: {} vs {} at scale 1, z = {z:.2} (critical {crit:.2})",
                    b.0[c],
                    a.0[c]
                );
            }
        }
    }
}

/// Every integrator: the image mean of each variant against the box's own (another seed), by a
/// z-test on both renders' standard errors. Photon radii are `Relative` (the default), so they
/// scale with the scene. `Ppm`, `Sppm` and `Vcm` have no standard error of their own: with the
/// same seed their renders differ only by rounding, so they must agree to 10⁻⁴ (measured: at most
/// 1.8·10⁻⁶, VCM at scale 10⁻⁴; a scale-dependent bias would exceed it). Before, light tracing and
/// BDPT judged Russian roulette by the light path's flux, which scales with the scene's area:
/// at 10⁻³ they lost every path beyond three bounces (−6 % and −2 %).
#[test]
fn every_integrator_is_scale_and_translation_invariant() {
    let res = (16, 12);
    let configs = [
        ("Path(max_bounces: 8)", 32),
        ("Light(max_bounces: 8)", 32),
        ("Bdpt(max_bounces: 8)", 8),
        (
            "PhotonMap(max_bounces: 8, photons: 20000, caustic_photons: 2000)",
            8,
        ),
        ("Sppm(max_bounces: 8, photons_per_pass: 10000)", 8),
        ("Ppm(max_bounces: 8, photons_per_pass: 10000)", 8),
        ("Vcm(max_bounces: 8)", 8),
        ("Vcm(max_bounces: 8, variant: Vc)", 8),
    ];
    let crit = z_critical(sidak(1e-3, (configs.len() * VARIANTS.len() * 3) as u64));
    for (config, spp) in configs {
        let base = render(&scene(&cornell(1.0, [0.0; 3], res)), config, spp, 3);
        let (m0, s0) = (base.film.average(), base.film.image_se);
        for (what, s, t) in VARIANTS {
            let seed = if s0.is_some() { 4 } else { 3 };
            let out = render(&scene(&cornell(s, t, res)), config, spp, seed);
            assert_eq!(out.stats.non_finite_total(), 0, "{config}, {what}");
            let m = out.film.average();
            for c in 0..3 {
                match (s0, out.film.image_se) {
                    (Some(a), Some(b)) => {
                        let zs = z(m[c], b[c], m0[c], a[c]);
                        assert!(
                            zs.abs() < crit,
                            "{config}, {what}: channel {c}: {} ± {} vs {} ± {} at scale 1, z {zs:.2}",
                            m[c],
                            b[c],
                            m0[c],
                            a[c]
                        );
                    }
                    _ => assert!(
                        (m[c] / m0[c] - 1.0).abs() < 1e-4,
                        "{config}, {what}: channel {c}: {} vs {} at scale 1",
                        m[c],
                        m0[c]
                    ),
                }
            }
        }
    }
}

/// A feature f32 cannot resolve even after centring — a 1 mm sphere beside a 10 km floor — is
/// reported when the scene loads; the box itself, however far away, is not.
#[test]
fn unresolvable_features_are_reported() {
    let far = scene(&cornell(1.0, [1e7, 1e7, 1e7], (8, 8)));
    assert!(far.warnings.is_empty(), "{:?}", far.warnings);
    let text = "Scene(camera: Camera(eye: (0, 1, 5), target: (0, 0, 0), fov: 40, resolution: (8, 8)),
        materials: { \"white\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
        shapes: [ Shape(geometry: Quad(corner: (-1e4, 0, -1e4), edge1: (0, 0, 2e4), edge2: (2e4, 0, 0)), material: \"white\"),
                  Shape(geometry: Sphere(center: (0, 0.001, 0), radius: 0.001), material: \"white\") ],
        lights: [ Point(position: (0, 3, 0), intensity: (1, 1, 1)) ])";
    let sc = scene(text);
    assert!(
        sc.warnings
            .iter()
            .any(|w| w.contains("smallest feature") && w.contains("float steps")),
        "{:?}",
        sc.warnings
    );
    // No small shape, but a point light one unit above a floor two million wide: positions on
    // the floor carry errors of its float steps, and the image was 25 % dark (3.6× too bright at
    // 2·10⁸), silently. The light's height is a feature, as is the camera's.
    let floor = |half: f64, light_height: f64, eye_height: f64| {
        let width = 2.0 * half;
        scene(&format!(
            "Scene(camera: Camera(eye: (0, {eye_height:e}, 2.5), target: (0, 0, 0), fov: 40, resolution: (8, 8)),
             materials: {{ \"white\": Diffuse(albedo: (0.5, 0.5, 0.5)) }},
             shapes: [ Shape(geometry: Quad(corner: (-{half:e}, 0, -{half:e}), edge1: (0, 0, {width:e}), edge2: ({width:e}, 0, 0)), material: \"white\") ],
             lights: [ Point(position: (0, {light_height:e}, 0), intensity: (1, 1, 1)) ])"
        ))
        .warnings
    };
    assert!(floor(20.0, 1.0, 1.0).is_empty());
    // Beyond 10⁹ from the centre f32 areas overflow (a floor 6·10⁹ wide had an infinite area and
    // Radiosity allocated gigabytes of patches for it): refused.
    let text = "Scene(camera: Camera(eye: (0, 1, 2.5), target: (0, 0, 0), fov: 40, resolution: (8, 8)),
        materials: { \"white\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
        shapes: [ Shape(geometry: Quad(corner: (-3e9, 0, -3e9), edge1: (0, 0, 6e9), edge2: (6e9, 0, 0)), material: \"white\") ],
        lights: [ Point(position: (0, 1, 0), intensity: (1, 1, 1)) ])";
    let e = lightlab_scene::parse_scene(text, std::path::Path::new("huge.ron"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("huge.ron:3:") && e.contains("overflow"), "{e}");
    for warnings in [floor(1e6, 1.0, 1.0), floor(20.0, 1.0, 1e-5)] {
        assert!(
            warnings.iter().any(|w| w.contains("smallest feature")),
            "{warnings:?}"
        );
    }
}

/// Scaling by a power of two changes no rounding, so the same seed must give the same image bit
/// for bit, down to a box 2⁻²⁰ across (≈ 10⁻⁶) and up to 2²⁰: no absolute epsilon anywhere. The
/// triangle test's t > 0 bound took a fixed γ₅ for segments (shadow rays, d = p1 − p0), which
/// at 2⁻²⁰ hid occluders in the first tenth of each segment: shadows filled in, +5–7 %.
/// Deterministic: no false failures.
#[test]
fn powers_of_two_scale_bit_for_bit() {
    let res = (12, 12);
    for config in ["Path(max_bounces: 4)", "Bdpt(max_bounces: 4)"] {
        let base = render(&scene(&cornell(1.0, [0.0; 3], res)), config, 8, 5);
        for s in [2f32.powi(-20), 2f32.powi(-10), 2f32.powi(20)] {
            let out = render(&scene(&cornell(s, [0.0; 3], res)), config, 8, 5);
            assert!(
                out.film.pixels == base.film.pixels,
                "{config} at scale {s:e}: the image differs from scale 1"
            );
        }
    }
}
