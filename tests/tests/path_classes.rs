//! Path classes (Heckbert 1990) across integrators: layers split every contribution and sum to the
//! image, a `paths` filter renders exactly its layer, bounce layers are the Neumann series term by
//! term, and the classes every method can render agree between methods.
//!
//! False-failure rate: the z-tests of this file are Šidák-corrected to ≤ 1e-3 together; fixed seeds.

use lightlab_integrators::RenderOutput;
use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{caustic_sphere, cornell, furnace, render, scene, z};

/// z-tests in this file: 3 channels × (furnace: 4 integrators × 5 layers; caustic: 5 methods ×
/// 3 classes).
const TESTS: u64 = 3 * (4 * 5 + 5 * 3);

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
        let has_caustic = sc.materials.iter().any(|m| m.is_delta());
        assert!(
            integrator.starts_with("Path") || (filtered.film.average().0[0] > 0.0) == has_caustic,
            "{integrator}: caustic {} where the scene has {}",
            filtered.film.average().0[0],
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
            64,
        ),
    ] {
        let out = render(&sc, config, spp, 4);
        assert_eq!(out.layers.len(), 5);
        for (k, (name, film)) in out.layers.iter().enumerate() {
            assert_eq!(name, &format!("bounces {k}"));
            let want = le * rho.powi(k as i32);
            let (mean, se) = film.average();
            for c in 0..3 {
                // (1e-5: f32 rounding of an exact answer.) SPPM's film variance leaves out the photon maps' correlation across pixels: allow
                // 1 % on top of noise there (the furnace has no density-estimation bias).
                let slack = if config.starts_with("Sppm") {
                    0.01 * want
                } else {
                    0.0
                };
                let excess = ((mean[c] - want).abs() - slack).max(0.0);
                assert!(
                    excess <= 1e-5 * want || excess / se[c] < crit(),
                    "{config}: {name}: {} ± {} vs {want}",
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
/// Photon maps are consistent, not unbiased, and one photon map serves the whole image, so its noise
/// is missing from the film's variance: their tolerance adds what was measured on this scene (SPPM's
/// bias 3 %; the photon map's caustic estimate varies by ±10 % between seeds at these photon counts,
/// with no bias visible across seeds).
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
        ("Sppm(max_bounces: 6, photons_per_pass: 50000", 64, 0.03),
        (
            "PhotonMap(max_bounces: 6, photons: 50000, caustic_photons: 200000, indirect: Off",
            16,
            0.10,
        ),
    ] {
        let out = render(&sc, &format!("{method}, {classes})"), spp, 2);
        for class in ["LS+DE", "LDE", "LE"] {
            let r = if class == "LE" {
                &le_reference
            } else {
                &reference
            };
            let (m, s) = layer(&out, class).average();
            let (rm, rs) = layer(r, class).average();
            for c in 0..3 {
                let excess = ((m[c] - rm[c]).abs() - bias * rm[c]).max(0.0);
                let zs = z(excess, s[c], 0.0, rs[c]);
                assert!(
                    zs < crit(),
                    "{method}: {class} channel {c}: {} ± {} vs {} ± {}",
                    m[c],
                    s[c],
                    rm[c],
                    rs[c]
                );
            }
        }
    }
}
