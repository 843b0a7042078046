//! `lightlab render`: one image of one scene with one integrator.

use crate::progress::Bar;
use clap::Args;
use lightlab_experiments::atomic::write_atomic;
use lightlab_experiments::image_io::{output_layers, write_exr, write_png};
use lightlab_integrators::paths::Layers;
use lightlab_integrators::{Budget, IntegratorConfig};
use std::path::PathBuf;

/// Render a scene and write OUT.exr (layers `radiance` and `variance`, linear float, plus any
/// path-class or bounce layers asked for), OUT.png (tone-mapped sRGB preview) and OUT.json
/// (statistics: time, samples, rays, non-finite samples).
#[derive(Args)]
pub struct RenderArgs {
    /// Scene file (RON), see scenes/README.md.
    scene: PathBuf,
    /// Integrator and its settings as RON, e.g. 'Path(max_bounces: 8, strategy: Mis)'.
    #[arg(long, short, default_value = "Path()")]
    integrator: String,
    /// Samples per pixel (≥ 1): camera paths per pixel, light paths per pixel for light tracing,
    /// passes for progressive photon mapping.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..), conflicts_with = "seconds")]
    spp: u32,
    /// Render for this many wall-clock seconds instead of a sample count: samples continue until
    /// the time is spent, so the image is the one `--spp` would give at the count reached (see
    /// the README, "Time budgets").
    #[arg(long, allow_negative_numbers = true)]
    seconds: Option<f64>,
    /// Seed of the random numbers: the same seed gives the same image, bit for bit, on any number of
    /// threads.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (≥ 1). Default: all cores.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..))]
    threads: Option<u32>,
    /// Output EXR path; the PNG and JSON are written beside it with the same stem.
    #[arg(long, short, default_value = "out.exr")]
    output: PathBuf,
    /// Render only the paths this Heckbert expression matches, e.g. 'LS+DE' (caustics); see the
    /// README's "Path classes". Overrides the integrator's `paths`.
    #[arg(long)]
    paths: Option<String>,
    /// Write extra EXR layers: `bounces` (one per bounce count: the Neumann series term by term)
    /// or comma-separated path expressions, e.g. 'LS+DE,LDE' (each layer holds the paths its
    /// expression matches first; a `rest` layer the others). The layers sum to the image.
    #[arg(long)]
    layers: Option<String>,
    /// Exposure of the PNG preview in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
}

pub fn run(args: RenderArgs) -> Result<(), String> {
    let layers = args.layers.as_deref().map(|l| match l.trim() {
        "bounces" => Layers::Bounces,
        list => Layers::Classes(list.split(',').map(|e| e.trim().to_string()).collect()),
    });
    let config = IntegratorConfig::from_ron(&args.integrator)
        .map_err(|e| format!("--integrator '{}': {e}", args.integrator))?
        .with_paths_and_layers(args.paths.clone(), layers)?;
    let budget = match args.seconds {
        Some(s) => Budget::Seconds(s),
        None => Budget::Samples(args.spp),
    };
    budget.check().map_err(|e| format!("--seconds: {e}"))?;
    let scene = lightlab_scene::load_scene(&args.scene).map_err(|e| e.to_string())?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = args.threads {
        pool = pool.num_threads(t as usize);
    }
    let pool = pool
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let integrator = config.build();
    integrator
        .check_scene(&scene)
        .map_err(|e| format!("{}: {e}", args.scene.display()))?;
    let bar = Bar::new("render");
    let out = pool.install(|| integrator.render(&scene, &budget, args.seed, &bar));
    bar.0.finish_and_clear();

    let (w, h) = (out.film.width, out.film.height);
    let layers = output_layers(&out);
    write_exr(&args.output, w, h, &layers).map_err(|e| e.to_string())?;
    let png = args.output.with_extension("png");
    write_png(&png, w, h, &layers[0].pixels, args.exposure).map_err(|e| e.to_string())?;
    let json_path = args.output.with_extension("json");
    let json = serde_json::json!({
        "scene": args.scene.display().to_string(),
        "integrator": config.to_ron(),
        "lightlab_version": env!("CARGO_PKG_VERSION"),
        "stats": out.stats,
    });
    write_atomic(
        &json_path,
        serde_json::to_string_pretty(&json)
            .expect("stats serialise")
            .as_bytes(),
    )
    .map_err(|e| format!("{}: {e}", json_path.display()))?;

    let s = &out.stats;
    println!(
        "{}: {}×{} at {} spp in {:.2} s on {} threads — {:.2} M rays/s, {:.2} M samples/s",
        s.integrator,
        w,
        h,
        s.spp,
        s.wall_seconds,
        s.threads,
        s.rays_per_second * 1e-6,
        s.samples_per_second * 1e-6
    );
    println!(
        "image mean radiance (R, G, B) = {}",
        image_mean(out.film.average(), out.film.image_se, s.spp)
    );
    if !s.pixel_variance.is_estimate() {
        println!(
            "  (the variance layer is not the variance of the pixel mean: {:?})",
            s.pixel_variance
        );
    }
    if s.non_finite_total() > 0 {
        eprintln!(
            "warning: {} non-finite contributions were left out of the image: {:?}",
            s.non_finite_total(),
            s.non_finite
        );
    }
    if !out.outliers.is_empty() {
        let path = args.output.with_extension("outliers.json");
        let json = serde_json::json!({
            "scene": args.scene.display().to_string(),
            "integrator": config.to_ron(),
            "seed": args.seed,
            "spp": out.stats.spp,
            "replay": "lightlab replay SCENE --integrator '…' --seed SEED --spp SPP --pixel X,Y --sample I",
            "outliers": out.outliers,
        });
        write_atomic(
            &path,
            serde_json::to_string_pretty(&json)
                .expect("outliers serialise")
                .as_bytes(),
        )
        .map_err(|e| format!("{}: {e}", path.display()))?;
        println!(
            "{} outliers logged by strategy {:?}: {}",
            out.outliers.len(),
            out.stats.outliers,
            path.display()
        );
    }
    for (name, film) in &out.layers {
        println!(
            "  layer {name:>12}: {}",
            image_mean(film.average(), film.image_se, s.spp)
        );
    }
    println!(
        "wrote {}, {}, {}",
        args.output.display(),
        png.display(),
        json_path.display()
    );
    Ok(())
}

/// The image average with its standard error where one exists, saying what the error is.
fn image_mean(mean: [f64; 3], se: Option<[f64; 3]>, spp: u32) -> String {
    let m = format!("({:.6}, {:.6}, {:.6})", mean[0], mean[1], mean[2]);
    match se {
        Some(e) => format!(
            "{m} ± ({:.2e}, {:.2e}, {:.2e}) (1 standard error, from the spread of {spp} independent sample passes)",
            e[0], e[1], e[2]
        ),
        None => format!(
            "{m} (no standard error: this integrator's or sampler's passes are not independent; measure it across seeds)"
        ),
    }
}
