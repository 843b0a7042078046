//! `lightlab run`, `lightlab plot` and `lightlab merge`: experiments from the command line.

use crate::progress::{Bar, Unit};
use clap::Args;
use indicatif::MultiProgress;
use lightlab_experiments::desc::load_experiment;
use lightlab_experiments::plan::expand;
use lightlab_experiments::report::{finished_runs, missing_inputs, plot_from_csv, write_report};
use lightlab_experiments::runner::{
    ExperimentIdentity, RunOptions, merge, output_dir, run_experiment, write_source,
};
use std::io::IsTerminal;
use std::path::PathBuf;

/// Run an experiment (a RON sweep file, see experiments/README.md): render every run that has not
/// finished yet, compare it with the cached reference, and write runs.csv, summary.json, SVG plots
/// and per-run images under RESULTS/<name>/. Interrupted runs resume where they stopped.
#[derive(Args)]
pub struct RunArgs {
    /// Experiment file (RON).
    experiment: PathBuf,
    /// Root directory of results (the experiment writes RESULTS/<name>/, references are cached in
    /// RESULTS/references/).
    #[arg(long, default_value = "results")]
    results: PathBuf,
    /// Run only shard I of N (1-based, e.g. 3/8): the runs with index mod N = I − 1. Shards share
    /// nothing but the results directory; `lightlab merge` combines shards written elsewhere.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<(u32, u32)>,
    /// Worker threads (1…1024; each is an OS thread with its own stack). Default: all cores.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Directory of the cached references (default RESULTS/references/). Point shards with their
    /// own --results at one shared directory so that each reference is rendered once.
    #[arg(long)]
    references: Option<PathBuf>,
    /// Only render (or find in the cache) the references, then stop: run this once before the
    /// shards of a cluster job, which then read them (a shard that finds a reference being
    /// rendered by another process waits for it).
    #[arg(long)]
    reference_only: bool,
}

fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("'{s}' is not a shard: write I/N with 1 ≤ I ≤ N, e.g. 2/4");
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (u32, u32) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if i == 0 || n == 0 || i > n {
        return Err(bad());
    }
    Ok((i - 1, n))
}

pub fn run(args: RunArgs) -> Result<(), String> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = args.threads {
        pool = pool.num_threads(t as usize);
    }
    let pool = pool
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let bars = MultiProgress::new();
    let overall = Bar::new("runs", Unit::Count("runs"));
    let per_run = Bar::new("run ", Unit::Percent);
    bars.add(overall.bar.clone());
    bars.add(per_run.bar.clone());
    let terminal = std::io::stderr().is_terminal();
    let log = |m: &str| {
        if terminal {
            bars.println(m).unwrap_or(())
        } else {
            eprintln!("{m}")
        }
    };
    let desc = load_experiment(&args.experiment).map_err(|e| e.to_string())?;
    let out_dir = output_dir(&desc, &args.results);
    let (done, command) = (
        overall.bar.clone(),
        std::env::args().collect::<Vec<_>>().join(" "),
    );
    crate::interrupt::on_interrupt(move || {
        format!(
            "interrupted after {} runs of this session; every finished run is kept in {} \
             (runs are written atomically, a run counts once its metrics.json exists); run the \
             same command again to resume — finished runs are skipped:\n  {command}",
            done.position(),
            out_dir.join("runs").display()
        )
    });
    let options = RunOptions {
        results: args.results,
        shard: args.shard,
        references: args.references,
        reference_only: args.reference_only,
    };
    let outcome =
        pool.install(|| run_experiment(&args.experiment, &options, &overall, &per_run, &log))?;
    overall.finish();
    per_run.finish();
    for w in &outcome.warnings {
        eprintln!("warning: {w}");
    }
    if args.reference_only {
        println!(
            "references ready for the {} runs of the experiment; now run its shards",
            outcome.total
        );
        return Ok(());
    }
    println!(
        "{} runs in the experiment{}; {} rendered now, {} already finished",
        outcome.total,
        args.shard
            .map_or(String::new(), |(i, n)| format!(" (shard {}/{n})", i + 1)),
        outcome.ran,
        outcome.skipped
    );
    if outcome.report_written {
        println!(
            "results in {}: index.html (the report), runs.csv, summary.json, *.svg, runs/",
            outcome.out_dir.display()
        );
    } else {
        println!(
            "results in {}: runs/; the report and tables there were not rebuilt (see the warning \
             above)",
            outcome.out_dir.display()
        );
    }
    Ok(())
}

/// Redraw an experiment's SVG plots from its runs.csv, without rendering anything.
#[derive(Args)]
pub struct PlotArgs {
    /// The experiment's results directory (RESULTS/<name>/, holding runs.csv), or its runs.csv.
    dir: PathBuf,
}

pub fn plot(args: PlotArgs) -> Result<(), String> {
    // A path to the table itself means the directory holding it.
    let dir = match args.dir.file_name() {
        Some(name) if args.dir.is_file() && name == "runs.csv" => args
            .dir
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .to_path_buf(),
        _ => args.dir.clone(),
    };
    let files = plot_from_csv(&dir).map_err(|e| e.to_string())?;
    println!(
        "wrote {} plots in {}: {}",
        files.len(),
        dir.display(),
        files.join(", ")
    );
    Ok(())
}

/// Rebuild an experiment's report (index.html), tables and plots from the runs on disk, without
/// rendering anything.
#[derive(Args)]
pub struct ReportArgs {
    /// The experiment file (its results are RESULTS/<name>/).
    experiment: PathBuf,
    /// Root directory of results.
    #[arg(long, default_value = "results")]
    results: PathBuf,
}

pub fn report(args: ReportArgs) -> Result<(), String> {
    let desc = load_experiment(&args.experiment).map_err(|e| e.to_string())?;
    let out_dir = output_dir(&desc, &args.results);
    let runs = finished_runs(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    if runs.is_empty() {
        return Err(format!(
            "{} holds no finished runs of experiment {:?}: run it first (lightlab run {})",
            out_dir.display(),
            desc.name,
            args.experiment.display()
        ));
    }
    // Rebuilding without the images would drop bias², variance and the mean images from
    // summary.json: refuse instead (results committed without their EXR files are like that).
    let missing = missing_inputs(&out_dir, &runs);
    if let Some(first) = missing.first() {
        return Err(format!(
            "the report needs every run's image and its reference; {} file(s) missing (first: {}): \
             nothing was rewritten. Results kept without their EXR files (as committed) cannot be \
             summarised again, and rerunning into the same directory skips their finished runs: \
             rerun into another one (lightlab run {} --results OTHER), which renders the same runs \
             with the same seeds",
            missing.len(),
            first.display(),
            args.experiment.display()
        ));
    }
    // Runs the experiment plans that have no results (not run yet, or deleted): the settings
    // they belong to are summarised from fewer trials, which the report cannot tell by itself.
    let planned = expand(&desc, &args.experiment).map_err(|e| e.to_string())?;
    // Not runs of another version of the experiment, or of other inputs.
    if let Some(found) = ExperimentIdentity::read(&out_dir) {
        let scenes = lightlab_experiments::runner::load_scenes(&desc, &args.experiment)?;
        ExperimentIdentity::of(&desc, &args.experiment, &planned, &scenes)?
            .check(&found, &out_dir)?;
    }
    let finished: std::collections::BTreeSet<&str> = runs.iter().map(|r| r.id.as_str()).collect();
    let unfinished: Vec<&str> = planned
        .iter()
        .map(|r| r.id.as_str())
        .filter(|id| !finished.contains(id))
        .collect();
    if let Some(first) = unfinished.first() {
        eprintln!(
            "warning: {} of the experiment's {} runs have no results (first: {first}); their \
             settings are summarised from the trials there are: `lightlab run {}` renders them",
            unfinished.len(),
            planned.len(),
            args.experiment.display()
        );
    }
    write_source(&args.experiment, &out_dir)?;
    write_report(&out_dir).map_err(|e| e.to_string())?;
    println!(
        "wrote {} from {} of {} runs (and runs.csv, summary.json, the plots)",
        out_dir.join("index.html").display(),
        runs.len(),
        planned.len()
    );
    Ok(())
}

/// Combine the results of shards run with separate results directories (e.g. on several machines)
/// into RESULTS/<name>/ and rewrite its tables and plots.
#[derive(Args)]
pub struct MergeArgs {
    /// The experiment file the shards ran.
    experiment: PathBuf,
    /// The shards' experiment directories (each SHARD_RESULTS/<name>/).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Root directory of the merged results.
    #[arg(long, default_value = "results")]
    results: PathBuf,
    /// Merge even if some of the experiment's runs are in no shard (they are listed); without it
    /// a merge with missing runs fails and writes nothing.
    #[arg(long)]
    partial: bool,
}

pub fn merge_shards(args: MergeArgs) -> Result<(), String> {
    let desc = load_experiment(&args.experiment).map_err(|e| e.to_string())?;
    let out = output_dir(&desc, &args.results);
    let m = merge(&args.experiment, &out, &args.shards, args.partial)?;
    println!("merged {} runs into {}", m.copied, out.display());
    if m.duplicated > 0 {
        eprintln!(
            "warning: {} runs were in more than one shard; the first copy was kept",
            m.duplicated
        );
    }
    if !m.missing.is_empty() {
        eprintln!(
            "warning: partial merge: {} runs of the experiment are missing (first: {})",
            m.missing.len(),
            m.missing[0]
        );
    }
    Ok(())
}

/// Measure how fast each sampler converges: integrate analytic 2D test functions (Gaussian, disk,
/// step, oblique edge, checkerboard) with every sampler at 1, 2, 4, … samples over independent
/// seeds, and write the MSE per sample count (convergence.csv), the fitted log–log slopes with 95 %
/// intervals (rates.json) and one SVG plot per function to RESULTS/convergence/.
#[derive(Args)]
pub struct ConvergenceArgs {
    /// Largest sample count (a power of two is reached exactly).
    #[arg(long, default_value_t = 4096, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    max_spp: u32,
    /// Independent seeds per sample count: 2 to 16 777 216 (each sample count keeps every seed's
    /// error in memory, 8 bytes each).
    #[arg(long, default_value_t = 256, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(2..=1 << 24))]
    seeds: u32,
    /// Smallest sample count in the slope fit (rates are asymptotic).
    #[arg(long, default_value_t = 16, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    fit_from: u32,
    /// Root directory of results.
    #[arg(long, default_value = "results")]
    results: PathBuf,
}

pub fn convergence(args: ConvergenceArgs) -> Result<(), String> {
    use lightlab_experiments::atomic::write_atomic;
    use lightlab_experiments::convergence::{FUNCTIONS, Study, plot, run};
    // The sample counts are the powers of two up to --max-spp; a slope needs two of them.
    let fitted = (0..32)
        .map(|k| 1u64 << k)
        .filter(|&n| n >= args.fit_from as u64 && n <= args.max_spp as u64)
        .count();
    if fitted < 2 {
        return Err(format!(
            "--fit-from {} leaves {fitted} sample count (1, 2, 4, … up to --max-spp {}) for the \
             slope fit, which needs two: lower --fit-from or raise --max-spp",
            args.fit_from, args.max_spp
        ));
    }
    let study = Study {
        max_spp: args.max_spp,
        seeds: args.seeds,
        fit_from: args.fit_from,
    };
    let bar = Bar::new("functions × samplers", Unit::Count("curves"));
    let (points, rates) = run(&study, &bar);
    bar.finish();
    let dir = args.results.join("convergence");
    let io = |e: std::io::Error| format!("{}: {e}", dir.display());
    let mut csv = String::from("function,sampler,spp,mse,mse_se\n");
    for p in &points {
        csv += &format!(
            "{},{},{},{:e},{:e}\n",
            p.function, p.sampler, p.spp, p.mse, p.mse_se
        );
    }
    write_atomic(&dir.join("convergence.csv"), csv.as_bytes()).map_err(io)?;
    let json = serde_json::json!({
        "max_spp": study.max_spp, "seeds": study.seeds, "fit_from": study.fit_from,
        "fit": "weighted least squares of ln MSE on ln spp over spp ≥ fit_from, each point weighted by its own standard error (disjoint seeds per sample count); slope_ci95 is the half-width of the 95 % interval (1.96 standard errors, or, when chi2/dof exceeds 1, Student's t on n − 2 degrees of freedom times the standard error widened by sqrt(chi2/dof); null when it cannot be bounded)",
        "rates": rates,
    });
    write_atomic(
        &dir.join("rates.json"),
        serde_json::to_string_pretty(&json)
            .expect("json")
            .as_bytes(),
    )
    .map_err(io)?;
    for f in &FUNCTIONS {
        let svg = lightlab_experiments::plot::render_svg(&plot(f.name, &points, &rates))?;
        write_atomic(&dir.join(format!("{}.svg", f.name)), svg.as_bytes()).map_err(io)?;
    }
    // The sample counts fitted: the powers of two from --fit-from to --max-spp.
    let counts = || (0..32).map(|k| 1u64 << k);
    let first = counts().find(|&n| n >= study.fit_from as u64).unwrap_or(0);
    let last = counts()
        .take_while(|&n| n <= study.max_spp as u64)
        .last()
        .unwrap_or(0);
    println!(
        "log–log slope of MSE against samples (spp {first}…{last}, {} seeds), ± 95 % interval \
         (— where too few points have a standard error to bound it):",
        study.seeds
    );
    print!("{:<15}", "function");
    let samplers = lightlab_samplers::SamplerConfig::ALL;
    for s in samplers {
        print!("{:>18}", s.name());
    }
    println!();
    for f in &FUNCTIONS {
        print!("{:<15}", f.name);
        for s in samplers {
            match rates
                .iter()
                .find(|r| r.function == f.name && r.sampler == s.name())
            {
                Some(r) if r.fit.slope_ci95.is_finite() => print!(
                    "{:>18}",
                    format!("{:.2} ± {:.2}", r.fit.slope, r.fit.slope_ci95)
                ),
                Some(r) => print!("{:>18}", format!("{:.2} ± —", r.fit.slope)),
                None => print!("{:>18}", "—"),
            }
        }
        println!();
    }
    println!(
        "wrote {}: convergence.csv, rates.json, one SVG per function",
        dir.display()
    );
    Ok(())
}
