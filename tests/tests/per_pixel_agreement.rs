//! Path tracing, light tracing and bidirectional path tracing agree pixel by pixel at 48 × 32
//! (non-square on purpose) on the Cornell box, the caustic sphere and a glossy, smooth-shaded mesh
//! scene (interpolated vertex normals differ from the facets' geometric normals) with the light as
//! an analytic quad and as a triangle mesh. Light tracing depends on the adjoint shading-normal
//! correction (Veach 1997, §5.3) there, and BDPT on it in every strategy that ends a light subpath
//! on the mesh.
//!
//! Each comparison is restricted (a `paths` filter) to the classes both methods estimate with a
//! trustworthy per-pixel variance: light tracing cannot see `…SE` paths; emitters seen directly
//! (`LE`) are left out everywhere, because where a pixel sees only a sliver of the light, a few
//! hundred camera samples rarely hit it and their sample variance cannot be trusted (light tracing
//! resolves it; path tracing reports 0 ± 0); for the same reason path tracing is compared on the
//! caustic scene without specular vertices (its `LS+DE` caustic is found by rare hits).
//!
//! False-failure rate ≤ 1e-3 for the whole file: per-pixel two-sample z-tests, Šidák-corrected
//! over pixels, channels and all comparisons; fixed seeds.

use lightlab_integrators::RenderOutput;
use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{caustic_sphere, render, scene, z};

const RES: (u32, u32) = (48, 32);

/// A UV sphere of `rings` × `segments` facets with vertex normals, as an inline mesh.
fn smooth_sphere(center: [f32; 3], radius: f32, rings: u32, segments: u32) -> String {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let n = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            positions.push(format!(
                "({}, {}, {})",
                center[0] + radius * n[0],
                center[1] + radius * n[1],
                center[2] + radius * n[2]
            ));
            normals.push(format!("({}, {}, {})", n[0], n[1], n[2]));
        }
    }
    let mut indices = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b) = (i * segments + j, i * segments + (j + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            // Counter-clockwise seen from outside.
            if i > 0 {
                indices.push(format!("({a}, {b}, {c})"));
            }
            if i + 1 < rings {
                indices.push(format!("({b}, {d}, {c})"));
            }
        }
    }
    format!(
        "Mesh(positions: [{}], indices: [{}], normals: [{}])",
        positions.join(", "),
        indices.join(", "),
        normals.join(", ")
    )
}

fn glossy_box(mesh_light: bool) -> String {
    let light = if mesh_light {
        "Mesh(positions: [(-0.25, 0.99, -0.2), (0.25, 0.99, -0.2), (0.25, 0.99, 0.2), (-0.25, 0.99, 0.2)],
              indices: [(0, 1, 2), (0, 2, 3)])"
    } else {
        "Quad(corner: (-0.25, 0.99, -0.2), edge1: (0.5, 0, 0), edge2: (0, 0, 0.4))"
    };
    format!(
        "Scene(
            camera: Camera(eye: (0, 0, 3.9), target: (0, 0, 0), fov: 39.3077, resolution: ({}, {})),
            materials: {{
                \"white\": Diffuse(albedo: (0.725, 0.71, 0.68)),
                \"red\": Diffuse(albedo: (0.63, 0.065, 0.05)),
                \"green\": Diffuse(albedo: (0.14, 0.45, 0.091)),
                \"black\": Diffuse(albedo: (0, 0, 0)),
                \"gold\": RoughConductor(roughness: Isotropic(0.25), eta: (0.143, 0.374, 1.442), k: (3.983, 2.385, 1.603)),
                \"plastic\": Phong(kd: (0.3, 0.3, 0.5), ks: (0.4, 0.4, 0.4), exponent: 30),
            }},
            shapes: [
                Shape(geometry: Quad(corner: (-1, -1, -1), edge1: (0, 0, 2), edge2: (2, 0, 0)), material: \"white\"),
                Shape(geometry: Quad(corner: (-1, 1, -1), edge1: (2, 0, 0), edge2: (0, 0, 2)), material: \"white\"),
                Shape(geometry: Quad(corner: (-1, -1, -1), edge1: (2, 0, 0), edge2: (0, 2, 0)), material: \"white\"),
                Shape(geometry: Quad(corner: (-1, -1, -1), edge1: (0, 2, 0), edge2: (0, 0, 2)), material: \"red\"),
                Shape(geometry: Quad(corner: (1, -1, -1), edge1: (0, 0, 2), edge2: (0, 2, 0)), material: \"green\"),
                Shape(geometry: {}, material: \"gold\"),
                Shape(geometry: {}, material: \"plastic\"),
                Shape(geometry: {light}, material: \"black\", emission: (radiance: (17, 12, 4))),
            ])",
        RES.0,
        RES.1,
        smooth_sphere([-0.4, -0.55, -0.2], 0.45, 6, 10),
        smooth_sphere([0.45, -0.65, 0.3], 0.35, 5, 8),
    )
}

fn check(a: &RenderOutput, b: &RenderOutput, what: &str, crit: f64) {
    let mut worst = (0.0f64, 0usize, 0usize);
    for i in 0..a.film.pixels.len() {
        let (ma, va) = (a.film.mean(i), a.film.variance_of_mean(i));
        let (mb, vb) = (b.film.mean(i), b.film.variance_of_mean(i));
        for c in 0..3 {
            let zs = z(ma[c], va[c].sqrt(), mb[c], vb[c].sqrt()).abs();
            if zs > worst.0 {
                worst = (zs, i, c);
            }
        }
    }
    let (zs, i, c) = worst;
    assert!(
        zs < crit,
        "{what}: pixel ({}, {}) channel {c}: {} ± {} vs {} ± {} (z = {zs:.2}, critical {crit:.2})",
        i as u32 % RES.0,
        i as u32 / RES.0,
        a.film.mean(i)[c],
        a.film.variance_of_mean(i)[c].sqrt(),
        b.film.mean(i)[c],
        b.film.variance_of_mean(i)[c].sqrt()
    );
}

/// Comparisons in this file.
const COMPARISONS: u64 = 2 * 2 + 2 + 2;

fn crit() -> f64 {
    z_critical(sidak(1e-3, COMPARISONS * 3 * (RES.0 * RES.1) as u64))
}

#[test]
fn cornell_box_and_caustic_sphere_agree_per_pixel() {
    let cornell = scene(&lightlab_tests::cornell(1.0, [0.0; 3], RES));
    let paths = r#"paths: "L.+E""#;
    let path = render(&cornell, &format!("Path(max_bounces: 4, {paths})"), 512, 1);
    let tracer = render(
        &cornell,
        &format!("Light(max_bounces: 4, {paths})"),
        2048,
        2,
    );
    let bdpt = render(&cornell, &format!("Bdpt(max_bounces: 4, {paths})"), 256, 3);
    check(&tracer, &path, "Cornell box: Light vs Path", crit());
    check(&bdpt, &path, "Cornell box: Bdpt vs Path", crit());

    let text = caustic_sphere(RES);
    let caustic = scene(&text);
    // Everything light tracing sees but the emitter: the caustic included.
    let seen = r#"paths: "L.*[DG]E""#;
    let tracer = render(&caustic, &format!("Light(max_bounces: 5, {seen})"), 2048, 4);
    let bdpt = render(&caustic, &format!("Bdpt(max_bounces: 5, {seen})"), 256, 5);
    check(&bdpt, &tracer, "caustic sphere: Bdpt vs Light", crit());
    let unspecular = r#"paths: "L[DG]+E""#;
    let path = render(
        &caustic,
        &format!("Path(max_bounces: 5, {unspecular})"),
        512,
        6,
    );
    let bdpt = render(
        &caustic,
        &format!("Bdpt(max_bounces: 5, {unspecular})"),
        256,
        7,
    );
    check(&bdpt, &path, "caustic sphere: Bdpt vs Path", crit());
}

#[test]
fn path_light_and_bdpt_agree_per_pixel_on_smooth_shaded_glossy_meshes() {
    let crit = crit();
    for mesh_light in [false, true] {
        let sc = scene(&glossy_box(mesh_light));
        let light = if mesh_light {
            "mesh light"
        } else {
            "quad light"
        };
        let paths = r#"paths: "L.+E""#;
        let path = render(&sc, &format!("Path(max_bounces: 4, {paths})"), 512, 1);
        let tracer = render(&sc, &format!("Light(max_bounces: 4, {paths})"), 2048, 2);
        let bdpt = render(&sc, &format!("Bdpt(max_bounces: 4, {paths})"), 256, 3);
        for out in [&path, &tracer, &bdpt] {
            assert_eq!(out.stats.non_finite_total(), 0, "{light}");
        }
        check(&tracer, &path, &format!("{light}: Light vs Path"), crit);
        check(&bdpt, &path, &format!("{light}: Bdpt vs Path"), crit);
    }
}
