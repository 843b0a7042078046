//! The statistics every render reports are what they claim to be: the film's variance is the
//! variance of the pixel mean (measured across independent seeds), a time budget is the estimator
//! of the sample budget it reaches, and several environment lights are one.
//!
//! False-failure rates are stated per test; seeds are fixed, so every outcome is reproducible.

use lightlab_core::NoProgress;
use lightlab_integrators::{Budget, IntegratorConfig, PixelVariance, RenderOutput};
use lightlab_tests::{cornell, render, scene};
/// The Cornell box seen from above its floor: floor, blocks and the lower walls, neither the light
/// nor the ceiling beside it — the pixels whose samples have the heaviest tails (edges of the
/// emitter, next-event estimation at 1/d² next to the light), which would make the variance
/// measured across seeds itself too noisy to test against.
fn lower_box(res: (u32, u32)) -> lightlab_scene::Scene {
    let text = cornell(1.0, [0.0; 3], res);
    let from = "camera: Camera(eye: (0, 0, 3.9), target: (0, 0, 0), fov: 39.3077";
    assert!(text.contains(from));
    scene(&text.replace(
        from,
        "camera: Camera(eye: (0, 0, 3.9), target: (0, -0.7, -0.3), fov: 24",
    ))
}

/// For each integrator: the mean over seeds of the reported variance of each pixel mean, against
/// the variance of the pixel means measured across the same seeds, pooled over the image — the
/// ratio must be 1 within 10 %. Two pixels, so that one light path often splats twice into the
/// same one; 2048 seeds, so the measured variance's relative standard deviation is about 3 %
/// (over four seed sets the ratios were 0.98–1.05 for Path, Light and Bdpt and 0.96–0.99 for the
/// k-nearest photon map, whose groups share their radius, so that the crossed design is only an
/// approximation there; the fixed-radius map, where it is exact, is tested too): 10 % is over 3σ,
/// a false-failure rate below 0.3 % per integrator under normal theory, so below 1.5 % for the five
/// (over the choice of the fixed seeds; heavy-tailed pixel means widen the measured variance's
/// spread and raise it). Before, light tracing squared each
/// splat on its own (0.76), BDPT added its splats as an independent estimate (0.83) and the photon
/// map left out its maps' noise (0.77); the photon map here has no direct light, so that the
/// photons carry most of its variance. Sobol' samples in 4 replicates (randomised quasi-Monte
/// Carlo) are tested the same way: their variance is the spread of the replicate means (ratios 0.97
/// for Path and 1.01 for Bdpt with these seeds); s²/n over the samples gave 1.69 for Path (the
/// samples beat independent ones).
#[test]
fn reported_pixel_variance_matches_the_variance_across_seeds() {
    let sc = lower_box((2, 1));
    for (config, spp) in [
        ("Path(max_bounces: 3)", 16),
        ("Light(max_bounces: 3)", 16),
        ("Bdpt(max_bounces: 3)", 8),
        (
            "PhotonMap(max_bounces: 3, photons: 500, caustic_photons: 100, gather: Nearest(k: 20, max_radius: Relative(0.3)), indirect: Direct, direct: false)",
            16,
        ),
        (
            "PhotonMap(max_bounces: 3, photons: 500, caustic_photons: 100, gather: Radius(Relative(0.15)), indirect: Direct, direct: false)",
            16,
        ),
        ("Path(max_bounces: 3, sampler: Sobol, replicates: 4)", 32),
        ("Bdpt(max_bounces: 3, sampler: Sobol, replicates: 4)", 16),
        (
            "Vcm(max_bounces: 3, variant: Vc, sampler: Sobol, replicates: 4)",
            16,
        ),
    ] {
        let seeds = 2048;
        let outs: Vec<RenderOutput> = (0..seeds)
            .map(|s| render(&sc, config, spp, 1000 + s))
            .collect();
        let pixels = outs[0].film.pixel_count();
        let (mut reported, mut measured) = (0.0f64, 0.0f64);
        for i in 0..pixels {
            for c in 0..3 {
                let xs: Vec<f64> = outs.iter().map(|o| o.film.mean(i)[c]).collect();
                let m = xs.iter().sum::<f64>() / seeds as f64;
                measured += xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
                reported += outs
                    .iter()
                    .map(|o| o.film.variance_of_mean(i)[c])
                    .sum::<f64>()
                    / seeds as f64;
            }
        }
        let ratio = reported / measured;
        assert!(
            (ratio - 1.0).abs() < 0.1,
            "{config}: reported variance / variance across seeds = {ratio:.3}"
        );
    }
}

/// The image's standard error is the spread of the image average across seeds, for the
/// integrators whose pixels are correlated (a light path splats into many; one photon map serves
/// all), and for Sobol' samples in replicates, where it is the spread of the replicates' image
/// averages: the variances agree within 30 %. 384 seeds, one image average each: the measured
/// variance's relative standard deviation is 7 % (over four seed sets the ratios were 0.85–1.13),
/// so 30 % is 4σ (false-failure rate below 1e-4 per integrator).
#[test]
fn image_standard_error_matches_the_spread_across_seeds() {
    let sc = lower_box((10, 8));
    for (config, spp) in [
        ("Light(max_bounces: 3)", 8),
        ("Bdpt(max_bounces: 3)", 4),
        (
            "PhotonMap(max_bounces: 3, photons: 500, caustic_photons: 100, gather: Nearest(k: 20, max_radius: Relative(0.3)), indirect: Direct, direct: false)",
            4,
        ),
        ("Path(max_bounces: 3, sampler: Sobol, replicates: 4)", 8),
    ] {
        let seeds = 384;
        let outs: Vec<RenderOutput> = (0..seeds)
            .map(|s| render(&sc, config, spp, 5000 + s))
            .collect();
        let (mut reported, mut measured) = (0.0f64, 0.0f64);
        for c in 0..3 {
            let xs: Vec<f64> = outs.iter().map(|o| o.film.average()[c]).collect();
            let m = xs.iter().sum::<f64>() / seeds as f64;
            measured += xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
            reported += outs
                .iter()
                .map(|o| o.film.image_se.expect("independent passes")[c].powi(2))
                .sum::<f64>()
                / seeds as f64;
        }
        let ratio = reported / measured;
        assert!(
            (ratio - 1.0).abs() < 0.3,
            "{config}: reported image variance / variance across seeds = {ratio:.3}"
        );
    }
}

/// A time budget is the estimator of the sample budget it reaches: the image is bit for bit that
/// of `Budget::Samples(N)` for the N the clock allowed, for every non-progressive integrator and
/// for the progressive samplers (which continue their sequence instead of restarting it).
#[test]
fn time_budget_renders_the_sample_budget_it_reaches() {
    let sc = scene(&cornell(1.0, [0.0; 3], (12, 10)));
    for config in [
        "Path(max_bounces: 3)",
        "Path(max_bounces: 3, sampler: Sobol)",
        "Path(max_bounces: 3, sampler: Halton)",
        "Light(max_bounces: 3)",
        "Bdpt(max_bounces: 3, sampler: Sobol)",
        "PhotonMap(max_bounces: 3, photons: 2000, caustic_photons: 100)",
        "Path(max_bounces: 3, sampler: Sobol, replicates: 8)",
        "Vcm(max_bounces: 3, variant: Vc, sampler: Sobol, replicates: 4)",
    ] {
        let integrator = IntegratorConfig::from_ron(config).unwrap().build().unwrap();
        let timed = integrator.render(&sc, &Budget::Seconds(0.15), 3, &NoProgress);
        let n = timed.stats.spp;
        assert!(n >= 2, "{config}: only {n} samples in 0.15 s");
        assert_eq!(n % integrator.replicates(), 0, "{config}: {n} samples");
        let counted = integrator.render(&sc, &Budget::Samples(n), 3, &NoProgress);
        assert_eq!(counted.stats.spp, n);
        assert!(
            timed.film.pixels == counted.film.pixels,
            "{config}: the 0.15 s render ({n} spp) differs from the {n}-spp render"
        );
    }
}

/// With a sampler that must know its sample count (stratified), a time budget is met by a
/// calibrated pilot and one render of the count that fills the rest: the result is exactly the
/// render of that count, the pilot's time is reported and within the budget. In replicates, the
/// count is a multiple of them.
#[test]
fn time_budget_with_a_stratified_sampler_calibrates_then_renders_one_count() {
    let sc = scene(&cornell(1.0, [0.0; 3], (12, 10)));
    for config in [
        "Path(max_bounces: 3, sampler: Stratified)",
        "Path(max_bounces: 3, sampler: Stratified, replicates: 3)",
    ] {
        let integrator = IntegratorConfig::from_ron(config).unwrap().build().unwrap();
        let timed = integrator.render(&sc, &Budget::Seconds(0.3), 3, &NoProgress);
        let n = timed.stats.spp;
        assert!(n >= 4, "{config}: {n} samples");
        assert_eq!(n % integrator.replicates(), 0, "{config}: {n} samples");
        assert!(
            timed.stats.pilot_seconds > 0.0 && timed.stats.pilot_seconds < 0.1,
            "{config}: pilot {} s",
            timed.stats.pilot_seconds
        );
        let counted = integrator.render(&sc, &Budget::Samples(n), 3, &NoProgress);
        assert!(timed.film.pixels == counted.film.pixels, "{config}");
    }
}

/// MSE of `config`'s renders of `sc` against `reference` (pixel means), averaged over six seeds,
/// and the mean samples per pixel they reached.
fn mse(
    sc: &lightlab_scene::Scene,
    config: &str,
    budget: Budget,
    reference: &RenderOutput,
) -> (f64, f64) {
    let integrator = IntegratorConfig::from_ron(config).unwrap().build().unwrap();
    let seeds = 6;
    let (mut total, mut spp) = (0.0, 0.0);
    for s in 0..seeds {
        let out = integrator.render(sc, &budget, 40 + s, &NoProgress);
        let n = out.film.pixel_count();
        total += (0..n)
            .map(|i| {
                let (a, b) = (out.film.mean(i), reference.film.mean(i));
                (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>()
            })
            .sum::<f64>()
            / (3 * n) as f64;
        spp += out.stats.spp as f64;
    }
    (total / seeds as f64, spp / seeds as f64)
}

/// The equal-time comparison of samplers measures the samplers: on the Cornell box's direct
/// lighting Sobol' beats independent sampling at equal time by far more than 2× (that a time
/// budget is exactly the render of the sample count it reaches is tested above). Before, a time
/// budget averaged one-sample renders and Sobol' fell back to independent sampling: a ratio of
/// about 1. Reference: 4096 independent samples, whose noise is below 2 % of either MSE; six
/// seeds per estimate. The seeds are fixed, so only the sample counts the clock allows vary:
/// over 12 runs beside two other processes the timed renders reached 209–383 spp and Sobol' was
/// 9.8–17× better (12–29× at the independent renders' count); failing needs a 5× drop. The window
/// once asserted between equal-time and equal-sample ratios ([0.5, 2]) was not kept: the ratio
/// came to 0.50 in those runs (at a count Sobol' favours, 209, against the timed renders' own).
#[test]
fn sobol_keeps_its_advantage_at_equal_time() {
    let sc = scene(&cornell(1.0, [0.0; 3], (16, 16)));
    let reference = render(&sc, "Path(max_bounces: 1)", 4096, 1);
    let independent = "Path(max_bounces: 1)";
    let sobol = "Path(max_bounces: 1, sampler: Sobol)";
    let (independent_timed, reached) = mse(&sc, independent, Budget::Seconds(0.05), &reference);
    let (sobol_timed, _) = mse(&sc, sobol, Budget::Seconds(0.05), &reference);
    let at_time = independent_timed / sobol_timed;
    assert!(
        at_time > 2.0,
        "Sobol' is only {at_time:.2}× better at equal time (independent: {reached:.0} spp)"
    );
}

/// Two environment lights of radiance 0.5 light a scene exactly as one of radiance 1 does, for
/// every integrator (they are merged when the scene is built; before, BDPT saw only the first
/// from escaped camera rays and the path tracer's MIS weights used their summed density against
/// one light's sample).
#[test]
fn two_environments_render_as_their_sum() {
    let text = |lights: &str| {
        format!(
            "Scene(camera: Camera(eye: (0, 3, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8)),
                materials: {{ \"plane\": Diffuse(albedo: (0.6, 0.5, 0.4)), \"glass\": Dielectric(ior: 1.5) }},
                shapes: [ Shape(geometry: Quad(corner: (-5, 0, -5), edge1: (0, 0, 10), edge2: (10, 0, 0)), material: \"plane\"),
                          Shape(geometry: Sphere(center: (0, 0.6, 0), radius: 0.5), material: \"glass\") ],
                lights: [ {lights}, Point(position: (1, 2, 0), intensity: (3, 3, 3)) ])"
        )
    };
    let one = scene(&text("Environment(radiance: (1, 1, 1))"));
    let two = scene(&text(
        "Environment(radiance: (0.5, 0.5, 0.5)), Environment(radiance: (0.5, 0.5, 0.5))",
    ));
    for config in [
        "Path(max_bounces: 4)",
        "Light(max_bounces: 4)",
        "Bdpt(max_bounces: 4)",
        "PhotonMap(max_bounces: 4, photons: 2000, caustic_photons: 2000)",
        "Sppm(max_bounces: 4, photons_per_pass: 2000)",
        "Ppm(max_bounces: 4, photons_per_pass: 2000)",
        "Vcm(max_bounces: 4, radius: Relative(0.05))",
    ] {
        let (a, b) = (render(&one, config, 4, 2), render(&two, config, 4, 2));
        assert!(
            a.film.pixels == b.film.pixels,
            "{config}: two environments of 0.5 differ from one of 1"
        );
    }
}

/// One sample per pixel gives no variance (the film writes 0 where s²/n needs two samples), and
/// the statistics say so instead of labelling the zeros an estimate of the variance of the mean.
#[test]
fn one_sample_per_pixel_is_not_a_variance_estimate() {
    let sc = lower_box((8, 8));
    for config in ["Path()", "Light()", "Bdpt()"] {
        let one = render(&sc, config, 1, 3);
        assert!(
            matches!(&one.stats.pixel_variance, PixelVariance::NotAnEstimate(why) if why.contains("one sample")),
            "{config}: {:?}",
            one.stats.pixel_variance
        );
        let two = render(&sc, config, 2, 3);
        assert_eq!(
            two.stats.pixel_variance,
            PixelVariance::Independent,
            "{config}"
        );
    }
}
