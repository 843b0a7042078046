//! The HTML report (`index.html`): one self-contained file holding every setting's mean image
//! and the reference (decoded here and compared with the EXR files), the budgets in order, the
//! experiment file and the machine; and, where a Chromium is installed, the page itself opened
//! headless: no errors, every image decoded, key presses and clicks switch images (the page's
//! `#selftest`), and a screenshot. `tests/browser/run.sh` installs Chromium and runs this.

use base64::Engine;
use lightlab_core::NoProgress;
use lightlab_experiments::reference::load_image;
use lightlab_experiments::report::{finished_runs, reference_file};
use lightlab_experiments::runner::{RunOptions, run_experiment};
use std::path::{Path, PathBuf};
use std::process::Command;

const SCENE: &str = r#"Scene(
    camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 50, resolution: (12, 8)),
    materials: { "white": Diffuse(albedo: (0.7, 0.7, 0.7)) },
    shapes: [
        Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: "white"),
        Shape(geometry: Sphere(center: (0, 3, 2), radius: 0.5), material: "white",
              emission: (radiance: (8, 8, 8), two_sided: false)),
    ])"#;

const EXPERIMENT: &str = r#"Experiment(
    name: "report",
    scenes: ["sphere.ron"],
    reference: Render(integrator: "Path()", spp: 256),
    methods: [
        (label: "path MIS", integrator: "Path"),
        (label: "bidirectional", integrator: "Bdpt"),
        (label: "SPPM", integrator: "Sppm", settings: {"photons_per_pass": 500}),
    ],
    sweep: [Values(field: "spp", values: [16, 2, 4])],
    trials: 2,
    seed: 3,
    classes: ["LE"],
)"#;

/// Runs the experiment in a fresh directory; returns its output directory.
fn run(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lightlab-report-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("sphere.ron"), SCENE).unwrap();
    std::fs::write(dir.join("report.ron"), EXPERIMENT).unwrap();
    let options = RunOptions::new(dir.join("results"));
    let o = run_experiment(
        &dir.join("report.ron"),
        &options,
        &NoProgress,
        &NoProgress,
        &|_| {},
    )
    .unwrap();
    o.out_dir
}

/// The page's embedded data.
fn data(page: &str) -> serde_json::Value {
    let start = r#"<script type="application/json" id="data">"#;
    let i = page.find(start).expect("data element") + start.len();
    let j = i + page[i..].find("</script>").expect("end of data");
    serde_json::from_str(&page[i..j]).expect("data is JSON")
}

fn decode(b64: &serde_json::Value) -> Vec<f32> {
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(b64.as_str().expect("image string"))
        .unwrap();
    bytes
        .chunks(2)
        .map(|c| half::f16::from_le_bytes([c[0], c[1]]).to_f32())
        .collect()
}

/// Whether `decoded` is `exact` rounded to half precision.
fn matches(decoded: &[f32], exact: &[[f32; 3]]) {
    assert_eq!(decoded.len(), 3 * exact.len());
    for (d, e) in decoded.iter().zip(exact.iter().flatten()) {
        assert!(
            (d - e).abs() <= e.abs() * 2f32.powi(-11) + 6e-8,
            "{d} for {e}"
        );
    }
}

#[test]
fn report_embeds_every_setting_with_its_image_in_budget_order() {
    let out = run("embed");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    for external in [
        "src=\"http",
        "href=\"http",
        "src='http",
        "@import",
        "url(http",
    ] {
        assert!(!page.contains(external), "the page loads {external}…");
    }
    let d = data(&page);
    assert_eq!(d["runs"], 18);
    assert!(d["source"].as_str().unwrap().contains("name: \"report\""));
    // The machine and the build: speed figures hold for both.
    let machine = d["machine"].as_str().unwrap();
    assert!(
        machine.contains("logical cores") && machine.ends_with(" build"),
        "{machine}"
    );
    assert!(d["help"].as_array().unwrap().len() >= 10);
    let scenes = d["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    let scene = &scenes[0];
    assert_eq!(
        (scene["width"].as_u64(), scene["height"].as_u64()),
        (Some(12), Some(8))
    );
    let reference = load_image(&reference_file(&out, &finished_runs(&out).unwrap()[0])).unwrap();
    let settings = scene["settings"].as_array().unwrap();
    assert_eq!(settings.len(), 9);
    let budgets: Vec<&str> = settings
        .iter()
        .map(|s| s["budget"].as_str().unwrap())
        .collect();
    assert_eq!(
        budgets,
        [
            "spp=2", "spp=2", "spp=2", "spp=4", "spp=4", "spp=4", "spp=16", "spp=16", "spp=16"
        ]
    );
    for s in settings {
        let file = s["image"].as_str().unwrap();
        matches(
            &decode(&s["pixels"]),
            &load_image(&out.join(file)).unwrap().mean,
        );
        assert!(s["rel_mse"][0].as_f64().unwrap() > 0.0);
        assert!(s["rays"].as_f64().unwrap() > 0.0);
        assert_eq!(s["trials"], 2);
        assert!(s["bias2_se"].is_null(), "no jackknife from two trials");
        let photons = s["photons"].as_f64().unwrap();
        let spp: f64 = s["budget"].as_str().unwrap()[4..].parse().unwrap();
        match s["method"].as_str().unwrap() {
            "SPPM" => assert_eq!(photons, 500.0 * spp, "photon paths of the passes"),
            _ => assert_eq!(photons, 0.0, "path tracing and BDPT trace no photons"),
        }
        let flip = s["flip"].as_f64().unwrap();
        assert!(flip > 0.0 && flip < 1.0, "mean ꟻLIP {flip}");
        let map = base64::engine::general_purpose::STANDARD
            .decode(s["flip_map"].as_str().unwrap())
            .unwrap();
        assert_eq!(map.len(), 12 * 8);
    }
    matches(&decode(&scene["reference"]), &reference.mean);
    // The path-class layers, of every setting and of the reference, averaged over the trials.
    let names = |layers: &serde_json::Value| -> Vec<String> {
        layers
            .as_array()
            .unwrap()
            .iter()
            .map(|l| l[0].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(names(&scene["reference_layers"]), ["LE", "rest"]);
    for s in settings {
        assert_eq!(names(&s["layers"]), ["LE", "rest"]);
        let trials = s["trial_pixels"].as_array().unwrap();
        assert_eq!(trials.len(), 2, "each trial's image");
        let mean: Vec<f32> = decode(&trials[0])
            .iter()
            .zip(decode(&trials[1]))
            .map(|(a, b)| (a + b) / 2.0)
            .collect();
        let exact = &load_image(&out.join(s["image"].as_str().unwrap()))
            .unwrap()
            .mean;
        for (m, e) in mean.iter().zip(exact.iter().flatten()) {
            assert!(
                (m - e).abs() <= e.abs() * 2f32.powi(-10) + 1e-7,
                "trials average {m}, mean {e}"
            );
        }
        let le = decode(&s["layers"][0][1]);
        assert_eq!(le.len(), 12 * 8 * 3);
    }
    let plots = d["plots"].as_array().unwrap().len();
    assert!(plots >= 3, "the plots inline ({plots})");
}

/// A Chromium to run the page in: `LIGHTLAB_CHROMIUM`, or `chromium` on the path.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("LIGHTLAB_CHROMIUM") {
        return Some(p.into());
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// Chromium headless, without the background connections this machine's closed network refuses.
fn headless(browser: &Path, profile: &Path) -> Command {
    let mut c = Command::new(browser);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--virtual-time-budget=10000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    c
}

#[test]
fn report_works_in_a_browser() {
    let Some(browser) = chromium() else {
        eprintln!(
            "skipped: no Chromium installed (tests/browser/run.sh installs Debian's chromium and \
             runs this test; or set LIGHTLAB_CHROMIUM)"
        );
        return;
    };
    let out = run("browser");
    let url = format!("file://{}#selftest", out.join("index.html").display());
    let dom = headless(&browser, &out.join("profile"))
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .expect("chromium runs");
    let dom = String::from_utf8_lossy(&dom.stdout);
    let start = r#"<pre id="selftest-result">"#;
    let i = dom.find(start).expect("the page ran its self-test") + start.len();
    let j = i + dom[i..].find("</pre>").unwrap();
    let result: serde_json::Value = serde_json::from_str(&dom[i..j]).expect("self-test JSON");
    assert_eq!(result["errors"], serde_json::json!([]), "console errors");
    let checks = result["checks"].as_array().unwrap();
    assert!(checks.len() >= 6);
    for c in checks {
        assert_eq!(c["ok"], true, "failed in the browser: {}", c["name"]);
    }
    let shot = out.join("report.png");
    let status = headless(&browser, &out.join("profile"))
        .arg("--window-size=1400,1000")
        .arg(format!("--screenshot={}", shot.display()))
        .arg(&url)
        .stderr(std::process::Stdio::null())
        .status()
        .expect("chromium runs");
    assert!(status.success());
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap()));
    let mut reader = decoder.read_info().expect("a PNG screenshot");
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!(info.width, 1400, "of the window's width");
    // The flip book is on screen: far from a blank page, many distinct colours.
    let mut colours: Vec<&[u8]> = pixels.chunks(info.color_type.samples()).collect();
    colours.sort();
    colours.dedup();
    assert!(
        colours.len() > 200,
        "a blank screenshot ({} colours)",
        colours.len()
    );
    eprintln!("screenshot: {}", shot.display());
}
