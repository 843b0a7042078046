//! Textured reflectance end to end: a Lambertian quad under a uniform white sky leaves radiance
//! ρ(u, v) (ρ/π · π), and a camera straight above it sees the quad exactly fill the image, so each
//! of the image's 4 × 4 regions sees one checker square or one texel of a 4 × 4 bitmap. The
//! expected ρ of each region comes from the test's own reading of the texture conventions
//! (quad (u, v) = (0, 0) at `corner`, u along `edge1`; image row 0 at v = 0; sRGB decoding; the
//! checkerboard's parity rule), at the point the region's centre ray hits — not from the
//! renderer's lookup. Every integrator family renders it: path tracing, light tracing, BDPT and
//! VCM (their shared walk applies the texture at every vertex).
//!
//! False-failure rate ≤ 1e-3 per test function (Šidák over integrators, regions and channels;
//! up to 4·10⁻³ where VCM's region variance, taken from independent pixels, is 1.15× too small:
//! see `lightlab_tests::regions`), fixed seeds.

use glam::{DVec3, Vec2};
use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{assert_mean_near, regions, render};
use std::path::PathBuf;

/// The quad [−1, 1]² in y = 0 facing +y, seen from (0, 2, 0) with a field of view that covers it
/// exactly; `albedo` is the material's colour parameter (a texture name).
fn scene_text(textures: &str, albedo: &str) -> String {
    let fov = 2.0 * 0.5f64.atan().to_degrees();
    format!(
        "Scene(camera: Camera(eye: (0, 2, 0), target: (0, 0, 0), up: (0, 0, -1), fov: {fov}, resolution: (32, 32)),
            textures: {{ {textures} }},
            materials: {{ \"quad\": Diffuse(albedo: {albedo}) }},
            shapes: [ Shape(geometry: Quad(corner: (-1, 0, -1), edge1: (0, 0, 2), edge2: (2, 0, 0)), material: \"quad\") ],
            lights: [ Environment(radiance: (1, 1, 1)) ])"
    )
}

/// The (u, v) the test expects at the point each region's centre ray hits (row-major regions).
fn region_uvs(sc: &lightlab_scene::Scene, n: usize) -> Vec<Vec2> {
    let (w, h) = (sc.camera.width as f32, sc.camera.height as f32);
    (0..n * n)
        .map(|r| {
            let film = Vec2::new(
                ((r % n) as f32 + 0.5) * w / n as f32,
                ((r / n) as f32 + 0.5) * h / n as f32,
            );
            let ray = sc.camera.generate_ray(film, Vec2::splat(0.5));
            let (o, d) = (ray.o.as_dvec3() + sc.origin, ray.d.as_dvec3());
            let p: DVec3 = o + d * (-o.y / d.y);
            // corner (−1, 0, −1), edge1 along +z, edge2 along +x, both of length 2.
            Vec2::new(((p.z + 1.0) / 2.0) as f32, ((p.x + 1.0) / 2.0) as f32)
        })
        .collect()
}

fn check(text: &str, name: &str, expected: impl Fn(Vec2) -> [f64; 3]) {
    let dir = std::env::temp_dir().join(format!("lightlab-textures-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("quad.ron");
    std::fs::write(&path, text).unwrap();
    let sc = lightlab_scene::load_scene(&path).unwrap();
    let n = 4;
    let want: Vec<[f64; 3]> = region_uvs(&sc, n).into_iter().map(expected).collect();
    let configs = [
        ("Path(max_bounces: 1)", 64),
        ("Light(max_bounces: 1)", 64),
        ("Bdpt(max_bounces: 1)", 32),
        ("Vcm(max_bounces: 1)", 32),
    ];
    let crit = z_critical(sidak(1e-3, (configs.len() * n * n * 3) as u64));
    for (config, spp) in configs {
        let got = regions(&render(&sc, config, spp, 3), n);
        for (r, ((mean, se), want)) in got.iter().zip(&want).enumerate() {
            assert_mean_near(
                &format!("{name}, {config}, region {r}"),
                *mean,
                *se,
                *want,
                crit,
            );
        }
    }
}

#[test]
fn checkerboard_on_a_quad_under_the_sky() {
    let text = scene_text(
        "\"board\": Checkerboard(color0: (0.9, 0.5, 0.1), color1: (0.2, 0.6, 0.8), scale: (2, 2))",
        "\"board\"",
    );
    check(&text, "checker", |uv| {
        // color0 where the fractional parts of 2u and 2v·… fall on the same side of ½.
        let uv = uv * 2.0;
        let odd = |x: f32| x - x.floor() > 0.5;
        if odd(uv.x) == odd(uv.y) {
            [0.9, 0.5, 0.1]
        } else {
            [0.2, 0.6, 0.8]
        }
    });
}

/// The sRGB decoding the test expects (IEC 61966-2-1), written out independently of the loader.
fn srgb(c: u8) -> f64 {
    let c = c as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A 4 × 4 PNG of distinct colours (row 0 at the top), looked up with the nearest filter.
#[test]
fn png_bitmap_on_a_quad_under_the_sky() {
    let texel = |x: u32, y: u32| [40 + 60 * x as u8, 30 + 70 * y as u8, 200 - 40 * x as u8];
    let dir = std::env::temp_dir().join(format!("lightlab-textures-png-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png: PathBuf = dir.join("tiles.png");
    image::RgbImage::from_fn(4, 4, |x, y| image::Rgb(texel(x, y)))
        .save(&png)
        .unwrap();
    let text = scene_text(
        "\"tiles\": Bitmap(file: \"tiles.png\", filter: Nearest)",
        "\"tiles\"",
    );
    check(&text, "png", |uv| {
        let t = texel((uv.x * 4.0) as u32, (uv.y * 4.0) as u32);
        t.map(srgb)
    });
}
