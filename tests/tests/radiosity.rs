//! Radiosity end to end: exact on the white furnace (term by term, for every solver, on a sphere
//! and on a box), the three solvers agreeing on the Cornell box, the Cornell image converging to
//! path tracing's as patches shrink, and the scenes it refuses.
//!
//! The furnace checks are exact (no statistics): inside a closed enclosure every form-factor ray
//! lands on the enclosure, so each row of F̂ sums to exactly 1 whatever the rays, and
//! B = E Σ ρᵏ. The convergence check compares mean squared errors of deterministic renders
//! (fixed seeds) whose ratio, measured at 3–4×, is asserted above 1.5×.

use lightlab_integrators::{IntegratorConfig, RadiosityStats, RenderOutput};
use lightlab_tests::{cornell, furnace, furnace_box, render, scene};

fn stats(out: &RenderOutput) -> &RadiosityStats {
    out.stats.radiosity.as_ref().expect("a radiosity render")
}

/// Largest relative deviation of any pixel (and channel) of `film` from `want`.
fn worst(film: &lightlab_integrators::Film, want: f64) -> f64 {
    (0..film.pixel_count())
        .flat_map(|i| film.mean(i))
        .map(|v| (v - want).abs() / want)
        .fold(0.0, f64::max)
}

#[test]
fn furnace_is_the_rho_series_exactly() {
    let (rho, le) = (0.8f64, 0.5f64);
    for text in [
        furnace(0.8, 0.5, 1.0, (8, 6)),
        furnace_box(0.8, 0.5, (8, 6)),
    ] {
        let sc = scene(&text);
        let series = |k: i32| (0..=k).map(|j| le * rho.powi(j)).sum::<f64>();
        for k in 0..=5 {
            let config = format!("Radiosity(patches: 200, rays: 32, max_bounces: {k})");
            let out = render(&sc, &config, 2, 1);
            assert!(worst(&out.film, series(k)) < 2e-6, "{config}");
            assert_eq!(stats(&out).iterations, k as u32);
        }
        let limit = le / (1.0 - rho);
        for solver in ["Jacobi", "GaussSeidel", "Shooting"] {
            let config =
                format!("Radiosity(patches: 200, rays: 32, solver: {solver}, tolerance: 1e-9)");
            let out = render(&sc, &config, 2, 1);
            assert!(worst(&out.film, limit) < 1e-6, "{config}");
            let s = stats(&out);
            assert_eq!(s.converged, Some(true), "{config}");
            assert!(*s.residuals.last().unwrap() < 1e-9, "{config}");
        }
        // One term alone, by bounds, by path expression and as a layer.
        let second = le * rho * rho;
        for config in [
            "Radiosity(patches: 200, rays: 32, min_bounces: 2, max_bounces: 2)",
            "Radiosity(patches: 200, rays: 32, paths: \"LDDE\")",
        ] {
            assert!(
                worst(&render(&sc, config, 2, 1).film, second) < 2e-6,
                "{config}"
            );
        }
        let out = render(
            &sc,
            "Radiosity(patches: 200, rays: 32, layers: Bounces, max_bounces: 4)",
            2,
            1,
        );
        assert_eq!(out.layers.len(), 5);
        for (k, (name, film)) in out.layers.iter().enumerate() {
            assert!(worst(film, le * rho.powi(k as i32)) < 2e-6, "{name}");
        }
    }
}

fn cornell_radiosity(config: &str) -> RenderOutput {
    render(&scene(&cornell(1.0, [0.0; 3], (24, 24))), config, 4, 3)
}

/// The images of two renders agree to `rel` in every pixel (relative to the image's mean).
fn max_difference(a: &RenderOutput, b: &RenderOutput) -> f64 {
    let scale = a.film.average().iter().sum::<f64>() / 3.0;
    (0..a.film.pixel_count())
        .flat_map(|i| {
            let (x, y) = (a.film.mean(i), b.film.mean(i));
            (0..3).map(move |c| (x[c] - y[c]).abs())
        })
        .fold(0.0, f64::max)
        / scale
}

/// Cohen et al.'s ambient term is exact in a closed sphere of uniform ρ, where F_ab = A_b / A (in
/// expectation over the form-factor rays): after one round of shots the image must be the
/// converged Lₑ/(1 − ρ) within 0.5 % (measured 0.01–0.05 %). Counting the sphere's outside, which
/// sees nothing, made it 3.04 against 2.5.
#[test]
fn ambient_term_completes_the_furnace() {
    let (rho, le) = (0.8f64, 0.5f64);
    let sc = scene(&furnace(rho as f32, le as f32, 1.0, (8, 6)));
    let limit = le / (1.0 - rho);
    for rays in [32, 128] {
        let config = format!(
            "Radiosity(patches: 200, rays: {rays}, solver: Shooting, iterations: Some(1), ambient: true)"
        );
        let out = render(&sc, &config, 2, 1);
        let mean = out.film.average();
        for c in 0..3 {
            assert!(
                (mean[c] / limit - 1.0).abs() < 5e-3,
                "{config}: {} against {limit}",
                mean[c]
            );
        }
    }
}

#[test]
fn the_three_solvers_solve_the_same_system() {
    let base = "patches: 300, rays: 128, tolerance: 1e-9";
    let jacobi = cornell_radiosity(&format!("Radiosity({base})"));
    let gs = cornell_radiosity(&format!("Radiosity({base}, solver: GaussSeidel)"));
    let shooting = cornell_radiosity(&format!("Radiosity({base}, solver: Shooting)"));
    for (name, out) in [("Gauss–Seidel", &gs), ("shooting", &shooting)] {
        let d = max_difference(&jacobi, out);
        assert!(d < 1e-6, "{name} differs from Jacobi by {d:e}");
        assert_eq!(stats(out).converged, Some(true));
    }
    // Gauss–Seidel needs fewer sweeps than Jacobi needs bounces (about half on diffuse scenes).
    let (j, g) = (stats(&jacobi).iterations, stats(&gs).iterations);
    assert!(
        g * 3 < j * 2,
        "Gauss–Seidel {g} sweeps, Jacobi {j} iterations"
    );
    // Before any shot and after one round, the ambient term brings the image closer to the
    // solution. Before any shot all that is unshot is the light's emission, and the light
    // reflects nothing: the term once left it out and added nothing.
    let mse = |o: &RenderOutput| {
        (0..o.film.pixel_count())
            .flat_map(|i| {
                let (x, y) = (o.film.mean(i), jacobi.film.mean(i));
                (0..3).map(move |c| (x[c] - y[c]).powi(2))
            })
            .sum::<f64>()
    };
    for iterations in [0, 1] {
        let early = format!("patches: 300, rays: 128, solver: Shooting, iterations: {iterations}");
        let plain = cornell_radiosity(&format!("Radiosity({early})"));
        let ambient = cornell_radiosity(&format!("Radiosity({early}, ambient: true)"));
        assert!(
            mse(&ambient) < 0.5 * mse(&plain),
            "{iterations} iterations: ambient {} vs without {}",
            mse(&ambient),
            mse(&plain)
        );
        assert!(
            stats(&ambient)
                .ambient
                .is_some_and(|a| a.iter().all(|&v| v > 0.0))
        );
    }
}

/// Away from the light (whose edge pixels carry the camera samples' own aliasing noise), the
/// radiosity image's squared error against a converged path-traced image falls as the patches
/// shrink: measured 4.5e-4, 1.8e-4, 5.8e-5 at 64, 256 and 1024 patches with 4096 rays each.
#[test]
fn cornell_radiosity_converges_to_path_tracing() {
    let sc = scene(&cornell(1.0, [0.0; 3], (32, 32)));
    let reference = render(&sc, "Path()", 2048, 1);
    let n = reference.film.pixel_count();
    // Rows 3–5 hold the light and its aliased edges.
    let away_from_light: Vec<usize> = (0..n)
        .filter(|&i| reference.film.mean(i)[0] < 3.0 && !(96..192).contains(&i))
        .collect();
    let mse = |out: &RenderOutput| {
        away_from_light
            .iter()
            .flat_map(|&i| {
                let (x, y) = (out.film.mean(i), reference.film.mean(i));
                (0..3).map(move |c| (x[c] - y[c]).powi(2))
            })
            .sum::<f64>()
            / (3 * away_from_light.len()) as f64
    };
    let errors: Vec<f64> = [64, 256, 1024]
        .iter()
        .map(|p| {
            mse(&render(
                &sc,
                &format!("Radiosity(patches: {p}, rays: 4096)"),
                256,
                2,
            ))
        })
        .collect();
    assert!(
        errors[1] * 1.5 < errors[0] && errors[2] * 1.5 < errors[1],
        "MSE at 64, 256, 1024 patches: {errors:?}"
    );
    // The image mean, which discretisation barely moves, agrees within 2 %.
    let fine = render(&sc, "Radiosity(patches: 1024, rays: 4096)", 256, 2);
    for c in 0..3 {
        let (a, b) = (fine.film.average()[c], reference.film.average()[c]);
        assert!((a - b).abs() < 0.02 * b, "channel {c}: {a} vs {b}");
    }
}

#[test]
fn radiosity_refuses_what_it_cannot_model() {
    let integrator = IntegratorConfig::from_ron("Radiosity()")
        .unwrap()
        .build()
        .unwrap();
    let glass = scene(&lightlab_tests::caustic_sphere((8, 8)));
    let e = integrator.check_scene(&glass).unwrap_err();
    assert!(e.contains("Lambertian") && e.contains("not Diffuse"), "{e}");
    let point = scene(
        "Scene(camera: Camera(eye: (0, 1, 3), target: (0, 0, 0), fov: 40, resolution: (4, 4)),
               materials: { \"w\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
               shapes: [Shape(geometry: Quad(corner: (-1, 0, -1), edge1: (0, 0, 2), edge2: (2, 0, 0)), material: \"w\")],
               lights: [Point(position: (0, 1, 0), intensity: (1, 1, 1))])",
    );
    let e = integrator.check_scene(&point).unwrap_err();
    assert!(
        e.contains("area lights") && e.contains("point light"),
        "{e}"
    );
    assert!(
        integrator
            .check_scene(&scene(&furnace(0.5, 1.0, 1.0, (4, 4))))
            .is_ok()
    );
}
