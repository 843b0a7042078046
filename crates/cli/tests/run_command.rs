//! `lightlab run`, `plot` and `merge` end to end, as a user runs them.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lightlab(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lightlab"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lightlab-cli-run-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SCENE: &str = r#"Scene(
    camera: Camera(eye: (0, 0, 0), target: (0, 0, -1), fov: 60, resolution: (6, 4)),
    materials: { "wall": Diffuse(albedo: (0.5, 0.5, 0.5)) },
    shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: "wall",
                    emission: (radiance: (1, 1, 1), two_sided: true)) ])"#;

const EXPERIMENT: &str = r#"Experiment(
    name: "cli",
    scenes: ["s.ron"],
    reference: Render(integrator: "Path(max_bounces: 2)", spp: 32),
    methods: [(label: "pt", integrator: "Path", settings: {"max_bounces": 2})],
    sweep: [Values(field: "spp", values: [1, 2])],
    trials: 2,
)"#;

#[test]
fn run_shard_merge_and_plot() {
    let dir = temp_dir("ok");
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(dir.join("e.ron"), EXPERIMENT).unwrap();
    let out = lightlab(&["run", "e.ron", "--results", "res"], &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("4 runs") && stdout.contains("4 rendered now"),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(dir.join("res/cli/runs.csv")).unwrap();
    assert!(
        csv.starts_with("run,scene,method,setting,trial,seed,metric,value"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 1 + 4 * 10);

    // Again: nothing to do.
    let again = lightlab(&["run", "e.ron", "--results", "res"], &dir);
    assert!(String::from_utf8_lossy(&again.stdout).contains("0 rendered now, 4 already finished"));

    for (i, shard) in ["1/2", "2/2"].iter().enumerate() {
        let out = lightlab(
            &[
                "run",
                "e.ron",
                "--shard",
                shard,
                "--results",
                &format!("shard{i}"),
            ],
            &dir,
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let out = lightlab(
        &[
            "merge",
            "e.ron",
            "shard0/cli",
            "shard1/cli",
            "--results",
            "merged",
        ],
        &dir,
    );
    assert!(
        out.status.success() && String::from_utf8_lossy(&out.stdout).contains("merged 4 runs"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The directory, or the runs.csv in it.
    for target in ["merged/cli", "merged/cli/runs.csv"] {
        let out = lightlab(&["plot", target], &dir);
        assert!(
            out.status.success() && String::from_utf8_lossy(&out.stdout).contains("wrote 3 plots"),
            "{target}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// An experiment may list Mitsuba 3 XML scenes beside RON ones; two scenes of one stem are told
/// apart by their file names.
#[test]
fn experiments_take_mitsuba_scenes() {
    let dir = temp_dir("xml");
    std::fs::write(
        dir.join("s.xml"),
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <film type="hdrfilm"><integer name="width" value="6"/><integer name="height" value="4"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><float name="radius" value="5"/>
        <bsdf type="twosided"><bsdf type="diffuse"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter>
    </shape>
    <shape type="rectangle"><transform name="to_world"><translate z="-2"/></transform></shape>
</scene>"#,
    )
    .unwrap();
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(
        dir.join("e.ron"),
        EXPERIMENT.replace(r#"scenes: ["s.ron"]"#, r#"scenes: ["s.xml", "s.ron"]"#),
    )
    .unwrap();
    let out = lightlab(&["run", "e.ron", "--results", "res"], &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(dir.join("res/cli/runs.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 8 * 10, "{csv}");
    assert!(csv.contains(",s.xml,") && csv.contains(",s.ron,"), "{csv}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_experiments_are_errors_not_panics() {
    let dir = temp_dir("bad");
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(
        dir.join("typo.ron"),
        EXPERIMENT.replace("trials: 2", "trails: 2"),
    )
    .unwrap();
    std::fs::write(
        dir.join("field.ron"),
        EXPERIMENT.replace("\"max_bounces\": 2}", "\"max_bounce\": 2}"),
    )
    .unwrap();
    std::fs::write(
        dir.join("noscene.ron"),
        EXPERIMENT.replace("s.ron", "missing.ron"),
    )
    .unwrap();
    std::fs::write(
        dir.join("twice.ron"),
        EXPERIMENT.replace(r#"["s.ron"]"#, r#"["s.ron", "s.ron"]"#),
    )
    .unwrap();
    let cases = [
        (vec!["run", "typo.ron"], "typo.ron:7:"),
        (vec!["run", "field.ron"], "max_bounce"),
        (vec!["run", "noscene.ron"], "missing.ron"),
        (
            vec!["run", "twice.ron"],
            "twice.ron:3:14: scene \"s.ron\" is listed twice",
        ),
        (vec!["run", "absent.ron"], "cannot read"),
        (vec!["run", "typo.ron", "--shard", "3/2"], "not a shard"),
        (vec!["plot", "nowhere"], "runs.csv"),
    ];
    for (args, want) in cases {
        let out = lightlab(&args, &dir);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.contains(want), "{args:?}: expected '{want}' in: {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// `merge` checks what it merges: a shard of another experiment is refused, a missing shard makes
/// the merge fail (writing nothing) unless `--partial`, and a shard given twice is reported.
#[test]
fn merge_refuses_foreign_and_incomplete_shards() {
    let dir = temp_dir("merge-checks");
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(dir.join("e.ron"), EXPERIMENT).unwrap();
    std::fs::write(
        dir.join("other.ron"),
        EXPERIMENT.replace("values: [1, 2]", "values: [1, 3]"),
    )
    .unwrap();
    for (file, shard, results) in [
        ("e.ron", "1/3", "a"),
        ("e.ron", "2/3", "b"),
        ("other.ron", "3/3", "c"),
    ] {
        let out = lightlab(&["run", file, "--shard", shard, "--results", results], &dir);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let merge = |shards: &[&str], extra: &[&str]| {
        let mut args = vec!["merge", "e.ron"];
        args.extend(shards);
        args.extend(["--results", "merged"]);
        args.extend(extra);
        let out = lightlab(&args, &dir);
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (ok, _, err) = merge(&["a/cli", "c/cli"], &[]);
    assert!(
        !ok && err.contains("another version") && err.contains("not a shard of"),
        "{err}"
    );
    let (ok, _, err) = merge(&["a/cli", "b/cli"], &[]);
    assert!(
        !ok && err.contains("in none of the shards") && err.contains("--partial"),
        "{err}"
    );
    assert!(
        !dir.join("merged/cli/runs").exists(),
        "a failed merge wrote runs"
    );
    let (ok, out, err) = merge(&["a/cli", "b/cli", "a/cli"], &["--partial"]);
    assert!(ok && out.contains("merged 3 runs"), "{out}{err}");
    assert!(
        err.contains("partial merge: 1 runs") && err.contains("more than one shard"),
        "{err}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

/// Finished runs are reused only for the inputs they were measured on: after a scene's contents,
/// the resolution, the reference or the path classes change, `run`, `report` and `merge` refuse
/// the old results (a resumed sweep mixed 64² and 32² runs, and two references, silently). A
/// results directory from before the inputs were recorded is taken on its runs, and upgraded.
#[test]
fn results_of_other_inputs_are_refused() {
    let dir = temp_dir("inputs");
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(dir.join("e.ron"), EXPERIMENT).unwrap();
    let run = |file: &str| lightlab(&["run", file, "--results", "r"], &dir);
    assert!(run("e.ron").status.success());
    let identity = dir.join("r/cli/experiment.json");
    let recorded = std::fs::read_to_string(&identity).unwrap();
    assert!(recorded.contains("inputs_hash"), "{recorded}");
    // Nothing changed: everything is reused.
    let again = run("e.ron");
    assert!(
        again.status.success() && String::from_utf8_lossy(&again.stdout).contains("0 rendered now")
    );
    for (what, file, text) in [
        (
            "scene",
            "s.ron",
            SCENE.replace("0.5, 0.5, 0.5", "0.6, 0.6, 0.6"),
        ),
        (
            "resolution",
            "e.ron",
            EXPERIMENT.replace("trials: 2,", "trials: 2, resolution: (3, 2),"),
        ),
        (
            "reference",
            "e.ron",
            EXPERIMENT.replace("spp: 32", "spp: 64"),
        ),
        (
            "classes",
            "e.ron",
            EXPERIMENT.replace("trials: 2,", "trials: 2, classes: [\"LE\"],"),
        ),
    ] {
        std::fs::write(dir.join(file), &text).unwrap();
        for command in [
            &["run", "e.ron", "--results", "r"][..],
            &["report", "e.ron", "--results", "r"],
        ] {
            let out = lightlab(command, &dir);
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                !out.status.success() && err.contains("measured on other inputs"),
                "{what}, {command:?}: {err}"
            );
        }
        std::fs::write(dir.join("s.ron"), SCENE).unwrap();
        std::fs::write(dir.join("e.ron"), EXPERIMENT).unwrap();
    }
    // An identity written before inputs were recorded.
    let legacy: String = recorded
        .lines()
        .filter(|l| !l.contains("inputs_hash"))
        .collect::<Vec<_>>()
        .join("\n")
        .replace("\",\n}", "\"\n}");
    let parsed: serde_json::Value = serde_json::from_str(&legacy).unwrap();
    assert!(parsed.get("runs_hash").is_some() && parsed.get("inputs_hash").is_none());
    std::fs::write(&identity, &legacy).unwrap();
    assert!(run("e.ron").status.success());
    assert_eq!(std::fs::read_to_string(&identity).unwrap(), recorded);
    std::fs::remove_dir_all(dir).unwrap();
}

/// References once for a cluster: `--reference-only` renders them into a shared `--references`
/// directory and stops; shards with their own results then read them (none renders one).
#[test]
fn references_render_once_for_all_shards() {
    let dir = temp_dir("reference-only");
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(dir.join("e.ron"), EXPERIMENT).unwrap();
    let out = lightlab(
        &[
            "run",
            "e.ron",
            "--reference-only",
            "--references",
            "refs",
            "--results",
            "r0",
        ],
        &dir,
    );
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        out.status.success() && stdout.contains("references ready"),
        "{stdout}{stderr}"
    );
    assert!(stderr.contains("rendered:"), "{stderr}");
    assert!(
        !dir.join("r0/cli/runs").exists(),
        "--reference-only rendered runs"
    );
    for (i, shard) in ["1/2", "2/2"].iter().enumerate() {
        let results = format!("r{}", i + 1);
        let out = lightlab(
            &[
                "run",
                "e.ron",
                "--shard",
                shard,
                "--references",
                "refs",
                "--results",
                &results,
            ],
            &dir,
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(
            stderr.contains("cached:") && !stderr.contains("rendered:"),
            "{stderr}"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// Ctrl-C during a sweep says what was kept and how to resume; running the same command again
/// skips every finished run.
#[test]
fn interrupted_run_says_how_to_resume() {
    let dir = temp_dir("interrupt");
    std::fs::write(dir.join("s.ron"), SCENE.replace("(6, 4)", "(32, 32)")).unwrap();
    std::fs::write(
        dir.join("e.ron"),
        EXPERIMENT.replace("values: [1, 2]", "values: [512, 1024]"),
    )
    .unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_lightlab"))
        .args(["run", "e.ron", "--results", "res"])
        .current_dir(&dir)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until at least one run has finished, then interrupt.
    let runs = dir.join("res/cli/runs");
    for _ in 0..600 {
        let finished = std::fs::read_dir(&runs)
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .any(|e| e.path().join("metrics.json").is_file())
            })
            .unwrap_or(false);
        if finished {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("interrupted after") && stderr.contains("run the same command again"),
        "{stderr}"
    );
    let kept = std::fs::read_dir(&runs)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().join("metrics.json").is_file())
        .count();
    assert!(kept >= 1);
    let out = lightlab(&["run", "e.ron", "--results", "res"], &dir);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains(&format!("{kept} already finished")),
        "{stdout}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn report_rebuilds_from_disk_and_refuses_without_images() {
    let dir = temp_dir("report");
    std::fs::write(dir.join("s.ron"), SCENE).unwrap();
    std::fs::write(dir.join("e.ron"), EXPERIMENT).unwrap();
    let none = lightlab(&["report", "e.ron", "--results", "res"], &dir);
    let stderr = String::from_utf8_lossy(&none.stderr);
    assert!(
        !none.status.success() && stderr.contains("no finished runs"),
        "{stderr}"
    );
    assert!(
        lightlab(&["run", "e.ron", "--results", "res"], &dir)
            .status
            .success()
    );
    let page = dir.join("res/cli/index.html");
    std::fs::remove_file(&page).unwrap();
    let out = lightlab(&["report", "e.ron", "--results", "res"], &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read_to_string(&page)
            .unwrap()
            .contains("\"runs\":4")
    );

    // Without a run's image the summary would lose bias² and variance: nothing is rewritten.
    let runs = dir.join("res/cli/runs");
    let run = std::fs::read_dir(&runs)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    std::fs::remove_file(run.join("image.exr")).unwrap();
    let summary = std::fs::read(dir.join("res/cli/summary.json")).unwrap();
    let refused = lightlab(&["report", "e.ron", "--results", "res"], &dir);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success()
            && stderr.contains("1 file(s) missing")
            && stderr.contains("image.exr")
            && stderr.contains("lightlab run e.ron --results OTHER"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(dir.join("res/cli/summary.json")).unwrap(),
        summary
    );
    // `run` with nothing to render warns and leaves them too, and does not claim a report it
    // did not write (it did).
    let again = lightlab(&["run", "e.ron", "--results", "res"], &dir);
    let stdout = String::from_utf8_lossy(&again.stdout);
    assert!(
        again.status.success()
            && stdout.contains("were not rebuilt")
            && !stdout.contains("index.html (the report)"),
        "{stdout}"
    );
    assert_eq!(
        std::fs::read(dir.join("res/cli/summary.json")).unwrap(),
        summary
    );

    // A run directory gone altogether: the report is rebuilt from the other runs, and says that
    // one of the experiment's runs has no results.
    std::fs::remove_dir_all(&run).unwrap();
    let partial = lightlab(&["report", "e.ron", "--results", "res"], &dir);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&partial.stdout),
        String::from_utf8_lossy(&partial.stderr),
    );
    assert!(
        partial.status.success()
            && stderr.contains("1 of the experiment's 4 runs have no results")
            && stdout.contains("from 3 of 4 runs"),
        "{stdout}{stderr}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}
