//! The experiment runner end to end on a tiny scene: resuming after an interruption gives the same
//! results as an uninterrupted run, shards merged equal the unsharded run, and references are
//! cached by exactly what produced them.

use lightlab_core::NoProgress;
use lightlab_experiments::reference::{cache_path, load_image};
use lightlab_experiments::report::{finished_runs, plot_from_csv, write_report};
use lightlab_experiments::runner::{RunOptions, RunRecord, merge, run_experiment};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

const SCENE: &str = r#"Scene(
    camera: Camera(eye: (0, 0, 0), target: (0, 0, -1), fov: 60, resolution: (8, 6)),
    materials: { "wall": Diffuse(albedo: (0.5, 0.5, 0.5)) },
    shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: "wall",
                    emission: (radiance: (1, 1, 1), two_sided: true)) ])"#;

const EXPERIMENT: &str = r#"Experiment(
    name: "tiny",
    scenes: ["furnace.ron"],
    reference: Render(integrator: "Path(max_bounces: 3)", spp: 64),
    methods: [
        (label: "mis", integrator: "Path", settings: {"max_bounces": 3}),
        (label: "bsdf", integrator: "Path", settings: {"max_bounces": 3, "strategy": "BsdfOnly"}),
    ],
    sweep: [Values(field: "spp", values: [1, 2, 4])],
    trials: 2,
    seed: 9,
)"#;

fn setup(name: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("lightlab-runner-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("furnace.ron"), SCENE).unwrap();
    std::fs::write(dir.join("tiny.ron"), EXPERIMENT).unwrap();
    (dir.join("tiny.ron"), dir)
}

fn run(
    experiment: &Path,
    results: &Path,
    shard: Option<(u32, u32)>,
) -> (usize, usize, Vec<String>) {
    let log = RefCell::new(Vec::new());
    let options = RunOptions {
        shard,
        ..RunOptions::new(results.to_path_buf())
    };
    let o = run_experiment(
        experiment,
        &options,
        &NoProgress,
        &NoProgress,
        &|m: &str| log.borrow_mut().push(m.to_string()),
    )
    .unwrap();
    (o.ran, o.skipped, log.into_inner())
}

/// What must not depend on how the sweep was run: everything but timings, and the images' bits.
fn comparable(out_dir: &Path) -> Vec<(RunRecord, Vec<[u32; 3]>)> {
    finished_runs(out_dir)
        .unwrap()
        .into_iter()
        .map(|mut r| {
            let image = load_image(&out_dir.join("runs").join(&r.id).join("image.exr")).unwrap();
            r.wall_seconds = 0.0;
            r.reference = PathBuf::new();
            (r, image.mean.iter().map(|p| p.map(f32::to_bits)).collect())
        })
        .collect()
}

#[test]
fn interrupted_sweep_resumes_to_the_same_results() {
    let (exp, dir) = setup("resume");
    let results = dir.join("results");
    let (ran, skipped, log) = run(&exp, &results, None);
    assert_eq!((ran, skipped), (12, 0));
    assert!(log.iter().any(|l| l.contains("rendered:")), "{log:?}");
    let out = results.join("tiny");
    let full = comparable(&out);
    assert_eq!(full.len(), 12);
    for f in [
        "runs.csv",
        "summary.json",
        "furnace-mse-vs-spp.svg",
        "furnace-mse-vs-time.svg",
        "furnace-efficiency.svg",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // One mean image per setting (2 methods × 3 sample counts).
    assert_eq!(std::fs::read_dir(out.join("images")).unwrap().count(), 6);

    // Interrupt: five runs lose their metrics.json (a kill before the last write), one of them
    // also its image, and temporary files are left behind: one by a kill two hours ago, one
    // that may be another process's write in progress.
    let runs: Vec<PathBuf> = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let (stale, recent) = (
        runs[0].join(".metrics.json.tmp1"),
        runs[1].join(".image.exr.tmp2"),
    );
    for (k, r) in runs.iter().take(5).enumerate() {
        std::fs::remove_file(r.join("metrics.json")).unwrap();
        if k == 0 {
            std::fs::remove_file(r.join("image.exr")).unwrap();
            let f = std::fs::File::create(&stale).unwrap();
            f.set_modified(SystemTime::now() - Duration::from_secs(7200))
                .unwrap();
            std::fs::write(&recent, "half").unwrap();
        }
    }
    let (ran, skipped, log) = run(&exp, &results, None);
    assert_eq!((ran, skipped), (5, 7));
    assert!(!stale.exists() && recent.exists());
    assert!(
        log.iter()
            .any(|l| l.starts_with("removed 1 temporary file that")),
        "{log:?}"
    );
    std::fs::remove_file(&recent).unwrap();
    assert!(
        log.iter().any(|l| l.contains("cached:")),
        "the reference must come from the cache: {log:?}"
    );
    assert_eq!(comparable(&out), full);

    // Nothing left to do.
    assert_eq!(run(&exp, &results, None).0, 0);
    // `lightlab plot` redraws from runs.csv alone.
    std::fs::remove_file(out.join("furnace-efficiency.svg")).unwrap();
    assert_eq!(plot_from_csv(&out).unwrap().len(), 3);
    assert!(out.join("furnace-efficiency.svg").is_file());
    // A runs.csv with no runs in it is an error, not "0 plots".
    std::fs::write(out.join("runs.csv"), "not,an,experiment\n").unwrap();
    let e = plot_from_csv(&out).unwrap_err().to_string();
    assert!(e.contains("no runs in it"), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn merged_shards_equal_the_unsharded_run() {
    let (exp, dir) = setup("shards");
    run(&exp, &dir.join("all"), None);
    let whole = comparable(&dir.join("all/tiny"));
    let (a, _, _) = run(&exp, &dir.join("shard1"), Some((0, 2)));
    let (b, _, _) = run(&exp, &dir.join("shard2"), Some((1, 2)));
    assert_eq!((a, b), (6, 6));
    let merged = dir.join("merged/tiny");
    let m = merge(
        &exp,
        &merged,
        &[dir.join("shard1/tiny"), dir.join("shard2/tiny")],
        false,
    )
    .unwrap();
    assert_eq!((m.copied, m.duplicated, m.missing.len()), (12, 0, 0));
    assert_eq!(comparable(&merged), whole);
    let csv = |p: &Path| {
        std::fs::read_to_string(p.join("runs.csv"))
            .unwrap()
            .lines()
            .count()
    };
    assert_eq!(csv(&merged), csv(&dir.join("all/tiny")));
    // The merge rebuilds the report, which shows the experiment file.
    let page = std::fs::read_to_string(merged.join("index.html")).unwrap();
    assert!(page.contains("\"runs\":12") && page.contains("name: \\\"tiny\\\""));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn reference_cache_key_changes_with_exactly_what_produced_it() {
    let dir = Path::new("refs");
    let base = cache_path(dir, "s", "scene text", (8, 6), "Path()", 64);
    assert_eq!(
        base,
        cache_path(dir, "s", "scene text", (8, 6), "Path()", 64)
    );
    for other in [
        cache_path(dir, "s", "scene text ", (8, 6), "Path()", 64),
        cache_path(dir, "s", "scene text", (8, 7), "Path()", 64),
        cache_path(dir, "s", "scene text", (8, 6), "Path(max_bounces: 2)", 64),
        cache_path(dir, "s", "scene text", (8, 6), "Path()", 65),
    ] {
        assert_ne!(base, other);
    }
}

/// The scene text the reference cache hashes includes the contents of the files the scene reads:
/// editing a mesh file changes it, rewriting the same bytes does not.
#[test]
fn scene_text_changes_with_the_files_the_scene_reads() {
    let dir = std::env::temp_dir().join(format!("lightlab-inputs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("mesh.ron");
    std::fs::write(
        &scene,
        r#"Scene(camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (4, 4)),
               materials: { "m": Diffuse(albedo: (0.5, 0.5, 0.5)) },
               shapes: [ Shape(geometry: Obj(file: "tri.obj"), material: "m",
                               emission: (radiance: (1, 1, 1), two_sided: true)) ])"#,
    )
    .unwrap();
    let obj = |z: f32| format!("v 0 0 {z}\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let text = || {
        lightlab_experiments::runner::load_scene(&scene, None)
            .unwrap()
            .1
    };
    std::fs::write(dir.join("tri.obj"), obj(0.0)).unwrap();
    let first = text();
    assert!(first.contains("input:tri.obj:"), "{first}");
    std::fs::write(dir.join("tri.obj"), obj(0.0)).unwrap();
    assert_eq!(text(), first);
    std::fs::write(dir.join("tri.obj"), obj(0.1)).unwrap();
    assert_ne!(text(), first);
    std::fs::remove_dir_all(dir).unwrap();
}

/// An equal-time budget runs a progressive integrator as one render, pass after pass, until the
/// time is up (merging independent one-pass renders would never shrink SPPM's radius), ending
/// within half a pass of the budget.
#[test]
fn time_budget_runs_progressive_photon_mapping_pass_after_pass() {
    use lightlab_integrators::{Budget, IntegratorConfig};
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/cornell-box.ron"
    ))
    .unwrap();
    let mut scene = lightlab_scene::parse_scene(&text, Path::new("cornell-box.ron")).unwrap();
    scene.camera = scene.camera.with_resolution(16, 16);
    let sppm = IntegratorConfig::from_ron("Sppm(photons_per_pass: 2000)")
        .unwrap()
        .build()
        .unwrap();
    let out = sppm.render(&scene, &Budget::Seconds(0.3), 1, &NoProgress);
    assert!(out.stats.spp > 3, "passes: {}", out.stats.spp);
    assert_eq!(out.stats.photons, 2000 * out.stats.spp as u64);
    let per_pass = out.stats.wall_seconds / out.stats.spp as f64;
    assert!(
        (out.stats.wall_seconds - 0.3).abs() <= 0.5 * per_pass + 0.05,
        "{} s in {} passes",
        out.stats.wall_seconds,
        out.stats.spp
    );
    assert_eq!(out.film.pixels[0].count, out.stats.spp as u64);
}

/// Path classes in an experiment: every run and the reference are split into the class layers,
/// each class gets its own metrics (rows `mse[LDE]`, `mse[rest]` in runs.csv, per-class entries in
/// summary.json) and plots, and the class MSEs reflect where the error is: a method limited to
/// direct light (`max_bounces: 1`) has its error in `rest`, not in `LDE`.
#[test]
fn classes_get_their_own_metrics_and_plots() {
    let (experiment, dir) = setup("classes");
    let text = EXPERIMENT
        .replace("name: \"tiny\"", "name: \"classes\"")
        .replace(
            r#"(label: "bsdf", integrator: "Path", settings: {"max_bounces": 3, "strategy": "BsdfOnly"}),"#,
            r#"(label: "direct only", integrator: "Path", settings: {"max_bounces": 1}),"#,
        )
        .replace("seed: 9,", "seed: 9,\n    classes: [\"LDE\"],");
    std::fs::write(&experiment, text).unwrap();
    let results = dir.join("results");
    run(&experiment, &results, None);
    let out = results.join("classes");
    let records = finished_runs(&out).unwrap();
    assert!(!records.is_empty());
    for r in &records {
        let names: Vec<&str> = r.class_errors.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["LDE", "rest"]);
        let (lde, rest) = (r.class_errors[0].1.mse, r.class_errors[1].1.mse);
        if r.method == "direct only" {
            // The missing 2–3 bounce light is the whole `rest` layer, and it dominates the error.
            assert!(rest > 10.0 * lde.abs(), "{}: LDE {lde}, rest {rest}", r.id);
        }
    }
    let csv = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert!(csv.contains("mse[LDE]") && csv.contains("mse[rest]"));
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"class\": \"LDE\""));
    // The reference (independent samples) has a variance: every setting and class gets the
    // standard error its noise adds.
    let summary: serde_json::Value = serde_json::from_str(&summary).unwrap();
    for s in summary["settings"].as_array().unwrap() {
        let positive = |v: &serde_json::Value| v["mse"].as_f64().unwrap() > 0.0;
        assert!(positive(&s["reference_se"]), "{}", s["reference_se"]);
        for c in s["classes"].as_array().unwrap() {
            assert!(
                positive(&c["reference_se"]),
                "{}: {}",
                c["class"],
                c["reference_se"]
            );
        }
    }
    for plot in ["furnace-mse-vs-spp-LDE.svg", "furnace-mse-vs-time-rest.svg"] {
        assert!(out.join(plot).is_file(), "{plot} missing");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// A reference rendered with a correlated sampler has no variance estimate: nothing is subtracted
/// from the errors (reference_variance 0 in every run) and the run says why.
#[test]
fn correlated_reference_variance_is_not_subtracted() {
    let (exp, dir) = setup("sobol-reference");
    let text = EXPERIMENT
        .replace("name: \"tiny\"", "name: \"sobolref\"")
        .replace(
            r#"reference: Render(integrator: "Path(max_bounces: 3)", spp: 64)"#,
            r#"reference: Render(integrator: "Path(max_bounces: 3, sampler: Sobol)", spp: 64)"#,
        );
    std::fs::write(&exp, text).unwrap();
    let options = RunOptions::new(dir.join("results"));
    let o = run_experiment(&exp, &options, &NoProgress, &NoProgress, &|_| {}).unwrap();
    assert!(
        o.warnings
            .iter()
            .any(|w| w.contains("not subtracted") && w.contains("Sobol")),
        "{:?}",
        o.warnings
    );
    for r in finished_runs(&o.out_dir).unwrap() {
        assert_eq!(r.errors.reference_variance, 0.0, "{}", r.id);
    }
    // Nor a reference standard error.
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(o.out_dir.join("summary.json")).unwrap()).unwrap();
    for s in summary["settings"].as_array().unwrap() {
        assert!(s["reference_se"].is_null(), "{}", s["reference_se"]);
    }
    // The summary's bias² and variance are measured against the reference as the runs were:
    // bias² + variance is the mean MSE (the report once reloaded the cached reference with its
    // variance, and bias² came out negative).
    assert_bias_and_variance_sum_to_mse(&o.out_dir);
    // Moved elsewhere, with the cache gone, the results rebuild to the same summary (they keep
    // the reference they were measured against); without a run's image nothing is rewritten.
    let summary = std::fs::read(o.out_dir.join("summary.json")).unwrap();
    let moved = dir.join("moved");
    std::fs::rename(&o.out_dir, &moved).unwrap();
    std::fs::remove_dir_all(dir.join("results")).unwrap();
    write_report(&moved).unwrap();
    assert!(std::fs::read(moved.join("summary.json")).unwrap() == summary);
    let run = finished_runs(&moved).unwrap().remove(0);
    std::fs::remove_file(moved.join("runs").join(&run.id).join("image.exr")).unwrap();
    let err = write_report(&moved).unwrap_err().to_string();
    assert!(
        err.contains("image.exr") && err.contains("not rewritten"),
        "{err}"
    );
    assert!(std::fs::read(moved.join("summary.json")).unwrap() == summary);
    // With an independent reference it is subtracted.
    let (exp, dir2) = setup("independent-reference");
    let o = run_experiment(
        &exp,
        &RunOptions::new(dir2.join("results")),
        &NoProgress,
        &NoProgress,
        &|_| {},
    )
    .unwrap();
    assert!(
        finished_runs(&o.out_dir)
            .unwrap()
            .iter()
            .all(|r| r.errors.reference_variance > 0.0)
    );
    assert_bias_and_variance_sum_to_mse(&o.out_dir);
    // So it is for Sobol' samples in independent replicates, whose spread estimates it.
    let (exp, dir3) = setup("replicated-reference");
    let text = EXPERIMENT.replace(
        r#"reference: Render(integrator: "Path(max_bounces: 3)", spp: 64)"#,
        r#"reference: Render(integrator: "Path(max_bounces: 3, sampler: Sobol, replicates: 4)", spp: 64)"#,
    );
    std::fs::write(&exp, text).unwrap();
    let o = run_experiment(
        &exp,
        &RunOptions::new(dir3.join("results")),
        &NoProgress,
        &NoProgress,
        &|_| {},
    )
    .unwrap();
    assert!(
        !o.warnings.iter().any(|w| w.contains("not subtracted")),
        "{:?}",
        o.warnings
    );
    assert!(
        finished_runs(&o.out_dir)
            .unwrap()
            .iter()
            .all(|r| r.errors.reference_variance > 0.0)
    );
    std::fs::remove_dir_all(dir).unwrap();
    std::fs::remove_dir_all(dir2).unwrap();
    std::fs::remove_dir_all(dir3).unwrap();
}

/// A swept sample count that the method's replicates do not divide is refused before any run,
/// with the file, line and column of the method.
#[test]
fn sample_counts_the_replicates_do_not_divide_are_refused_before_any_run() {
    let (exp, dir) = setup("replicates-budget");
    let text = EXPERIMENT.replace(
        r#"settings: {"max_bounces": 3, "strategy": "BsdfOnly"}"#,
        r#"settings: {"max_bounces": 3, "sampler": "Sobol", "replicates": 2}"#,
    );
    std::fs::write(&exp, text).unwrap();
    let options = RunOptions::new(dir.join("results"));
    let Err(err) = run_experiment(&exp, &options, &NoProgress, &NoProgress, &|_| {}) else {
        panic!("the experiment ran");
    };
    let err = err.to_string();
    assert!(
        err.contains("tiny.ron:7:")
            && err.contains("\"bsdf\"")
            && err.contains("1 samples per pixel cannot be split into 2 equal replicates"),
        "{err}"
    );
    assert!(!dir.join("results").join("tiny").join("runs").exists());
    std::fs::remove_dir_all(dir).unwrap();
}

/// bias² + variance = mean MSE over each setting's trials, to rounding (both subtract the same
/// reference variance; see `metrics::bias_variance`).
fn assert_bias_and_variance_sum_to_mse(out_dir: &Path) {
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("summary.json")).unwrap())
            .unwrap();
    let records = finished_runs(out_dir).unwrap();
    for s in summary["settings"].as_array().unwrap() {
        let mses: Vec<f64> = records
            .iter()
            .filter(|r| r.method == s["method"] && r.setting == s["setting"])
            .map(|r| r.errors.mse)
            .collect();
        let mse = mses.iter().sum::<f64>() / mses.len() as f64;
        let sum = s["bias2"].as_f64().unwrap() + s["variance"].as_f64().unwrap();
        assert!(
            (sum - mse).abs() <= 1e-9 * mse.abs(),
            "{} {}: bias² + variance = {sum}, mean MSE {mse}",
            s["method"],
            s["setting"]
        );
    }
}

/// summary.json: efficiency is 1/(mean MSE × mean time) of the setting's trials (not the mean of
/// the per-trial ratios), relative efficiency likewise with relMSE, each with a standard error and
/// whether the error is significant; every convergence fit lists the points it left out.
#[test]
fn summary_efficiency_is_a_ratio_of_means() {
    let (exp, dir) = setup("efficiency");
    run(&exp, &dir.join("results"), None);
    let out = dir.join("results/tiny");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let records = finished_runs(&out).unwrap();
    for s in summary["settings"].as_array().unwrap() {
        let trials: Vec<&RunRecord> = records
            .iter()
            .filter(|r| r.method == s["method"] && r.setting == s["setting"])
            .collect();
        let mean = |f: &dyn Fn(&RunRecord) -> f64| {
            trials.iter().map(|r| f(r)).sum::<f64>() / trials.len() as f64
        };
        let (mse, time) = (mean(&|r| r.errors.mse), mean(&|r| r.wall_seconds));
        let e = &s["efficiency"];
        if mse > 0.0 {
            let want = 1.0 / (mse * time);
            let got = e["value"].as_f64().unwrap();
            assert!((got / want - 1.0).abs() < 1e-9, "{s}");
            assert!(e["se"].as_f64().unwrap() >= 0.0);
        } else {
            assert!(e["value"].is_null(), "{s}");
        }
        assert!(e["error_significant"].is_boolean());
        assert!(s["rel_efficiency"]["error_significant"].is_boolean());
    }
    let fitted = |summary: &serde_json::Value| -> Vec<usize> {
        summary["convergence"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| {
                f["fit"]["points"].as_u64().unwrap() as usize
                    + f["fit"]["excluded"].as_array().unwrap().len()
            })
            .collect()
    };
    assert_eq!(fitted(&summary), [3, 3], "spp 1, 2 and 4");
    // `fit_from: 2`, added to the experiment and run again (nothing renders), fits spp 2 and 4.
    let text = std::fs::read_to_string(&exp).unwrap();
    std::fs::write(&exp, text.replace("seed: 9,", "seed: 9,\n    fit_from: 2,")).unwrap();
    run(&exp, &dir.join("results"), None);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(fitted(&summary), [2, 2], "spp 2 and 4");
    std::fs::remove_dir_all(dir).unwrap();
}

/// References from other renderers: a single-part EXR with plain R, G, B channels (as Mitsuba 3
/// and pbrt-v4 write them) with its variance in a separate file, and a single-part file whose
/// layers are channel prefixes (`radiance.R`, `variance.R`), give the same image and variance;
/// pbrt-v4's per-sample `Variance` layer is not taken for the variance of the mean.
#[test]
fn foreign_exr_references_load() {
    use exr::prelude::*;
    use lightlab_experiments::reference::load_foreign;
    let dir = std::env::temp_dir().join(format!("lightlab-foreign-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (5usize, 3usize);
    let value = |x: usize, y: usize| (x as f32 * 0.1, y as f32, 2.0);
    let var = |x: usize, y: usize| (1e-4 * x as f32, 1e-4, 1e-4 * y as f32);
    write_rgb_file(dir.join("plain.exr"), w, h, value).unwrap();
    write_rgb_file(dir.join("var.exr"), w, h, var).unwrap();
    let plain = load_foreign(&dir.join("plain.exr"), None, Some(&dir.join("var.exr"))).unwrap();
    assert_eq!((plain.width, plain.height), (5, 3));
    assert_eq!(plain.mean[7], [0.2, 1.0, 2.0]);
    assert_eq!(plain.variance.as_ref().unwrap()[7], [2e-4, 1e-4, 1e-4]);

    let channel = |name: &str, f: &dyn Fn(usize, usize) -> f32| {
        AnyChannel::new(
            name,
            FlatSamples::F32((0..w * h).map(|i| f(i % w, i / w)).collect()),
        )
    };
    // One part: the image's channels named `{image}R` …, its variance's `{variance}R` …, and A.
    let write = |file: &str, image: &str, variance: &str| {
        let layer = Layer::new(
            Vec2(w, h),
            LayerAttributes::default(),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(smallvec::smallvec![
                channel(&format!("{image}R"), &|x, y| value(x, y).0),
                channel(&format!("{image}G"), &|x, y| value(x, y).1),
                channel(&format!("{image}B"), &|x, y| value(x, y).2),
                channel(&format!("{variance}R"), &|x, y| var(x, y).0),
                channel(&format!("{variance}G"), &|x, y| var(x, y).1),
                channel(&format!("{variance}B"), &|x, y| var(x, y).2),
                channel("A", &|_, _| 1.0),
            ]),
        );
        Image::from_layer(layer)
            .write()
            .to_file(dir.join(file))
            .unwrap();
    };
    write("prefixed.exr", "radiance.", "variance.");
    let prefixed = load_foreign(&dir.join("prefixed.exr"), None, None).unwrap();
    assert_eq!(prefixed, plain);
    // A path-class layer comes with its own variance, `LDE.variance`, which a z-test of the layer
    // must use (the image's `variance` made it far too lenient); a variance layer has none.
    let quarter = |x: usize, y: usize| (0.25 * value(x, y).0, value(x, y).1, value(x, y).2);
    let layer = Layer::new(
        Vec2(w, h),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(smallvec::smallvec![
            channel("radiance.R", &|x, y| value(x, y).0),
            channel("radiance.G", &|x, y| value(x, y).1),
            channel("radiance.B", &|x, y| value(x, y).2),
            channel("variance.R", &|x, y| var(x, y).0),
            channel("variance.G", &|x, y| var(x, y).1),
            channel("variance.B", &|x, y| var(x, y).2),
            channel("LDE.R", &|x, y| quarter(x, y).0),
            channel("LDE.G", &|x, y| quarter(x, y).1),
            channel("LDE.B", &|x, y| quarter(x, y).2),
            channel("LDE.variance.R", &|x, y| 0.5 * var(x, y).0),
            channel("LDE.variance.G", &|x, y| 0.5 * var(x, y).1),
            channel("LDE.variance.B", &|x, y| 0.5 * var(x, y).2),
        ]),
    );
    Image::from_layer(layer)
        .write()
        .to_file(dir.join("layers.exr"))
        .unwrap();
    let lde = load_foreign(&dir.join("layers.exr"), Some("LDE"), None).unwrap();
    assert_eq!(lde.mean[7], [0.05, 1.0, 2.0]);
    assert_eq!(lde.variance.as_ref().unwrap()[7], [1e-4, 5e-5, 5e-5]);
    let image = load_foreign(&dir.join("layers.exr"), None, None).unwrap();
    assert_eq!(image, plain);
    let variance = load_foreign(&dir.join("layers.exr"), Some("LDE.variance"), None).unwrap();
    assert_eq!(variance.variance, None);
    // A file with several unnamed candidates and no `radiance` says which layers it has.
    let e = load_foreign(&dir.join("prefixed.exr"), Some("beauty"), None).unwrap_err();
    assert!(e.contains("\"radiance\"") && e.contains("beauty"), "{e}");
    // pbrt-v4's `Variance` layer is the variance of one sample, not of the mean: not read as one.
    write("pbrt.exr", "", "Variance.");
    let pbrt = load_foreign(&dir.join("pbrt.exr"), None, None).unwrap();
    assert_eq!(pbrt.mean, plain.mean);
    assert_eq!(pbrt.variance, None);
    std::fs::remove_dir_all(dir).unwrap();
}

/// A radiosity sweep records each run's patches, iterations and residual in runs.csv, and every
/// numeric setting an axis sweeps (here `max_bounces` and `patches`) gets an MSE plot against it.
#[test]
fn radiosity_runs_record_their_solve_and_plot_error_against_each_swept_setting() {
    let (_, dir) = setup("radiosity");
    let exp = dir.join("radiosity.ron");
    std::fs::write(
        &exp,
        r#"Experiment(
            name: "rad",
            scenes: ["furnace.ron"],
            reference: Render(integrator: "Path(max_bounces: 3)", spp: 64),
            methods: [(label: "jacobi", integrator: "Radiosity", settings: {"rays": 16})],
            sweep: [
                Values(field: "max_bounces", values: [0, 1, 2, 3]),
                Values(field: "patches", values: [20, 80]),
                Values(field: "sampler", values: ["Sobol"]),
            ],
            budget: Samples(2),
            trials: 2,
            seed: 3,
        )"#,
    )
    .unwrap();
    let results = dir.join("results");
    let (ran, _, _) = run(&exp, &results, None);
    assert_eq!(ran, 16);
    let out = results.join("rad");
    let csv = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    for metric in [
        ",patches,",
        ",iterations,",
        ",residual,",
        ",form_factor_rays,",
    ] {
        assert!(csv.contains(metric), "runs.csv lacks {metric}");
    }
    // Jacobi's iterations are the bounces asked for.
    let mut reader = csv::Reader::from_reader(csv.as_bytes());
    let mut checked = 0;
    for row in reader.records() {
        let row = row.unwrap();
        if &row[6] == "iterations" {
            let bounces = row[3]
                .split(", ")
                .next()
                .unwrap()
                .strip_prefix("max_bounces=");
            assert_eq!(bounces, Some(row[7].trim_end_matches(".0")), "{row:?}");
            checked += 1;
        }
    }
    assert_eq!(checked, 16);
    for plot in [
        "furnace-mse-vs-max_bounces.svg",
        "furnace-mse-vs-patches.svg",
    ] {
        let svg = std::fs::read_to_string(out.join(plot)).unwrap_or_else(|_| panic!("{plot}"));
        assert!(svg.contains("jacobi"), "{plot} has no series");
    }
    assert!(
        !out.join("furnace-mse-vs-sampler.svg").exists(),
        "non-numeric axis plotted"
    );
}

/// A reference with a NaN pixel, or with a negative variance, is refused before any run, naming
/// the file, how many pixels and the first of them; no run is recorded, so a corrected reference
/// is measured from scratch (a NaN error once made every statistic NaN, and resuming kept it).
#[test]
fn non_finite_references_are_refused_before_any_run() {
    use exr::prelude::write_rgb_file;
    let (experiment, dir) = setup("nanref");
    let (w, h) = (8usize, 6usize);
    let text = EXPERIMENT.replace(
        r#"Render(integrator: "Path(max_bounces: 3)", spp: 64)"#,
        r#"Exr(path: "ref.exr", variance: Some("var.exr"))"#,
    );
    std::fs::write(&experiment, text).unwrap();
    let results = dir.join("results");
    let attempt = |value: f32, variance: f32| {
        write_rgb_file(dir.join("ref.exr"), w, h, |x, y| {
            let v = if (x, y) == (3, 2) { value } else { 1.0 };
            (v, 1.0, 1.0)
        })
        .unwrap();
        write_rgb_file(dir.join("var.exr"), w, h, |x, y| {
            let v = if (x, y) == (5, 1) { variance } else { 1e-6 };
            (1e-6, v, 1e-6)
        })
        .unwrap();
        run_experiment(
            &experiment,
            &RunOptions::new(results.clone()),
            &NoProgress,
            &NoProgress,
            &|_: &str| {},
        )
    };
    let e = attempt(f32::NAN, 1e-6).map(|o| o.ran).unwrap_err();
    assert!(
        e.contains("ref.exr") && e.contains("1 pixels are NaN or infinite") && e.contains("(3, 2)"),
        "{e}"
    );
    // A bad variance given as a file of its own names that file, not the image.
    let e = attempt(1.0, -1.0).map(|o| o.ran).unwrap_err();
    assert!(
        e.contains("var.exr (its variance file)")
            && !e.contains("ref.exr")
            && e.contains("variance of 1 pixels")
            && e.contains("(5, 1)"),
        "{e}"
    );
    assert!(
        finished_runs(&results.join("tiny"))
            .unwrap_or_default()
            .is_empty()
    );
    let ok = attempt(1.0, 1e-6).unwrap();
    assert_eq!(ok.ran, 12);
    std::fs::remove_dir_all(dir).unwrap();
}
