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
    let out = lightlab(&["plot", "merged/cli"], &dir);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("wrote 3 plots"));
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
    let cases = [
        (vec!["run", "typo.ron"], "typo.ron:7:"),
        (vec!["run", "field.ron"], "max_bounce"),
        (vec!["run", "noscene.ron"], "missing.ron"),
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
