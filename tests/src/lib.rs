//! Shared helpers of the end-to-end tests in `tests/tests/`: render scene text with an integrator
//! given as RON, and generate variants of the bundled scenes.

use lightlab_core::NoProgress;
use lightlab_integrators::{Budget, Film, IntegratorConfig, RenderOutput};
use lightlab_scene::{Scene, parse_scene};
use std::path::Path;

/// Parses scene text (errors name `inline.ron`).
pub fn scene(text: &str) -> Scene {
    parse_scene(text, Path::new("inline.ron"))
        .unwrap_or_else(|e| panic!("test scene does not load: {e}"))
}

/// Renders `scene` with the integrator `config` (RON) at `spp` samples per pixel.
pub fn render(scene: &Scene, config: &str, spp: u32, seed: u64) -> RenderOutput {
    let cfg = IntegratorConfig::from_ron(config)
        .unwrap_or_else(|e| panic!("bad integrator {config}: {e}"));
    cfg.build()
        .unwrap_or_else(|e| panic!("bad integrator {config}: {e}"))
        .render(scene, &Budget::Samples(spp), seed, &NoProgress)
}

/// The image average of `film` and its standard error, which the integrator must provide (its
/// sample passes are independent).
pub fn image_mean(film: &Film) -> ([f64; 3], [f64; 3]) {
    (
        film.average(),
        film.image_se
            .expect("this render has no standard error of its image mean"),
    )
}

/// The image average of `film` and its standard error from the per-pixel variances, for estimators
/// whose pixels are independent (camera paths only: path tracing). With a stratified sampler each
/// pixel's s²/n overestimates its variance on average where the sampler beats independent samples
/// (`SamplerConfig::correlation_note`), as on the scenes these tests render, which makes tests
/// built on this conservative there.
pub fn independent_pixels_mean(film: &Film) -> ([f64; 3], [f64; 3]) {
    let n = film.pixel_count() as f64;
    let mut var = [0.0; 3];
    for p in &film.pixels {
        let v = p.variance_of_mean();
        for c in 0..3 {
            var[c] += v[c] / (n * n);
        }
    }
    (film.average(), var.map(f64::sqrt))
}

/// Image averages of `config` over `seeds` independent renders (seeds 0, 1, …): for the full
/// image and then each layer, the mean over seeds and its standard error — for integrators with
/// no standard error of their own (progressive photon mapping), to be tested with Student's t on
/// `seeds − 1` degrees of freedom.
pub fn across_seeds(
    scene: &Scene,
    config: &str,
    spp: u32,
    seeds: u64,
) -> Vec<([f64; 3], [f64; 3])> {
    let outs: Vec<RenderOutput> = (0..seeds).map(|s| render(scene, config, spp, s)).collect();
    let films = |o: &RenderOutput| -> Vec<[f64; 3]> {
        std::iter::once(o.film.average())
            .chain(o.layers.iter().map(|(_, f)| f.average()))
            .collect()
    };
    let per_seed: Vec<Vec<[f64; 3]>> = outs.iter().map(films).collect();
    (0..per_seed[0].len())
        .map(|k| {
            let mut mean = [0.0; 3];
            let mut se = [0.0; 3];
            for c in 0..3 {
                let xs: Vec<f64> = per_seed.iter().map(|v| v[k][c]).collect();
                (mean[c], se[c]) = lightlab_testkit::stats::mean_and_std_error(&xs);
            }
            (mean, se)
        })
        .collect()
}

/// The furnace: camera inside a closed sphere of albedo `rho` emitting `le` from its inside.
pub fn furnace(rho: f32, le: f32, radius: f32, res: (u32, u32)) -> String {
    format!(
        "Scene(camera: Camera(eye: (0, 0, 0), target: (0, 0, -1), fov: 60, resolution: ({}, {})),
               materials: {{ \"wall\": Diffuse(albedo: ({rho}, {rho}, {rho})) }},
               shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: {radius}), material: \"wall\",
                               emission: (radiance: ({le}, {le}, {le}), two_sided: true)) ])",
        res.0, res.1
    )
}

/// The furnace as a triangle mesh: inside any closed enclosure of uniform albedo and emission the
/// radiance is the same everywhere, so a box gives the same answer as the sphere.
pub fn furnace_box(rho: f32, le: f32, res: (u32, u32)) -> String {
    format!(
        "Scene(camera: Camera(eye: (0.1, -0.2, 0.3), target: (0, 0, -1), fov: 70, resolution: ({}, {})),
               materials: {{ \"wall\": Diffuse(albedo: ({rho}, {rho}, {rho})) }},
               shapes: [ Shape(geometry: Cuboid(half_extents: (1, 1.5, 2)), material: \"wall\",
                               emission: (radiance: ({le}, {le}, {le}), two_sided: true)) ])",
        res.0, res.1
    )
}

/// The shipped `scenes/caustic-sphere.ron` at resolution `res` (it ships at 256 × 256).
pub fn caustic_sphere(res: (u32, u32)) -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/caustic-sphere.ron"
    ))
    .expect("scenes/caustic-sphere.ron is readable");
    assert!(text.contains("resolution: (256, 256)"));
    text.replace(
        "resolution: (256, 256)",
        &format!("resolution: ({}, {})", res.0, res.1),
    )
}

/// The Cornell box of `scenes/cornell-box.ron`, uniformly scaled by `s` about the origin and then
/// moved by `t`, at resolution `res`. The light's radiance is unchanged, so the image is the same.
/// Positions are written in f64, as a file far from the origin would hold them.
pub fn cornell(s: f32, t: [f64; 3], res: (u32, u32)) -> String {
    let p = |x: f64, y: f64, z: f64| {
        let s = s as f64;
        format!("({}, {}, {})", x * s + t[0], y * s + t[1], z * s + t[2])
    };
    let v = |x: f32, y: f32, z: f32| format!("({}, {}, {})", x * s, y * s, z * s);
    let quad = |c: String, a: String, b: String, m: &str| {
        format!("Shape(geometry: Quad(corner: {c}, edge1: {a}, edge2: {b}), material: \"{m}\"),")
    };
    let cuboid = |h: String, deg: f32, c: String| {
        format!(
            "Shape(geometry: Cuboid(half_extents: {h}), material: \"white\",
                   transform: (scale: ({s}, {s}, {s}), rotate: [(axis: (0, 1, 0), degrees: {deg})], translate: {c})),"
        )
    };
    format!(
        "Scene(
            camera: Camera(eye: {eye}, target: {target}, fov: 39.3077, resolution: ({w}, {h})),
            materials: {{
                \"white\": Diffuse(albedo: (0.725, 0.71, 0.68)),
                \"red\": Diffuse(albedo: (0.63, 0.065, 0.05)),
                \"green\": Diffuse(albedo: (0.14, 0.45, 0.091)),
                \"black\": Diffuse(albedo: (0, 0, 0)),
            }},
            shapes: [ {floor} {ceiling} {back} {left} {right} {tall} {short}
                Shape(geometry: Quad(corner: {lc}, edge1: {la}, edge2: {lb}), material: \"black\",
                      emission: (radiance: (17, 12, 4))),
            ])",
        eye = p(0.0, 0.0, 3.9),
        target = p(0.0, 0.0, 0.0),
        w = res.0,
        h = res.1,
        floor = quad(
            p(-1.0, -1.0, -1.0),
            v(0.0, 0.0, 2.0),
            v(2.0, 0.0, 0.0),
            "white"
        ),
        ceiling = quad(
            p(-1.0, 1.0, -1.0),
            v(2.0, 0.0, 0.0),
            v(0.0, 0.0, 2.0),
            "white"
        ),
        back = quad(
            p(-1.0, -1.0, -1.0),
            v(2.0, 0.0, 0.0),
            v(0.0, 2.0, 0.0),
            "white"
        ),
        left = quad(
            p(-1.0, -1.0, -1.0),
            v(0.0, 2.0, 0.0),
            v(0.0, 0.0, 2.0),
            "red"
        ),
        right = quad(
            p(1.0, -1.0, -1.0),
            v(0.0, 0.0, 2.0),
            v(0.0, 2.0, 0.0),
            "green"
        ),
        tall = cuboid("(0.3, 0.61, 0.3)".into(), 18.25, p(-0.33, -0.4, -0.28)),
        short = cuboid("(0.3, 0.3, 0.3)".into(), -17.0, p(0.335, -0.7, 0.38)),
        lc = p(-0.23, 0.99, -0.18),
        la = v(0.46, 0.0, 0.0),
        lb = v(0.0, 0.0, 0.38),
    )
}

/// Mean and standard error (from the per-pixel variances) of each of the n × n regions of an
/// image, so that comparisons cannot hide a local error in the image average.
///
/// The standard error assumes independent pixels, which holds for camera paths only: one light
/// path splats into several pixels, and VCM's merges share light paths across the image, so
/// pixels of a region covary. Measured (48 seeds; 32² Cornell box and caustic sphere, 4 × 4
/// regions, the variance across seeds over the mean reported one, averaged over regions and
/// channels, ±0.05): path tracing 0.98 and 1.03 (the control), light tracing 0.98 and 1.06, BDPT
/// 0.99 and 0.94, `Vcm(variant: Vc)` 1.10 and 0.98, `Vcm` 1.14 and 1.02. So the z-tests built on it
/// hold their stated rates for light tracing and BDPT; for VCM a variance 1.15× the reported one
/// moves a critical value of 4.4σ to 4.1σ (a false-failure rate up to 4× the stated one), so VCM's
/// tests take their regions from [`pass_regions`].
pub fn regions(out: &RenderOutput, n: usize) -> Vec<([f64; 3], [f64; 3])> {
    let f = &out.film;
    let (w, h) = (f.width as usize, f.height as usize);
    let mut r = vec![([0.0; 3], [0.0; 3]); n * n];
    let per = (w / n * (h / n)) as f64;
    for y in 0..h {
        for x in 0..w {
            let (m, v) = (f.mean(y * w + x), f.variance_of_mean(y * w + x));
            let g = &mut r[(y * n / h) * n + x * n / w];
            for c in 0..3 {
                g.0[c] += m[c] / per;
                g.1[c] += v[c] / (per * per);
            }
        }
    }
    r.into_iter().map(|(m, v)| (m, v.map(f64::sqrt))).collect()
}

/// Renders `scene` with `config` at `spp` one-sample passes and returns each of the n × n
/// regions' mean with a standard error from the spread of its per-pass estimates, which stays
/// honest where pixels covary (light paths shared across the image: `Vcm`), as [`regions`]'
/// sum of pixel variances does not. Passes are independent; the errors have `spp − 1` degrees of
/// freedom (Student's t). Under a shrinking merge radius the passes are not identically
/// distributed, which only widens their spread (the error is then conservative). Measured (24
/// seeds, 32² Cornell box at 64 spp, 4 × 4 regions, the variance across seeds over the mean
/// reported one, ±0.07): `Vcm` 1.02 (1.04 for [`regions`]), `Vcm(variant: Vc)` 1.01 (1.03).
pub fn pass_regions(
    scene: &Scene,
    config: &str,
    spp: u32,
    seed: u64,
    n: usize,
) -> Vec<([f64; 3], [f64; 3])> {
    let integrator = IntegratorConfig::from_ron(config)
        .and_then(|c| c.build())
        .unwrap_or_else(|e| panic!("bad integrator {config}: {e}"));
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    // Region sums of every pixel's total after each pass, and the passes' own region sums.
    let (mut before, mut passes) = (vec![[0.0f64; 3]; n * n], Vec::new());
    let mut last = 0;
    integrator.render_passes(
        scene,
        &Budget::Samples(spp),
        seed,
        &NoProgress,
        &mut |done, film| {
            assert_eq!(done, last + 1, "{config}: a pass of more than one sample");
            last = done;
            let mut now = vec![[0.0f64; 3]; n * n];
            for y in 0..h {
                for x in 0..w {
                    let m = film.mean(y * w + x);
                    let g = &mut now[(y * n / h) * n + x * n / w];
                    for c in 0..3 {
                        g[c] += m[c] * done as f64;
                    }
                }
            }
            let pass: Vec<[f64; 3]> = now
                .iter()
                .zip(&before)
                .map(|(a, b)| std::array::from_fn(|c| a[c] - b[c]))
                .collect();
            passes.push(pass);
            before = now;
            true
        },
    );
    assert_eq!(last, spp, "{config}: stopped after {last} of {spp} passes");
    let per = (w / n * (h / n)) as f64;
    (0..n * n)
        .map(|k| {
            let mut out = ([0.0; 3], [0.0; 3]);
            for c in 0..3 {
                let values: Vec<f64> = passes.iter().map(|p| p[k][c] / per).collect();
                let (mean, se) = lightlab_testkit::stats::mean_and_std_error(&values);
                (out.0[c], out.1[c]) = (mean, se);
            }
            out
        })
        .collect()
}

/// Two-sample z statistic of estimates a ± sa and b ± sb (standard errors); the denominator is
/// floored at 1e-9 of |b| so that two exact, equal answers give 0.
pub fn z(a: f64, sa: f64, b: f64, sb: f64) -> f64 {
    (a - b) / (sa * sa + sb * sb).sqrt().max(1e-9 * b.abs().max(1e-30))
}

/// The white furnace term by term for `integrator` (e.g. "Light"): max_bounces 0…4, the second
/// term alone and the unbounded series, each image mean z-tested against Lₑ·Σρᵏ (Šidák-corrected
/// to ≤ 1e-3 over the whole check).
pub fn check_furnace_every_bounce(integrator: &str, spp: u32) {
    let (rho, le) = (0.7f64, 0.5f64);
    let sc = scene(&furnace(rho as f32, le as f32, 1.0, (12, 8)));
    let configs: Vec<(String, f64)> = (0..=4)
        .map(|k| {
            (
                format!("{integrator}(max_bounces: {k})"),
                (0..=k).map(|i| le * rho.powi(i)).sum(),
            )
        })
        .chain([
            (
                format!("{integrator}(min_bounces: 2, max_bounces: 2)"),
                le * rho * rho,
            ),
            (format!("{integrator}()"), le / (1.0 - rho)),
        ])
        .collect();
    let crit = lightlab_testkit::stats::z_critical(lightlab_testkit::stats::sidak(
        1e-3,
        configs.len() as u64 * 3,
    ));
    for (config, want) in configs {
        let out = render(&sc, &config, spp, 11);
        assert_eq!(out.stats.non_finite_total(), 0);
        let (mean, se) = image_mean(&out.film);
        for c in 0..3 {
            let z = z(mean[c], se[c], want, 0.0);
            assert!(
                z.abs() < crit,
                "{config}: {} ± {} vs {want}, z = {z:.2}",
                mean[c],
                se[c]
            );
        }
    }
}

/// A Lambertian plane under a uniform sky L leaves radiance ρ/π · πL = ρL: each `config`'s image
/// mean is z-tested against it (Šidák-corrected to ≤ 1e-3 over all configs and channels).
pub fn check_plane_under_sky(configs: &[&str]) {
    let text = "Scene(camera: Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 30, resolution: (16, 16)),
        materials: { \"plane\": Diffuse(albedo: (0.6, 0.5, 0.4)) },
        shapes: [ Shape(geometry: Quad(corner: (-5, 0, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"plane\") ],
        lights: [ Environment(radiance: (2, 2, 2)) ])";
    let sc = scene(text);
    let want = [1.2, 1.0, 0.8];
    let crit = lightlab_testkit::stats::z_critical(lightlab_testkit::stats::sidak(
        1e-3,
        configs.len() as u64 * 3,
    ));
    for config in configs {
        let (mean, se) = image_mean(&render(&sc, config, 256, 5).film);
        assert_mean_near(config, mean, se, want, crit);
    }
}

/// Asserts that every channel of an image mean ± its standard error is within `crit` standard
/// errors of the exact `want`.
pub fn assert_mean_near(config: &str, mean: [f64; 3], se: [f64; 3], want: [f64; 3], crit: f64) {
    for c in 0..3 {
        let z = z(mean[c], se[c], want[c], 0.0);
        assert!(
            z.abs() < crit,
            "{config}: channel {c}: {} ± {} vs {}, z = {z:.2}",
            mean[c],
            se[c],
            want[c]
        );
    }
}
