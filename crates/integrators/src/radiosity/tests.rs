//! The ray-cast form factors against closed forms (Howell's catalogue, configurations C-11 and
//! C-14), and the row sums of a closed enclosure. Scene-level tests (furnace, Cornell box, the
//! solvers, errors) are in `tests/tests/radiosity.rs`.
//!
//! False failures: each z-test has a critical value of 4 (two-sided 6.3·10⁻⁵); seeds are fixed.

use super::form_factors::FormFactors;
use super::patches::Patches;
use lightlab_scene::{Scene, parse_scene};
use std::f64::consts::PI;
use std::path::Path;

fn scene(shapes: &str) -> Scene {
    parse_scene(
        &format!(
            "Scene(camera: Camera(eye: (0, 0, 5), target: (0, 0, 0), fov: 40, resolution: (4, 4)),
                   materials: {{ \"w\": Diffuse(albedo: (0.5, 0.5, 0.5)) }},
                   shapes: [{shapes}])"
        ),
        Path::new("inline.ron"),
    )
    .unwrap()
}

/// F̂ from shape 0 to shape 1 (every side of each) with its standard error: the area-weighted
/// mean of the rows' hit fractions, each binomial.
fn form_factor(scene: &Scene, patches: u32, rays: u32, seed: u64) -> (f64, f64) {
    let p = Patches::new(scene, patches);
    let active = vec![true; 2 * p.list.len()];
    let ff = FormFactors::estimate(scene, &p, &active, rays, seed);
    let total: f64 = p.list.iter().filter(|q| q.shape == 0).map(|q| q.area).sum();
    let (mut f, mut var) = (0.0, 0.0);
    for a in 0..ff.len() {
        let patch = &p.list[a / 2];
        if patch.shape != 0 {
            continue;
        }
        let hits: u32 = ff
            .row(a)
            .iter()
            .filter(|&&(b, _)| p.list[b as usize / 2].shape == 1)
            .map(|&(_, n)| n)
            .sum();
        let frac = hits as f64 / rays as f64;
        let w = patch.area / total;
        f += w * frac;
        var += w * w * frac * (1.0 - frac) / rays as f64;
    }
    (f, var.sqrt())
}

/// Howell C-11: directly opposed parallel rectangles a × b at distance c.
fn parallel(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    2.0 / (PI * x * y)
        * (((1.0 + x * x) * (1.0 + y * y) / (1.0 + x * x + y * y))
            .sqrt()
            .ln()
            + x * sy * (x / sy).atan()
            + y * sx * (y / sx).atan()
            - x * x.atan()
            - y * y.atan())
}

/// Howell C-14: from a rectangle w × l to a perpendicular h × l one sharing the edge l.
fn perpendicular(w: f64, h: f64, l: f64) -> f64 {
    let (w, h) = (w / l, h / l);
    let (w2, h2) = (w * w, h * h);
    let r = (w2 + h2).sqrt();
    let log = ((1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2)).ln()
        + w2 * (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).ln()
        + h2 * (h2 * (1.0 + h2 + w2) / ((1.0 + h2) * (h2 + w2))).ln();
    (w * (1.0 / w).atan() + h * (1.0 / h).atan() - r * (1.0 / r).atan() + 0.25 * log) / (PI * w)
}

#[test]
fn closed_forms_check_themselves() {
    assert!((parallel(1.0, 1.0, 1.0) - 0.19982).abs() < 1e-5);
    assert!((perpendicular(1.0, 1.0, 1.0) - 0.20004).abs() < 1e-5);
}

#[test]
fn ray_cast_form_factors_match_closed_forms() {
    let cases = [
        (
            // Unit squares one apart, facing each other.
            "Shape(geometry: Quad(corner: (0, 0, 0), edge1: (1, 0, 0), edge2: (0, 1, 0)), material: \"w\"),
             Shape(geometry: Quad(corner: (0, 0, 1), edge1: (0, 1, 0), edge2: (1, 0, 0)), material: \"w\")",
            parallel(1.0, 1.0, 1.0),
        ),
        (
            // 2 × 3 rectangles 0.7 apart.
            "Shape(geometry: Quad(corner: (0, 0, 0), edge1: (2, 0, 0), edge2: (0, 3, 0)), material: \"w\"),
             Shape(geometry: Quad(corner: (0, 0, 0.7), edge1: (0, 3, 0), edge2: (2, 0, 0)), material: \"w\")",
            parallel(2.0, 3.0, 0.7),
        ),
        (
            // Floor 1 (x) × 2 (z) and a wall 0.5 (y) × 2 (z) along the edge x = 0.
            "Shape(geometry: Quad(corner: (0, 0, 0), edge1: (0, 0, 2), edge2: (1, 0, 0)), material: \"w\"),
             Shape(geometry: Quad(corner: (0, 0, 0), edge1: (0, 0.5, 0), edge2: (0, 0, 2)), material: \"w\")",
            perpendicular(1.0, 0.5, 2.0),
        ),
    ];
    for (i, (shapes, want)) in cases.into_iter().enumerate() {
        let sc = scene(shapes);
        // Few patches and many: the estimator is unbiased at any subdivision.
        for patches in [2, 200] {
            let (f, se) = form_factor(&sc, patches, 4096, 7 + i as u64);
            let z = (f - want) / se;
            assert!(
                z.abs() < 4.0,
                "case {i}, {patches} patches: F̂ = {f} ± {se}, closed form {want}, z = {z:.2}"
            );
        }
    }
}

/// Inside a closed sphere every ray from the inner side lands on the sphere and none from the
/// outer side does, so rows sum to exactly the ray count — what makes the furnace's radiosity
/// exact whatever the form factors' noise.
#[test]
fn a_closed_enclosure_keeps_every_ray() {
    let sc =
        scene("Shape(geometry: Sphere(center: (0.3, -0.2, 0.1), radius: 1.7), material: \"w\")");
    let p = Patches::new(&sc, 300);
    let ff = FormFactors::estimate(&sc, &p, &vec![true; 2 * p.list.len()], 256, 3);
    for a in 0..ff.len() {
        let sum: u32 = ff.row(a).iter().map(|&(_, n)| n).sum();
        // Side 0 faces out (the sphere's normal), side 1 in; inner rays land on inner sides.
        let want = if a % 2 == 0 { 0 } else { 256 };
        assert_eq!(sum, want, "row {a}");
        assert!(ff.row(a).iter().all(|&(b, _)| b % 2 == 1), "row {a}");
    }
}
