//! Path-tracing benchmark (BENCHMARKS.md, "Path tracing"): camera paths per CPU-second on the shipped
//! Cornell box and caustic scenes with `Path()` (no bounce limit; Russian roulette from the third
//! bounce ends paths), on rayon pools of 1 and 2 threads, with rays per second, mean rays per path,
//! the two-thread speed-up and peak memory.
//!
//! Run: `cargo bench -p lightlab-integrators --bench path`.

use lightlab_core::NoProgress;
use lightlab_integrators::{Budget, IntegratorConfig};
use lightlab_testkit::timing::{peak_rss_bytes, timed};
use std::path::Path;

/// Samples per pixel of a timed render (256 × 256 × 64 = 4.2 M paths, several seconds per run).
const SPP: u32 = 64;

fn main() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let config = IntegratorConfig::from_ron("Path()").expect("default path tracer");
    println!("integrator: {}, {SPP} spp, seed 1\n", config.to_ron());
    println!(
        "| scene | threads | paths | wall s | CPU s | M paths / CPU-s | M paths / wall-s | M rays / wall-s | rays per path | speed-up |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for name in ["cornell-box", "caustic-sphere"] {
        let scene = lightlab_scene::load_scene(&scenes.join(format!("{name}.ron")))
            .unwrap_or_else(|e| panic!("{e}"));
        let integrator = config.build();
        let mut one_thread_wall = None;
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            pool.install(|| integrator.render(&scene, &Budget { spp: 1 }, 0, &NoProgress));
            let (out, wall, cpu) = timed(|| {
                pool.install(|| integrator.render(&scene, &Budget { spp: SPP }, 1, &NoProgress))
            });
            let paths = out.stats.samples as f64;
            let speed_up =
                one_thread_wall.map_or("".to_string(), |w: f64| format!("{:.2}×", w / wall));
            one_thread_wall.get_or_insert(wall);
            println!(
                "| {name} | {threads} | {} | {wall:.2} | {cpu:.2} | {:.3} | {:.3} | {:.2} | {:.2} | {speed_up} |",
                out.stats.samples,
                paths / cpu / 1e6,
                paths / wall / 1e6,
                out.stats.rays as f64 / wall / 1e6,
                out.stats.rays as f64 / paths,
            );
        }
    }
    println!(
        "\npeak resident memory: {:.1} MB",
        peak_rss_bytes() as f64 / 1e6
    );
}
