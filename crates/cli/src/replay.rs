//! `lightlab replay`: recompute one pixel sample of a bidirectional render (BDPT or VCM), every
//! technique's contribution with its provenance, from (seed, pixel, sample index) alone.

use crate::scene_args::SceneArgs;
use clap::Args;
use lightlab_integrators::IntegratorConfig;
use lightlab_integrators::Vcm;
use lightlab_integrators::bdpt::Bdpt;
use std::io::Write;

/// Replay one pixel sample of a `Bdpt` or `Vcm` render deterministically — e.g. an outlier from
/// OUT.outliers.json — and print every technique's contribution: (s, t) (and `merge` for a VCM
/// merge), path class, weighted and unweighted value, MIS weight and the path's area-measure
/// densities, as JSON. For `Vcm` the sample index is the pass, whose light subpaths are retraced.
#[derive(Args)]
pub struct ReplayArgs {
    /// The scene as the render read it (give the same --set, -D and --resolution).
    #[command(flatten)]
    source: SceneArgs,
    /// The render's integrator settings (`Bdpt(...)` or `Vcm(...)`).
    #[arg(long, short)]
    integrator: String,
    /// The render's seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The render's samples per pixel (stratified samplers depend on it).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    spp: u32,
    /// Pixel as X,Y.
    #[arg(long, value_parser = parse_pixel)]
    pixel: (u32, u32),
    /// Sample index within the pixel (0-based, < spp).
    #[arg(long)]
    sample: u64,
}

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("pixel must be X,Y, got {s:?}"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|e| format!("pixel coordinate {v:?}: {e}"))
    };
    Ok((n(x)?, n(y)?))
}

pub fn run(args: ReplayArgs) -> Result<(), String> {
    let config = IntegratorConfig::from_ron(&args.integrator)
        .map_err(|e| format!("--integrator '{}': {e}", args.integrator))?;
    if !matches!(config, IntegratorConfig::Bdpt(_) | IntegratorConfig::Vcm(_)) {
        return Err("replay works on Bdpt(...) and Vcm(...) renders".into());
    }
    let (scene, _, _) = args.source.load(true)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    if args.pixel.0 >= w || args.pixel.1 >= h {
        return Err(format!(
            "pixel ({}, {}) is outside the {w}×{h} image",
            args.pixel.0, args.pixel.1
        ));
    }
    if args.sample >= args.spp as u64 {
        return Err(format!(
            "sample {} does not exist at {} spp (indices are 0…{})",
            args.sample,
            args.spp,
            args.spp - 1
        ));
    }
    // The render being replayed passed the same check (replicates must divide the samples).
    config
        .build()?
        .check_budget(&lightlab_integrators::Budget::Samples(args.spp))?;
    let (seed, spp, pixel, sample) = (args.seed, args.spp, args.pixel, args.sample);
    let contributions = match config {
        IntegratorConfig::Bdpt(c) => Bdpt::new(c)?.replay(&scene, seed, spp, pixel, sample),
        IntegratorConfig::Vcm(c) => Vcm::new(c)?.replay(&scene, seed, spp, pixel, sample),
        _ => unreachable!("checked above"),
    };
    let json = serde_json::to_string_pretty(&contributions).expect("contributions serialise");
    // A closed pipe (`| head`) is not an error.
    match writeln!(std::io::stdout(), "{json}") {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(format!("stdout: {e}")),
        _ => Ok(()),
    }
}
