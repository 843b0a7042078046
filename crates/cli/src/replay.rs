//! `lightlab replay`: recompute one pixel sample of a bidirectional render, every strategy's
//! contribution with its provenance, from (seed, pixel, sample index) alone.

use clap::Args;
use lightlab_integrators::IntegratorConfig;
use lightlab_integrators::bdpt::Bdpt;
use std::io::Write;
use std::path::PathBuf;

/// Replay one pixel sample of a `Bdpt` render deterministically — e.g. an outlier from
/// OUT.outliers.json — and print every strategy's contribution: (s, t), path class, weighted and
/// unweighted value, MIS weight and the path's area-measure densities, as JSON.
#[derive(Args)]
pub struct ReplayArgs {
    /// Scene file (RON).
    scene: PathBuf,
    /// The render's integrator settings (must be `Bdpt(...)`).
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
    let IntegratorConfig::Bdpt(bdpt) = config else {
        return Err("replay works on Bdpt(...) renders".into());
    };
    let scene = lightlab_scene::load_scene(&args.scene).map_err(|e| e.to_string())?;
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
    let contributions =
        Bdpt::new(bdpt)?.replay(&scene, args.seed, args.spp, args.pixel, args.sample);
    let json = serde_json::to_string_pretty(&contributions).expect("contributions serialise");
    // A closed pipe (`| head`) is not an error.
    match writeln!(std::io::stdout(), "{json}") {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(format!("stdout: {e}")),
        _ => Ok(()),
    }
}
