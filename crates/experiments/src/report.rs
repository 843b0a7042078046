//! Tables and plots of an experiment, rebuilt from its finished runs: `runs.csv` (one tidy row per
//! run and metric), `summary.json` (per setting: means over trials with standard errors, bias² and
//! variance, efficiency as a ratio of means; per series: the fitted log–log convergence slope with
//! its 95 % interval and the points it left out), the mean image of every setting (`images/`), and
//! SVG plots per scene of MSE against samples, MSE against time, and efficiency.

use crate::atomic::write_atomic;
use crate::html;
use crate::image_io::{RgbLayer, read_exr, write_exr};
use crate::metrics::{
    Efficiency, Fit, REL_EPSILON, ReferenceSe, bias_variance, bias_variance_se, efficiency,
    fit_power_law, reference_se,
};
use crate::perceptual;
use crate::plot::{LinePlot, Series, render_svg};
use crate::reference::load_image;
use crate::runner::RunRecord;
use serde::Serialize;
use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

/// The finished runs under `out_dir/runs/`, in expansion order.
pub fn finished_runs(out_dir: &Path) -> io::Result<Vec<RunRecord>> {
    let mut records = Vec::new();
    let runs = out_dir.join("runs");
    if !runs.is_dir() {
        return Ok(records);
    }
    for entry in std::fs::read_dir(&runs)? {
        let path = entry?.path().join("metrics.json");
        if path.is_file() {
            let text = std::fs::read_to_string(&path)?;
            let r: RunRecord = serde_json::from_str(&text)
                .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))?;
            records.push(r);
        }
    }
    records.sort_by_key(|r| r.index);
    Ok(records)
}

/// One row of `runs.csv`.
#[derive(Clone, Debug, Serialize, serde::Deserialize, PartialEq)]
pub struct CsvRow {
    pub run: String,
    pub scene: String,
    pub method: String,
    pub setting: String,
    pub trial: u32,
    pub seed: u64,
    pub metric: String,
    pub value: f64,
}

fn csv_rows(records: &[RunRecord]) -> Vec<CsvRow> {
    let mut rows = Vec::new();
    for r in records {
        let metrics = [
            ("spp", r.spp as f64),
            ("wall_seconds", r.wall_seconds),
            ("pilot_seconds", r.pilot_seconds),
            ("samples", r.samples as f64),
            ("rays", r.rays as f64),
            ("non_finite", r.non_finite as f64),
            ("mse", r.errors.mse),
            ("rel_mse", r.errors.rel_mse),
            ("mae", r.errors.mae),
            ("reference_variance", r.errors.reference_variance),
        ];
        let radiosity = r.radiosity.iter().flat_map(|s| {
            [
                ("patches".to_string(), s.patches as f64),
                ("form_factor_rays".to_string(), s.form_factor_rays as f64),
                ("iterations".to_string(), s.iterations as f64),
                ("residual".to_string(), s.residual),
                ("form_factor_seconds".to_string(), s.form_factor_seconds),
                ("solve_seconds".to_string(), s.solve_seconds),
            ]
        });
        let per_class = r.class_errors.iter().flat_map(|(class, e)| {
            [
                (format!("mse[{class}]"), e.mse),
                (format!("rel_mse[{class}]"), e.rel_mse),
                (format!("reference_variance[{class}]"), e.reference_variance),
            ]
        });
        for (metric, value) in metrics
            .into_iter()
            .map(|(m, v)| (m.to_string(), v))
            .chain(radiosity)
            .chain(per_class)
        {
            rows.push(CsvRow {
                run: r.id.clone(),
                scene: r.scene.clone(),
                method: r.method.clone(),
                setting: r.setting.clone(),
                trial: r.trial,
                seed: r.seed,
                metric,
                value,
            });
        }
    }
    rows
}

/// The values of one run read back from `runs.csv` (what the plots need).
#[derive(Clone, Debug, Default)]
struct RunPoint {
    scene: String,
    method: String,
    setting: String,
    spp: f64,
    wall_seconds: f64,
    mse: f64,
    /// MSE of each path-class layer.
    class_mse: BTreeMap<String, f64>,
}

fn points(rows: &[CsvRow]) -> Vec<RunPoint> {
    let mut by_run: BTreeMap<&str, RunPoint> = BTreeMap::new();
    let mut order = Vec::new();
    for row in rows {
        let p = by_run.entry(&row.run).or_insert_with(|| {
            order.push(row.run.as_str());
            RunPoint {
                scene: row.scene.clone(),
                method: row.method.clone(),
                setting: row.setting.clone(),
                ..Default::default()
            }
        });
        match row.metric.as_str() {
            "spp" => p.spp = row.value,
            "wall_seconds" => p.wall_seconds = row.value,
            "mse" => p.mse = row.value,
            m => {
                if let Some(class) = m.strip_prefix("mse[").and_then(|c| c.strip_suffix(']')) {
                    p.class_mse.insert(class.to_string(), row.value);
                }
            }
        }
    }
    order.iter().map(|r| by_run[r].clone()).collect()
}

/// The setting without its budget (`spp=…`, `seconds=…`): runs that differ only in budget form
/// one series of a convergence plot.
fn series_setting(setting: &str) -> String {
    setting
        .split(", ")
        .filter(|s| !s.starts_with("spp=") && !s.starts_with("seconds="))
        .collect::<Vec<_>>()
        .join(", ")
}

fn series_label(method: &str, setting: &str) -> String {
    if setting.is_empty() {
        method.to_string()
    } else {
        format!("{method} ({setting})")
    }
}

fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    if xs.len() < 2 {
        return (m, 0.0);
    }
    let s2 = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (s2 / n).sqrt())
}

#[derive(Serialize)]
pub(crate) struct SettingSummary {
    scene: String,
    pub method: String,
    pub setting: String,
    trials: usize,
    spp: f64,
    wall_seconds: f64,
    rays: f64,
    /// Photon (light) paths traced and photons stored, means over trials.
    photons: f64,
    photons_stored: f64,
    mse: (f64, f64),
    rel_mse: (f64, f64),
    mae: (f64, f64),
    /// The standard error the reference's own noise adds to `mse`, `rel_mse` and `bias2`, common
    /// to every setting measured against it (`metrics::reference_se`); `None` without a reference
    /// variance.
    reference_se: Option<ReferenceSe>,
    /// 1 / (mean MSE × mean time), with its delta-method standard error.
    efficiency: Efficiency,
    /// 1 / (mean relMSE × mean time).
    rel_efficiency: Efficiency,
    bias2: Option<f64>,
    variance: Option<f64>,
    /// Their jackknife standard errors (T ≥ 3 trials; see `bias_variance_se`).
    bias2_se: Option<f64>,
    variance_se: Option<f64>,
    /// Mean ꟻLIP of the mean image against the reference (tone-mapped; see `perceptual`).
    flip: Option<f64>,
    non_finite: u64,
    /// What the method's pixels converge to (see `PixelLimit`).
    pixel_limit: lightlab_integrators::PixelLimit,
    /// Mean image over the trials (layers `radiance` and `variance` = variance of that mean).
    image: Option<String>,
    /// Errors of each path-class layer (the experiment's `classes`, then `rest`).
    classes: Vec<ClassSummary>,
}

#[derive(Serialize)]
pub(crate) struct ClassSummary {
    class: String,
    mse: (f64, f64),
    rel_mse: (f64, f64),
    /// As `SettingSummary::reference_se`, against the reference's layer of the class.
    reference_se: Option<ReferenceSe>,
}

/// The mean over trials of `images` and the variance of that mean (sample variance / T).
fn mean_image(images: &[&[[f32; 3]]]) -> Option<Vec<RgbLayer>> {
    let t = images.len();
    let n = images.first()?.len();
    if images.iter().any(|i| i.len() != n) {
        return None;
    }
    let mut mean = vec![[0.0f32; 3]; n];
    let mut var = vec![[0.0f32; 3]; n];
    for i in 0..n {
        for c in 0..3 {
            let m = images.iter().map(|x| x[i][c] as f64).sum::<f64>() / t as f64;
            let s2 = if t > 1 {
                images
                    .iter()
                    .map(|x| (x[i][c] as f64 - m).powi(2))
                    .sum::<f64>()
                    / (t - 1) as f64
            } else {
                0.0
            };
            mean[i][c] = m as f32;
            var[i][c] = (s2 / t as f64) as f32;
        }
    }
    Some(vec![
        RgbLayer {
            name: "radiance".into(),
            pixels: mean,
        },
        RgbLayer {
            name: "variance".into(),
            pixels: var,
        },
    ])
}

fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '=' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[derive(Serialize)]
struct SeriesFit {
    scene: String,
    series: String,
    /// Fit of ln MSE against ln spp (slope, 95 % half-width, χ²/dof, points left out).
    fit: Fit,
}

/// Where the reference run `r` was measured against is: `reference/<scene>.exr` in the output
/// directory (the image and the variance the errors used), or, for runs recorded before it was
/// kept there, the path recorded (the cache file, relative to the directory `run` started in).
pub fn reference_file(out_dir: &Path, r: &RunRecord) -> PathBuf {
    let kept = out_dir.join(&r.reference);
    if r.reference.is_relative() && kept.is_file() {
        kept
    } else {
        r.reference.clone()
    }
}

/// The files `write_report` reads besides the runs' metrics — every run's image and its reference
/// — that are missing.
pub fn missing_inputs(out_dir: &Path, records: &[RunRecord]) -> Vec<PathBuf> {
    records
        .iter()
        .map(|r| out_dir.join("runs").join(&r.id).join("image.exr"))
        .chain(records.iter().map(|r| reference_file(out_dir, r)))
        .filter(|p| !p.is_file())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect()
}

/// Rewrites `runs.csv`, `summary.json`, the plots and the report of `out_dir` from its finished
/// runs.
/// Bias², variance, ꟻLIP and the mean images come from the runs' images and their reference: if
/// one is missing or unreadable nothing but runs.csv is rewritten, and the error says which.
pub fn write_report(out_dir: &Path) -> io::Result<()> {
    let records = finished_runs(out_dir)?;
    if let Some(first) = missing_inputs(out_dir, &records).first() {
        return Err(io::Error::other(format!(
            "the report needs every run's image and its reference, and {} is missing: summary.json \
             and the report were not rewritten (results kept without their EXR files cannot be \
             summarised again; rerun the experiment into another --results directory)",
            first.display()
        )));
    }
    let rows = csv_rows(&records);
    let mut w = csv::Writer::from_writer(Vec::new());
    for row in &rows {
        w.serialize(row).map_err(io::Error::other)?;
    }
    write_atomic(
        &out_dir.join("runs.csv"),
        &w.into_inner()
            .map_err(|e| io::Error::other(e.to_string()))?,
    )?;

    // Per setting: means over trials, and bias/variance from the trial images.
    let mut groups: BTreeMap<(String, String, String), Vec<&RunRecord>> = BTreeMap::new();
    for r in &records {
        groups
            .entry((r.scene.clone(), r.method.clone(), r.setting.clone()))
            .or_default()
            .push(r);
    }
    let mut references: BTreeMap<PathBuf, crate::metrics::Image> = BTreeMap::new();
    let mut class_references: BTreeMap<(PathBuf, String), crate::metrics::Image> = BTreeMap::new();
    // Per setting, what the HTML report shows besides the summary.
    let (mut settings, mut shown) = (Vec::new(), Vec::new());
    for ((scene, method, setting), rs) in &groups {
        let get = |f: fn(&RunRecord) -> f64| mean_se(&rs.iter().map(|r| f(r)).collect::<Vec<_>>());
        let file = reference_file(out_dir, rs[0]);
        if !references.contains_key(&file) {
            let image = load_image(&file).map_err(io::Error::other)?;
            references.insert(file.clone(), image);
        }
        let reference = &references[&file];
        // Each run's image file, read once: its image and its further layers.
        let (images, trial_layers): (Vec<Vec<[f32; 3]>>, Vec<Vec<RgbLayer>>) = rs
            .iter()
            .map(|r| {
                let path = out_dir.join("runs").join(&r.id).join("image.exr");
                let unreadable = |why: String| {
                    io::Error::other(format!(
                        "{}: {why}; summary.json and the report were not rewritten",
                        path.display()
                    ))
                };
                let (_, _, mut layers) = read_exr(&path).map_err(|e| unreadable(e.to_string()))?;
                let i = layers
                    .iter()
                    .position(|l| l.name == "radiance")
                    .ok_or_else(|| unreadable("no radiance layer".into()))?;
                let image = layers.swap_remove(i).pixels;
                Ok((image, html::extra_layers(layers)))
            })
            .collect::<io::Result<Vec<_>>>()?
            .into_iter()
            .unzip();
        let slices: Vec<&[[f32; 3]]> = images.iter().map(|i| i.as_slice()).collect();
        let bv = bias_variance(&slices, reference);
        let bv_se = bias_variance_se(&slices, reference);
        let ref_se = reference_se(&slices, reference);
        // Each path class's reference layer (read once per reference) and trial layers, for its
        // reference standard error.
        let mut class_ref_se = |class: &String| -> io::Result<Option<ReferenceSe>> {
            let layers: Option<Vec<&[[f32; 3]]>> = trial_layers
                .iter()
                .map(|t| {
                    t.iter()
                        .find(|l| &l.name == class)
                        .map(|l| l.pixels.as_slice())
                })
                .collect();
            let Some(layers) = layers else {
                return Ok(None);
            };
            let key = (file.clone(), class.clone());
            if !class_references.contains_key(&key) {
                let image = crate::reference::load_foreign(&file, Some(class), None)
                    .map_err(io::Error::other)?;
                class_references.insert(key.clone(), image);
            }
            Ok(reference_se(&layers, &class_references[&key]))
        };
        let class_se: Vec<Option<ReferenceSe>> = rs[0]
            .class_errors
            .iter()
            .map(|(class, _)| class_ref_se(class))
            .collect::<io::Result<_>>()?;
        let (mut flip, mut mean) = (None, None);
        let image = match mean_image(&slices) {
            Some(layers) => {
                let r = reference;
                flip = perceptual::flip(&r.mean, &layers[0].pixels, r.width, r.height);
                mean = Some(layers[0].pixels.clone());
                let file = format!(
                    "images/{}.exr",
                    sanitize(&format!("{scene}-{method}-{setting}"))
                );
                write_exr(&out_dir.join(&file), r.width, r.height, &layers)
                    .map_err(io::Error::other)?;
                Some(file)
            }
            None => None,
        };
        let flip_mean = flip.as_ref().map(|f| f.mean);
        shown.push((file, mean, flip.map(|f| f.map), images, trial_layers));
        settings.push(SettingSummary {
            scene: scene.clone(),
            method: method.clone(),
            setting: setting.clone(),
            trials: rs.len(),
            spp: get(|r| r.spp as f64).0,
            wall_seconds: get(|r| r.wall_seconds).0,
            rays: get(|r| r.rays as f64).0,
            photons: get(|r| r.photons as f64).0,
            photons_stored: get(|r| r.photons_stored as f64).0,
            mse: get(|r| r.errors.mse),
            rel_mse: get(|r| r.errors.rel_mse),
            mae: get(|r| r.errors.mae),
            reference_se: ref_se,
            efficiency: efficiency(
                &rs.iter().map(|r| r.errors.mse).collect::<Vec<_>>(),
                &rs.iter().map(|r| r.wall_seconds).collect::<Vec<_>>(),
            ),
            rel_efficiency: efficiency(
                &rs.iter().map(|r| r.errors.rel_mse).collect::<Vec<_>>(),
                &rs.iter().map(|r| r.wall_seconds).collect::<Vec<_>>(),
            ),
            flip: flip_mean,
            bias2: bv.map(|b| b.bias2),
            variance: bv.map(|b| b.variance),
            bias2_se: bv_se.map(|b| b.bias2),
            variance_se: bv_se.map(|b| b.variance),
            non_finite: rs.iter().map(|r| r.non_finite).sum(),
            pixel_limit: rs[0].pixel_limit,
            image,
            classes: rs[0]
                .class_errors
                .iter()
                .enumerate()
                .map(|(k, (class, _))| {
                    let of = |f: fn(&crate::metrics::Errors) -> f64| {
                        mean_se(
                            &rs.iter()
                                .filter_map(|r| r.class_errors.get(k).map(|e| f(&e.1)))
                                .collect::<Vec<_>>(),
                        )
                    };
                    ClassSummary {
                        class: class.clone(),
                        mse: of(|e| e.mse),
                        rel_mse: of(|e| e.rel_mse),
                        reference_se: class_se[k],
                    }
                })
                .collect(),
        });
    }
    let plots = write_plots(out_dir, &rows)?;
    let summary = serde_json::json!({
        "runs": records.len(),
        "rel_mse_epsilon": REL_EPSILON,
        "metrics": "mse and rel_mse have the reference's own variance subtracted where it is an estimate (see warnings); values are (mean over trials, standard error over the trials); reference_se is the standard error the reference's own noise adds to mse, rel_mse and bias2, common to every setting against that reference (independent reference pixels assumed; null without a reference variance); bias2_se and variance_se are leave-one-out jackknife standard errors (T ≥ 3 trials; conservative); efficiency = 1/(mean error × mean seconds) with a delta-method standard error on degrees_of_freedom = T − 1 and relative_bias, its second-order bias (positive: too high) from the trials' spread, error_significant false where the mean error is not significantly above zero; convergence fits weight each point by its pooled log-space standard error and list the points left out (mean MSE ≤ 2 standard errors: not significantly above zero, where ln MSE is noise)",
        "settings": settings,
        "convergence": plots.fits,
        "plots": plots.files,
    });
    write_atomic(
        &out_dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)
            .map_err(io::Error::other)?
            .as_bytes(),
    )?;

    // The HTML report: per scene with a reference, its settings in budget order.
    let mut scenes: Vec<html::SceneInput> = Vec::new();
    for ((((scene, _, _), _), summary), (file, mean, flip_map, trial_images, trials)) in
        groups.iter().zip(&settings).zip(shown)
    {
        let reference = &references[&file];
        // The further layers averaged over the trials.
        let mut layers = trials.first().cloned().unwrap_or_default();
        for l in &mut layers {
            let of_trials: Vec<&[[f32; 3]]> = trials
                .iter()
                .filter_map(|t| t.iter().find(|m| m.name == l.name))
                .map(|m| m.pixels.as_slice())
                .collect();
            if let Some(mean) = mean_image(&of_trials) {
                l.pixels = mean.into_iter().next().expect("the mean layer").pixels;
            }
        }
        let entry = html::Entry {
            summary,
            trial_images,
            layers,
            flip_map,
            mean,
        };
        match scenes.iter_mut().find(|s| &s.name == scene) {
            Some(s) => s.entries.push(entry),
            None => scenes.push(html::SceneInput {
                name: scene.clone(),
                reference: reference.clone(),
                reference_layers: read_exr(&file)
                    .map(|(_, _, l)| html::extra_layers(l))
                    .unwrap_or_default(),
                entries: vec![entry],
            }),
        }
    }
    for s in &mut scenes {
        s.entries.sort_by(|a, b| {
            budget_key(&a.summary.setting).total_cmp(&budget_key(&b.summary.setting))
        });
    }
    let distinct = |f: fn(&RunRecord) -> &str| {
        let mut v: Vec<String> = records
            .iter()
            .map(f)
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        v.sort();
        v.dedup();
        v
    };
    let provenance = html::Provenance {
        runs: records.len(),
        versions: distinct(|r| &r.lightlab_version),
        machines: distinct(|r| &r.machine),
    };
    html::write_html(
        out_dir,
        &provenance,
        &scenes,
        &summary["convergence"],
        &plots.files,
    )
}

/// The numeric part of a setting's first `key=value` (its budget, as the expansion names it
/// first), for ordering; settings without one first.
fn budget_key(setting: &str) -> f64 {
    setting
        .split(',')
        .next()
        .and_then(|kv| kv.split('=').nth(1))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(f64::NEG_INFINITY)
}

/// A series' legend with the count of its points that a log axis cannot show (MSE ≤ 0: an error
/// at or below the reference's noise once its variance is subtracted), so that none vanishes
/// silently.
fn legend_with_dropped(label: &str, points: &[(f64, f64, f64)]) -> String {
    match points.iter().filter(|p| !(p.1 > 0.0)).count() {
        0 => label.to_string(),
        n => format!("{label} ({n} point(s) with MSE ≤ 0 left out)"),
    }
}

/// A series' legend with its fitted slope and the points the fit left out.
fn fit_legend(label: &str, f: &Fit) -> String {
    let mut text = format!("{label}: slope {:.2} ± {:.2}", f.slope, f.slope_ci95);
    if !f.excluded.is_empty() {
        text += &format!(
            " ({} point(s) not significantly above 0 left out of the fit)",
            f.excluded.len()
        );
    }
    text
}

struct Plots {
    fits: Vec<SeriesFit>,
    files: Vec<String>,
}

/// A setting's `key=value` pairs, in order.
fn setting_pairs(setting: &str) -> impl Iterator<Item = (&str, &str)> {
    setting.split(", ").filter_map(|kv| kv.split_once('='))
}

/// For every setting besides the budget that takes two or more numeric values among one scene's
/// `points`, the MSE (and each class's) against it, one series per method and remaining settings:
/// `(file stem, plot)`. The x axis is logarithmic when every value is positive and they span a
/// factor of 8 or more.
fn field_plots(scene: &str, points: &[&RunPoint]) -> Vec<(String, LinePlot)> {
    let mut fields: Vec<&str> = Vec::new();
    for p in points {
        for (k, _) in setting_pairs(&p.setting) {
            if k != "spp" && k != "seconds" && !fields.contains(&k) {
                fields.push(k);
            }
        }
    }
    let mut classes: Vec<&String> = points.iter().flat_map(|p| p.class_mse.keys()).collect();
    classes.sort();
    classes.dedup();
    let mut plots = Vec::new();
    for field in fields {
        // (series label, x, the run) for every run that sets the field to a number.
        let mut keyed = Vec::new();
        for p in points {
            let Some((_, v)) = setting_pairs(&p.setting).find(|(k, _)| *k == field) else {
                continue;
            };
            let Ok(x) = v.parse::<f64>() else {
                keyed.clear();
                break;
            };
            let rest: Vec<String> = setting_pairs(&p.setting)
                .filter(|(k, _)| *k != field)
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            keyed.push((series_label(&p.method, &rest.join(", ")), x, *p));
        }
        let mut xs: Vec<f64> = keyed.iter().map(|k| k.1).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        if xs.len() < 2 {
            continue;
        }
        let log_x = xs[0] > 0.0 && xs[xs.len() - 1] >= 8.0 * xs[0];
        let metrics = std::iter::once(None).chain(classes.iter().map(|c| Some(*c)));
        for class in metrics {
            let mut order: Vec<&str> = Vec::new();
            let mut by_series: BTreeMap<&str, Vec<(f64, Vec<f64>)>> = BTreeMap::new();
            for (label, x, p) in &keyed {
                let mse = match class {
                    None => p.mse,
                    Some(c) => match p.class_mse.get(c) {
                        Some(&m) => m,
                        None => continue,
                    },
                };
                if !order.contains(&label.as_str()) {
                    order.push(label);
                }
                let series = by_series.entry(label).or_default();
                match series.iter_mut().find(|(sx, _)| sx == x) {
                    Some((_, trials)) => trials.push(mse),
                    None => series.push((*x, vec![mse])),
                }
            }
            let series = order
                .iter()
                .map(|label| {
                    let mut points: Vec<(f64, f64, f64)> = by_series[label]
                        .iter()
                        .map(|(x, trials)| {
                            let (m, se) = mean_se(trials);
                            (*x, m, se)
                        })
                        .collect();
                    points.sort_by(|a, b| a.0.total_cmp(&b.0));
                    Series {
                        label: label.to_string(),
                        points,
                    }
                })
                .collect();
            let (what, suffix) = match class {
                None => ("MSE".to_string(), String::new()),
                Some(c) => (format!("MSE of {c}"), format!("-{}", sanitize(c))),
            };
            plots.push((
                format!("mse-vs-{}{suffix}", sanitize(field)),
                LinePlot {
                    title: format!("{scene}: {what} against {field}"),
                    x_label: field.to_string(),
                    y_label: format!("{what} (mean over trials ± 1 s.e.)"),
                    log_x,
                    log_y: true,
                    series,
                },
            ));
        }
    }
    plots
}

/// `lightlab plot`: redraws the plots of `out_dir` from its `runs.csv` alone.
pub fn plot_from_csv(out_dir: &Path) -> io::Result<Vec<String>> {
    let path = out_dir.join("runs.csv");
    let mut reader = csv::Reader::from_path(&path)
        .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))?;
    let rows: Vec<CsvRow> = reader
        .deserialize()
        .collect::<Result<_, _>>()
        .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))?;
    if rows.is_empty() {
        return Err(io::Error::other(format!(
            "{}: no runs in it (an experiment's runs.csv has a header line, then a row per run \
             and metric)",
            path.display()
        )));
    }
    Ok(write_plots(out_dir, &rows)?.files)
}

fn write_plots(out_dir: &Path, rows: &[CsvRow]) -> io::Result<Plots> {
    let pts = points(rows);
    // The experiment's `fit_from`, from the copy of its file kept with the results (none for
    // results without one).
    let source = out_dir.join("experiment.ron");
    let fit_from = std::fs::read_to_string(&source)
        .ok()
        .and_then(|text| crate::desc::parse_experiment(&text, &source).ok())
        .and_then(|d| d.fit_from)
        .map_or(0.0, f64::from);
    let mut scenes: Vec<&str> = pts.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    let mut fits = Vec::new();
    let mut files = Vec::new();
    for scene in scenes {
        // Series (method + non-budget setting) → budget setting → trial points.
        let mut series: BTreeMap<String, BTreeMap<String, Vec<&RunPoint>>> = BTreeMap::new();
        let mut order: Vec<String> = Vec::new();
        for p in pts.iter().filter(|p| p.scene == scene) {
            let label = series_label(&p.method, &series_setting(&p.setting));
            if !order.contains(&label) {
                order.push(label.clone());
            }
            series
                .entry(label)
                .or_default()
                .entry(p.setting.clone())
                .or_default()
                .push(p);
        }
        let mut mse_spp = Vec::new();
        let mut mse_time = Vec::new();
        let mut efficiency_series = Vec::new();
        for label in &order {
            let mut a = Vec::new();
            let mut b = Vec::new();
            let mut c = Vec::new();
            let mut no_efficiency = 0;
            // The fewest trials behind a point: the pooled variance's degrees of freedom per point.
            let mut fewest = u32::MAX;
            for trials in series[label].values() {
                fewest = fewest.min(trials.len() as u32);
                let (spp, _) = mean_se(&trials.iter().map(|p| p.spp).collect::<Vec<_>>());
                let (time, _) = mean_se(&trials.iter().map(|p| p.wall_seconds).collect::<Vec<_>>());
                let mse: Vec<f64> = trials.iter().map(|p| p.mse).collect();
                let (m, mse_se) = mean_se(&mse);
                a.push((spp, m, mse_se));
                b.push((time, m, mse_se));
                let times: Vec<f64> = trials.iter().map(|p| p.wall_seconds).collect();
                let e = efficiency(&mse, &times);
                match e.value {
                    Some(v) => c.push((spp, v, e.se.unwrap_or(0.0))),
                    None => no_efficiency += 1,
                }
            }
            a.sort_by(|x, y| x.0.total_cmp(&y.0));
            b.sort_by(|x, y| x.0.total_cmp(&y.0));
            c.sort_by(|x, y| x.0.total_cmp(&y.0));
            let fitted: Vec<(f64, f64, f64)> =
                a.iter().filter(|p| p.0 >= fit_from).copied().collect();
            let fit = fit_power_law(&fitted, Some(fewest));
            let legend = match &fit {
                Some(f) => fit_legend(label, f),
                None => legend_with_dropped(label, &a),
            };
            if let Some(f) = fit {
                fits.push(SeriesFit {
                    scene: scene.into(),
                    series: label.clone(),
                    fit: f,
                });
            }
            mse_spp.push(Series {
                label: legend,
                points: a,
            });
            mse_time.push(Series {
                label: legend_with_dropped(label, &b),
                points: b,
            });
            efficiency_series.push(Series {
                label: match no_efficiency {
                    0 => label.clone(),
                    n => format!("{label} ({n} point(s) with mean MSE ≤ 0 left out)"),
                },
                points: c,
            });
        }
        let plots = [
            (
                "mse-vs-spp",
                "MSE against samples per pixel",
                "samples per pixel",
                "MSE (mean over trials ± 1 s.e.)",
                mse_spp,
            ),
            (
                "mse-vs-time",
                "MSE against render time",
                "wall seconds",
                "MSE (mean over trials ± 1 s.e.)",
                mse_time,
            ),
            (
                "efficiency",
                "Efficiency 1 / (MSE · time)",
                "samples per pixel",
                "1 / (mean MSE · mean s) ± 1 s.e.",
                efficiency_series,
            ),
        ];
        for (name, title, x, y, series) in plots {
            let plot = LinePlot {
                title: format!("{scene}: {title}"),
                x_label: x.into(),
                y_label: y.into(),
                log_x: true,
                log_y: true,
                series,
            };
            let svg = render_svg(&plot).map_err(io::Error::other)?;
            let file = format!("{scene}-{name}.svg");
            write_atomic(&out_dir.join(&file), svg.as_bytes())?;
            files.push(file);
        }

        // The error against every other numeric setting an axis sweeps (max_bounces, patches, …).
        let scene_points: Vec<&RunPoint> = pts.iter().filter(|p| p.scene == scene).collect();
        for (name, plot) in field_plots(scene, &scene_points) {
            let svg = render_svg(&plot).map_err(io::Error::other)?;
            let file = format!("{scene}-{name}.svg");
            write_atomic(&out_dir.join(&file), svg.as_bytes())?;
            files.push(file);
        }

        // The error of each path class alone, against samples and against time.
        let classes: std::collections::BTreeSet<&String> = pts
            .iter()
            .filter(|p| p.scene == scene)
            .flat_map(|p| p.class_mse.keys())
            .collect();
        for class in classes {
            let mut by_spp = Vec::new();
            let mut by_time = Vec::new();
            for label in &order {
                let mut a = Vec::new();
                let mut b = Vec::new();
                let mut fewest = u32::MAX;
                for trials in series[label].values() {
                    let mse: Vec<f64> = trials
                        .iter()
                        .filter_map(|p| p.class_mse.get(class).copied())
                        .collect();
                    if mse.is_empty() {
                        continue;
                    }
                    fewest = fewest.min(mse.len() as u32);
                    let (spp, _) = mean_se(&trials.iter().map(|p| p.spp).collect::<Vec<_>>());
                    let (time, _) =
                        mean_se(&trials.iter().map(|p| p.wall_seconds).collect::<Vec<_>>());
                    let (m, se) = mean_se(&mse);
                    a.push((spp, m, se));
                    b.push((time, m, se));
                }
                a.sort_by(|x, y| x.0.total_cmp(&y.0));
                b.sort_by(|x, y| x.0.total_cmp(&y.0));
                let fitted: Vec<(f64, f64, f64)> =
                    a.iter().filter(|p| p.0 >= fit_from).copied().collect();
                let fit = fit_power_law(&fitted, Some(fewest));
                by_spp.push(Series {
                    label: fit
                        .as_ref()
                        .map_or_else(|| legend_with_dropped(label, &a), |f| fit_legend(label, f)),
                    points: a,
                });
                if let Some(f) = fit {
                    fits.push(SeriesFit {
                        scene: scene.into(),
                        series: format!("{label} [{class}]"),
                        fit: f,
                    });
                }
                by_time.push(Series {
                    label: legend_with_dropped(label, &b),
                    points: b,
                });
            }
            for (name, title, x, series) in [
                (
                    "mse-vs-spp",
                    "against samples per pixel",
                    "samples per pixel",
                    by_spp,
                ),
                (
                    "mse-vs-time",
                    "against render time",
                    "wall seconds",
                    by_time,
                ),
            ] {
                let plot = LinePlot {
                    title: format!("{scene}: MSE of the {class} paths {title}"),
                    x_label: x.into(),
                    y_label: format!("MSE of {class} (mean over trials ± 1 s.e.)"),
                    log_x: true,
                    log_y: true,
                    series,
                };
                let svg = render_svg(&plot).map_err(io::Error::other)?;
                let file = format!("{scene}-{name}-{}.svg", sanitize(class));
                write_atomic(&out_dir.join(&file), svg.as_bytes())?;
                files.push(file);
            }
        }
    }
    Ok(Plots { fits, files })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points a log axis cannot show are counted in the legend.
    #[test]
    fn legends_count_points_with_no_positive_error() {
        let points = [(1.0, 0.5, 0.1), (2.0, 0.0, 0.1), (4.0, -1e-6, 0.1)];
        assert_eq!(
            legend_with_dropped("Path", &points),
            "Path (2 point(s) with MSE ≤ 0 left out)"
        );
        assert_eq!(legend_with_dropped("Path", &points[..1]), "Path");
    }
}
