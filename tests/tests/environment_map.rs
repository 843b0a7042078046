//! A Lambertian plane under an environment map: every unoccluded point of the plane leaves
//! ρ/π · E, E = ∫ L(ω) cos θ dω over the upper hemisphere (the map is at infinity, so E is the same
//! everywhere on the plane). E comes from a fine quadrature of the loaded map's own radiance; each
//! integrator's image mean is z-tested against ρ/π · E — path tracing with its three light
//! strategies (so the map's importance sampling, its density and their MIS), light tracing (the map
//! emitting), BDPT, VCM and SPPM (the map's photons). And a camera looking at the sky sees the
//! map's radiance itself, pixel by pixel.
//!
//! False-failure rate ≤ 1e-3 per test function (Šidák over configurations and channels), fixed seeds.

use glam::Vec3;
use lightlab_testkit::stats::{sidak, t_critical, z_critical};
use lightlab_tests::{across_seeds, assert_mean_near, image_mean, render};
use std::path::{Path, PathBuf};

/// A 64 × 32 map with a broad warm glow, a cool gradient and a dark band, written as OpenEXR.
fn write_map(dir: &Path) -> PathBuf {
    let (w, h) = (64usize, 32usize);
    let path = dir.join("sky.exr");
    exr::prelude::write_rgb_file(&path, w, h, |i, j| {
        let (u, v) = ((i as f32 + 0.5) / w as f32, j as f32 / (h - 1) as f32);
        let glow = (-((u - 0.3).powi(2) + (v - 0.3).powi(2)) / 0.01).exp() * 8.0;
        let band = if (0.55..0.62).contains(&v) { 0.0 } else { 1.0 };
        (
            band * (0.3 + glow),
            band * (0.2 + 0.5 * u + 0.5 * glow),
            band * (0.6 * (1.0 - v) + 0.2 * glow),
        )
    })
    .unwrap();
    path
}

/// The plane scene seen by `camera`, written (with its map) to a directory of its own, `name`.
fn scene_with_map(name: &str, camera: &str) -> lightlab_scene::Scene {
    let dir = std::env::temp_dir().join(format!("lightlab-envmap-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let map = write_map(&dir);
    let text = format!(
        "Scene(camera: {camera},
            materials: {{ \"plane\": Diffuse(albedo: (0.6, 0.5, 0.4)) }},
            shapes: [ Shape(geometry: Quad(corner: (-5, 0, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"plane\") ],
            lights: [ EnvironmentMap(file: {:?}, scale: 1.5, rotate: [(axis: (0.3, 1, 0.2), degrees: 40)]),
                      Environment(radiance: (0.05, 0.05, 0.05)) ])",
        map.display().to_string()
    );
    let path = dir.join("plane.ron");
    std::fs::write(&path, &text).unwrap();
    lightlab_scene::load_scene(&path).unwrap()
}

/// E = ∫ L cos θ dω over the upper hemisphere (+y), midpoint rule in (cos θ, φ), in f64.
fn irradiance(sc: &lightlab_scene::Scene) -> [f64; 3] {
    let (n_mu, n_phi) = (600, 1200);
    let mut e = [0.0f64; 3];
    for a in 0..n_mu {
        let mu = (a as f64 + 0.5) / n_mu as f64;
        let s = (1.0 - mu * mu).sqrt();
        for b in 0..n_phi {
            let phi = (b as f64 + 0.5) / n_phi as f64 * std::f64::consts::TAU;
            let d = Vec3::new((s * phi.cos()) as f32, mu as f32, (s * phi.sin()) as f32);
            let l = sc.environment_le(d);
            for c in 0..3 {
                e[c] += l.to_array()[c] as f64 * mu;
            }
        }
    }
    e.map(|x| x * std::f64::consts::TAU / (n_mu * n_phi) as f64)
}

#[test]
fn a_plane_under_an_environment_map_has_the_analytic_radiance_in_every_integrator() {
    let sc = scene_with_map(
        "plane",
        "Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 30, resolution: (16, 16))",
    );
    let e = irradiance(&sc);
    let rho = [0.6, 0.5, 0.4];
    let want: [f64; 3] = std::array::from_fn(|c| rho[c] / std::f64::consts::PI * e[c]);
    let configs = [
        ("Path()", 256),
        ("Path(strategy: LightOnly)", 256),
        ("Path(strategy: BsdfOnly)", 256),
        ("Light()", 256),
        ("Bdpt()", 128),
        ("Vcm(variant: Vc)", 64),
    ];
    // SPPM's passes are not independent within a render: its error bar comes from 8 seeds
    // (Student's t, 7 degrees of freedom).
    let tests = (configs.len() + 1) as u64 * 3;
    let crit = z_critical(sidak(1e-3, tests));
    for (config, spp) in configs {
        let (mean, se) = image_mean(&render(&sc, config, spp, 11).film);
        assert_mean_near(config, mean, se, want, crit);
    }
    let sppm = "Sppm(photons_per_pass: 20000)";
    let (mean, se) = across_seeds(&sc, sppm, 16, 8)[0];
    assert_mean_near(sppm, mean, se, want, t_critical(sidak(1e-3, tests), 7.0));
}

/// Looking up into the sky, each pixel is the map's radiance averaged over the pixel's
/// directions (16 × 16 points per pixel), z-tested on the pixel's own standard error (Šidák over
/// all pixels and integrators) — for path tracing and for BDPT and VCM's connections, whose
/// weights must give a camera ray escaping at once the whole weight (the lens is never joined to
/// a light at infinity).
#[test]
fn the_sky_seen_directly_is_the_map() {
    let sc = scene_with_map(
        "sky",
        "Camera(eye: (0, 1, 0), target: (0.3, 2, 0.1), fov: 60, resolution: (12, 8))",
    );
    let (w, h) = (sc.camera.width, sc.camera.height);
    let configs = ["Path()", "Bdpt()", "Vcm(variant: Vc)"];
    let crit = z_critical(sidak(1e-3, (configs.len() * 3 * (w * h) as usize) as u64));
    for config in configs {
        sky_pixels_match(&sc, config, crit);
    }
}

fn sky_pixels_match(sc: &lightlab_scene::Scene, config: &str, crit: f64) {
    let out = render(sc, config, 64, 12);
    let (w, h) = (sc.camera.width, sc.camera.height);
    for y in 0..h {
        for x in 0..w {
            let n = 16;
            let mut want = [0.0f64; 3];
            for k in 0..n * n {
                let film = glam::Vec2::new(
                    x as f32 + ((k % n) as f32 + 0.5) / n as f32,
                    y as f32 + ((k / n) as f32 + 0.5) / n as f32,
                );
                let d = sc.camera.generate_ray(film, glam::Vec2::ZERO).d;
                let l = sc.environment_le(d.normalize()).to_array();
                for c in 0..3 {
                    want[c] += l[c] as f64 / (n * n) as f64;
                }
            }
            let i = (y * w + x) as usize;
            let (m, v) = (out.film.mean(i), out.film.variance_of_mean(i));
            for c in 0..3 {
                let z = (m[c] - want[c]) / v[c].sqrt().max(1e-6 * want[c].max(1e-3));
                assert!(
                    z.abs() < crit,
                    "{config}: pixel ({x}, {y}) channel {c}: {} vs {}",
                    m[c],
                    want[c]
                );
            }
        }
    }
}

/// A constant sky and nothing else: every camera ray escapes at once and sees L, so every
/// integrator that sees emitters directly renders exactly L with no non-finite sample (the photon
/// methods store no photon and must keep their estimate defined; BDPT and VCM weigh s = 0 alone).
/// Light tracing cannot see a light at infinity through the lens and is not among them.
#[test]
fn an_environment_alone_is_seen_exactly_by_every_integrator() {
    let sc = lightlab_tests::scene(
        "Scene(camera: Camera(eye: (0, 0, 0), target: (0, 0, -1), fov: 40, resolution: (8, 8)),
            materials: {}, shapes: [], lights: [ Environment(radiance: (1, 0.5, 0.25)) ])",
    );
    for config in [
        "Path()",
        "Bdpt()",
        "Bdpt(mis: Uniform)",
        "Vcm(variant: Vc)",
        "Vcm(variant: Bpm)",
        "Vcm()",
        "Sppm(photons_per_pass: 100)",
        "Ppm(photons_per_pass: 100)",
        "PhotonMap(photons: 100)",
    ] {
        every_pixel_is(&render(&sc, config, 4, 3), config, [1.0, 0.5, 0.25]);
    }
    // A point light with nothing to light: every image is black and defined.
    let dark = lightlab_tests::scene(
        "Scene(camera: Camera(eye: (0, 0, 0), target: (0, 0, -1), fov: 40, resolution: (8, 8)),
            materials: {}, shapes: [], lights: [ Point(position: (0, 0, -1), intensity: (1, 1, 1)) ])",
    );
    for config in [
        "Path()",
        "Light()",
        "Bdpt()",
        "Vcm()",
        "Sppm(photons_per_pass: 100)",
        "PhotonMap(photons: 100)",
    ] {
        every_pixel_is(&render(&dark, config, 2, 3), config, [0.0; 3]);
    }
}

/// Every pixel of `out` is `want` to 1e-6 relative (exactly, where `want` is 0), and no sample was
/// non-finite.
fn every_pixel_is(out: &lightlab_integrators::RenderOutput, config: &str, want: [f64; 3]) {
    for i in 0..(out.film.width * out.film.height) as usize {
        let m = out.film.mean(i);
        for c in 0..3 {
            assert!(
                (m[c] - want[c]).abs() <= 1e-6 * want[c],
                "{config}: pixel {i} channel {c}: {} instead of {} (non-finite: {:?})",
                m[c],
                want[c],
                out.stats.non_finite
            );
        }
    }
    assert_eq!(out.stats.non_finite_total(), 0, "{config}");
}

/// A map whose brightest texel times `scale` passes the emitted-radiance cap (10¹⁵, where pixel
/// variances overflow f32) is refused at load, naming the texel, like any other light; before,
/// a texel of 10³⁰ rendered (light tracing silently black, path tracing and BDPT 5× apart).
#[test]
fn a_map_brighter_than_the_cap_is_refused() {
    let dir = std::env::temp_dir().join(format!("lightlab-envmap-cap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sun.exr");
    exr::prelude::write_rgb_file(&path, 4, 2, |i, j| {
        let sun = if (i, j) == (2, 1) { 1e12 } else { 1.0 };
        (sun, sun, sun)
    })
    .unwrap();
    let load = |scale: f32| {
        let text = format!(
            "Scene(camera: Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 30, resolution: (4, 4)),
                materials: {{ \"plane\": Diffuse(albedo: (0.5, 0.5, 0.5)) }},
                shapes: [ Shape(geometry: Quad(corner: (-5, 0, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"plane\") ],
                lights: [ EnvironmentMap(file: \"sun.exr\", scale: {scale}) ])"
        );
        let scene = dir.join("sun.ron");
        std::fs::write(&scene, &text).unwrap();
        lightlab_scene::load_scene(&scene).map(|_| ())
    };
    assert!(load(100.0).is_ok());
    let err = load(1e4).unwrap_err().to_string();
    assert!(
        err.contains("sun.ron") && err.contains("texel (2, 1)") && err.contains("1e15"),
        "{err}"
    );
}
