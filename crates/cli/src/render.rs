//! `lightlab render`: one image of one scene with one integrator.

use crate::progress::{Bar, Unit};
use crate::scene_args::{SceneArgs, shell_quote};
use clap::Args;
use lightlab_experiments::atomic::write_atomic;
use lightlab_experiments::image_io::{f32_overflows, output_layers, write_exr, write_png};
use lightlab_integrators::paths::Layers;
use lightlab_integrators::{Budget, IntegratorConfig, PixelVariance, RenderStats};
use lightlab_testkit::timing::try_cpu_seconds;
use std::path::PathBuf;

/// Render a scene and write OUT.exr (layers `radiance` and `variance`, linear float, plus any
/// path-class or bounce layers asked for), OUT.png (tone-mapped sRGB preview) and OUT.json
/// (statistics: time, samples, rays, non-finite samples).
#[derive(Args)]
pub struct RenderArgs {
    #[command(flatten)]
    source: SceneArgs,
    /// Integrator and its settings as RON, e.g. 'Path(max_bounces: 8, strategy: Mis)': Path,
    /// Light, Bdpt, PhotonMap, Ppm, Sppm, Vcm, Radiosity or Cone (README, "Integrators"). Default:
    /// a Mitsuba file's own integrator (its max_depth mapped to max_bounces), else 'Path()'.
    #[arg(long, short)]
    integrator: Option<String>,
    /// Samples per pixel (≥ 1): camera paths per pixel, light paths per pixel for light tracing,
    /// passes for progressive photon mapping, camera samples of the solution for radiosity
    /// (ignored by cone tracing: one cone per pixel). With motion blur, `PhotonMap` and `Radiosity`
    /// solve the scene anew at each sample's instant and `Cone` traces a cone per instant, so their
    /// cost grows with it (README, "Motion blur"). Default: a Mitsuba file's sample_count, else 16.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..), conflicts_with = "seconds")]
    spp: Option<u32>,
    /// Render for this many wall-clock seconds instead of a sample count: samples continue until
    /// the time is spent, so the image is the one `--spp` would give at the count reached (see
    /// the README, "Time budgets").
    #[arg(long, allow_negative_numbers = true)]
    seconds: Option<f64>,
    /// Seed of the random numbers: the same seed gives the same image, bit for bit, on any number of
    /// threads.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (1…1024; each is an OS thread with its own stack). Default: all cores.
    #[arg(long, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Output EXR path (`.exr`, or no extension, which gets one); the PNG preview and JSON
    /// statistics are written beside it with the same stem, so nothing overwrites anything.
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
    /// Exposure of the PNG preview in stops (finite).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_exposure)]
    exposure: f32,
}

fn parse_exposure(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!(
            "'{s}' is not an exposure: give a finite number of stops, e.g. -1.5"
        )),
    }
}

/// Whether an output path names a directory: one that exists, or any path ending in a separator.
pub(crate) fn names_directory(path: &std::path::Path) -> bool {
    path.is_dir()
        || path
            .as_os_str()
            .to_string_lossy()
            .ends_with(std::path::MAIN_SEPARATOR)
}

/// The EXR path for `-o`: `.exr` as given, no extension gets `.exr`; anything else is refused,
/// since the PNG and JSON written beside it would take that name, and so is a directory.
fn exr_path(output: &std::path::Path) -> Result<PathBuf, String> {
    // `-o out/` named a directory, and the files went beside it as out.exr, out.png, out.json.
    if names_directory(output) {
        return Err(format!(
            "-o {}: names a directory; give the image's file name, e.g. {}",
            output.display(),
            output.join("render.exr").display()
        ));
    }
    match output.extension().and_then(|e| e.to_str()) {
        None => Ok(output.with_extension("exr")),
        Some(e) if e.eq_ignore_ascii_case("exr") => Ok(output.to_path_buf()),
        Some(e) => Err(format!(
            "-o {}: the output is the OpenEXR image, so name it .exr (the PNG preview and the JSON \
             statistics are written beside it with the same stem); .{e} would be overwritten by them",
            output.display()
        )),
    }
}

pub fn run(args: RenderArgs) -> Result<(), String> {
    // `bounces`, or `Bounces` as the RON settings spell it (no path expression is a word).
    let layers = args.layers.as_deref().map(|l| match l.trim() {
        b if b.eq_ignore_ascii_case("bounces") => Layers::Bounces,
        list => Layers::Classes(list.split(',').map(|e| e.trim().to_string()).collect()),
    });
    // The command line is checked before the scene is read (as for a RON scene, whose errors
    // come after those of the flags).
    let parse = |ron: &str, what: &str| {
        IntegratorConfig::from_ron(ron).map_err(|e| format!("{what} '{ron}': {e}"))
    };
    let given = args
        .integrator
        .as_deref()
        .map(|i| parse(i, "--integrator"))
        .transpose()?;
    if let Some(s) = args.seconds {
        Budget::Seconds(s)
            .check()
            .map_err(|e| format!("--seconds: {e}"))?;
    }
    let output = exr_path(&args.output)?;
    let (scene, file_integrator, file_spp) = args.source.load(args.integrator.is_some())?;
    let config = match (given, file_integrator) {
        (Some(c), _) => c,
        (None, Some(i)) => parse(&i, "the scene's integrator")?,
        (None, None) => parse("Path()", "--integrator")?,
    }
    .with_paths_and_layers(args.paths.clone(), layers)?;
    let budget = match args.seconds {
        Some(s) => Budget::Seconds(s),
        None => Budget::Samples(args.spp.or(file_spp).unwrap_or(16)),
    };
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
    let integrator = config.build()?;
    lightlab_integrators::memory::check_render(&*integrator, &scene, &budget)
        .map_err(|e| format!("{}: {e}", args.source.scene.display()))?;
    for w in integrator.scene_warnings(&scene) {
        eprintln!("warning: {w}");
    }
    let bar = Bar::new("render", Unit::Percent);
    crate::interrupt::on_interrupt(|| {
        "interrupted: nothing was written (the EXR, PNG and JSON are written, atomically, when \
         the render finishes); render again, or with --seconds or fewer --spp"
            .into()
    });
    let cpu_before = try_cpu_seconds();
    let out = pool.install(|| integrator.render(&scene, &budget, args.seed, &bar));
    // The render's own CPU time, without start-up, scene loading and writing the images: the
    // timed region of a peer renderer's render call (benches/peers/mitsuba_speed.py).
    let cpu_seconds = cpu_before
        .zip(try_cpu_seconds())
        .map(|(before, after)| after - before);
    bar.finish();

    let (w, h) = (out.film.width, out.film.height);
    let layers = output_layers(&out);
    let overflows = f32_overflows(&layers);
    write_exr(&output, w, h, &layers).map_err(|e| e.to_string())?;
    let png = output.with_extension("png");
    write_png(&png, w, h, &layers[0].pixels, args.exposure).map_err(|e| e.to_string())?;
    let json_path = output.with_extension("json");
    let json = serde_json::json!({
        "scene": args.source.scene.display().to_string(),
        "integrator": config.to_ron(),
        "lightlab_version": env!("CARGO_PKG_VERSION"),
        "render_cpu_seconds": cpu_seconds,
        "f32_overflows": overflows.iter().cloned().collect::<std::collections::BTreeMap<_, _>>(),
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
        image_mean(out.film.average(), out.film.image_se, s)
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
    for (layer, n) in &overflows {
        eprintln!(
            "warning: {n} values of layer {layer} exceed the largest 32-bit float (3.4e38) and are \
             written to {} as infinities (the render's own f64 values are finite; its JSON lists \
             them under f32_overflows): the scene's radiance reaches about 1e19, where its square, \
             the variance, overflows — scale its lights down",
            output.display()
        );
    }
    if !out.outliers.is_empty() {
        let path = output.with_extension("outliers.json");
        let json = serde_json::json!({
            "scene": args.source.scene.display().to_string(),
            "integrator": config.to_ron(),
            "seed": args.seed,
            "spp": out.stats.spp,
            "replay": format!(
                "lightlab replay {} --integrator {} --seed {} --spp {} --pixel X,Y --sample I",
                args.source.command_line(),
                shell_quote(&config.to_ron()),
                args.seed,
                out.stats.spp
            ),
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
            image_mean(film.average(), film.image_se, s)
        );
    }
    println!(
        "wrote {}, {}, {}",
        output.display(),
        png.display(),
        json_path.display()
    );
    Ok(())
}

/// The image average with its standard error where one exists, saying what the error is.
fn image_mean(mean: [f64; 3], se: Option<[f64; 3]>, stats: &RenderStats) -> String {
    let m = format!("({:.6}, {:.6}, {:.6})", mean[0], mean[1], mean[2]);
    let spp = stats.spp;
    let from = match &stats.pixel_variance {
        PixelVariance::CameraAndPhotonGroups { groups } => format!(
            "1 standard error, from the spread of {spp} camera sample passes and of {groups} \
             independent photon groups"
        ),
        PixelVariance::Replicates { replicates } => format!(
            "1 standard error, from the spread of {replicates} independent replicates of the \
             sampler ({} degrees of freedom), {} samples each",
            replicates - 1,
            spp / replicates.max(&1)
        ),
        // Passes at stratified instants, or not identically distributed: their spread is no
        // estimate of the standard error.
        PixelVariance::NotAnEstimate(why) => {
            format!("the spread of {spp} sample passes, not a standard error: {why}")
        }
        _ => format!("1 standard error, from the spread of {spp} independent sample passes"),
    };
    match se {
        Some(e) => format!("{m} ± ({:.2e}, {:.2e}, {:.2e}) ({from})", e[0], e[1], e[2]),
        // One sample per pixel (a time budget spent before a second) has no spread to measure.
        None if spp < 2 => format!(
            "{m} (no standard error from {spp} sample per pixel; render more, or measure it across seeds)"
        ),
        None => format!(
            "{m} (no standard error: this integrator's or sampler's passes are not independent; measure it across seeds)"
        ),
    }
}
