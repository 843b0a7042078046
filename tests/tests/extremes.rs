//! Extremes of the image and of photon radii: extreme aspect ratios and fields of view near 180°,
//! emitters smaller than a pixel's footprint (BDPT's s = t = 1 strategy), and gather radii at the
//! limit of what f32 positions resolve.
//!
//! False-failure rate ≤ 1e-3 for the file (Šidák over its z-tests), fixed seeds.

use glam::Vec3;
use lightlab_core::Rgb;
use lightlab_integrators::IntegratorConfig;
use lightlab_integrators::photon::map::{GatherPoint, PhotonMap, Search};
use lightlab_integrators::photon::trace::{Photon, Traced, photon_sampler};
use lightlab_materials::{Bsdf, SurfaceBsdf};
use lightlab_samplers::Sampler;
use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{caustic_sphere, cornell, image_mean, render, scene, z};

/// z-tests in this file (3 channels each).
const TESTS: u64 = 3 * (2 * 2 + 2 + 1 + 1);

fn crit() -> f64 {
    z_critical(sidak(1e-3, TESTS))
}

/// Light tracing against path tracing and BDPT at 4000 × 1 (the long axis spans almost 180°)
/// and with a 170° field of view, on the Cornell box's light that reaches surfaces
/// (`min_bounces: 1`; the emitter itself is smaller than these pixels' footprints, see the next
/// test): the camera importance and its density stay right where cos θ → 0.
#[test]
fn light_tracing_agrees_at_extreme_aspect_ratios_and_fields_of_view() {
    let box_text = cornell(1.0, [0.0; 3], (4000, 1));
    let wide = cornell(1.0, [0.0; 3], (24, 24)).replace("fov: 39.3077", "fov: 170");
    assert!(wide.contains("fov: 170"));
    for (what, text, spp_light, spp_path) in [
        ("4000 × 1", box_text, 256, 2048),
        ("fov 170°", wide, 1024, 4096),
    ] {
        let sc = scene(&text);
        let (l, ls) =
            image_mean(&render(&sc, "Light(max_bounces: 4, min_bounces: 1)", spp_light, 1).film);
        for (config, spp) in [
            ("Path(max_bounces: 4, min_bounces: 1)", spp_path),
            ("Bdpt(max_bounces: 4, min_bounces: 1)", spp_path / 8),
        ] {
            let (m, s) = image_mean(&render(&sc, config, spp, 2).film);
            for c in 0..3 {
                let zs = z(l[c], ls[c], m[c], s[c]);
                assert!(
                    zs.abs() < crit(),
                    "{what}: light tracing {} ± {} vs {config} {} ± {}, z {zs:.2}",
                    l[c],
                    ls[c],
                    m[c],
                    s[c]
                );
            }
        }
    }
}

/// An emitter seen directly but smaller than a pixel's footprint — the caustic sphere's light at
/// 4000 × 1, where each pixel spans 39° vertically — is found by light tracing's emission
/// connection; BDPT has the same strategy (s = t = 1, the light's point splatted through the lens),
/// so it renders it too, and with that strategy alone gives exactly light tracing's emitter.
/// Camera rays almost never hit it: before s = t = 1 existed BDPT rendered it black here, and
/// path tracing still does at these sample counts (its standard error, from pixels whose samples
/// all missed, says 0 — a rare event the sample variance cannot see).
#[test]
fn emitters_smaller_than_a_pixel_are_rendered_by_bdpt() {
    let sc = scene(&caustic_sphere((4000, 1)));
    let (l, ls) = image_mean(&render(&sc, "Light(max_bounces: 0)", 64, 1).film);
    assert!(l[0] > 1e-6, "light tracing sees the emitter: {}", l[0]);
    let (b, bs) = image_mean(&render(&sc, "Bdpt(max_bounces: 0)", 64, 2).film);
    for c in 0..3 {
        let zs = z(l[c], ls[c], b[c], bs[c]);
        assert!(
            zs.abs() < crit(),
            "{} ± {} vs BDPT {} ± {}",
            l[c],
            ls[c],
            b[c],
            bs[c]
        );
    }
    let only = render(&sc, "Bdpt(max_bounces: 0, mis: Only(s: 1, t: 1))", 64, 1).film;
    let light = render(&sc, "Light(max_bounces: 0)", 64, 1).film;
    let (a, b) = (only.average(), light.average());
    assert!(
        (a[0] / b[0] - 1.0).abs() < 1e-3,
        "s = t = 1 alone {} vs light tracing {}",
        a[0],
        b[0]
    );
    // Where camera rays do reach the emitter (32 × 32), both strategies together give its value.
    let sc = scene(&caustic_sphere((32, 32)));
    let (l, ls) = image_mean(&render(&sc, "Light(max_bounces: 0)", 64, 3).film);
    let (b, bs) = image_mean(&render(&sc, "Bdpt(max_bounces: 0)", 64, 4).film);
    for c in 0..3 {
        let zs = z(l[c], ls[c], b[c], bs[c]);
        assert!(
            zs.abs() < crit(),
            "32 × 32: {} ± {} vs BDPT {} ± {}",
            l[c],
            ls[c],
            b[c],
            bs[c]
        );
    }
}

/// Gather radii below what f32 positions resolve, or wider than the scene, are refused, naming the
/// usable range;
/// at twice that radius, far from the origin (coordinates near 10³, where positions are 6e-5
/// apart), a constant photon density is still estimated without bias.
#[test]
fn photon_radii_at_the_limit_of_f32() {
    let point_over_plane = scene(
        "Scene(camera: Camera(eye: (0, 2.5, 2.5), target: (0, 0, 0), fov: 60, resolution: (8, 8)),
               materials: { \"plane\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
               shapes: [ Shape(geometry: Quad(corner: (-30, 0, -30), edge1: (0, 0, 60), edge2: (60, 0, 0)), material: \"plane\") ],
               lights: [ Point(position: (0.3, 1, -0.2), intensity: (10, 10, 10)) ])",
    );
    let min = lightlab_integrators::photon::config::smallest_radius(&point_over_plane);
    for config in [
        "Sppm(radius: Absolute(1e-7))",
        "Ppm(radius: Absolute(1e-7))",
        "Vcm(radius: Absolute(1e-7))",
        "Vcm(variant: Bpm, radius: Absolute(1e-7))",
        "PhotonMap(gather: Radius(Absolute(1e-7)))",
        "PhotonMap(caustic_gather: Nearest(k: 50, max_radius: Absolute(1e-7)))",
    ] {
        let integrator = IntegratorConfig::from_ron(config).unwrap().build().unwrap();
        let e = integrator.check_scene(&point_over_plane).unwrap_err();
        assert!(
            e.contains("smallest radius") && e.contains(&format!("{min:.2e}")),
            "{config}: {e}"
        );
    }
    let ok = IntegratorConfig::from_ron(&format!("Sppm(radius: Absolute({}))", 2.0 * min)).unwrap();
    assert!(ok.build().unwrap().check_scene(&point_over_plane).is_ok());
    // Nor wider than the scene: a disk beyond its diameter (r² overflows f32 at Relative(1e20))
    // gathered nothing, and the photon term left the image without a word.
    for config in [
        "Sppm(radius: Relative(1e20))",
        "Vcm(radius: Relative(2.5))",
        "PhotonMap(gather: Radius(Absolute(1e4)))",
    ] {
        let integrator = IntegratorConfig::from_ron(config).unwrap().build().unwrap();
        let e = integrator.check_scene(&point_over_plane).unwrap_err();
        assert!(e.contains("wider than the scene itself"), "{config}: {e}");
    }
    let ok = IntegratorConfig::from_ron("Vcm(radius: Relative(2))").unwrap();
    assert!(ok.build().unwrap().check_scene(&point_over_plane).is_ok());

    // A constant density near (1000, 0, 1000): the radius 2 × 256 float steps there.
    let offset = 1000.0f32;
    let r = 2.0 * 256.0 * f32::EPSILON * (offset + 1.0);
    let side = 400.0 * r;
    let n = 2_000_000u64;
    let mut sampler = photon_sampler(5, 0);
    let class =
        lightlab_integrators::paths::PathClass::EMPTY.push(lightlab_materials::LobeClass::Diffuse);
    let photons: Vec<Photon> = (0..n)
        .map(|_| {
            let u = sampler.next_2d();
            Photon::new(
                Vec3::new(offset + u.x * side, 0.0, offset + u.y * side),
                Vec3::Y,
                Vec3::Y,
                Rgb::splat(side * side / n as f32),
                class,
            )
        })
        .collect();
    let map = PhotonMap::new(Traced::ungrouped(photons));
    let estimates: Vec<f64> = (0..400)
        .map(|q| {
            let (i, j) = ((q % 20) as f32, (q / 20) as f32);
            let p = Vec3::new(
                offset + (10.0 + 19.0 * i) * r,
                0.0,
                offset + (10.0 + 19.0 * j) * r,
            );
            let g = GatherPoint {
                p,
                wo: Vec3::Y,
                bsdf: SurfaceBsdf::new(
                    Vec3::Y,
                    Vec3::X,
                    Vec3::Y,
                    Bsdf::Diffuse { albedo: Rgb::WHITE },
                ),
            };
            let mut l = 0.0f64;
            map.estimate(
                &g,
                Search::Radius { radius_sq: r * r },
                lightlab_integrators::Kernel::Uniform,
                |_, _, c| l += c.r as f64,
            );
            std::f64::consts::PI * l
        })
        .collect();
    let (mean, se) = lightlab_testkit::stats::mean_and_std_error(&estimates);
    let zs = (mean - 1.0) / se;
    assert!(
        zs.abs() < crit(),
        "irradiance {mean} ± {se} vs 1 at radius {r:.2e} near {offset}"
    );
}

/// A plane of focus at the farthest allowed distance (10²⁰) is focus at infinity: the images of
/// path tracing and BDPT equal bit for bit those focused at 10¹⁰, where every lens ray's
/// direction already rounds to the pinhole ray's. Before, beyond about 10¹⁹ the focus point's
/// squared distance overflowed f32 and every camera ray came out zero: path tracing's image was
/// black and BDPT's 28 % dark. Deterministic: no false failures.
#[test]
fn focus_at_the_farthest_plane_is_focus_at_infinity() {
    let text = |focus: &str| {
        cornell(1.0, [0.0; 3], (8, 8)).replace(
            "resolution: (8, 8)",
            &format!(
                "resolution: (8, 8), lens: ThinLens(aperture_radius: 0.1, focus_distance: {focus})"
            ),
        )
    };
    assert!(text("1e20").contains("1e20"));
    let (near, far) = (scene(&text("1e10")), scene(&text("1e20")));
    for config in ["Path()", "Bdpt()"] {
        let (a, b) = (render(&near, config, 8, 1), render(&far, config, 8, 1));
        assert!(
            a.film.pixels == b.film.pixels,
            "{config}: the images differ"
        );
        let m = image_mean(&b.film).0;
        assert!(m.iter().sum::<f64>() > 0.1, "{config}: dark, {m:?}");
    }
}

/// Directions given at any magnitude mean the same: a directional light's direction, a spot's
/// axis and the camera's view at 10²⁰⁰ times unit length (the directional light also at 10⁻²⁰⁰)
/// render bit for bit as at unit length. Before, the squared length overflowed f64 and the
/// direction normalised to zero (black images), or underflowed and was refused as zero.
#[test]
fn directions_at_any_magnitude_render_alike() {
    let text = |view: &str, axis: &str, direction: &str| {
        format!(
            "Scene(camera: Camera(eye: (0, 2, 2), target: {view}, fov: 40, resolution: (6, 6)),
                materials: {{ \"w\": Diffuse(albedo: (0.5, 0.5, 0.5)) }},
                shapes: [ Shape(geometry: Quad(corner: (-5, -1, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"w\") ],
                lights: [ Directional(direction: {direction}, irradiance: (1, 1, 1)),
                          Spot(position: (0, 2, 0), target: {axis}, intensity: (4, 4, 4), cone_angle: 60) ])"
        )
    };
    // Camera and spot targets are positions: their differences from the eye and the spot's
    // position are (0, −1, −1) and (0, −1, 1) times 1 or 10²⁰⁰.
    let unit = scene(&text("(0, 1, 1)", "(0, 1, 1)", "(1, -1, -1)"));
    let huge = scene(&text(
        "(0, -1e200, -1e200)",
        "(0, -1e200, 1e200)",
        "(1e200, -1e200, -1e200)",
    ));
    let tiny = scene(&text(
        "(0, 1, 1)",
        "(0, 1, 1)",
        "(1e-200, -1e-200, -1e-200)",
    ));
    let want = render(&unit, "Path()", 4, 1);
    assert!(image_mean(&want.film).0[0] > 0.01, "the unit scene is dark");
    for (what, sc) in [("10²⁰⁰", huge), ("10⁻²⁰⁰", tiny)] {
        assert!(
            render(&sc, "Path()", 4, 1).film.pixels == want.film.pixels,
            "directions at {what} render differently"
        );
    }
}
