//! `lightlab`: render scenes with a chosen light-transport integrator and run experiments.

mod bench;
mod compare;
mod experiment;
mod interrupt;
mod progress;
mod render;
mod replay;
mod scene_args;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Lightlab: a light-transport research testbed. Renders RON scenes with path tracing and other
/// global-illumination methods, writes OpenEXR images with their variance, PNG previews and
/// statistics, and runs experiments that sweep methods and settings against a reference and report
/// error, bias, variance, time and efficiency.
#[derive(Parser)]
#[command(name = "lightlab", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Render(render::RenderArgs),
    Run(experiment::RunArgs),
    Plot(experiment::PlotArgs),
    Report(experiment::ReportArgs),
    Merge(experiment::MergeArgs),
    Convergence(experiment::ConvergenceArgs),
    Replay(replay::ReplayArgs),
    Compare(compare::CompareArgs),
    Bench(bench::BenchArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    interrupt::install();
    let result = match cli.command {
        Command::Render(args) => render::run(args),
        Command::Run(args) => experiment::run(args),
        Command::Plot(args) => experiment::plot(args),
        Command::Report(args) => experiment::report(args),
        Command::Merge(args) => experiment::merge_shards(args),
        Command::Convergence(args) => experiment::convergence(args),
        Command::Replay(args) => replay::run(args),
        Command::Compare(args) => compare::run(args),
        Command::Bench(args) => bench::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_is_well_formed() {
        Cli::command().debug_assert();
    }

    #[test]
    fn render_arguments_parse_and_reject_bad_values() {
        let ok = Cli::try_parse_from([
            "lightlab",
            "render",
            "s.ron",
            "--spp",
            "4",
            "--integrator",
            "Path(max_bounces: 2)",
        ]);
        assert!(ok.is_ok());
        for bad in [["--spp", "-1"], ["--spp", "0"], ["--threads", "0"]] {
            let r = Cli::try_parse_from(["lightlab", "render", "s.ron", bad[0], bad[1]]);
            assert!(r.is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn bench_threads_default_and_list() {
        // The default is written as the flag is ("1,2", which --help shows) and means 1 and 2.
        let threads = |extra: &[&str]| match Cli::try_parse_from(
            ["lightlab", "bench"].iter().chain(extra).copied(),
        ) {
            Ok(Cli {
                command: Command::Bench(args),
            }) => args.threads,
            other => panic!("{extra:?}: {:?}", other.err()),
        };
        assert_eq!(threads(&[]), [1, 2]);
        assert_eq!(threads(&["--threads", "2,1,4"]), [2, 1, 4]);
    }
}
