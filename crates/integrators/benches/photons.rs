//! Photon-map benchmark (BENCHMARKS.md, "Photon maps"): photon tracing rate on the shipped scenes,
//! kd-tree (kiddo) build time and bytes per photon, gathering rates — k = 50 nearest, and a fixed
//! radius holding about 50 photons, kd-tree against the uniform hash grid — on rayon pools of 1 and
//! 2 threads, and the peak memory of 10 million photon paths traced, stored and queried (measured
//! first, so that the process's peak is theirs).
//!
//! Run: `cargo bench -p lightlab-integrators --bench photons`.

use glam::Vec3;
use lightlab_integrators::photon::grid::HashGrid;
use lightlab_integrators::photon::map::PhotonMap;
use lightlab_integrators::photon::trace::{Keep, Photon, PhotonTracing, Traced, trace_photons};
use lightlab_integrators::{Counters, RoulettePolicy};
use lightlab_testkit::timing::{peak_rss_bytes, timed};
use rayon::prelude::*;
use std::path::Path;

const QUERIES: usize = 400_000;

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

/// Query points: photon positions (a surface distribution, as a camera's visible points are)
/// of every `stride`-th photon, nudged off the photon itself.
fn queries(photons: &[Photon]) -> Vec<Vec3> {
    let stride = (photons.len() / QUERIES).max(1);
    photons
        .iter()
        .step_by(stride)
        .take(QUERIES)
        .map(|p| p.p + Vec3::splat(1e-4))
        .collect()
}

fn main() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let how = PhotonTracing {
        max_bounces: u32::MAX,
        // The policy of the figures recorded in BENCHMARKS.md ("Photon maps"), kept so that they
        // stay comparable: roulette from the third vertex, survival in proportion to flux.
        roulette: RoulettePolicy {
            start: Some(3),
            threshold: 1.0,
        },
        keep: Keep::All,
    };
    // 10 million photon paths traced, stored and queried: the memory that takes.
    let scene = lightlab_scene::load_scene(&scenes.join("cornell-box.ron"))
        .unwrap_or_else(|e| panic!("{e}"));
    let (stored, wall, _) = timed(|| {
        pool(2).install(|| {
            let photons = trace_photons(
                &scene,
                3,
                (0, 10_000_000),
                0.0,
                how,
                &mut Counters::default(),
            );
            let map = PhotonMap::new(photons);
            let qs = queries(map.photons());
            let found: usize = qs
                .par_iter()
                .map(|&q| map.nearest(q, 50, f32::INFINITY).len())
                .sum();
            assert!(found > 0);
            map.len()
        })
    });
    println!(
        "10 M photon paths ({stored} photons stored) traced, indexed and queried in {wall:.1} s; peak resident memory {:.0} MB; size_of::<Photon>() = {} B\n",
        peak_rss_bytes() as f64 / 1e6,
        std::mem::size_of::<Photon>()
    );

    println!("### Photon tracing\n");
    println!(
        "| scene | threads | photon paths | stored | wall s | CPU s | M paths / CPU-s | M paths / wall-s | M rays / wall-s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for name in ["cornell-box", "caustic-sphere"] {
        let scene = lightlab_scene::load_scene(&scenes.join(format!("{name}.ron")))
            .unwrap_or_else(|e| panic!("{e}"));
        for threads in [1, 2] {
            let n = 2_000_000u64;
            let mut c = Counters::default();
            let (photons, wall, cpu) = timed(|| {
                pool(threads).install(|| trace_photons(&scene, 1, (0, n), 0.0, how, &mut c))
            });
            println!(
                "| {name} | {threads} | {n} | {} | {wall:.2} | {cpu:.2} | {:.3} | {:.3} | {:.2} |",
                photons.photons.len(),
                n as f64 / cpu / 1e6,
                n as f64 / wall / 1e6,
                c.rays as f64 / wall / 1e6
            );
        }
    }

    let scene = lightlab_scene::load_scene(&scenes.join("cornell-box.ron"))
        .unwrap_or_else(|e| panic!("{e}"));
    println!("\n### Gathering (Cornell box photons)\n");
    println!(
        "| stored photons | structure | build wall s (2 threads) | bytes / photon | query | threads | M queries / s | photons found / query |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for paths in [400_000u64, 4_000_000] {
        let photons = pool(2)
            .install(|| trace_photons(&scene, 2, (0, paths), 0.0, how, &mut Counters::default()))
            .photons;
        let n = photons.len();
        let qs = queries(&photons);
        let (map, build, _) =
            timed(|| pool(2).install(|| PhotonMap::new(Traced::ungrouped(photons.clone()))));
        // The radius that holds about 50 photons on average, from the k-nearest distances.
        let mean_r2 = qs
            .iter()
            .take(2000)
            .map(|&q| {
                map.nearest(q, 50, f32::INFINITY)
                    .last()
                    .map_or(0.0, |x| x.1) as f64
            })
            .sum::<f64>()
            / 2000.0;
        let r2 = mean_r2 as f32;
        let kd_bytes = map.bytes() as f64 / n as f64;
        for threads in [1, 2] {
            let (found, wall, _) = timed(|| {
                pool(threads).install(|| {
                    qs.par_iter()
                        .map(|&q| map.nearest(q, 50, f32::INFINITY).len())
                        .sum::<usize>()
                })
            });
            println!(
                "| {n} | kd-tree | {build:.3} | {kd_bytes:.0} | k = 50 nearest | {threads} | {:.3} | {:.1} |",
                qs.len() as f64 / wall / 1e6,
                found as f64 / qs.len() as f64
            );
            let (found, wall, _) = timed(|| {
                pool(threads).install(|| {
                    qs.par_iter()
                        .map(|&q| {
                            let mut k = 0usize;
                            map.within(q, r2, |_, _, _| k += 1);
                            k
                        })
                        .sum::<usize>()
                })
            });
            println!(
                "| {n} | kd-tree | {build:.3} | {kd_bytes:.0} | radius {:.4} | {threads} | {:.3} | {:.1} |",
                r2.sqrt(),
                qs.len() as f64 / wall / 1e6,
                found as f64 / qs.len() as f64
            );
        }
        let (grid, grid_build, _) =
            timed(|| pool(2).install(|| HashGrid::new(&photons, r2.sqrt())));
        let grid_bytes = (n * std::mem::size_of::<Photon>() + n.max(1) * std::mem::size_of::<u32>())
            as f64
            / n as f64;
        for threads in [1, 2] {
            let (found, wall, _) = timed(|| {
                pool(threads).install(|| {
                    qs.par_iter()
                        .map(|&q| {
                            let mut k = 0usize;
                            grid.within(q, |_, _| k += 1);
                            k
                        })
                        .sum::<usize>()
                })
            });
            println!(
                "| {n} | hash grid | {grid_build:.3} | {grid_bytes:.0} | radius {:.4} | {threads} | {:.3} | {:.1} |",
                r2.sqrt(),
                qs.len() as f64 / wall / 1e6,
                found as f64 / qs.len() as f64
            );
        }
    }
}
