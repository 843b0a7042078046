//! `lightlab render` end to end, as a user runs it: writes a readable EXR with radiance and variance
//! layers, a PNG and JSON statistics; bad input is an error message and a failure exit code, never a
//! panic.

use lightlab_experiments::image_io::read_exr;
use std::path::{Path, PathBuf};
use std::process::Command;

fn lightlab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lightlab"))
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lightlab-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn render_writes_exr_png_and_stats() {
    let dir = temp_dir("render");
    let out = dir.join("cb.exr");
    let status = lightlab()
        .args([
            "render",
            "--spp",
            "2",
            "--threads",
            "2",
            "--integrator",
            "Path(max_bounces: 3)",
            "-o",
        ])
        .arg(&out)
        .arg(repo().join("scenes/cornell-box.ron"))
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let (w, h, layers) = read_exr(&out).unwrap();
    assert_eq!((w, h), (256, 256));
    let names: Vec<&str> = layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["radiance", "variance"]);
    let mean: f64 = layers[0].pixels.iter().map(|p| p[0] as f64).sum::<f64>() / (w * h) as f64;
    assert!(
        mean > 0.05 && mean < 5.0,
        "implausible mean radiance {mean}"
    );
    assert!(
        layers[1].pixels.iter().any(|p| p[0] > 0.0),
        "variance layer is empty"
    );
    assert!(dir.join("cb.png").metadata().unwrap().len() > 1000);
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("cb.json")).unwrap()).unwrap();
    assert_eq!(stats["stats"]["samples"], 256 * 256 * 2);
    assert!(stats["stats"]["rays"].as_u64().unwrap() >= 256 * 256 * 2);
    assert!(
        stats["integrator"]
            .as_str()
            .unwrap()
            .starts_with("Path(max_bounces: 3, ")
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let dir = temp_dir("bad");
    let bad_scene = dir.join("bad.ron");
    std::fs::write(&bad_scene, "Scene(camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8)),\n  materials: { \"a\": Dielectric(ior: -2) })").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["render".into(), bad_scene.display().to_string()],
            "bad.ron:2:",
        ),
        (
            vec![
                "render".into(),
                dir.join("missing.ron").display().to_string(),
            ],
            "cannot read",
        ),
        (
            vec![
                "render".into(),
                bad_scene.display().to_string(),
                "--integrator".into(),
                "Path(max_bouncs: 2)".into(),
            ],
            "max_bouncs",
        ),
        (
            vec![
                "render".into(),
                bad_scene.display().to_string(),
                "--spp".into(),
                "-3".into(),
            ],
            "--spp",
        ),
    ];
    for (args, want) in cases {
        let out = lightlab().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.contains(want), "{args:?}: expected '{want}' in: {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn every_command_has_help() {
    for args in [
        vec!["--help"],
        vec!["render", "--help"],
        vec!["run", "--help"],
        vec!["plot", "--help"],
        vec!["merge", "--help"],
    ] {
        let out = lightlab().args(&args).output().unwrap();
        assert!(out.status.success());
        assert!(
            String::from_utf8_lossy(&out.stdout).len() > 200,
            "{args:?}: help too short"
        );
    }
}
