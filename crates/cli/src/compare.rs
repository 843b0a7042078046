//! `lightlab compare`: one EXR image against another (pbrt-v4's `imgtool diff`).

use clap::Args;
use lightlab_experiments::compare::{FEW_EFFECTIVE_SAMPLES, Region, ZTest, compare, error_layers};
use lightlab_experiments::image_io::write_exr;
use lightlab_experiments::reference::load_foreign;
use std::path::{Path, PathBuf};

/// Compare two EXR images — Lightlab's own or another renderer's (plain R, G, B channels, or
/// prefixed layers such as `radiance.R`): the image means and their ratio, MSE and relMSE, and,
/// when both carry their variance of the mean (a `variance` layer, or --variance-a/--variance-b
/// files), a per-pixel z-test z = (a − b)/√(v_a + v_b) with a Šidák-corrected critical value and a
/// χ² test; t-corrected (Welch–Satterthwaite) when both images' samples per pixel are known (from
/// Lightlab's OUT.json beside the EXR, or --samples-a/--samples-b), else a normal approximation
/// that holds only for many samples. Exits with status 1 when the z-test finds the images disagree.
#[derive(Args)]
pub struct CompareArgs {
    /// The image tested.
    a: PathBuf,
    /// The image it is compared with (the reference).
    b: PathBuf,
    /// Layer of A to use (default: `radiance`, else the unnamed channels, else the only layer);
    /// its variance is the layer `<LAYER_A>.variance` (`variance` for `radiance`).
    #[arg(long)]
    layer_a: Option<String>,
    /// Layer of B to use (likewise).
    #[arg(long)]
    layer_b: Option<String>,
    /// A separate EXR holding A's variance of the mean.
    #[arg(long)]
    variance_a: Option<PathBuf>,
    /// A separate EXR holding B's variance of the mean.
    #[arg(long)]
    variance_b: Option<PathBuf>,
    /// Independent samples per pixel behind A's variance, its degrees of freedom plus one
    /// (default: from the OUT.json Lightlab wrote beside A: `spp` where its variance is
    /// `Independent`, the replicates where it is `Replicates`, the photon groups where it is
    /// `CameraAndPhotonGroups`).
    #[arg(long)]
    samples_a: Option<u64>,
    /// Likewise for B.
    #[arg(long)]
    samples_b: Option<u64>,
    /// Compare only pixels X0 ≤ x < X1, Y0 ≤ y < Y1, given as X0,Y0,X1,Y1.
    #[arg(long, value_parser = parse_rect, conflicts_with = "mask")]
    region: Option<(u32, u32, u32, u32)>,
    /// Compare only the pixels where this EXR (same size) is non-zero.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Family-wise false-alarm rate of the per-pixel z-test, in (0, 1).
    #[arg(long, default_value_t = 1e-3)]
    alpha: f64,
    /// Write the error images (layers `difference`, `relative` and, with variances, `z`) here.
    #[arg(long)]
    error: Option<PathBuf>,
    /// Print the result as JSON instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_rect(s: &str) -> Result<(u32, u32, u32, u32), String> {
    let bad = || format!("'{s}' is not a region: write X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1");
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok((x0, y0, x1, y1)),
        _ => Err(bad()),
    }
}

/// The statistics Lightlab wrote beside the image at `path`, if any.
/// Said where an image's samples per pixel are unknown.
const NORMAL_APPROXIMATION: &str = "z taken as normal: an image's samples per pixel are unknown (give --samples-a/--samples-b); the false-alarm rate then holds only for many samples per pixel";

fn stats_of(path: &std::path::Path) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(path.with_extension("json")).ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(json["stats"].clone())
}

/// The independent samples per pixel behind an image's variance: `given`, else from the
/// statistics Lightlab wrote beside it: its `spp` when the variance is s²/n over independent
/// samples, its replicates when it is s²/R over replicate means, and its photon groups G for
/// `PhotonMap`'s camera samples × photon groups, whose photon part has G − 1 degrees of freedom
/// (the fewer of the two parts: conservative where Welch–Satterthwaite would give more).
fn samples(stats: Option<&serde_json::Value>, given: Option<u64>) -> Option<u64> {
    given.or_else(|| {
        let variance = &stats?["pixel_variance"];
        if variance == "Independent" {
            stats?["spp"].as_u64()
        } else {
            variance["Replicates"]["replicates"]
                .as_u64()
                .or_else(|| variance["CameraAndPhotonGroups"]["groups"].as_u64())
        }
    })
}

/// What to make of disagreeing channels whose variance rests on a few samples.
fn few_samples_caution(z: &ZTest) -> Option<String> {
    (z.exceeding_on_few_samples > 0).then(|| {
        format!(
            "{} of the {} channels beyond the critical value rest on fewer than {FEW_EFFECTIVE_SAMPLES} \
             effective samples (mean² / variance of the mean) in an image: a variance from so few \
             contributions is usually too small for an estimator with rare large samples (small \
             lights by BSDF sampling, caustics by path tracing, sub-pixel features), so they may be \
             false alarms; render more samples, compare the mean ratio, or look at the z image \
             (--error)",
            z.exceeding_on_few_samples, z.exceeding
        )
    })
}

/// Why an image's variance layer is not the variance of its pixel mean, where the statistics
/// Lightlab wrote beside it say so.
fn not_an_estimate(stats: Option<&serde_json::Value>) -> Option<&str> {
    stats?["pixel_variance"]["NotAnEstimate"].as_str()
}

pub fn run(args: CompareArgs) -> Result<(), String> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(format!("--alpha must be in (0, 1), got {}", args.alpha));
    }
    // An output that exists already may be one of the inputs under another name.
    if let Some(error) = &args.error
        && let Ok(target) = std::fs::canonicalize(error)
    {
        let same = |input: &Path| std::fs::canonicalize(input).is_ok_and(|i| i == target);
        let inputs = [
            Some(&args.a),
            Some(&args.b),
            args.variance_a.as_ref(),
            args.variance_b.as_ref(),
            args.mask.as_ref(),
        ];
        if let Some(input) = inputs.into_iter().flatten().find(|i| same(i)) {
            return Err(format!(
                "--error {} is one of the images compared ({}): the error images would replace \
                 it; write them to another file",
                error.display(),
                input.display()
            ));
        }
    }
    let a = load_foreign(&args.a, args.layer_a.as_deref(), args.variance_a.as_deref())?;
    let b = load_foreign(&args.b, args.layer_b.as_deref(), args.variance_b.as_deref())?;
    // A NaN or an infinity makes every statistic NaN or infinite: say where instead.
    for (path, variance, image) in [
        (&args.a, &args.variance_a, &a),
        (&args.b, &args.variance_b, &b),
    ] {
        image.check_finite().map_err(|e| {
            // A variance from a separate file is that file's fault.
            let file = match variance {
                Some(v) if e.starts_with("the variance") => v,
                _ => path,
            };
            format!(
                "{}: {e}; compare needs finite values (and variances ≥ 0)",
                file.display()
            )
        })?;
    }
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "{} is {}×{} but {} is {}×{}",
            args.a.display(),
            a.width,
            a.height,
            args.b.display(),
            b.width,
            b.height
        ));
    }
    let region = match (args.region, &args.mask) {
        (Some((x0, y0, x1, y1)), _) => {
            if x1 > a.width || y1 > a.height {
                return Err(format!(
                    "--region reaches past the {}×{} image",
                    a.width, a.height
                ));
            }
            Region::Rect { x0, y0, x1, y1 }
        }
        (None, Some(mask)) => {
            let m = load_foreign(mask, None, None)?;
            if (m.width, m.height) != (a.width, a.height) {
                return Err(format!(
                    "mask {} is {}×{}, the images {}×{}",
                    mask.display(),
                    m.width,
                    m.height,
                    a.width,
                    a.height
                ));
            }
            Region::Mask(m.mean.iter().map(|p| p.iter().any(|&v| v != 0.0)).collect())
        }
        (None, None) => Region::All,
    };
    for (name, n) in [
        ("--samples-a", args.samples_a),
        ("--samples-b", args.samples_b),
    ] {
        if n.is_some_and(|n| n < 2) {
            return Err(format!(
                "{name} must be at least 2: a variance needs two samples"
            ));
        }
    }
    let stats = [stats_of(&args.a), stats_of(&args.b)];
    let counts = (
        samples(stats[0].as_ref(), args.samples_a),
        samples(stats[1].as_ref(), args.samples_b),
    );
    let c = compare(&a, &b, &region, args.alpha, counts).ok_or("the region holds no pixel")?;
    if let Some(path) = &args.error {
        write_exr(path, a.width, a.height, &error_layers(&a, &b, &region))
            .map_err(|e| e.to_string())?;
    }
    // What keeps the z-test from holding its false-alarm rate, in both output forms: variance
    // layers that are no variance of the mean, and the normal approximation.
    let variance_cautions: Vec<String> = match &c.z {
        Some(_) => [&args.a, &args.b]
            .into_iter()
            .zip(&stats)
            .filter_map(|(path, stats)| {
                not_an_estimate(stats.as_ref()).map(|why| {
                    format!(
                        "the variance layer of {} is not the variance of its pixel mean ({why}), so the z-test does not hold its false-alarm rate",
                        path.display()
                    )
                })
            })
            .collect(),
        None => Vec::new(),
    };
    let normal =
        c.z.as_ref()
            .is_some_and(|z| z.min_degrees_of_freedom.is_none());
    let few = c.z.as_ref().and_then(few_samples_caution);
    if args.json {
        let mut value = serde_json::to_value(&c).expect("comparison serialises");
        let cautions = variance_cautions
            .iter()
            .map(String::as_str)
            .chain(normal.then_some(NORMAL_APPROXIMATION))
            .chain(few.as_deref());
        value["cautions"] = serde_json::json!(cautions.collect::<Vec<_>>());
        println!(
            "{}",
            serde_json::to_string_pretty(&value).expect("comparison serialises")
        );
    } else {
        let f = |v: [f64; 3]| format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2]);
        println!("{} pixels compared", c.pixels);
        println!("mean A = {}, mean B = {}", f(c.mean_a), f(c.mean_b));
        let r = c
            .ratio
            .map(|r| r.map_or("— (B is 0)".to_string(), |r| format!("{r:.6}")));
        println!("ratio A/B = ({}, {}, {})", r[0], r[1], r[2]);
        println!("MSE = {:.4e}, relMSE = {:.4e}", c.mse, c.rel_mse);
        match &c.z {
            Some(z) => {
                println!(
                    "z-test over {} pixel channels: rms z = {:.3}, max |z| = {:.2} at pixel ({}, {}) channel {}, {} beyond the critical {:.2} (α = {}), χ² p-value {:.3e} (channels taken as independent)",
                    z.tested,
                    z.rms_z,
                    z.max_abs_z,
                    z.worst.0,
                    z.worst.1,
                    z.worst.2,
                    z.exceeding,
                    z.critical,
                    z.alpha,
                    z.chi2_p_value
                );
                for caution in variance_cautions.iter().chain(&few) {
                    println!("caution: {caution}");
                }
                match z.min_degrees_of_freedom {
                    Some(dof) => println!(
                        "z t-corrected: variances from {} and {} samples per pixel (Welch–Satterthwaite, at least {dof:.1} degrees of freedom)",
                        counts.0.unwrap_or(0),
                        counts.1.unwrap_or(0)
                    ),
                    None => println!("{NORMAL_APPROXIMATION}"),
                }
            }
            None if a.variance.is_some() && b.variance.is_some() => {
                println!("no z-test: the variances of A and B are both 0 in every pixel compared")
            }
            None => println!(
                "no z-test: an image has no variance layer (give --variance-a/--variance-b)"
            ),
        }
    }
    match &c.z {
        Some(z) if !z.agrees() => Err(format!(
            "the images disagree: {} pixel channels differ by more than {:.2} standard errors",
            z.exceeding, z.critical
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::samples;
    use serde_json::json;

    /// The degrees of freedom of an image's variance come from what its statistics say it is:
    /// s²/n over `spp` independent samples, or s²/R over R replicate means (not `spp`: 64 samples
    /// in 8 replicates give 7 degrees of freedom, not 63); none where it is no estimate.
    #[test]
    fn samples_behind_the_variance() {
        let independent = json!({"spp": 64, "pixel_variance": "Independent"});
        let replicates = json!({"spp": 64, "pixel_variance": {"Replicates": {"replicates": 8}}});
        let correlated = json!({"spp": 64, "pixel_variance": {"NotAnEstimate": "stratified"}});
        assert_eq!(samples(Some(&independent), None), Some(64));
        assert_eq!(samples(Some(&replicates), None), Some(8));
        assert_eq!(samples(Some(&correlated), None), None);
        assert_eq!(samples(None, None), None);
        assert_eq!(samples(Some(&replicates), Some(5)), Some(5));
    }
}
