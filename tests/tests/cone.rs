//! Cone tracing (Amanatides 1984) against distributed ray tracing on `scenes/sphere-on-plane.ron`:
//! `Path(max_bounces: 1)` at high spp is the reference, and the cone tracer's image must agree
//! with it within the approximation error measured here, region by region: smooth regions (its
//! irradiance is exact there), the sphere's anti-aliased silhouette, and the soft shadows.
//!
//! The bounds are the measured errors with margin (noted at each); the reference's own noise is
//! subtracted where it is estimated. Seeds are fixed; the cone image is deterministic.

use lightlab_tests::{render, scene};

fn sphere_on_plane(res: (u32, u32)) -> lightlab_scene::Scene {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/sphere-on-plane.ron"
    ))
    .unwrap();
    scene(&text.replace(
        "resolution: (160, 120)",
        &format!("resolution: ({}, {})", res.0, res.1),
    ))
}

/// Pixel sets of the image: `smooth` (no neighbour differs by more than 10 % in the unshadowed
/// reference, and fully lit or unlit by the geometry), `umbrae` (below 0.1 % of the light
/// reaches them), `edges` (silhouettes: the sphere's, the lights',
/// the floor's horizon) and `penumbrae` (partly visible lights, away from edges).
struct Regions {
    smooth: Vec<usize>,
    edges: Vec<usize>,
    penumbrae: Vec<usize>,
    umbrae: Vec<usize>,
}

fn regions(
    width: usize,
    lit: &lightlab_integrators::Film,
    unshadowed: &lightlab_integrators::Film,
) -> Regions {
    let n = lit.pixel_count();
    let l = |f: &lightlab_integrators::Film, j: usize| f.mean(j).iter().sum::<f64>();
    let mut r = Regions {
        smooth: Vec::new(),
        edges: Vec::new(),
        penumbrae: Vec::new(),
        umbrae: Vec::new(),
    };
    for i in 0..n {
        let (x, y) = (i % width, i / width);
        let edge = [
            (x.wrapping_sub(1), y),
            (x + 1, y),
            (x, y.wrapping_sub(1)),
            (x, y + 1),
        ]
        .iter()
        .filter(|(a, b)| *a < width && *b < n / width)
        .any(|&(a, b)| {
            let j = b * width + a;
            (l(unshadowed, j) - l(unshadowed, i)).abs() > 0.1 * l(unshadowed, i).max(0.05)
        });
        let visible = l(lit, i) / l(unshadowed, i).max(1e-9);
        if edge {
            r.edges.push(i);
        } else if l(unshadowed, i) <= 0.01 || visible > 1.0 - 1e-3 {
            r.smooth.push(i);
        } else if visible < 1e-3 {
            r.umbrae.push(i);
        } else {
            r.penumbrae.push(i);
        }
    }
    r
}

/// Mean squared error of `a` against `b` over `set`, less `b`'s own variance, and `b`'s mean.
fn error(
    a: &lightlab_integrators::Film,
    b: &lightlab_integrators::Film,
    set: &[usize],
) -> (f64, f64) {
    let (mut mse, mut mean) = (0.0, 0.0);
    for &i in set {
        let (x, y, v) = (a.mean(i), b.mean(i), b.variance_of_mean(i));
        for c in 0..3 {
            mse += (x[c] - y[c]).powi(2) - v[c];
            mean += y[c];
        }
    }
    let m = (3 * set.len()) as f64;
    (mse / m, mean / m)
}

/// Measured at 64 × 48 against 4096 spp: smooth pixels agree to 0.5 % rms (MSE 3.6e-8 beyond the
/// reference's noise: the irradiance is exact; what is left is pixels across the terminator,
/// shaded at one point), penumbrae to 1.2 % rms of their mean, silhouettes to 9.8 % rms (the disk
/// footprint is another filter than the pixel's box, and the lights' edges are bright), the image
/// mean to 0.3 %.
#[test]
fn cone_tracing_agrees_with_distributed_ray_tracing_within_its_approximations() {
    let sc = sphere_on_plane((64, 48));
    let cone = render(&sc, "Cone()", 1, 0);
    let path = render(&sc, "Path(max_bounces: 1)", 4096, 1);
    let unshadowed = render(&sc, "Path(max_bounces: 1, shadows: false)", 1024, 2);
    let r = regions(64, &path.film, &unshadowed.film);
    assert!(r.smooth.len() > 1000 && r.edges.len() > 300 && r.penumbrae.len() > 200);
    // Smooth pixels: every one within 5 reference standard errors plus 0.5 %, plus 2e-4 (0.2 %
    // of the image mean) for pixels across the sphere's terminator, shaded at one point.
    for &i in &r.smooth {
        let (a, b, v) = (
            cone.film.mean(i),
            path.film.mean(i),
            path.film.variance_of_mean(i),
        );
        for c in 0..3 {
            let tol = 5.0 * v[c].sqrt() + 5e-3 * b[c] + 2e-4;
            assert!(
                (a[c] - b[c]).abs() <= tol,
                "smooth pixel {i}: cone {} vs path {}",
                a[c],
                b[c]
            );
        }
    }
    // Umbrae: dark within 0.2 % of the unshadowed light.
    for &i in &r.umbrae {
        let (a, u) = (cone.film.mean(i), unshadowed.film.mean(i));
        assert!(
            (0..3).all(|c| a[c] <= 2e-3 * u[c] + 1e-9),
            "umbra pixel {i}: {a:?} of {u:?}"
        );
    }
    let (smooth, _) = error(&cone.film, &path.film, &r.smooth);
    assert!(
        smooth < 1e-7,
        "smooth MSE beyond the reference's noise: {smooth:e}"
    );
    for (name, set, bound) in [
        ("penumbrae", &r.penumbrae, 0.04),
        ("silhouettes", &r.edges, 0.2),
    ] {
        let (mse, mean) = error(&cone.film, &path.film, set);
        let rms = mse.max(0.0).sqrt() / mean;
        assert!(
            rms < bound,
            "{name}: rms error {rms:.4} of the mean, bound {bound}"
        );
    }
    for c in 0..3 {
        let (a, b) = (cone.film.average()[c], path.film.average()[c]);
        assert!(
            (a - b).abs() < 0.01 * b,
            "image mean, channel {c}: {a} vs {b}"
        );
    }
    // Shadows off, the cone tracer's penumbrae are fully lit like the unshadowed reference's.
    let free = render(&sc, "Cone(shadows: false)", 1, 0);
    let (mse, mean) = error(&free.film, &unshadowed.film, &r.penumbrae);
    assert!(
        mse.max(0.0).sqrt() < 0.01 * mean,
        "unshadowed penumbrae: {mse:e}"
    );
}

#[test]
fn cone_tracing_splits_emission_from_direct_light() {
    let sc = sphere_on_plane((32, 24));
    let full = render(&sc, "Cone(layers: Bounces)", 1, 0);
    let emission = render(&sc, "Cone(max_bounces: 0)", 1, 0);
    let direct = render(&sc, "Cone(paths: \"LDE\")", 1, 0);
    assert_eq!(full.layers.len(), 2);
    for i in 0..full.film.pixel_count() {
        let (le, lde) = (full.layers[0].1.mean(i), full.layers[1].1.mean(i));
        for c in 0..3 {
            assert!((le[c] - emission.film.mean(i)[c]).abs() < 1e-6);
            assert!((lde[c] - direct.film.mean(i)[c]).abs() < 1e-6);
            assert!((le[c] + lde[c] - full.film.mean(i)[c]).abs() < 1e-5);
        }
    }
}

#[test]
fn cone_tracing_refuses_what_it_cannot_trace() {
    let cone = lightlab_integrators::IntegratorConfig::from_ron("Cone()")
        .unwrap()
        .build()
        .unwrap();
    let glass = scene(&lightlab_tests::caustic_sphere((8, 8)));
    let e = cone.check_scene(&glass).unwrap_err();
    assert!(e.contains("Lambertian"), "{e}");
    let lens = scene(
        "Scene(camera: Camera(eye: (0, 1, 3), target: (0, 0, 0), fov: 40, resolution: (4, 4),
                              lens: ThinLens(aperture_radius: 0.1, focus_distance: 3)),
               materials: { \"w\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
               shapes: [Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"w\",
                              emission: (radiance: (1, 1, 1)))])",
    );
    assert!(cone.check_scene(&lens).unwrap_err().contains("pinhole"));
    // The shading leaves a light's own shape out, so a light that can light itself is refused:
    // the furnace (camera inside an emitting sphere, where Cone rendered Lₑ for Lₑ(1 + ρ)) and a
    // folded, concave emitting mesh; a flat one and a sphere seen from outside are rendered.
    let furnace = lightlab_scene::load_scene(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/furnace.ron"),
    )
    .unwrap();
    assert!(
        cone.check_scene(&furnace)
            .unwrap_err()
            .contains("can light itself")
    );
    let mesh = |positions: &str| {
        scene(&format!(
            "Scene(camera: Camera(eye: (0, 1, 3), target: (0, 0, 0), fov: 40, resolution: (4, 4)),
                   materials: {{ \"w\": Diffuse(albedo: (0.5, 0.5, 0.5)) }},
                   shapes: [Shape(geometry: Mesh(positions: [{positions}],
                                                 indices: [(0, 1, 2), (3, 4, 5)]),
                                  material: \"w\", emission: (radiance: (1, 1, 1)))])"
        ))
    };
    // Two triangles facing +y side by side, then the second folded up to face the first.
    let flat = mesh("(0, 0, 0), (1, 0, 0), (0, 0, -1), (0, 0, 0), (0, 0, 1), (1, 0, 0)");
    let folded = mesh("(0, 0, 0), (1, 0, 0), (0, 0, -1), (0, 0, 0), (0, 1, 0), (1, 0, 0)");
    cone.check_scene(&flat).unwrap();
    assert!(
        cone.check_scene(&folded)
            .unwrap_err()
            .contains("can light itself")
    );
    cone.check_scene(&sphere_on_plane((4, 4))).unwrap();
    for (bad, words) in [
        ("Cone(max_bounces: 2)", "max_bounces must be 0 or 1"),
        ("Cone(min_bounces: 1, max_bounces: 0)", "min_bounces"),
    ] {
        let e = lightlab_integrators::IntegratorConfig::from_ron(bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{bad}: {e}");
    }
}
