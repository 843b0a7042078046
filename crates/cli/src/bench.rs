//! `lightlab bench`: speed and error per sample of integrators, measured side by side in one run.

use crate::progress::{Bar, Unit};
use crate::scene_args::parse_resolution;
use clap::Args;
use lightlab_core::NoProgress;
use lightlab_experiments::atomic::write_atomic;
use lightlab_experiments::desc::ReferenceDesc;
use lightlab_experiments::image_io::output_layers;
use lightlab_experiments::metrics::{REL_EPSILON, errors};
use lightlab_experiments::reference::reference;
use lightlab_experiments::runner::load_scene;
use lightlab_integrators::{Budget, IntegratorConfig};
use lightlab_testkit::timing::{build_simd, cpu_model, peak_rss_bytes, timed};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Benchmark integrators: for each scene, integrator and thread count, timed renders with
/// independent seeds (--trials, after a one-sample warm-up on the same threads; trial 1 of every
/// row, then trial 2, …, so that a drift of the machine's speed falls on all rows alike) and their
/// error against a cached high-sample reference.
/// Prints a Markdown table of paths per CPU-second (a camera path for Path and the photon-mapping
/// integrators, a light path for Light, a camera–light subpath pair for Bdpt and Vcm), photon
/// paths per CPU-second (photon-mapping integrators and Vcm's light paths; each row's rate counts
/// the whole render's CPU time), rays per second, relMSE, relMSE × spp (for an unbiased estimator
/// the relative variance of one sample, constant in spp and so comparable across integrators run
/// at different spp; for a biased one it also holds spp × bias², which grows with spp) and
/// efficiency 1 / (mean relMSE × mean CPU seconds), a ratio of means over the trials.
/// CPU time is the process's user + system time over all threads (/proc/self/stat), so rates per
/// CPU-second compare thread counts fairly. Figures are ratios within one run: compare rows,
/// not runs on different days (BENCHMARKS.md).
#[derive(Args)]
pub struct BenchArgs {
    /// Scene files. Default: scenes/cornell-box.ron and scenes/caustic-sphere.ron.
    scenes: Vec<PathBuf>,
    /// An integrator and its samples per pixel as INTEGRATOR@SPP, e.g. 'Path(russian_roulette: 5)@64'
    /// (repeatable). Default: Path()@256, Path(sampler: Sobol)@256, Light()@256, Bdpt()@32,
    /// Vcm()@32, Sppm()@64, PhotonMap()@1.
    #[arg(short, long)]
    integrator: Vec<String>,
    /// Thread counts to run each integrator on, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub(crate) threads: Vec<usize>,
    /// Image size WIDTHxHEIGHT of every render and of the reference.
    #[arg(long, value_parser = parse_resolution, default_value = "128x128")]
    resolution: (u32, u32),
    /// Integrator of the reference (RON).
    #[arg(long, default_value = "Bdpt()")]
    reference: String,
    /// Samples per pixel of the reference (rendered once on all cores, then cached).
    #[arg(long, default_value_t = 4096)]
    reference_spp: u32,
    /// Directory of cached references, shared with `lightlab run`.
    #[arg(long, default_value = "results/references")]
    references: PathBuf,
    /// Seed of the first trial; trial k renders with seed SEED + k.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Timed renders per row, with independent seeds: times and relMSE are their means, relMSE
    /// with its standard error over the trials (from 2 trials on).
    #[arg(long, default_value_t = 3)]
    trials: u32,
    /// Also write the rows as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// One scene, integrator and thread count, measured over `trials` renders.
#[derive(Serialize)]
struct Row {
    scene: String,
    integrator: String,
    threads: usize,
    spp: u32,
    trials: u32,
    /// Camera (light, subpath-pair) paths of one trial.
    paths: u64,
    /// Means over the trials.
    wall_seconds: f64,
    cpu_seconds: f64,
    cpu_seconds_per_trial: Vec<f64>,
    rel_mse_per_trial: Vec<f64>,
    /// `None` when the render took less CPU time than the clock resolves (10 ms).
    paths_per_cpu_second: Option<f64>,
    /// The mean CPU time is under `PRECISE_TICKS` ticks of the 10 ms clock: the CPU rates and the
    /// efficiency carry more than 2 % rounding (marked `~` in the table).
    cpu_rates_rounded: bool,
    /// Photon paths traced in one trial (0 for integrators without photons).
    photon_paths: u64,
    /// `None` without photons or when the CPU time is below the clock's resolution.
    photon_paths_per_cpu_second: Option<f64>,
    rays_per_second: f64,
    rays_per_path: f64,
    /// Mean over the trials, and its standard error (`None` for one trial).
    rel_mse: f64,
    rel_mse_se: Option<f64>,
    rel_mse_times_spp: f64,
    efficiency: Option<f64>,
    /// The machine: its CPU model (`None` where /proc/cpuinfo does not name it) and logical CPUs;
    /// and the widest SIMD instruction set the build was compiled for.
    cpu_model: Option<String>,
    logical_cpus: usize,
    build_simd: &'static str,
}

/// Seconds per tick of the CPU-time clock (/proc/self/stat counts in 10 ms ticks).
const CLOCK_TICK: f64 = 0.01;
/// Ticks of CPU time below which a row's CPU rates are marked as rounded (50: 2 %).
const PRECISE_TICKS: f64 = 50.0;

/// One row in the making: an integrator on a pool of threads, and its trials so far.
struct Cell<'a> {
    label: &'a str,
    config: &'a IntegratorConfig,
    spp: u32,
    threads: usize,
    integrator: &'a dyn lightlab_integrators::Integrator,
    pool: &'a rayon::ThreadPool,
    trials: Trials,
}

/// What a cell's trials measured: per trial, and the paths and photons of one trial with the rays
/// of all.
#[derive(Default)]
struct Trials {
    walls: Vec<f64>,
    cpus: Vec<f64>,
    rel_mses: Vec<f64>,
    paths: u64,
    photons: u64,
    rays: u64,
}

/// `INTEGRATOR@SPP`, checked: the integrator as written, its settings and its spp.
fn parse_spec(s: &str) -> Result<(String, IntegratorConfig, u32), String> {
    let (ron, spp) = s
        .rsplit_once('@')
        .ok_or_else(|| format!("--integrator '{s}': write INTEGRATOR@SPP, e.g. 'Path()@64'"))?;
    let spp: u32 =
        spp.trim().parse().ok().filter(|&n| n >= 1).ok_or_else(|| {
            format!("--integrator '{s}': samples per pixel must be an integer ≥ 1")
        })?;
    let config = IntegratorConfig::from_ron(ron).map_err(|e| {
        format!("--integrator '{s}': the integrator '{ron}' before the last '@': {e}")
    })?;
    Ok((ron.trim().to_string(), config, spp))
}

pub fn run(args: BenchArgs) -> Result<(), String> {
    // Said before the benchmark runs, not after it.
    if let Some(json) = &args.json {
        let dir = json.parent().filter(|d| !d.as_os_str().is_empty());
        if crate::render::names_directory(json) {
            return Err(format!(
                "--json {}: names a directory; give a file name",
                json.display()
            ));
        }
        if let Some(dir) = dir
            && !dir.is_dir()
        {
            return Err(format!(
                "--json {}: the directory {} does not exist",
                json.display(),
                dir.display()
            ));
        }
    }
    let specs: Vec<String> = if args.integrator.is_empty() {
        [
            "Path()@256",
            // The same estimator with the sampler that buys most per CPU-second on the Cornell box.
            "Path(sampler: Sobol)@256",
            "Light()@256",
            "Bdpt()@32",
            "Vcm()@32",
            "Sppm()@64",
            "PhotonMap()@1",
        ]
        .map(String::from)
        .to_vec()
    } else {
        args.integrator.clone()
    };
    let integrators = specs
        .iter()
        .map(|s| parse_spec(s))
        .collect::<Result<Vec<_>, _>>()?;
    if args.trials == 0 {
        return Err("--trials must be ≥ 1".into());
    }
    if args.threads.iter().any(|t| !(1..=1024).contains(t)) {
        return Err(format!(
            "--threads: every thread count must be 1…1024, got {:?}",
            args.threads
        ));
    }
    if args.reference_spp == 0 {
        return Err("--reference-spp must be ≥ 1".into());
    }
    let scenes = if args.scenes.is_empty() {
        vec![
            PathBuf::from("scenes/cornell-box.ron"),
            PathBuf::from("scenes/caustic-sphere.ron"),
        ]
    } else {
        args.scenes.clone()
    };
    let reference_desc = ReferenceDesc::Render {
        integrator: args.reference.clone(),
        spp: args.reference_spp,
    };
    // Built once: an integrator and a pool per thread count serve every scene.
    let built = integrators
        .iter()
        .map(|(_, config, _)| config.build())
        .collect::<Result<Vec<_>, _>>()?;
    let pools = args
        .threads
        .iter()
        .map(|&threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| format!("cannot start worker threads: {e}"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    let cpu_model = cpu_model();
    let logical_cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Rates and ratios hold for one machine and one build: say which.
    println!(
        "Machine: {logical_cpus} logical CPUs, {}; this build uses {} vectors\n",
        cpu_model.as_deref().unwrap_or("CPU model unknown"),
        build_simd()
    );
    println!(
        "| scene | integrator | threads | spp | wall s | CPU s | M paths / CPU-s | M photon paths / CPU-s | M rays / s | rays per path | relMSE | relMSE × spp | efficiency |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for path in &scenes {
        let (scene, text) = load_scene(path, Some(args.resolution))?;
        let name = path
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        let bar = Bar::new("reference", Unit::Percent);
        let log = |m: &str| eprintln!("{m}");
        let r = reference(
            &reference_desc,
            path.parent().unwrap_or(Path::new(".")),
            &args.references,
            &name,
            &text,
            &scene,
            &[],
            &bar,
            &log,
        )?;
        bar.finish();
        eprintln!(
            "reference for {name}: {} ({})",
            r.path.display(),
            if r.cached { "cached" } else { "rendered now" }
        );
        // One cell per integrator and thread count, each warmed up on its own threads; then the
        // trials go round-robin (trial 1 of every cell, then trial 2, …), so that a drift of the
        // machine's speed during the run falls on every row alike rather than on the last ones.
        let mut cells = Vec::new();
        for ((label, config, spp), integrator) in integrators.iter().zip(&built) {
            lightlab_integrators::memory::check_render(
                &**integrator,
                &scene,
                &Budget::Samples(*spp),
            )
            .map_err(|e| format!("{}: {e}", path.display()))?;
            for (&threads, pool) in args.threads.iter().zip(&pools) {
                pool.install(|| integrator.render(&scene, &Budget::Samples(1), 0, &NoProgress));
                cells.push(Cell {
                    label,
                    config,
                    spp: *spp,
                    threads,
                    integrator: &**integrator,
                    pool,
                    trials: Trials::default(),
                });
            }
        }
        for trial in 0..args.trials as u64 {
            let seed = args.seed.wrapping_add(trial);
            for cell in &mut cells {
                let budget = Budget::Samples(cell.spp);
                let (out, wall, cpu) = timed(|| {
                    cell.pool
                        .install(|| cell.integrator.render(&scene, &budget, seed, &NoProgress))
                });
                let layers = output_layers(&out);
                let e = errors(&layers[0].pixels, &r.image)
                    .ok_or("image and reference sizes differ")?;
                let t = &mut cell.trials;
                t.walls.push(wall);
                t.cpus.push(cpu);
                t.rel_mses.push(e.rel_mse);
                (t.paths, t.photons, t.rays) = (
                    out.stats.samples,
                    out.stats.photons,
                    t.rays + out.stats.rays,
                );
            }
        }
        for cell in cells {
            let (label, config, spp, threads) = (cell.label, cell.config, cell.spp, cell.threads);
            let Trials {
                walls,
                cpus,
                rel_mses,
                paths,
                photons,
                rays,
            } = cell.trials;
            let n = args.trials as f64;
            let (wall, cpu) = (walls.iter().sum::<f64>() / n, cpus.iter().sum::<f64>() / n);
            let rel_mse = rel_mses.iter().sum::<f64>() / n;
            // The trials are independent renders: the standard error of their mean.
            let rel_mse_se = (args.trials > 1).then(|| {
                let ss = rel_mses.iter().map(|x| (x - rel_mse).powi(2)).sum::<f64>();
                (ss / (n - 1.0) / n).sqrt()
            });
            // Rates are totals over totals (a ratio of means, not a mean of ratios).
            let row = Row {
                scene: name.clone(),
                integrator: config.to_ron(),
                threads,
                spp,
                trials: args.trials,
                paths,
                wall_seconds: wall,
                cpu_seconds: cpu,
                cpu_seconds_per_trial: cpus,
                rel_mse_per_trial: rel_mses,
                paths_per_cpu_second: (cpu > 0.0).then(|| paths as f64 / cpu),
                cpu_rates_rounded: cpu < PRECISE_TICKS * CLOCK_TICK,
                photon_paths: photons,
                photon_paths_per_cpu_second: (cpu > 0.0 && photons > 0)
                    .then(|| photons as f64 / cpu),
                rays_per_second: rays as f64 / (wall * n),
                rays_per_path: rays as f64 / (paths as f64 * n),
                rel_mse,
                rel_mse_se,
                rel_mse_times_spp: rel_mse * spp as f64,
                // Undefined where the error is at or below the reference's noise (relMSE ≤ 0
                // once its variance is subtracted), as in experiments.
                efficiency: (cpu > 0.0 && rel_mse > 0.0).then(|| 1.0 / (rel_mse * cpu)),
                cpu_model: cpu_model.clone(),
                logical_cpus,
                build_simd: build_simd(),
            };
            let mark = if row.cpu_rates_rounded { "~" } else { "" };
            let or_dash = |x: Option<f64>, f: &dyn Fn(f64) -> String| {
                x.map_or("—".into(), |x| format!("{mark}{}", f(x)))
            };
            println!(
                "| {} | {} | {} | {} | {:.2} | {:.2} | {} | {} | {:.2} | {:.2} | {} | {:.3e} | {} |",
                row.scene,
                label,
                threads,
                spp,
                wall,
                cpu,
                or_dash(row.paths_per_cpu_second, &|r| format!("{:.3}", r / 1e6)),
                or_dash(row.photon_paths_per_cpu_second, &|r| format!(
                    "{:.3}",
                    r / 1e6
                )),
                row.rays_per_second / 1e6,
                row.rays_per_path,
                match row.rel_mse_se {
                    Some(se) => format!("{:.3e} ± {se:.1e}", row.rel_mse),
                    None => format!("{:.3e}", row.rel_mse),
                },
                row.rel_mse_times_spp,
                or_dash(row.efficiency, &|e| format!("{e:.1}"))
            );
            rows.push(row);
        }
    }
    if rows.iter().any(|r| r.cpu_rates_rounded) {
        println!(
            "\n~: the row's mean CPU time is under {PRECISE_TICKS} ticks of the {} ms CPU clock, so \
             its CPU rates and efficiency carry more than 2 % rounding (rows differing by one tick \
             can look 30 % apart): raise its spp before comparing them",
            CLOCK_TICK * 1e3
        );
    }
    println!(
        "\nEach row: the mean of {} timed renders with seeds {}…{}{}; rates are total paths or rays over total CPU or wall seconds. relMSE = \
         mean of ((x − r)² − v_r) / (r² + {REL_EPSILON}) over pixels and channels, r the reference \
         ({} at {} spp, {}×{}) and v_r its variance of the mean (less the first-order bias of dividing by \
         the noisy r: lightlab_experiments::metrics); efficiency — where a render took less CPU \
         time than the clock resolves (10 ms: raise its spp) or relMSE ≤ 0 (the error is within \
         the reference's noise: raise --reference-spp); peak resident memory {:.1} MB",
        args.trials,
        args.seed,
        args.seed.wrapping_add(args.trials as u64 - 1),
        if args.trials > 1 {
            " (± one standard error of the mean relMSE over them)"
        } else {
            ""
        },
        args.reference,
        args.reference_spp,
        args.resolution.0,
        args.resolution.1,
        peak_rss_bytes() as f64 / 1e6
    );
    if let Some(json) = &args.json {
        let text = serde_json::to_string_pretty(&rows).expect("rows serialise");
        write_atomic(json, text.as_bytes()).map_err(|e| format!("{}: {e}", json.display()))?;
    }
    Ok(())
}
