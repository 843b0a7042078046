//! `index.html`: the experiment report to look at, one self-contained file that opens from disk
//! in any browser (no server, no network). Per scene a flip book of the reference and every
//! setting's mean image (click, number keys, synchronised zoom and pan, exposure), signed- and
//! relative-error false colour and the ꟻLIP map (`perceptual`) with colour bars, the sortable table of `summary.json` with
//! speed-ups against a chosen baseline, the convergence fits and the plots; then what each number
//! means and the experiment file.
//!
//! Images are embedded as half floats (RGB, little endian, base64): the page tone-maps and
//! computes the error maps itself. Half floats round to 2⁻¹¹ relative, so the error maps are
//! exact to that (a display, not a measurement: the table's numbers come from the f32 images).

use crate::atomic::write_atomic;
use crate::image_io::RgbLayer;
use crate::metrics::Image;
use crate::report::SettingSummary;
use base64::Engine;
use serde::Serialize;
use std::io;
use std::path::Path;

const TEMPLATE: &str = include_str!("html/report.html");

/// One line per metric, as experiments/README.md defines them.
const HELP: [(&str, &str); 14] = [
    (
        "MSE",
        "mean over pixels and channels of (x − r)² − v_r: the reference's own noise v_r is not charged to the method; mean over trials ± standard error over the trials, then (ref. ± …) the standard error the reference's noise adds, common to every setting measured against it (it moves ratios of errors; it assumes independent reference pixels)",
    ),
    (
        "relMSE",
        "mean of ((x − r)² − v_r) / (r² + 0.01), less the first-order bias of dividing by the reference's noisy value; ± as for MSE",
    ),
    (
        "bias²",
        "(x̄ − r)² − variance/T − v_r averaged over pixels, from the T trials' images (can be slightly negative from noise); ± a leave-one-out jackknife standard error (T ≥ 3 trials; conservative), then the reference's standard error (the MSE's)",
    ),
    (
        "variance",
        "variance of one trial's pixel value across the trials, averaged over pixels",
    ),
    (
        "efficiency",
        "1 / (mean MSE × mean seconds): a ratio of means, not the mean of per-trial ratios; ± a delta-method standard error on T − 1 degrees of freedom. With few trials or a noisy mean error it is biased high (about Var(MSE̅)/MSE̅²; summary.json's relative_bias) and skewed: read the ± as a scale",
    ),
    (
        "relMSE × t",
        "inefficiency: mean relMSE × mean seconds; the speed-up against the baseline is its ratio",
    ),
    (
        "spp / passes",
        "samples per pixel (passes for progressive photon mapping and VCM) reached, mean over trials",
    ),
    (
        "seconds",
        "wall-clock seconds of the render, mean over trials (time budgets stop at the pass boundary nearest the budget)",
    ),
    ("rays", "rays traced, mean over trials"),
    (
        "photons",
        "photon (light) paths traced and photons stored (photon mapping, VCM: its light vertices), means over trials",
    ),
    (
        "ꟻLIP",
        "perceptual error of the mean image against the reference (Andersson et al. 2020), both tone-mapped to 8-bit sRGB at exposure 0, 67 pixels per degree; mean of the per-pixel map in [0, 1]",
    ),
    (
        "non-finite",
        "samples whose value was NaN or infinite: counted and left out of the image, summed over trials",
    ),
    (
        "relMSE per class",
        "the error of a path-class layer (the experiment's classes, then the rest) against the same layer of the reference",
    ),
    (
        "slope",
        "weighted least-squares fit of ln MSE against ln spp, with its 95 % interval (Birge-scaled) and χ²/dof; points whose mean MSE is not significantly above 0 (at most 2 standard errors) are left out of the fit and counted in the legend",
    ),
];

#[derive(Serialize)]
struct Data<'a> {
    runs: usize,
    version: String,
    machine: String,
    source: Option<String>,
    scenes: Vec<Scene<'a>>,
    fits: &'a serde_json::Value,
    plots: Vec<Plot>,
    help: &'a [(&'a str, &'a str)],
}

#[derive(Serialize)]
struct Scene<'a> {
    name: &'a str,
    width: u32,
    height: u32,
    reference: String,
    /// The reference's further layers (name, encoded pixels): the error maps of a layer need it.
    reference_layers: Vec<(&'a str, String)>,
    settings: Vec<Setting<'a>>,
}

#[derive(Serialize)]
struct Setting<'a> {
    label: &'a str,
    /// The setting's budget and swept values ("as configured" for none).
    budget: String,
    #[serde(flatten)]
    summary: &'a SettingSummary,
    /// The mean image, encoded (none when its size differs from the reference's).
    pixels: Option<String>,
    /// Its ꟻLIP map, 8 bits per pixel (0–255 for 0–1), base64.
    flip_map: Option<String>,
    /// Its further layers (name, encoded pixels).
    layers: Vec<(&'a str, String)>,
    /// Each trial's image, encoded.
    trial_pixels: Vec<String>,
}

#[derive(Serialize)]
struct Plot {
    scene: String,
    svg: String,
}

/// What one setting brings to the report: its summary and mean image.
pub(crate) struct Entry<'a> {
    pub summary: &'a SettingSummary,
    /// The mean image over the trials.
    pub mean: Option<Vec<[f32; 3]>>,
    /// Each trial's image, in trial order.
    pub trial_images: Vec<Vec<[f32; 3]>>,
    /// Mean over the trials of each further layer of the runs' images (path classes, bounces,
    /// techniques), by name.
    pub layers: Vec<RgbLayer>,
    /// Its ꟻLIP map against the reference.
    pub flip_map: Option<Vec<f32>>,
}

/// One scene of the report: its reference (with its further layers) and its settings.
pub(crate) struct SceneInput<'a> {
    pub name: String,
    pub reference: Image,
    pub reference_layers: Vec<RgbLayer>,
    pub entries: Vec<Entry<'a>>,
}

/// The report's facts about the runs: their number, Lightlab versions and machines.
pub(crate) struct Provenance {
    pub runs: usize,
    pub versions: Vec<String>,
    pub machines: Vec<String>,
}

/// Writes `out_dir/index.html` from the settings (grouped by scene, in order), each scene's
/// reference, the fits and plot files of `summary.json`.
pub(crate) fn write_html(
    out_dir: &Path,
    provenance: &Provenance,
    scenes: &[SceneInput],
    fits: &serde_json::Value,
    plot_files: &[String],
) -> io::Result<()> {
    let plots = plot_files
        .iter()
        .filter_map(|file| {
            let svg = std::fs::read_to_string(out_dir.join(file)).ok()?;
            let svg = match svg.find("<svg") {
                Some(i) => svg[i..].to_string(),
                None => svg,
            };
            let scene = scenes
                .iter()
                .map(|s| s.name.as_str())
                .filter(|s| file.starts_with(&format!("{s}-")))
                .max_by_key(|s| s.len())?;
            Some(Plot {
                scene: scene.to_string(),
                svg,
            })
        })
        .collect();
    let data = Data {
        runs: provenance.runs,
        version: join_or(&provenance.versions, "unknown"),
        machine: join_or(&provenance.machines, "machine not recorded"),
        source: std::fs::read_to_string(out_dir.join("experiment.ron")).ok(),
        scenes: scenes
            .iter()
            .map(|scene| {
                (
                    &scene.name,
                    &scene.reference,
                    &scene.reference_layers,
                    &scene.entries,
                )
            })
            .map(|(name, reference, reference_layers, entries)| Scene {
                name,
                width: reference.width,
                height: reference.height,
                reference: encode(&reference.mean),
                reference_layers: encode_layers(reference_layers, reference.mean.len()),
                settings: entries
                    .iter()
                    .map(|e| Setting {
                        label: &e.summary.method,
                        budget: if e.summary.setting.is_empty() {
                            "as configured".into()
                        } else {
                            e.summary.setting.clone()
                        },
                        summary: e.summary,
                        pixels: e
                            .mean
                            .as_ref()
                            .filter(|m| m.len() == reference.mean.len())
                            .map(|m| encode(m)),
                        flip_map: e.flip_map.as_ref().map(|m| {
                            let bytes: Vec<u8> = m
                                .iter()
                                .map(|&e| (e.clamp(0.0, 1.0) * 255.0).round() as u8)
                                .collect();
                            base64::engine::general_purpose::STANDARD.encode(bytes)
                        }),
                        layers: encode_layers(&e.layers, reference.mean.len()),
                        trial_pixels: e
                            .trial_images
                            .iter()
                            .filter(|t| t.len() == reference.mean.len())
                            .map(|t| encode(t))
                            .collect(),
                    })
                    .collect(),
            })
            .collect(),
        fits,
        plots,
        help: &HELP,
    };
    let json = serde_json::to_string(&data).map_err(io::Error::other)?;
    let title = out_dir
        .file_name()
        .map_or("experiment".into(), |n| n.to_string_lossy().into_owned());
    // Inside <script>, "</" would end the element; JSON allows "<\/" for it.
    let page = TEMPLATE
        .replace("@TITLE@", &escape(&title))
        .replace("@DATA@", &json.replace("</", "<\\/"));
    write_atomic(&out_dir.join("index.html"), page.as_bytes())
}

fn join_or(items: &[String], otherwise: &str) -> String {
    if items.is_empty() {
        otherwise.into()
    } else {
        items.join("; ")
    }
}

/// The layers of `pixels` pixels, encoded by name.
fn encode_layers(layers: &[RgbLayer], pixels: usize) -> Vec<(&str, String)> {
    layers
        .iter()
        .filter(|l| l.pixels.len() == pixels)
        .map(|l| (l.name.as_str(), encode(&l.pixels)))
        .collect()
}

/// The layers of an image file a report shows beside the image: every one but the image itself
/// (`radiance`) and the variances.
pub(crate) fn extra_layers(layers: Vec<RgbLayer>) -> Vec<RgbLayer> {
    layers
        .into_iter()
        .filter(|l| {
            !(l.name.is_empty()
                || l.name == "radiance"
                || l.name == "variance"
                || l.name.ends_with(".variance"))
        })
        .collect()
}

/// RGB pixels as little-endian half floats, base64.
fn encode(pixels: &[[f32; 3]]) -> String {
    let bytes: Vec<u8> = pixels
        .iter()
        .flatten()
        .flat_map(|&v| half::f16::from_f32(v).to_le_bytes())
        .collect();
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// This machine and build, as a report names them: CPU model, logical cores, operating system and
/// the widest SIMD instruction set the build was compiled for.
pub fn machine() -> String {
    let cpu =
        lightlab_testkit::timing::cpu_model().unwrap_or_else(|| std::env::consts::ARCH.into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{cpu}, {cores} logical cores, {}, {} build",
        std::env::consts::OS,
        lightlab_testkit::timing::build_simd()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of a fit that the report's script reads (`f.fit.NAME`) is one `Fit` serialises:
    /// a misspelt name shows "—" in every row instead of failing.
    #[test]
    fn the_report_reads_fit_fields_that_exist() {
        let fit = crate::metrics::Fit {
            intercept: 0.0,
            slope: -1.0,
            slope_ci95: 0.1,
            points: 3,
            chi2_per_dof: Some(1.0),
            excluded: Vec::new(),
        };
        let fields = serde_json::to_value(&fit).unwrap();
        let read: Vec<&str> = TEMPLATE
            .split("f.fit.")
            .skip(1)
            .map(|rest| {
                let end = rest
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .unwrap_or(rest.len());
                &rest[..end]
            })
            .collect();
        assert!(read.len() >= 4, "{read:?}");
        for name in read {
            assert!(fields.get(name).is_some(), "the report reads f.fit.{name}");
        }
    }

    #[test]
    fn half_floats_round_trip_to_their_precision() {
        let values = [[0.0, 1.0, -2.5], [1e-3, 65504.0, 0.3333]];
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(encode(&values))
            .unwrap();
        let back: Vec<f32> = bytes
            .chunks(2)
            .map(|c| half::f16::from_le_bytes([c[0], c[1]]).to_f32())
            .collect();
        for (a, b) in values.iter().flatten().zip(&back) {
            assert!((a - b).abs() <= a.abs() * 2f32.powi(-11), "{a} → {b}");
        }
    }
}
