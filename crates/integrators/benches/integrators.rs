//! Integrator benchmark (BENCHMARKS.md, "Path tracing" and "Light and bidirectional tracing"):
//! paths per CPU-second on the shipped Cornell box and caustic scenes for `Path()`, `Light()`,
//! `Bdpt()` and `Vcm()` (no bounce limit; the default Russian roulette ends paths), on
//! rayon pools of 1 and 2 threads, with rays per second, mean rays per path, the two-thread speed-up
//! and peak memory. A "path" is a camera path for `Path`, a light path for `Light`, a camera–light
//! subpath pair for `Bdpt` and `Vcm` (whose camera paths also merge with every light path of their
//! pass).
//!
//! Run: `cargo bench -p lightlab-integrators --bench integrators`.

use lightlab_core::NoProgress;
use lightlab_integrators::{Budget, IntegratorConfig};
use lightlab_testkit::timing::{peak_rss_bytes, timed};
use std::path::Path;

fn main() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    // Samples per pixel of a timed render at 256 × 256: several seconds per run.
    let integrators = [("Path()", 64), ("Light()", 64), ("Bdpt()", 8), ("Vcm()", 8)];
    println!(
        "| scene | integrator | threads | paths | wall s | CPU s | M paths / CPU-s | M paths / wall-s | M rays / wall-s | rays per path | speed-up |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in ["cornell-box", "caustic-sphere"] {
        let scene = lightlab_scene::load_scene(&scenes.join(format!("{name}.ron")))
            .unwrap_or_else(|e| panic!("{e}"));
        for (ron, spp) in integrators {
            let config = IntegratorConfig::from_ron(ron).expect("integrator settings");
            let integrator = config.build().expect("integrator settings");
            let mut one_thread_wall = None;
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("thread pool");
                pool.install(|| integrator.render(&scene, &Budget::Samples(1), 0, &NoProgress));
                let (out, wall, cpu) = timed(|| {
                    pool.install(|| {
                        integrator.render(&scene, &Budget::Samples(spp), 1, &NoProgress)
                    })
                });
                let paths = out.stats.samples as f64;
                let speed_up =
                    one_thread_wall.map_or(String::new(), |w: f64| format!("{:.2}×", w / wall));
                one_thread_wall.get_or_insert(wall);
                println!(
                    "| {name} | {ron} | {threads} | {} | {wall:.2} | {cpu:.2} | {:.3} | {:.3} | {:.2} | {:.2} | {speed_up} |",
                    out.stats.samples,
                    paths / cpu / 1e6,
                    paths / wall / 1e6,
                    out.stats.rays as f64 / wall / 1e6,
                    out.stats.rays as f64 / paths,
                );
            }
        }
    }
    println!(
        "\npeak resident memory: {:.1} MB",
        peak_rss_bytes() as f64 / 1e6
    );
}
