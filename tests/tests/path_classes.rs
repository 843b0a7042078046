//! Path classes (Heckbert 1990) across integrators: layers split every contribution and sum to the
//! image, a `paths` filter renders exactly its layer, bounce layers are the Neumann series term by
//! term, and the classes every method can render agree between methods.
//!
//! False-failure rate: the z-tests of this file are Šidák-corrected to ≤ 1e-3 together; fixed seeds.

use lightlab_integrators::{IntegratorConfig, RenderOutput};
use lightlab_testkit::stats::{sidak, t_critical, z_critical};
use lightlab_tests::{
    across_seeds, caustic_sphere, cornell, furnace, image_mean, render, scene, z,
};

/// z-tests in this file: 3 channels × (furnace: 5 integrators × 5 layers; caustic: 8 methods ×
/// 3 classes, less the 3 where a method meets its own reference).
const TESTS: u64 = 3 * (5 * 5 + 8 * 3 - 3);

/// Integrators without a standard error of their own, tested across 8 seeds.
fn across_trials(config: &str) -> bool {
    config.starts_with("Sppm")
        || config.starts_with("Ppm")
        || (config.starts_with("Vcm") && !config.contains("Vc,"))
}

/// An image average and its standard error.
type MeanSe = ([f64; 3], [f64; 3]);

/// Each class layer's image average and standard error under `config`, and the critical value
/// for one of `tests` tests: across `seeds` seeds (Student t) for integrators without a standard
/// error of their own (`across_trials`), else from one render's (normal).
fn class_estimates(
    sc: &lightlab_scene::Scene,
    config: &str,
    spp: u32,
    classes: &[&str],
    seeds: u64,
    tests: u64,
) -> (Vec<MeanSe>, f64) {
    if across_trials(config) {
        // Entry 0 is the whole image, then the layers in order.
        let all = across_seeds(sc, config, spp, seeds);
        (
            all[1..=classes.len()].to_vec(),
            t_critical(sidak(1e-3, tests), (seeds - 1) as f64),
        )
    } else {
        let out = render(sc, config, spp, 2);
        let got = classes.iter().map(|c| image_mean(layer(&out, c))).collect();
        (got, z_critical(sidak(1e-3, tests)))
    }
}

fn crit() -> f64 {
    z_critical(sidak(1e-3, TESTS))
}

fn caustic(res: u32) -> lightlab_scene::Scene {
    let text = caustic_sphere((res, res));
    scene(&text)
}

fn layer<'a>(out: &'a RenderOutput, name: &str) -> &'a lightlab_integrators::Film {
    &out.layers
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no layer {name}"))
        .1
}

/// Asserts that `method`'s estimate of `class` (mean ± standard error per channel) agrees with the
/// reference's within `crit` standard errors, after an allowance of `bias` × the reference for a
/// consistent method's blur.
fn assert_agrees(method: &str, class: &str, got: MeanSe, want: MeanSe, bias: f64, crit: f64) {
    let ((m, s), (rm, rs)) = (got, want);
    for c in 0..3 {
        let excess = ((m[c] - rm[c]).abs() - bias * rm[c]).max(0.0);
        let zs = z(excess, s[c], 0.0, rs[c]);
        assert!(
            zs < crit,
            "{method}: {class} channel {c}: {} ± {} vs {} ± {}",
            m[c],
            s[c],
            rm[c],
            rs[c]
        );
    }
}

/// Every integrator's layers — by class with overlapping expressions, and by bounce count — add
/// up to its image pixel by pixel (to rounding), and a `paths` filter gives exactly its layer.
#[test]
fn layers_sum_to_the_image_and_filters_equal_layers() {
    for sc in [caustic(12), scene(&cornell(1.0, [0.0; 3], (12, 10)))] {
        layers_sum_on(&sc);
    }
}

fn layers_sum_on(sc: &lightlab_scene::Scene) {
    for integrator in [
        "Path(max_bounces: 6",
        "Light(max_bounces: 6",
        "Bdpt(max_bounces: 6",
        "PhotonMap(max_bounces: 6, photons: 20000, caustic_photons: 20000, indirect: FinalGather(rays: 2)",
        "Sppm(max_bounces: 6, photons_per_pass: 5000",
        "Vcm(max_bounces: 6, radius: Relative(0.05)",
        "Vcm(max_bounces: 6, variant: Bpm, radius: Relative(0.05)",
    ] {
        for layers in [r#"Classes(["LS+DE", "L.*D.*E", "LDE"])"#, "Bounces"] {
            let out = render(sc, &format!("{integrator}, layers: {layers})"), 4, 9);
            assert!(!out.layers.is_empty());
            for i in 0..out.film.pixels.len() {
                let whole = out.film.mean(i);
                for c in 0..3 {
                    let sum: f64 = out.layers.iter().map(|(_, f)| f.mean(i)[c]).sum();
                    assert!(
                        (sum - whole[c]).abs() <= 1e-5 * whole[c].abs().max(1e-3),
                        "{integrator} {layers}: pixel {i} channel {c}: layers {sum} vs image {}",
                        whole[c]
                    );
                }
            }
            if layers == "Bounces" {
                assert_eq!(out.layers.len(), 7, "{integrator}: bounces 0…6");
            }
        }
        let layered = render(
            sc,
            &format!(r#"{integrator}, layers: Classes(["LS+DE"]))"#),
            4,
            9,
        );
        let filtered = render(sc, &format!(r#"{integrator}, paths: "LS+DE")"#), 4, 9);
        assert_eq!(
            layer(&layered, "LS+DE")
                .pixels
                .iter()
                .map(|p| p.mean)
                .collect::<Vec<_>>(),
            filtered
                .film
                .pixels
                .iter()
                .map(|p| p.mean)
                .collect::<Vec<_>>(),
            "{integrator}: the LS+DE filter differs from the LS+DE layer"
        );
        // (Path tracing finds this small light's caustic too rarely at 4 spp to test for it; the
        // Cornell box has no caustic at all.)
        let has_caustic = sc.materials.iter().any(|m| m.bsdf.is_delta());
        assert!(
            integrator.starts_with("Path") || (filtered.film.average()[0] > 0.0) == has_caustic,
            "{integrator}: caustic {} where the scene has {}",
            filtered.film.average()[0],
            if has_caustic { "one" } else { "none" }
        );
    }
}

/// Bounce layers of the white furnace: layer k is the k-th Neumann term Lₑρᵏ, for every integrator.
#[test]
fn furnace_bounce_layers_are_the_neumann_terms() {
    let (rho, le) = (0.6f64, 0.5f64);
    let sc = scene(&furnace(rho as f32, le as f32, 1.0, (8, 6)));
    for (config, spp) in [
        ("Path(max_bounces: 4, layers: Bounces)", 256),
        ("Light(max_bounces: 4, layers: Bounces)", 1024),
        ("Bdpt(max_bounces: 4, layers: Bounces)", 64),
        (
            "Sppm(max_bounces: 4, layers: Bounces, photons_per_pass: 20000, update: Global)",
            8,
        ),
        (
            "Vcm(max_bounces: 4, layers: Bounces, radius: Relative(0.05))",
            32,
        ),
    ] {
        // SPPM and VCM have no standard error of their own: 8 independent renders give one
        // (Student t).
        let (layers, crit): (Vec<MeanSe>, f64) = if across_trials(config) {
            let all = across_seeds(&sc, config, spp, 8);
            (all[1..].to_vec(), t_critical(sidak(1e-3, TESTS), 7.0))
        } else {
            let out = render(&sc, config, spp, 4);
            (
                out.layers.iter().map(|(_, f)| image_mean(f)).collect(),
                crit(),
            )
        };
        assert_eq!(layers.len(), 5);
        for (k, (mean, se)) in layers.iter().enumerate() {
            let want = le * rho.powi(k as i32);
            for c in 0..3 {
                // (1e-5: f32 rounding of an exact answer.)
                let excess = (mean[c] - want).abs();
                assert!(
                    excess <= 1e-5 * want || excess / se[c] < crit,
                    "{config}: bounces {k}: {} ± {} vs {want}",
                    mean[c],
                    se[c]
                );
            }
        }
    }
}

/// On the caustic sphere the classes every method can render agree: the caustic `LS+DE`, direct
/// light `LDE` and the emitter `LE`, each method against light tracing (the most precise on the
/// first two; path tracing on `LE`, which light tracing sees only at the emitter's own pixels too).
/// A method is not compared with its own reference (no power against its own bias). Photon maps
/// are consistent, not unbiased: their tolerance adds the density-estimation bias measured on this
/// scene (SPPM 3 %, PPM 3 %, the photon map 5 %, VCM — whose weights leave the merges little of
/// these classes — 1 %); SPPM's, PPM's and VCM's standard errors come from 8 independent renders
/// (Student t), the photon map's own includes its photon groups.
#[test]
fn caustic_classes_agree_between_methods() {
    let sc = caustic(32);
    let classes = r#"layers: Classes(["LS+DE", "LDE", "LE"])"#;
    let reference = render(&sc, &format!("Light(max_bounces: 6, {classes})"), 1024, 1);
    let le_reference = render(&sc, &format!("Path(max_bounces: 6, {classes})"), 256, 1);
    for (method, spp, bias) in [
        ("Path(max_bounces: 6", 1024, 0.0),
        ("Bdpt(max_bounces: 6", 256, 0.0),
        ("Light(max_bounces: 6", 1024, 0.0),
        ("Sppm(max_bounces: 6, photons_per_pass: 50000", 8, 0.03),
        ("Ppm(max_bounces: 6, photons_per_pass: 50000", 8, 0.03),
        ("Vcm(variant: Vc, max_bounces: 6", 256, 0.0),
        ("Vcm(max_bounces: 6", 32, 0.01),
        (
            "PhotonMap(max_bounces: 6, photons: 50000, caustic_photons: 200000, indirect: Off",
            16,
            0.05,
        ),
    ] {
        let config = format!("{method}, {classes})");
        let (estimates, crit) =
            class_estimates(&sc, &config, spp, &["LS+DE", "LDE", "LE"], 8, TESTS);
        for (class, (m, s)) in ["LS+DE", "LDE", "LE"].into_iter().zip(estimates) {
            let own = if class == "LE" { "Path" } else { "Light" };
            if method.starts_with(own) {
                continue;
            }
            let r = if class == "LE" {
                &le_reference
            } else {
                &reference
            };
            assert_agrees(
                method,
                class,
                (m, s),
                image_mean(layer(r, class)),
                bias,
                crit,
            );
        }
    }
}

/// A path that leaves plastic by its coating's reflection is classed `S` there by every method,
/// whichever strategy ends it: BDPT's and VCM's emission hits (s = 0) and VCM's merges used to
/// name the vertex by the plastic's own class `D` (the coating's correction reaches only the class
/// arriving at the next vertex), so `LSE` came out exactly 0 and `LDE` 3 % high, and merges moved
/// `LDSE` into `LDDE`. The Cornell box with plastic white surfaces, two bounces, against path
/// tracing: BDPT and `Vc` by their own standard errors, `Vcm` and `Bpm` (merges only, but
/// emission seen directly) across 16 seeds (Student t) with the allowance for merging's blur of
/// `vcm_and_bpm_agree_with_path_tracing` (1 %, 3 %). Its own Šidák budget: 4 methods × 3 classes
/// × 3 channels at ≤ 1e-3 together.
#[test]
fn plastic_coating_reflections_are_specular_in_every_method() {
    let text = cornell(1.0, [0.0; 3], (16, 16)).replace(
        "\"white\": Diffuse(albedo: (0.725, 0.71, 0.68))",
        "\"white\": Plastic(kd: (0.725, 0.71, 0.68))",
    );
    assert!(text.contains("Plastic"));
    let sc = scene(&text);
    let classes = ["LSE", "LDSE", "LDE"];
    let layers = r#"layers: Classes(["LSE", "LDSE", "LDE"])"#;
    let tests = 4 * 3 * 3;
    let reference = render(&sc, &format!("Path(max_bounces: 2, {layers})"), 2048, 1);
    for (method, spp, bias) in [
        ("Bdpt(max_bounces: 2", 512, 0.0),
        ("Vcm(variant: Vc, max_bounces: 2", 512, 0.0),
        ("Vcm(max_bounces: 2, radius: Relative(0.02)", 64, 0.01),
        (
            "Vcm(variant: Bpm, max_bounces: 2, radius: Relative(0.02)",
            64,
            0.03,
        ),
    ] {
        let config = format!("{method}, {layers})");
        let (estimates, crit) = class_estimates(&sc, &config, spp, &classes, 16, tests);
        for (class, (m, s)) in classes.into_iter().zip(estimates) {
            let want = image_mean(layer(&reference, class));
            assert!(
                want.0.iter().all(|&r| r > 0.0),
                "{class}: the reference is black"
            );
            assert_agrees(method, class, (m, s), want, bias, crit);
        }
    }
}

/// Path tracing finds a point light only by next-event estimation, which no specular vertex
/// passes: the point light's caustic `LS+DE` is black in its image (light tracing's is not), and
/// it says so before rendering, while it says nothing where it misses nothing (no specular
/// surface, or only area lights) and BDPT never says it. Deterministic checks: no false failures.
#[test]
fn path_tracing_warns_that_it_misses_point_light_caustics() {
    // The area light switched off: the point light is the only one.
    let text = caustic_sphere((16, 16))
        .replace("emission: (radiance: (50, 50, 50)),", "")
        .replace(
            "    ],\n)",
            "    ],\n    lights: [Point(position: (0, 0.5, -0.3), intensity: (2, 2, 2))],\n)",
        );
    assert!(text.contains("Point("));
    let sc = scene(&text);
    let warnings = |config: &str, sc: &lightlab_scene::Scene| {
        IntegratorConfig::from_ron(config)
            .unwrap()
            .build()
            .unwrap()
            .scene_warnings(sc)
    };
    let said = warnings("Path()", &sc);
    assert!(said.len() == 1 && said[0].contains("L S+"), "{said:?}");
    assert!(warnings("Path(strategy: LightOnly)", &sc).len() == 1);
    assert!(warnings("Bdpt()", &sc).is_empty());
    assert!(warnings("Path()", &caustic(8)).is_empty());
    let matte = scene(&text.replace(
        "\"glass\": Dielectric(ior: 1.5)",
        "\"glass\": Diffuse(albedo: (0.5, 0.5, 0.5))",
    ));
    assert!(warnings("Path()", &matte).is_empty());
    // What it warns of: the caustic is black for the path tracer only.
    let caustic_of = |config: &str| {
        let out = render(
            &sc,
            &format!("{config}(max_bounces: 4, paths: \"LS+DE\")"),
            64,
            5,
        );
        image_mean(&out.film).0
    };
    assert_eq!(caustic_of("Path"), [0.0; 3]);
    assert!(caustic_of("Light").iter().all(|&c| c > 0.0));
}
