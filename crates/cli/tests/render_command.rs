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
    // The render's own CPU time: on Linux a number of 10 ms ticks, at most what the whole
    // process's threads can have spent in the render's wall time.
    if cfg!(target_os = "linux") {
        let cpu = stats["render_cpu_seconds"].as_f64().unwrap();
        let wall = stats["stats"]["wall_seconds"].as_f64().unwrap();
        let threads = stats["stats"]["threads"].as_f64().unwrap();
        assert!(
            cpu >= 0.0 && cpu <= 1.05 * threads * wall + 0.05,
            "cpu {cpu} s, wall {wall} s"
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// A point light 10⁻⁵ from a floor within every documented limit: its radiance (about 4·10²²)
/// fits a 32-bit float, its variance does not. The EXR holds infinities there; the render must
/// say so on standard error and in its JSON, not silently.
#[test]
fn variance_beyond_f32_is_reported() {
    let dir = temp_dir("overflow");
    let scene = dir.join("hot.ron");
    std::fs::write(
        &scene,
        "Scene(camera: Camera(eye: (0, 0.002, 0.00001), target: (0, 0, 0), fov: 5, resolution: (8, 8)),
         materials: { \"plane\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
         shapes: [ Shape(geometry: Quad(corner: (-0.001, 0, -0.001), edge1: (0, 0, 0.002), edge2: (0.002, 0, 0)), material: \"plane\") ],
         lights: [ Point(position: (0, 0.00001, 0), intensity: (1e15, 1e15, 1e15)) ])",
    )
    .unwrap();
    let out = dir.join("hot.exr");
    let run = lightlab()
        .args(["render", "--spp", "4", "-o"])
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("192 values of layer variance exceed the largest 32-bit float"),
        "{stderr}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("hot.json")).unwrap()).unwrap();
    assert_eq!(json["f32_overflows"]["variance"], 192);
    let (_, _, layers) = read_exr(&out).unwrap();
    assert!(layers[0].pixels.iter().flatten().all(|v| v.is_finite()));
    assert!(layers[1].pixels.iter().flatten().all(|v| v.is_infinite()));
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
            // 200 bounces asked for 40 000 full-image layers.
            vec![
                "render".into(),
                bad_scene.display().to_string(),
                "--integrator".into(),
                "Vcm(max_bounces: 200, strategy_layers: true)".into(),
            ],
            "up to 16",
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
        (
            // 100 000 OS threads took over a minute to start before anything rendered.
            vec![
                "render".into(),
                bad_scene.display().to_string(),
                "--threads".into(),
                "100000".into(),
            ],
            "1..=1024",
        ),
        (
            // Refused before rendering: two layers of one name were found only when writing.
            vec![
                "render".into(),
                repo().join("scenes/cornell-box.ron").display().to_string(),
                "--layers".into(),
                "LDE,LS+DE,LDE".into(),
                "-o".into(),
                dir.join("twice.exr").display().to_string(),
            ],
            "LDE is given twice",
        ),
        (
            // No slope can be fitted to fewer than two sample counts (it printed only "—").
            vec![
                "convergence".into(),
                "--fit-from".into(),
                "64".into(),
                "--max-spp".into(),
                "4".into(),
                "--results".into(),
                dir.join("conv").display().to_string(),
            ],
            "leaves 0 sample count",
        ),
        (
            // s = 0 keeps camera paths that hit a light: black under point lights alone.
            vec![
                "render".into(),
                repo()
                    .join("scenes/point-over-plane.ron")
                    .display()
                    .to_string(),
                "--integrator".into(),
                "Bdpt(mis: Only(s: 0, t: 3))".into(),
                "-o".into(),
                dir.join("black.exr").display().to_string(),
            ],
            "choose a strategy with s ≥ 1",
        ),
    ];
    let mut cases = cases;
    // `-D res=16 -D res=8` kept the last without a word.
    cases.push((
        vec![
            "render".into(),
            repo()
                .join("scenes/mitsuba/materials.xml")
                .display()
                .to_string(),
            "-D".into(),
            "res=16".into(),
            "-D".into(),
            "res=8".into(),
        ],
        "-D res is given twice",
    ));
    // An expression matching no path within the bounce limit rendered black without a word.
    cases.push((
        vec![
            "render".into(),
            repo().join("scenes/cornell-box.ron").display().to_string(),
            "-i".into(),
            "Path(max_bounces: 1)".into(),
            "--paths".into(),
            "LDDE".into(),
            "-o".into(),
            dir.join("black-paths.exr").display().to_string(),
        ],
        "matches no path of 0 to 1 scattering vertices",
    ));
    // A few hundred bytes of EXR header claiming 100 000² pixels: the allocation aborted.
    let huge = dir.join("huge-header.exr");
    std::fs::write(
        &huge,
        lightlab_testkit::files::exr_header_only(100_000, 100_000),
    )
    .unwrap();
    let huge = huge.display().to_string();
    cases.push((
        vec!["compare".into(), huge.clone(), huge],
        "header declares 100000 × 100000",
    ));
    // Four billion seeds' errors (32 GiB) aborted the process.
    cases.push((
        vec![
            "convergence".into(),
            "--seeds".into(),
            "4294967295".into(),
            "--results".into(),
            dir.join("conv").display().to_string(),
        ],
        "2..=16777216",
    ));
    // Refused before allocating: 16384² pixels × 1024 light subpaths each is tens of terabytes
    // of light vertices (the kernel's out-of-memory kill ended it otherwise).
    if cfg!(target_os = "linux") {
        cases.push((
            vec![
                "render".into(),
                repo().join("scenes/cornell-box.ron").display().to_string(),
                "--resolution".into(),
                "16384x16384".into(),
                "--integrator".into(),
                "Vcm(max_bounces: 8, light_paths: 1024)".into(),
                "-o".into(),
                dir.join("huge.exr").display().to_string(),
            ],
            "of memory are available",
        ));
        // Four billion photon paths: about a terabyte of photons, estimated by a pilot.
        cases.push((
            vec![
                "render".into(),
                repo().join("scenes/cornell-box.ron").display().to_string(),
                "--integrator".into(),
                "PhotonMap(photons: 4000000000)".into(),
                "-o".into(),
                dir.join("photons.exr").display().to_string(),
            ],
            "of memory are available",
        ));
    }
    for (args, want) in cases {
        let out = lightlab().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.contains(want), "{args:?}: expected '{want}' in: {err}");
    }
    assert!(!dir.join("twice.json").exists());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn every_command_has_help() {
    for args in [
        vec!["--help"],
        vec!["render", "--help"],
        vec!["run", "--help"],
        vec!["plot", "--help"],
        vec!["report", "--help"],
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

/// Runs `lightlab render` on `scene` with `args`, returning (success, stdout, stderr).
fn render_with(scene: &Path, args: &[&str], out: &Path) -> (bool, String, String) {
    let o = lightlab()
        .arg("render")
        .args(args)
        .arg("-o")
        .arg(out)
        .arg(scene)
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `--seconds` renders for a time instead of a sample count, and the statistics say how many
/// samples it reached; the image's standard error is printed only where the sample passes are
/// independent, and says what it is; invalid budgets and impossible settings are errors.
#[test]
fn time_budget_and_honest_error_bars() {
    let dir = temp_dir("seconds");
    let scene = repo().join("scenes/cornell-box.ron");
    let small = dir.join("small.ron");
    std::fs::write(
        &small,
        std::fs::read_to_string(&scene)
            .unwrap()
            .replace("resolution: (256, 256)", "resolution: (32, 32)"),
    )
    .unwrap();
    let out = dir.join("t.exr");
    let (ok, stdout, stderr) = render_with(
        &small,
        &["--seconds", "0.3", "-i", "Light(max_bounces: 3)"],
        &out,
    );
    assert!(ok, "{stderr}");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("t.json")).unwrap()).unwrap();
    let spp = stats["stats"]["spp"].as_u64().unwrap();
    assert!(spp >= 2, "{spp} samples in 0.3 s");
    assert!(
        stdout.contains(&format!(
            "from the spread of {spp} independent sample passes"
        )),
        "{stdout}"
    );
    let (ok, stdout, stderr) = render_with(
        &small,
        &["--spp", "4", "-i", "Sppm(photons_per_pass: 1000)"],
        &out,
    );
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("no standard error") && !stdout.contains(" ± "),
        "{stdout}"
    );
    assert!(
        stdout.contains("not the variance of the pixel mean"),
        "{stdout}"
    );
    // Jensen's photon map: the standard error also holds the photon groups' spread.
    let (ok, stdout, stderr) = render_with(
        &small,
        &[
            "--spp",
            "4",
            "-i",
            "PhotonMap(photons: 2000, caustic_photons: 200, indirect: Direct)",
        ],
        &out,
    );
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(
            "from the spread of 4 camera sample passes and of 16 independent photon groups"
        ),
        "{stdout}"
    );
    // With motion blur its passes take stratified instants: the spread is printed, but not as
    // a standard error of independent passes (it was).
    let blurred = dir.join("blurred.ron");
    std::fs::write(
        &blurred,
        std::fs::read_to_string(repo().join("scenes/motion-blur.ron"))
            .unwrap()
            .replace("resolution: (192, 128)", "resolution: (24, 16)"),
    )
    .unwrap();
    let (ok, stdout, stderr) = render_with(
        &blurred,
        &[
            "--spp",
            "4",
            "-i",
            "PhotonMap(photons: 2000, caustic_photons: 200)",
        ],
        &out,
    );
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("the spread of 4 sample passes, not a standard error: an upper bound")
            && !stdout.contains("independent sample passes"),
        "{stdout}"
    );
    for bad in ["0", "-1", "nan", "inf"] {
        let (ok, _, stderr) = render_with(&small, &["--seconds", bad], &out);
        assert!(
            !ok && stderr.contains("--seconds") && !stderr.contains("panicked"),
            "{bad}: {stderr}"
        );
    }
    let (ok, _, stderr) = render_with(&small, &["--spp", "4", "--seconds", "1"], &out);
    assert!(!ok && stderr.contains("cannot be used with"), "{stderr}");
    let point = dir.join("point.ron");
    std::fs::write(
        &point,
        "Scene(camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8)),
               materials: { \"white\": Diffuse(albedo: (0.5, 0.5, 0.5)) },
               shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"white\") ],
               lights: [ Point(position: (0, 2, 2), intensity: (1, 1, 1)) ])",
    )
    .unwrap();
    let (ok, _, stderr) = render_with(&point, &["-i", "Path(strategy: BsdfOnly)"], &out);
    assert!(
        !ok && stderr.contains("point.ron")
            && stderr.contains("point, spot and directional")
            && !stderr.contains("panicked"),
        "{stderr}"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// No output overwrites another: `-o x.png` is refused (the PNG preview would be written over the
/// EXR), and an output without extension becomes `.exr` beside its `.png` and `.json`.
#[test]
fn outputs_never_overwrite_each_other() {
    let dir = temp_dir("names");
    let scene = repo().join("scenes/furnace.ron");
    let (ok, _, stderr) = render_with(&scene, &["--spp", "1"], &dir.join("x.png"));
    assert!(
        !ok && stderr.contains(".exr") && !dir.join("x.png").exists(),
        "{stderr}"
    );
    let (ok, stdout, stderr) = render_with(
        &scene,
        &["--spp", "1", "--resolution", "4x3"],
        &dir.join("plain"),
    );
    assert!(ok, "{stderr}");
    for f in ["plain.exr", "plain.png", "plain.json"] {
        assert!(dir.join(f).is_file(), "{f} missing: {stdout}");
    }
    // One sample has no spread: said so, not blamed on dependent passes.
    assert!(
        stdout.contains("no standard error from 1 sample per pixel"),
        "{stdout}"
    );
    let (w, h, _) = read_exr(&dir.join("plain.exr")).unwrap();
    assert_eq!((w, h), (4, 3));
    // A directory is no file name: `-o out/` wrote out.exr, out.png and out.json beside it.
    std::fs::create_dir_all(dir.join("out")).unwrap();
    for out in [dir.join("out"), dir.join("new/")] {
        let (ok, _, stderr) = render_with(&scene, &["--spp", "1"], &out);
        assert!(!ok && stderr.contains("names a directory"), "{stderr}");
    }
    assert!(!dir.join("out.exr").exists() && !dir.join("new.exr").exists());
    std::fs::remove_dir_all(dir).ok();
}

/// `--set PATH=VALUE` overrides a value of the scene file without copying it, `--resolution` its
/// size; a bad path says what is there.
#[test]
fn scene_overrides_from_the_command_line() {
    let dir = temp_dir("set");
    let scene = repo().join("scenes/cornell-box.ron");
    let out = dir.join("o.exr");
    let (ok, _, stderr) = render_with(
        &scene,
        &[
            "--spp",
            "1",
            "--resolution",
            "8x6",
            "--set",
            "camera.fov=20",
            "--set",
            "materials.white.albedo=(0.1, 0.1, 0.1)",
        ],
        &out,
    );
    assert!(ok, "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("o.json")).unwrap()).unwrap();
    assert_eq!(
        (
            json["stats"]["width"].as_u64(),
            json["stats"]["height"].as_u64()
        ),
        (Some(8), Some(6))
    );
    let (ok, _, stderr) = render_with(&scene, &["--spp", "1", "--set", "camera.fovv=20"], &out);
    assert!(
        !ok && stderr.contains("fovv") && stderr.contains("fov") && !stderr.contains("panicked"),
        "{stderr}"
    );
    for bad in ["0x4", "12", "axb"] {
        let (ok, _, stderr) = render_with(&scene, &["--resolution", bad], &out);
        assert!(!ok && stderr.contains("resolution"), "{bad}: {stderr}");
    }
    let (ok, _, stderr) = render_with(&scene, &["--exposure", "nan"], &out);
    assert!(!ok && stderr.contains("exposure"), "{stderr}");
    std::fs::remove_dir_all(dir).ok();
}

/// Not on a terminal (a cluster job's log), progress is written as lines with what is done, the
/// time elapsed and remaining.
#[test]
fn progress_lines_when_not_on_a_terminal() {
    let dir = temp_dir("lines");
    let o = lightlab()
        .env("LIGHTLAB_PROGRESS_SECONDS", "0")
        .args(["render", "--spp", "4", "--resolution", "16x16", "-o"])
        .arg(dir.join("p.exr"))
        .arg(repo().join("scenes/cornell-box.ron"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("render: 100 %, elapsed 0:00:0")
                && l.contains("remaining ≈ 0:00:00")),
        "{stderr}"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// `lightlab compare`: two renders of one scene with different seeds agree by the per-pixel
/// z-test (exit 0), t-corrected with the samples per pixel their JSON names (normal without it),
/// with a caution where the JSON says a variance layer is no variance of the mean;
/// a render missing a bounce does not (exit 1), and the error image is written.
#[test]
fn compare_two_renders() {
    let dir = temp_dir("compare");
    let scene = repo().join("scenes/cornell-box.ron");
    for (name, args) in [
        (
            "a.exr",
            vec!["--spp", "16", "--seed", "1", "-i", "Path(max_bounces: 3)"],
        ),
        (
            "b.exr",
            vec!["--spp", "16", "--seed", "2", "-i", "Path(max_bounces: 3)"],
        ),
        (
            "c.exr",
            vec!["--spp", "16", "--seed", "3", "-i", "Path(max_bounces: 1)"],
        ),
        (
            "s.exr",
            vec!["--spp", "4", "-i", "Sppm(photons_per_pass: 1000)"],
        ),
        (
            "p.exr",
            vec![
                "--spp",
                "4",
                "-i",
                "PhotonMap(photons: 2000, caustic_photons: 200)",
            ],
        ),
    ] {
        let mut a = args.clone();
        a.extend(["--resolution", "24x24"]);
        let (ok, _, stderr) = render_with(&scene, &a, &dir.join(name));
        assert!(ok, "{stderr}");
    }
    let run = |args: &[&str]| {
        let o = lightlab()
            .arg("compare")
            .args(args)
            .current_dir(&dir)
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (code, out, err) = run(&["a.exr", "b.exr"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("576 pixels compared") && out.contains("0 beyond the critical"),
        "{out}"
    );
    // 16 samples per pixel each, read from the renders' JSON: the z are t-corrected.
    assert!(
        out.contains("t-corrected: variances from 16 and 16 samples per pixel"),
        "{out}"
    );
    // A photon map's variance has its 16 photon groups' G − 1 degrees of freedom, not spp − 1
    // (it was taken as normal).
    let (_, out, err) = run(&["p.exr", "a.exr"]);
    assert!(
        out.contains("t-corrected: variances from 16 and 16 samples per pixel"),
        "{out}{err}"
    );
    let (code, out, err) = run(&["a.exr", "b.exr", "--samples-b", "1"]);
    assert!(
        code == Some(1) && err.contains("--samples-b must be at least 2"),
        "{out}{err}"
    );
    // SPPM's variance layer is no variance of the mean: said beside the z-test.
    let (_, out, err) = run(&["s.exr", "a.exr"]);
    assert!(
        out.contains("caution: the variance layer of s.exr is not the variance of its pixel mean"),
        "{out}{err}"
    );
    assert!(!out.contains("of a.exr is not"), "{out}");
    // And in the JSON, which used to drop it.
    let (_, out, err) = run(&["s.exr", "a.exr", "--json"]);
    let json: serde_json::Value = serde_json::from_str(&out).expect(&err);
    let cautions = json["cautions"].as_array().expect("a cautions list");
    assert!(
        cautions
            .iter()
            .any(|c| c.as_str().unwrap().contains("s.exr is not the variance")),
        "{out}"
    );
    std::fs::remove_file(dir.join("b.json")).unwrap();
    let (code, out, err) = run(&["a.exr", "b.exr"]);
    assert!(
        code == Some(0) && out.contains("z taken as normal"),
        "{out}{err}"
    );
    let (_, out, _) = run(&["a.exr", "b.exr", "--json"]);
    assert!(
        out.contains("\"cautions\"") && out.contains("z taken as normal"),
        "{out}"
    );
    let (code, out, err) = run(&[
        "c.exr",
        "b.exr",
        "--error",
        "err.exr",
        "--region",
        "0,0,24,12",
    ]);
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(
        out.contains("288 pixels compared") && err.contains("disagree"),
        "{out}{err}"
    );
    let (_, _, layers) = read_exr(&dir.join("err.exr")).unwrap();
    assert_eq!(
        layers.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(),
        ["difference", "relative", "z"]
    );
    // The error images written over an input replaced it.
    let before = std::fs::read(dir.join("b.exr")).unwrap();
    let (code, _, err) = run(&["a.exr", "b.exr", "--error", "./b.exr"]);
    assert!(
        code == Some(1) && err.contains("is one of the images compared (b.exr)"),
        "{err}"
    );
    assert!(std::fs::read(dir.join("b.exr")).unwrap() == before);
    let (code, _, err) = run(&["a.exr", "b.exr", "--region", "0,0,99,2"]);
    assert!(code == Some(1) && err.contains("past"), "{err}");
    // One NaN pixel made the MSE NaN, printed as a result: now the file and pixel are named.
    let mut pixels = vec![[0.5f32; 3]; 24 * 24];
    pixels[24 + 3][1] = f32::NAN;
    let layer = lightlab_experiments::image_io::RgbLayer {
        name: "radiance".into(),
        pixels,
    };
    lightlab_experiments::image_io::write_exr(&dir.join("nan.exr"), 24, 24, &[layer]).unwrap();
    std::fs::write(dir.join("png.exr"), b"\x89PNG\r\n\x1a\n").unwrap();
    let (code, _, err) = run(&["a.exr", "png.exr"]);
    assert!(
        code == Some(1) && err.contains("png.exr") && err.contains("not an OpenEXR file"),
        "{err}"
    );
    let (code, out, err) = run(&["a.exr", "nan.exr"]);
    assert!(
        code == Some(1)
            && err.contains("nan.exr: 1 pixels are NaN or infinite")
            && err.contains("(3, 1)"),
        "{out}{err}"
    );
    // A NaN in a variance given as a file of its own names that file, not the image.
    let (code, out, err) = run(&["a.exr", "a.exr", "--variance-a", "nan.exr"]);
    assert!(
        code == Some(1) && err.contains("nan.exr: the variance of 1 pixels"),
        "{out}{err}"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// A Mitsuba file renders with its own integrator and sample count (both recorded in the JSON),
/// `-D` overrides its defaults, and the flags that belong to the other format are refused.
#[test]
fn mitsuba_files_render_with_their_settings_and_defines() {
    let dir = temp_dir("mitsuba");
    let scene = repo().join("scenes/mitsuba/materials.xml");
    let out = dir.join("m.exr");
    let (ok, stdout, stderr) = render_with(&scene, &["-D", "res=16", "-D", "spp=3"], &out);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("16×16 at 3 spp"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("m.json")).unwrap()).unwrap();
    let integrator = json["integrator"].as_str().unwrap();
    assert!(
        integrator.starts_with("Path(max_bounces: 7, min_bounces: 0, russian_roulette: 5"),
        "max_depth 8 is 7 bounces: {integrator}"
    );
    // --spp and --integrator win over the file's.
    let (ok, stdout, stderr) = render_with(
        &scene,
        &[
            "-D",
            "res=8",
            "--spp",
            "2",
            "--integrator",
            "Bdpt(max_bounces: 2)",
        ],
        &out,
    );
    assert!(
        ok && stdout.contains("8×8 at 2 spp") && stdout.starts_with("Bdpt"),
        "{stdout}{stderr}"
    );
    for (args, expect) in [
        (
            vec!["-D", "nope=1"],
            "never refers to $nope (its other parameters: res, spp)",
        ),
        (vec!["--set", "camera.fov=10"], "with -D NAME=VALUE"),
    ] {
        let (ok, _, stderr) = render_with(&scene, &args, &out);
        assert!(!ok && stderr.contains(expect), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    let (ok, _, stderr) = render_with(&repo().join("scenes/cornell-box.ron"), &["-D", "a=1"], &out);
    assert!(!ok && stderr.contains("use --set"), "{stderr}");
}

/// The replay command an outlier file gives reproduces its outliers from a render whose scene was
/// changed on the command line (`--resolution`, `--set`): it carries those changes, quoted for the
/// shell. Without them it replayed the scene file's own 256×256 image.
#[test]
fn outliers_replay_from_the_command_they_name() {
    let dir = temp_dir("replay");
    let out = dir.join("bdpt.exr");
    let status = lightlab()
        .args(["render"])
        .arg(repo().join("scenes/caustic-sphere.ron"))
        .args([
            "--resolution",
            "32x24",
            "--set",
            "camera.fov=41",
            "--spp",
            "32",
            "--seed",
            "4",
        ])
        .args([
            "-i",
            "Bdpt(max_bounces: 6, outliers: 20, mis: Uniform)",
            "-o",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let log: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.with_extension("outliers.json")).unwrap())
            .unwrap();
    let command = log["replay"].as_str().unwrap();
    assert!(command.contains("--resolution 32x24") && command.contains("--set camera.fov=41"));
    let outliers = log["outliers"].as_array().unwrap();
    assert!(!outliers.is_empty());
    for o in outliers.iter().take(3) {
        let line = command
            .replacen("lightlab", env!("CARGO_BIN_EXE_lightlab"), 1)
            .replace("X,Y", &format!("{},{}", o["pixel"][0], o["pixel"][1]))
            .replace("--sample I", &format!("--sample {}", o["sample"]));
        let replay = Command::new("sh").args(["-c", &line]).output().unwrap();
        assert!(
            replay.status.success(),
            "{line}: {}",
            String::from_utf8_lossy(&replay.stderr)
        );
        let replayed: serde_json::Value = serde_json::from_slice(&replay.stdout).unwrap();
        // Values are f32, printed at f32 precision by one and widened to f64 by the other.
        let value = |v: &serde_json::Value| {
            let v = v.as_array().unwrap();
            v.iter()
                .map(|c| c.as_f64().unwrap() as f32)
                .collect::<Vec<_>>()
        };
        assert!(
            replayed.as_array().unwrap().iter().any(|r| {
                (&r["s"], &r["t"], value(&r["value"])) == (&o["s"], &o["t"], value(&o["value"]))
            }),
            "{line} does not reproduce {o}"
        );
    }
    // A sample count the render would refuse (3 replicates do not divide 4 samples) is refused.
    let out = lightlab()
        .args([
            "replay",
            "-i",
            "Bdpt(replicates: 3)",
            "--spp",
            "4",
            "--pixel",
            "0,0",
            "--sample",
            "0",
        ])
        .arg(repo().join("scenes/cornell-box.ron"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("cannot be split into 3 equal replicates"),
        "{err}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}
