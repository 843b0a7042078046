//! Every integrator renders an imported Mitsuba scene — `scenes/mitsuba/materials.xml` (every
//! imported BSDF, an area and a spot light, a thin lens) at 24 × 24 — and the unbiased ones agree
//! with path tracing on the image mean (z-test, Šidák over integrators and channels at 1e-3; light
//! tracing on the paths it can sample); the photon methods, consistent but biased at a finite
//! radius, within 10 %. Fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{across_seeds, image_mean, render, z};
use std::path::Path;

#[test]
fn every_integrator_renders_an_imported_scene_and_agrees_with_path_tracing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/mitsuba/materials.xml");
    let imported = lightlab_scene::mitsuba::import(&path, &[("res".into(), "24".into())]).unwrap();
    let sc = lightlab_scene::build_scene(imported.desc, &path).unwrap();
    let max = "max_bounces: 7";
    let (reference, ref_se) = image_mean(&render(&sc, &format!("Path({max})"), 512, 1).film);
    // Light tracing cannot connect to the camera through a specular vertex (mirror, glass, the
    // pane): it is compared with path tracing on the other paths.
    let seen = "paths: \"LE|L.*[DG]E\"";
    let (seen_ref, seen_se) =
        image_mean(&render(&sc, &format!("Path({max}, {seen})"), 512, 3).film);
    let unbiased = [
        (format!("Light({max}, {seen})"), 512, seen_ref, seen_se),
        (format!("Bdpt({max})"), 128, reference, ref_se),
        (format!("Vcm({max}, variant: Vc)"), 64, reference, ref_se),
    ];
    let crit = z_critical(sidak(1e-3, 3 * unbiased.len() as u64));
    for (config, spp, reference, ref_se) in &unbiased {
        let (mean, se) = image_mean(&render(&sc, config, *spp, 2).film);
        for c in 0..3 {
            let z = z(mean[c], se[c], reference[c], ref_se[c]);
            assert!(
                z.abs() < crit,
                "{config}: channel {c}: {} ± {} vs path tracing {} ± {}, z = {z:.2}",
                mean[c],
                se[c],
                reference[c],
                ref_se[c]
            );
        }
    }
    for config in [
        format!("PhotonMap({max})"),
        format!("Sppm({max}, photons_per_pass: 20000)"),
        format!("Vcm({max})"),
    ] {
        let (mean, _) = across_seeds(&sc, &config, 16, 2)[0];
        for c in 0..3 {
            let ratio = mean[c] / reference[c];
            assert!(
                (ratio - 1.0).abs() < 0.1,
                "{config}: channel {c}: {} vs path tracing {} (ratio {ratio:.3})",
                mean[c],
                reference[c]
            );
        }
    }
}
