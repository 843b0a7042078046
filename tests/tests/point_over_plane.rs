//! A point light of intensity I at height h over a Lambertian plane of albedo ρ: the radiance leaving
//! the plane towards the camera is ρ/π · I·cosθ/r² exactly (the plane is flat, so there is no
//! interreflection). Every pixel's mean is z-tested against that function averaged over the pixel.
//!
//! False-failure rate ≤ 1e-3 per test function (Šidák over all pixels and channels), fixed seeds.

use lightlab_core::Vec2;
use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{render, scene};

const RHO: f64 = 0.5;
const INTENSITY: f64 = 10.0;
const LIGHT: [f64; 3] = [0.3, 1.0, -0.2];

fn text(res: (u32, u32)) -> String {
    format!(
        "Scene(camera: Camera(eye: (0, 2.5, 2.5), target: (0, 0, 0), fov: 60, resolution: ({}, {})),
               materials: {{ \"plane\": Diffuse(albedo: ({RHO}, {RHO}, {RHO})) }},
               shapes: [ Shape(geometry: Quad(corner: (-30, 0, -30), edge1: (0, 0, 60), edge2: (60, 0, 0)), material: \"plane\") ],
               lights: [ Point(position: ({}, {}, {}), intensity: ({INTENSITY}, {INTENSITY}, {INTENSITY})) ])",
        res.0, res.1, LIGHT[0], LIGHT[1], LIGHT[2]
    )
}

/// ρ/π · I cosθ / r² at the plane point seen through raster position `film`, 0 if the ray misses
/// (the camera ray is in render space, centred at `scene.origin`).
fn analytic(scene: &lightlab_scene::Scene, film: Vec2) -> f64 {
    let ray = scene.camera.generate_ray(film, Vec2::ZERO);
    if ray.d.y >= 0.0 {
        return 0.0;
    }
    let (o, d) = (ray.o.as_dvec3() + scene.origin, ray.d.as_dvec3());
    let p = o + d * (-o.y / d.y);
    let to_light = glam::DVec3::from_array(LIGHT) - p;
    let r2 = to_light.length_squared();
    let cos = to_light.y / r2.sqrt();
    RHO / std::f64::consts::PI * INTENSITY * cos / r2
}

#[test]
fn point_light_over_plane_matches_analytic_radiance_per_pixel() {
    let res = (48, 32);
    let sc = scene(&text(res));
    for config in [
        "Path()",
        "Path(max_bounces: 1)",
        "Path(max_bounces: 1, strategy: LightOnly)",
        "Light()",
        "Light(max_bounces: 1)",
    ] {
        // Light tracing spreads its paths over the plane, not the pixels: pixels whose footprint
        // receives few paths (near the camera, far away) need many more paths than pixel samples
        // for their variance estimate to be usable.
        let spp = if config.starts_with("Light") {
            1024
        } else {
            64
        };
        let out = render(&sc, config, spp, 3);
        let crit = z_critical(sidak(1e-3 / 5.0, 3 * res.0 as u64 * res.1 as u64));
        let mut worst = (0.0f64, 0usize);
        for y in 0..res.1 {
            for x in 0..res.0 {
                let i = (y * res.0 + x) as usize;
                // The pixel's exact value is the analytic radiance averaged over the pixel (box filter).
                let n = 16;
                let want: f64 = (0..n * n)
                    .map(|k| {
                        analytic(
                            &sc,
                            Vec2::new(
                                x as f32 + ((k % n) as f32 + 0.5) / n as f32,
                                y as f32 + ((k / n) as f32 + 0.5) / n as f32,
                            ),
                        )
                    })
                    .sum::<f64>()
                    / (n * n) as f64;
                let (m, v) = (out.film.mean(i), out.film.variance_of_mean(i));
                for c in 0..3 {
                    // Within a pixel the radiance varies, so the sample variance is never zero here.
                    let z = (m[c] - want) / v[c].sqrt().max(1e-9);
                    if z.abs() > worst.0 {
                        worst = (z.abs(), i);
                    }
                    assert!(
                        z.abs() < crit,
                        "{config}: pixel ({x}, {y}) channel {c}: {} ± {} vs {want}, z = {z:.2} > {crit:.2}",
                        m[c],
                        v[c].sqrt()
                    );
                }
            }
        }
        assert!(worst.0 > 0.0, "no pixel was tested");
    }
}
