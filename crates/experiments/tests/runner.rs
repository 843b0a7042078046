//! The experiment runner end to end on a tiny scene: resuming after an interruption gives the same
//! results as an uninterrupted run, shards merged equal the unsharded run, and references are
//! cached by exactly what produced them.

use lightlab_core::NoProgress;
use lightlab_experiments::reference::{cache_path, load_image};
use lightlab_experiments::report::{finished_runs, plot_from_csv};
use lightlab_experiments::runner::{RunOptions, RunRecord, merge, run_experiment};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

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
        results: results.to_path_buf(),
        shard,
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
    // also its image, and a temporary file is left behind.
    let runs: Vec<PathBuf> = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    for (k, r) in runs.iter().take(5).enumerate() {
        std::fs::remove_file(r.join("metrics.json")).unwrap();
        if k == 0 {
            std::fs::remove_file(r.join("image.exr")).unwrap();
            std::fs::write(r.join(".metrics.json.tmp1"), "{ half").unwrap();
        }
    }
    let (ran, skipped, log) = run(&exp, &results, None);
    assert_eq!((ran, skipped), (5, 7));
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
    let copied = merge(&merged, &[dir.join("shard1/tiny"), dir.join("shard2/tiny")]).unwrap();
    assert_eq!(copied, 12);
    assert_eq!(comparable(&merged), whole);
    let csv = |p: &Path| {
        std::fs::read_to_string(p.join("runs.csv"))
            .unwrap()
            .lines()
            .count()
    };
    assert_eq!(csv(&merged), csv(&dir.join("all/tiny")));
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
        .build();
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
    for plot in ["furnace-mse-vs-spp-LDE.svg", "furnace-mse-vs-time-rest.svg"] {
        assert!(out.join(plot).is_file(), "{plot} missing");
    }
    std::fs::remove_dir_all(dir).ok();
}
