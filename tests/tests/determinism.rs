//! Determinism (design.md): the same seed gives the same image, bit for bit, on 1 or 2 threads; a
//! different seed gives a different one.

use lightlab_tests::{cornell, render, scene};

fn render_on(threads: usize, seed: u64) -> lightlab_integrators::Film {
    render_with(threads, seed, "Path()", 8)
}

fn render_with(threads: usize, seed: u64, config: &str, spp: u32) -> lightlab_integrators::Film {
    let sc = scene(&cornell(1.0, [0.0; 3], (37, 23)));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| render(&sc, config, spp, seed)).film
}

/// Photon maps (and VCM's light subpaths) are traced in parallel chunks and searched by a kd-tree
/// or hash grid: the images must still be identical on one and two threads.
#[test]
fn photon_mapping_same_bits_on_one_and_two_threads() {
    for config in [
        "PhotonMap(photons: 30000, caustic_photons: 10000, indirect: FinalGather(rays: 2))",
        "Sppm(photons_per_pass: 10000)",
        "Ppm(photons_per_pass: 10000, update: Global)",
        "Vcm(radius: Relative(0.05), light_paths: 2, outliers: Some(5))",
        "Vcm(variant: Bpm, radius: Relative(0.05), layers: Bounces, max_bounces: 4)",
        "Radiosity(patches: 300, rays: 64, layers: Bounces, max_bounces: 3)",
        "Radiosity(patches: 300, rays: 64, solver: Shooting, ambient: true, iterations: 1)",
        "Cone()",
    ] {
        same_bits_on_one_and_two_threads(config, 3);
    }
}

/// The image `config` renders at `spp` with seed 4 on one thread, after checking that two give the
/// same bits.
fn same_bits_on_one_and_two_threads(config: &str, spp: u32) -> lightlab_integrators::Film {
    let one = render_with(1, 4, config, spp);
    assert_eq!(one, render_with(2, 4, config, spp), "{config}");
    one
}

/// Replicated samplers (randomised quasi-Monte Carlo): each pixel's replicate sums are merged in a
/// fixed order too, so the images and their variances are the same bits on one and two threads.
#[test]
fn replicates_same_bits_on_one_and_two_threads() {
    for config in [
        "Path(sampler: Sobol, replicates: 4)",
        "Bdpt(sampler: Stratified, replicates: 2)",
        "Vcm(variant: Vc, sampler: Sobol, replicates: 2)",
    ] {
        let one = same_bits_on_one_and_two_threads(config, 8);
        assert!(
            one.pixels.iter().any(|p| p.shared_var != [0.0; 3]),
            "{config}"
        );
    }
}

#[test]
fn same_seed_same_bits_on_one_and_two_threads() {
    let one = render_on(1, 5);
    let two = render_on(2, 5);
    assert!(
        one.pixels
            .iter()
            .zip(&two.pixels)
            .all(
                |(a, b)| a.mean.map(f64::to_bits) == b.mean.map(f64::to_bits)
                    && a.m2.map(f64::to_bits) == b.m2.map(f64::to_bits)
                    && a.count == b.count
            )
    );
    let other = render_on(2, 6);
    assert_ne!(one, other, "a different seed must change the image");
}

/// The directional light and the plastics (a mixed delta lobe, a tabulated coating) under every
/// kind of integrator: the same bits on one and two threads.
#[test]
fn directional_light_and_plastics_same_bits_on_one_and_two_threads() {
    let sc = scene(
        "Scene(camera: Camera(eye: (0, 2, 3), target: (0, 0, 0), fov: 40, resolution: (19, 13)),
               materials: { \"floor\": RoughPlastic(kd: (0.6, 0.5, 0.4), roughness: Isotropic(0.2)),
                            \"ball\": Plastic(kd: (0.2, 0.3, 0.7), nonlinear: true) },
               shapes: [
                   Shape(geometry: Quad(corner: (-3, 0, -3), edge1: (0, 0, 6), edge2: (6, 0, 0)), material: \"floor\"),
                   Shape(geometry: Sphere(center: (0, 0.5, 0), radius: 0.5), material: \"ball\"),
               ],
               lights: [ Directional(direction: (-0.3, -1, 0.2), irradiance: (2, 2, 2)),
                         Point(position: (1, 2, 1), intensity: (1, 1, 1)) ])",
    );
    for config in [
        "Path()",
        "Light()",
        "Bdpt()",
        "Sppm(photons_per_pass: 5000)",
        "Vcm(radius: Relative(0.05))",
    ] {
        let on = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| render(&sc, config, 4, 9)).film
        };
        let one = on(1);
        assert!(one.average()[0] > 0.0, "{config}: the image is black");
        assert_eq!(one, on(2), "{config}");
    }
}
