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
/// (the camera ray is in render space, centred at `scene.origin`). `light` is on the side of the
/// plane the camera is on.
fn analytic(scene: &lightlab_scene::Scene, film: Vec2, light: [f64; 3]) -> f64 {
    let ray = scene.camera.generate_ray(film, Vec2::ZERO);
    let (o, d) = (ray.o.as_dvec3() + scene.origin, ray.d.as_dvec3());
    if d.y * o.y >= 0.0 {
        return 0.0;
    }
    let p = o + d * (-o.y / d.y);
    let to_light = glam::DVec3::from_array(light) - p;
    let r2 = to_light.length_squared();
    let cos = to_light.y.abs() / r2.sqrt();
    RHO / std::f64::consts::PI * INTENSITY * cos / r2
}

/// Every pixel of `config`'s image of `sc` z-tested against the analytic radiance averaged over
/// the pixel; `tests` is the number of configurations sharing the 1e-3 false-failure budget.
fn assert_pixels_match(
    sc: &lightlab_scene::Scene,
    config: &str,
    spp: u32,
    light: [f64; 3],
    tests: u64,
) {
    let (w, h) = (sc.camera.width, sc.camera.height);
    let out = render(sc, config, spp, 3);
    let crit = z_critical(sidak(1e-3 / tests as f64, 3 * w as u64 * h as u64));
    let mut worst = (0.0f64, 0usize);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            // The pixel's exact value is the analytic radiance averaged over the pixel (box filter).
            let n = 16;
            let want: f64 = (0..n * n)
                .map(|k| {
                    analytic(
                        sc,
                        Vec2::new(
                            x as f32 + ((k % n) as f32 + 0.5) / n as f32,
                            y as f32 + ((k / n) as f32 + 0.5) / n as f32,
                        ),
                        light,
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

#[test]
fn point_light_over_plane_matches_analytic_radiance_per_pixel() {
    let sc = scene(&text((48, 32)));
    let configs = [
        "Path()",
        "Path(max_bounces: 1)",
        "Path(max_bounces: 1, strategy: LightOnly)",
        "Light()",
        "Light(max_bounces: 1)",
    ];
    for config in configs {
        // Light tracing spreads its paths over the plane, not the pixels: pixels whose footprint
        // receives few paths (near the camera, far away) need many more paths than pixel samples
        // for their variance estimate to be usable.
        let spp = if config.starts_with("Light") {
            1024
        } else {
            64
        };
        assert_pixels_match(&sc, config, spp, LIGHT, configs.len() as u64);
    }
}

/// The same scene as a Mitsuba 3 file: the importer's camera is the RON scene's (fov along the
/// smaller axis, look-at frame), and its rectangle and transform, point light intensity and diffuse
/// BSDF give the analytic image. Seen from below with the light below, Mitsuba's one-sided diffuse
/// plane is black, and the same BSDF wrapped in `twosided` gives the mirrored analytic image.
#[test]
fn the_mitsuba_file_of_the_scene_matches_analytic_radiance_and_mitsuba_sidedness() {
    let xml = |eye_y: f64, light: [f64; 3], bsdf: &str| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/><string name="fov_axis" value="smaller"/>
        <transform name="to_world"><lookat origin="0, {eye_y}, 2.5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="32"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="30"/><rotate x="1" angle="-90"/></transform>
        {bsdf}
    </shape>
    <emitter type="point">
        <point name="position" x="{}" y="{}" z="{}"/>
        <rgb name="intensity" value="{INTENSITY}"/>
    </emitter>
</scene>"#,
            light[0], light[1], light[2]
        )
    };
    let diffuse = format!(r#"<bsdf type="diffuse"><rgb name="reflectance" value="{RHO}"/></bsdf>"#);
    let dir =
        std::env::temp_dir().join(format!("lightlab-point-over-plane-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let load = |text: String| {
        let path = dir.join("plane.xml");
        std::fs::write(&path, text).unwrap();
        let imported = lightlab_scene::mitsuba::import(&path, &[]).unwrap();
        lightlab_scene::build_scene(imported.desc, &path).unwrap()
    };
    let above = load(xml(2.5, LIGHT, &diffuse));
    let ron = scene(&text((48, 32)));
    let (a, b) = (&above.camera, &ron.camera);
    let eye = |s: &lightlab_scene::Scene| s.camera.eye.as_dvec3() + s.origin;
    assert!((eye(&above) - eye(&ron)).length() < 1e-5, "eye");
    for (u, v) in [(a.forward, b.forward), (a.right, b.right), (a.up, b.up)] {
        assert!((u - v).length() < 1e-6, "camera frame: {u} vs {v}");
    }
    assert!(
        (a.half_size - b.half_size).length() < 1e-6,
        "{} vs {}",
        a.half_size,
        b.half_size
    );
    assert_pixels_match(&above, "Path()", 64, LIGHT, 2);
    let below_light = [LIGHT[0], -LIGHT[1], LIGHT[2]];
    let from_below = load(xml(-2.5, below_light, &diffuse));
    let out = render(&from_below, "Path()", 4, 3);
    for i in 0..from_below.camera.pixel_count() {
        assert_eq!(
            out.film.mean(i),
            [0.0; 3],
            "pixel {i}: the back of a one-sided BSDF is black"
        );
    }
    let two_sided = load(xml(
        -2.5,
        below_light,
        &format!(r#"<bsdf type="twosided">{diffuse}</bsdf>"#),
    ));
    assert_pixels_match(&two_sided, "Path()", 64, below_light, 2);
}
