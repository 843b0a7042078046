//! `lightlab bench` end to end: the table and JSON rows, the reference cache, identical errors on
//! every thread count (the renders are deterministic), and clear errors for bad flags.

use std::path::{Path, PathBuf};
use std::process::Command;

fn lightlab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lightlab"))
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn bench_measures_every_integrator_and_thread_count() {
    let dir = std::env::temp_dir().join(format!("lightlab-cli-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("bench.json");
    let bench = || {
        lightlab()
            .args(["bench", "--resolution", "16x16", "--reference-spp", "64"])
            .args(["--trials", "2"])
            .args([
                "-i",
                "Path()@16",
                "-i",
                "Light(max_bounces: 4)@8",
                "-i",
                "Sppm(photons_per_pass: 20000)@4",
                "--threads",
                "1,2",
            ])
            .arg("--references")
            .arg(dir.join("references"))
            .arg("--json")
            .arg(&json)
            .arg(repo().join("scenes/cornell-box.ron"))
            .output()
            .unwrap()
    };
    let first = bench();
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(first.status.success(), "{stderr}");
    assert!(stderr.contains("rendered now"), "{stderr}");
    let table = String::from_utf8_lossy(&first.stdout);
    // The machine and the build's vector width are named: ratios against other renderers
    // depend on both.
    let machine = table.lines().next().unwrap();
    assert!(
        machine.starts_with("Machine: ") && machine.contains("; this build uses "),
        "{table}"
    );
    assert_eq!(
        table
            .lines()
            .filter(|l| l.starts_with("| cornell-box |"))
            .count(),
        6,
        "{table}"
    );
    assert!(
        table.contains("~: the row's mean CPU time is under 50 ticks"),
        "{table}"
    );
    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(rows.len(), 6);
    for pair in rows.chunks(2) {
        let (one, two) = (&pair[0], &pair[1]);
        assert_eq!(
            (one["threads"].as_u64(), two["threads"].as_u64()),
            (Some(1), Some(2))
        );
        let spp = one["spp"].as_f64().unwrap();
        assert_eq!(one["paths"].as_f64().unwrap(), 16.0 * 16.0 * spp);
        let rel = one["rel_mse"].as_f64().unwrap();
        assert!(rel > 0.0 && rel < 1.0, "relMSE {rel}");
        // Same seeds, same images on any thread count, so the same errors.
        assert_eq!(one["rel_mse_per_trial"], two["rel_mse_per_trial"]);
        assert_eq!(one["rel_mse"], two["rel_mse"]);
        // Two trials of independent seeds: their mean, and the standard error |x₁ − x₂| / 2.
        let trials: Vec<f64> = one["rel_mse_per_trial"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(trials.len(), 2);
        assert_ne!(trials[0], trials[1], "the trials used the same seed");
        assert!((rel - (trials[0] + trials[1]) / 2.0).abs() <= 1e-15 * rel);
        let se = one["rel_mse_se"].as_f64().unwrap();
        let expected = (trials[0] - trials[1]).abs() / 2.0;
        assert!(
            (se - expected).abs() <= 1e-12 * expected,
            "{se} against {expected}"
        );
        assert_eq!(one["cpu_seconds_per_trial"].as_array().unwrap().len(), 2);
        assert!(one["logical_cpus"].as_u64().unwrap() >= 1);
        let simd = one["build_simd"].as_str().unwrap();
        assert!(
            ["AVX-512", "AVX2", "AVX", "SSE4.2", "SSE2", "NEON", "none"].contains(&simd),
            "{simd}"
        );
        assert!(
            one["cpu_model"].is_string() || one["cpu_model"].is_null(),
            "{}",
            one["cpu_model"]
        );
        let per_spp = one["rel_mse_times_spp"].as_f64().unwrap();
        assert!(
            (per_spp - rel * spp).abs() <= 1e-12 * per_spp,
            "{per_spp} against {rel} × {spp}"
        );
        // Null only when the render was shorter than the CPU clock's 10 ms tick.
        let rate = &one["paths_per_cpu_second"];
        assert!(rate.is_null() || rate.as_f64().unwrap() > 0.0, "{rate}");
        // Under 50 ticks of the clock (these 16² renders are) the CPU rates are marked rounded.
        let cpu = one["cpu_seconds"].as_f64().unwrap();
        assert_eq!(
            one["cpu_rates_rounded"].as_bool().unwrap(),
            cpu < 0.5,
            "{cpu}"
        );
        // Photon paths: 20 000 per pass for Sppm, none (and no rate) for the others.
        let photons = one["photon_paths"].as_u64().unwrap();
        let photon_rate = &one["photon_paths_per_cpu_second"];
        if one["integrator"].as_str().unwrap().starts_with("Sppm") {
            assert_eq!(photons, 20_000 * spp as u64);
            assert!(
                photon_rate.is_null() || photon_rate.as_f64().unwrap() > 0.0,
                "{photon_rate}"
            );
        } else {
            assert_eq!(photons, 0);
            assert!(photon_rate.is_null(), "{photon_rate}");
        }
    }
    // The reference is now cached.
    let again = bench();
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(
        again.status.success() && stderr.contains("(cached)"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bench_rejects_bad_flags() {
    for (args, expected) in [
        (vec!["-i", "Path()"], "INTEGRATOR@SPP"),
        (vec!["-i", "Path()@0"], "≥ 1"),
        (vec!["-i", "Nope()@4"], "Nope"),
        // The message quotes what was given, and which part of it is the integrator.
        (
            vec!["-i", "Path()@4@4"],
            "'Path()@4@4': the integrator 'Path()@4' before the last '@'",
        ),
        (vec!["--threads", "0"], "thread count"),
        (vec!["--trials", "0"], "--trials"),
        // Said at once, not after the whole benchmark.
        (vec!["--json", "/nonexistent-dir/b.json"], "does not exist"),
        (vec!["--json", "/tmp/"], "names a directory"),
    ] {
        let out = lightlab().arg("bench").args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}
