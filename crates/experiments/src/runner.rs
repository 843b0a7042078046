//! `lightlab run`: renders every run of an experiment that has not finished yet, compares it with
//! the reference and records it under `results/<name>/runs/<id>/` (image.exr, run.ron, then
//! metrics.json, each written atomically; metrics.json last, so its presence marks a finished run).
//! An interrupted sweep therefore resumes where it stopped; shards run disjoint slices of it.

use crate::atomic::{STALE_AFTER, sweep_stale_temps, write_atomic};
use crate::desc::{BudgetDesc, ExperimentDesc, ReferenceDesc, load_experiment};
use crate::image_io::{RgbLayer, output_layers, write_exr};
use crate::metrics::{Errors, errors};
use crate::plan::{RunSpec, expand, shard};
use crate::reference::{Reference, class_layers, reference};
use crate::report::write_report;
use lightlab_core::Progress;
use lightlab_integrators::{IntegratorConfig, PixelLimit};
use lightlab_scene::Scene;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where results go and which part of the sweep to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Root of all results: the experiment writes `<results>/<name>/`, references are cached in
    /// `<results>/references/`.
    pub results: PathBuf,
    /// `Some((i, n))`: run only shard i of n (0-based), the runs with index % n == i.
    pub shard: Option<(u32, u32)>,
    /// Where rendered references are cached; default `<results>/references/`. Shards with their
    /// own results directories point this at one shared directory to render each reference once.
    pub references: Option<PathBuf>,
    /// Render (or find) the references and stop, so that shards started afterwards only read them.
    pub reference_only: bool,
}

impl RunOptions {
    pub fn new(results: PathBuf) -> RunOptions {
        RunOptions {
            results,
            shard: None,
            references: None,
            reference_only: false,
        }
    }
}

/// What identifies an experiment's runs (`experiment.json` in its output directory): a hash of
/// every resolved run id (what each run renders: scene, method, settings, budget, trial, seed),
/// and a hash of what they are measured on and against, so that shards of one experiment, and
/// only those, merge, and finished runs are reused only for the experiment that made them.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ExperimentIdentity {
    pub name: String,
    pub runs: usize,
    pub runs_hash: String,
    /// Every scene's contents (with the meshes and images it reads), the resolution, the
    /// reference (its settings and the version of what the reference cache holds, or the files'
    /// contents), the path classes and the version of the errors' definitions. `None` in output
    /// directories written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inputs_hash: Option<String>,
}

/// Every scene of an experiment, loaded (`load_scene`) with its identifying text, by the path its
/// runs name it with (the experiment file's directory joined with the path as listed).
pub type LoadedScenes = BTreeMap<PathBuf, (Scene, String)>;

/// Loads every scene of experiment `desc` (read from `path`) once: its identity hashes them, and
/// its runs render them. A scene that cannot be built is an error before anything renders.
pub fn load_scenes(desc: &ExperimentDesc, path: &Path) -> Result<LoadedScenes, String> {
    let base = path.parent().unwrap_or(Path::new("."));
    desc.scenes
        .iter()
        .map(|scene| {
            let path = base.join(scene);
            load_scene(&path, desc.resolution).map(|loaded| (path, loaded))
        })
        .collect()
}

impl ExperimentIdentity {
    /// The identity of experiment `desc` (read from `path`) expanded into `runs`, with its
    /// `scenes` loaded.
    pub fn of(
        desc: &ExperimentDesc,
        path: &Path,
        runs: &[RunSpec],
        scenes: &LoadedScenes,
    ) -> Result<ExperimentIdentity, String> {
        let ids: String = runs
            .iter()
            .map(|r| r.id.as_str())
            .collect::<Vec<_>>()
            .join("\n");
        let base = path.parent().unwrap_or(Path::new("."));
        let file_hash = |p: &Path| {
            std::fs::read(p)
                .map(|bytes| crate::plan::fnv1a(&bytes))
                .map_err(|e| format!("{}: {e}", p.display()))
        };
        let mut inputs = format!(
            "resolution:{:?}\nreference:{:?}\nclasses:{:?}\nmetrics:{}",
            desc.resolution,
            desc.reference,
            desc.classes,
            crate::metrics::FORMAT
        );
        match &desc.reference {
            ReferenceDesc::Exr { path, variance, .. } => {
                for p in std::iter::once(path).chain(variance) {
                    inputs += &format!("\nreference file:{:016x}", file_hash(&base.join(p))?);
                }
            }
            // A rendered reference changes with what its cache holds (its format's version).
            ReferenceDesc::Render { .. } => {
                inputs += &format!("\nreference format:{}", crate::reference::REFERENCE_FORMAT)
            }
        }
        for scene in &desc.scenes {
            let (_, text) = scenes
                .get(&base.join(scene))
                .ok_or_else(|| format!("{}: not loaded", scene.display()))?;
            inputs += &format!(
                "\nscene:{}:{:016x}",
                scene.display(),
                crate::plan::fnv1a(text.as_bytes())
            );
        }
        Ok(ExperimentIdentity {
            name: desc.name.clone(),
            runs: runs.len(),
            runs_hash: format!("{:016x}", crate::plan::fnv1a(ids.as_bytes())),
            inputs_hash: Some(format!("{:016x}", crate::plan::fnv1a(inputs.as_bytes()))),
        })
    }

    pub fn read(dir: &Path) -> Option<ExperimentIdentity> {
        serde_json::from_str(&std::fs::read_to_string(dir.join("experiment.json")).ok()?).ok()
    }

    /// `Err` saying why the results in `dir`, of identity `found`, are not of this experiment. A
    /// directory from before the inputs were recorded is taken on its runs alone.
    pub fn check(&self, found: &ExperimentIdentity, dir: &Path) -> Result<(), String> {
        if (&found.name, found.runs, &found.runs_hash) != (&self.name, self.runs, &self.runs_hash) {
            return Err(format!(
                "{} holds the results of another version of experiment {:?} ({} runs, hash {}; \
                 this file expands to {} runs, hash {}): move them away, or use another --results",
                dir.display(),
                found.name,
                found.runs,
                found.runs_hash,
                self.runs,
                self.runs_hash
            ));
        }
        match &found.inputs_hash {
            Some(h) if Some(h) != self.inputs_hash.as_ref() => Err(format!(
                "{} holds runs of experiment {:?} measured on other inputs: a scene's contents, \
                 the resolution, the reference, the path classes or the errors' definitions have \
                 changed since (inputs hash {h}, now {}); move them away, or use another --results",
                dir.display(),
                self.name,
                self.inputs_hash.as_deref().unwrap_or("none")
            )),
            _ => Ok(()),
        }
    }
}

/// Whether output directory `dir` holds a finished run (an identity alone, written by a run that
/// stopped before its first, binds nothing).
fn holds_runs(dir: &Path) -> bool {
    std::fs::read_dir(dir.join("runs")).is_ok_and(|entries| {
        entries
            .flatten()
            .any(|e| e.path().join("metrics.json").is_file())
    })
}

/// What a finished run records (`metrics.json`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct RunRecord {
    pub id: String,
    pub index: usize,
    pub scene: String,
    pub method: String,
    pub integrator: String,
    pub setting: String,
    pub trial: u32,
    pub seed: u64,
    /// Budget asked for: samples per pixel, or seconds (then `spp` is what was reached).
    pub budget_spp: Option<u32>,
    pub budget_seconds: Option<f64>,
    pub spp: u32,
    pub wall_seconds: f64,
    /// Of `wall_seconds`, the pilot renders that calibrated a time budget (stratified samplers).
    #[serde(default)]
    pub pilot_seconds: f64,
    pub samples: u64,
    pub rays: u64,
    /// Photon (light) paths traced and photons stored, for the photon-mapping methods and VCM.
    #[serde(default)]
    pub photons: u64,
    #[serde(default)]
    pub photons_stored: u64,
    pub non_finite: u64,
    pub errors: Errors,
    /// Errors of each path-class layer (the experiment's `classes`, then `rest`) against the same
    /// layer of the reference.
    #[serde(default)]
    pub class_errors: Vec<(String, Errors)>,
    /// The reference image the errors were measured against: `reference/<scene>.exr`, relative
    /// to the output directory (before it was kept there: the cache file's path as given).
    pub reference: PathBuf,
    /// What the method's pixel values converge to (`OneCameraPath` for `Ppm`: not the pixel
    /// integral the reference estimates).
    #[serde(default)]
    pub pixel_limit: PixelLimit,
    pub lightlab_version: String,
    /// The machine it ran on (CPU model, logical cores, operating system, the build's SIMD width).
    #[serde(default)]
    pub machine: String,
    /// A radiosity run's discretisation and solve.
    #[serde(default)]
    pub radiosity: Option<RadiosityRecord>,
}

/// What a radiosity run did besides rendering (from its `RadiosityStats`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct RadiosityRecord {
    /// Patches made.
    pub patches: usize,
    /// Form-factor rays cast.
    pub form_factor_rays: u64,
    /// Solver iterations done.
    pub iterations: u32,
    /// Relative residual ‖E + ρF̂B − B‖ / ‖E‖ of the solution.
    pub residual: f64,
    /// Seconds estimating the form factors and solving (both within `wall_seconds`).
    pub form_factor_seconds: f64,
    pub solve_seconds: f64,
}

/// Summary of one `lightlab run`.
pub struct Outcome {
    pub out_dir: PathBuf,
    pub total: usize,
    pub ran: usize,
    pub skipped: usize,
    pub warnings: Vec<String>,
    /// Whether the tables, plots and report were rebuilt (not when nothing was rendered and
    /// the results lack inputs the report needs: a warning says which).
    pub report_written: bool,
}

/// Copies the experiment file beside its results (`experiment.ron`), for the report to show.
pub fn write_source(path: &Path, out_dir: &Path) -> Result<(), String> {
    let text = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    write_atomic(&out_dir.join("experiment.ron"), &text)
        .map_err(|e| format!("{}: {e}", out_dir.display()))
}

/// Loads a scene with the experiment's resolution override; returns it with its text (for a
/// Mitsuba file, the imported description, which includes its meshes and included files), to
/// which the name and a hash of the contents of every file it reads are appended (meshes, texture
/// images, the environment map): the reference cache's key must change when any of them does.
pub fn load_scene(path: &Path, resolution: Option<(u32, u32)>) -> Result<(Scene, String), String> {
    let (mut scene, text) = if lightlab_scene::mitsuba::is_mitsuba(path) {
        let imported = lightlab_scene::mitsuba::import(path, &[]).map_err(|e| e.to_string())?;
        let text = format!("{:?}", imported.desc);
        let mut scene =
            lightlab_scene::build_scene(imported.desc, path).map_err(|e| e.to_string())?;
        scene.warnings.extend(imported.notes);
        (scene, text)
    } else {
        let text = lightlab_scene::text::read_text(path).map_err(|e| e.located(path))?;
        let scene = lightlab_scene::parse_scene(&text, path).map_err(|e| e.to_string())?;
        (scene, text)
    };
    if let Some((w, h)) = resolution {
        scene.camera = scene.camera.with_resolution(w, h);
    }
    let mut text = text;
    for input in &scene.inputs {
        let bytes = std::fs::read(input)
            .map_err(|e| format!("{}: cannot read scene input: {e}", input.display()))?;
        let name = input.file_name().unwrap_or_default().to_string_lossy();
        text += &format!("\ninput:{name}:{:016x}", crate::plan::fnv1a(&bytes));
    }
    Ok((scene, text))
}

/// Where in the output directory the reference of scene `name` is kept as the runs were measured
/// against it (relative to the output directory, as runs record it).
fn kept_reference(name: &str) -> PathBuf {
    Path::new("reference").join(format!("{name}.exr"))
}

/// Keeps reference `r` of scene `name` in `out_dir` as the errors use it: its image, and the
/// variance only where it is subtracted (a rendered reference whose variance is no estimate, or an
/// `Exr` reference's separate variance file or chosen layer, are stored as measured), with each
/// path class's layer. The report recomputes bias² and variance from it, wherever the results are
/// moved and whatever the cache holds.
fn keep_reference(out_dir: &Path, name: &str, r: &Reference) -> Result<(), String> {
    let (w, h) = (r.image.width, r.image.height);
    let layers = |name: &str, image: &crate::metrics::Image| {
        let variance = image.variance.as_ref().map(|v| RgbLayer {
            name: if name == "radiance" {
                "variance".into()
            } else {
                format!("{name}.variance")
            },
            pixels: v.clone(),
        });
        std::iter::once(RgbLayer {
            name: name.into(),
            pixels: image.mean.clone(),
        })
        .chain(variance)
    };
    let all: Vec<RgbLayer> = layers("radiance", &r.image)
        .chain(r.classes.iter().flat_map(|(n, c)| layers(n, c)))
        .collect();
    let path = out_dir.join(kept_reference(name));
    write_exr(&path, w, h, &all).map_err(|e| format!("{}: {e}", path.display()))
}

/// The experiment's output directory.
pub fn output_dir(desc: &ExperimentDesc, results: &Path) -> PathBuf {
    results.join(&desc.name)
}

/// Runs (or resumes) the experiment at `path`.
pub fn run_experiment(
    path: &Path,
    options: &RunOptions,
    overall: &dyn Progress,
    per_run: &dyn Progress,
    log: &dyn Fn(&str),
) -> Result<Outcome, String> {
    let desc = load_experiment(path).map_err(|e| e.to_string())?;
    let mut runs = expand(&desc, path).map_err(|e| e.to_string())?;
    let total = runs.len();
    let mut loaded = load_scenes(&desc, path)?;
    let identity = ExperimentIdentity::of(&desc, path, &runs, &loaded)?;
    if let Some((i, n)) = options.shard {
        runs = shard(runs, i, n);
    }
    let out_dir = output_dir(&desc, &options.results);
    let experiment_dir = path.parent().unwrap_or(Path::new("."));
    let cache_dir = options
        .references
        .clone()
        .unwrap_or_else(|| options.results.join(crate::desc::REFERENCE_CACHE));
    let found = ExperimentIdentity::read(&out_dir);
    if let Some(found) = &found
        && holds_runs(&out_dir)
    {
        identity.check(found, &out_dir)?;
    }
    // New, or from before the inputs were recorded: record them now.
    if found.as_ref() != Some(&identity) {
        let json = serde_json::to_string_pretty(&identity).map_err(|e| e.to_string())?;
        write_atomic(&out_dir.join("experiment.json"), json.as_bytes())
            .map_err(|e| format!("{}: {e}", out_dir.display()))?;
    }
    write_source(path, &out_dir)?;
    for dir in [&out_dir, &cache_dir] {
        let swept =
            sweep_stale_temps(dir, STALE_AFTER).map_err(|e| format!("{}: {e}", dir.display()))?;
        if swept > 0 {
            log(&format!(
                "removed {swept} temporary file{} that interrupted writes left in {} (older than \
                 an hour)",
                if swept == 1 { "" } else { "s" },
                dir.display()
            ));
        }
    }
    // A scene, loaded once, with its reference (found in the cache, rendered, or read).
    let mut prepare =
        |run: &RunSpec, warnings: &mut Vec<String>| -> Result<(Scene, Reference), String> {
            let (scene, text) = loaded
                .remove(&run.scene)
                .ok_or_else(|| format!("{}: not loaded", run.scene.display()))?;
            warnings.extend(scene.warnings.iter().cloned());
            log(&format!(
                "reference for {}: {}",
                run.scene_name,
                match &desc.reference {
                    crate::desc::ReferenceDesc::Render { integrator, spp } =>
                        format!("{integrator} at {spp} spp"),
                    crate::desc::ReferenceDesc::Exr { path, .. } => path.display().to_string(),
                }
            ));
            let r = reference(
                &desc.reference,
                experiment_dir,
                &cache_dir,
                &run.scene_name,
                &text,
                &scene,
                &desc.classes,
                per_run,
                log,
            )?;
            log(&format!(
                "  {} {}",
                if r.cached { "cached:" } else { "rendered:" },
                r.path.display()
            ));
            if let Some(note) = &r.variance_note {
                warnings.push(format!("{}: {note}", run.scene_name));
            }
            keep_reference(&out_dir, &run.scene_name, &r)?;
            Ok((scene, r))
        };
    let mut warnings = Vec::new();
    if options.reference_only {
        let mut seen = std::collections::BTreeSet::new();
        for run in &runs {
            if seen.insert(run.scene.clone()) {
                prepare(run, &mut warnings)?;
            }
        }
        return Ok(Outcome {
            out_dir,
            total,
            ran: 0,
            skipped: runs.len(),
            warnings,
            report_written: false,
        });
    }
    let pending: Vec<&RunSpec> = runs
        .iter()
        .filter(|r| !run_dir(&out_dir, r).join("metrics.json").is_file())
        .collect();
    let skipped = runs.len() - pending.len();
    if skipped > 0 {
        log(&format!(
            "resuming: {skipped} of {} runs already finished",
            runs.len()
        ));
    }
    overall.start(pending.len() as u64);

    let mut scenes: BTreeMap<PathBuf, (Scene, Reference)> = BTreeMap::new();
    for run in &pending {
        if !scenes.contains_key(&run.scene) {
            let prepared = prepare(run, &mut warnings)?;
            scenes.insert(run.scene.clone(), prepared);
        }
        let (scene, reference) = &scenes[&run.scene];
        let config = IntegratorConfig::from_ron(&run.integrator)
            .and_then(|c| c.with_paths_and_layers(None, class_layers(&desc.classes)))
            .map_err(|e| e.to_string())?;
        let integrator = config.build().map_err(|e| e.to_string())?;
        lightlab_integrators::memory::check_render(&*integrator, scene, &run.budget.into())
            .map_err(|e| format!("{} / {}: {e}", run.scene_name, run.method))?;
        for w in integrator.scene_warnings(scene) {
            warnings.push(format!("{} / {}: {w}", run.scene_name, run.method));
        }
        let out = integrator.render(scene, &run.budget.into(), run.seed, per_run);
        let layers = output_layers(&out);
        let e = errors(&layers[0].pixels, &reference.image)
            .ok_or("image and reference sizes differ")?;
        let mut class_errors = Vec::new();
        for (name, image) in &reference.classes {
            let layer = layers
                .iter()
                .find(|l| &l.name == name)
                .ok_or_else(|| format!("the render has no layer {name}"))?;
            let e = errors(&layer.pixels, image).ok_or("layer and reference sizes differ")?;
            class_errors.push((name.clone(), e));
        }
        // A run is recorded (and so counted as finished) only with finite errors: one NaN would
        // make every statistic of its setting NaN, and resuming would keep it.
        if let Some((what, bad)) = std::iter::once(("", &e))
            .chain(class_errors.iter().map(|(n, e)| (n.as_str(), e)))
            .find(|(_, e)| !e.is_finite())
        {
            return Err(format!(
                "{} / {} / {} trial {}: its error{}{} against the reference is not finite ({:?}): \
                 the run's image or the reference holds values beyond 32-bit floats; nothing was recorded",
                run.scene_name,
                run.method,
                run.setting,
                run.trial,
                if what.is_empty() { "" } else { " in layer " },
                what,
                bad
            ));
        }
        if out.stats.pixel_limit == PixelLimit::OneCameraPath {
            warnings.push(format!(
                "{} / {}: {} converges to the radiance along one camera path per pixel, not to the \
                 pixel's box-filtered value the reference estimates; its error keeps that difference",
                run.scene_name, run.method, out.stats.integrator
            ));
        }
        if e.reference_variance > 0.1 * e.mse.abs() {
            warnings.push(format!(
                "{} / {} / {}: the reference's own variance ({:.3e}) is more than 10 % of the measured MSE ({:.3e}); render the reference with more samples",
                run.scene_name, run.method, run.setting, e.reference_variance, e.mse
            ));
        }
        let record = RunRecord {
            id: run.id.clone(),
            index: run.index,
            scene: run.scene_name.clone(),
            method: run.method.clone(),
            integrator: run.integrator.clone(),
            setting: run.setting.clone(),
            trial: run.trial,
            seed: run.seed,
            budget_spp: match run.budget {
                BudgetDesc::Samples(s) => Some(s),
                _ => None,
            },
            budget_seconds: match run.budget {
                BudgetDesc::Seconds(s) => Some(s),
                _ => None,
            },
            spp: out.stats.spp,
            wall_seconds: out.stats.wall_seconds,
            pilot_seconds: out.stats.pilot_seconds,
            samples: out.stats.samples,
            rays: out.stats.rays,
            photons: out.stats.photons,
            photons_stored: out.stats.photons_stored,
            non_finite: out.stats.non_finite_total(),
            errors: e,
            class_errors,
            reference: kept_reference(&run.scene_name),
            pixel_limit: out.stats.pixel_limit,
            lightlab_version: env!("CARGO_PKG_VERSION").into(),
            machine: crate::html::machine(),
            radiosity: out.stats.radiosity.as_ref().map(|r| RadiosityRecord {
                patches: r.patches,
                form_factor_rays: r.form_factor_rays,
                iterations: r.iterations,
                residual: r.residuals.last().copied().unwrap_or(0.0),
                form_factor_seconds: r.form_factor_seconds,
                solve_seconds: r.solve_seconds,
            }),
        };
        let dir = run_dir(&out_dir, run);
        write_exr(
            &dir.join("image.exr"),
            out.film.width,
            out.film.height,
            &layers,
        )
        .map_err(|e| e.to_string())?;
        let run_ron =
            ron::ser::to_string_pretty(run, ron::ser::PrettyConfig::new().struct_names(true))
                .map_err(|e| e.to_string())?;
        write_atomic(&dir.join("run.ron"), run_ron.as_bytes())
            .map_err(|e| format!("{}: {e}", dir.display()))?;
        let json = serde_json::to_string_pretty(&record).map_err(|e| e.to_string())?;
        write_atomic(&dir.join("metrics.json"), json.as_bytes())
            .map_err(|e| format!("{}: {e}", dir.display()))?;
        overall.advance(1);
    }
    warnings.sort();
    warnings.dedup();
    // With nothing rendered now, results kept without their images (committed ones) stay as
    // they are; after rendering, a report that cannot be rebuilt is an error.
    let report_written = match write_report(&out_dir) {
        Err(e) if pending.is_empty() => {
            warnings.push(e.to_string());
            false
        }
        r => r.map(|_| true).map_err(|e| e.to_string())?,
    };
    Ok(Outcome {
        out_dir,
        total,
        ran: pending.len(),
        skipped,
        warnings,
        report_written,
    })
}

fn run_dir(out_dir: &Path, run: &RunSpec) -> PathBuf {
    out_dir.join("runs").join(&run.id)
}

/// What `lightlab merge` found.
#[derive(Debug)]
pub struct MergeOutcome {
    /// Runs copied now.
    pub copied: usize,
    /// Runs found in more than one shard (the first copy is kept).
    pub duplicated: usize,
    /// Runs of the experiment that no shard (nor the merged directory) has.
    pub missing: Vec<String>,
}

/// `lightlab merge`: copies the finished runs of shard output directories of experiment `path`
/// into `out_dir` (runs already present are kept) and rewrites the tables and plots. Every shard
/// must be of this experiment (its `experiment.json` identity, and every run id one of its runs);
/// unless `partial`, every run must be present, or nothing is merged.
pub fn merge(
    path: &Path,
    out_dir: &Path,
    shard_dirs: &[PathBuf],
    partial: bool,
) -> Result<MergeOutcome, String> {
    let desc = load_experiment(path).map_err(|e| e.to_string())?;
    let runs = expand(&desc, path).map_err(|e| e.to_string())?;
    let identity = ExperimentIdentity::of(&desc, path, &runs, &load_scenes(&desc, path)?)?;
    if let Some(found) = ExperimentIdentity::read(out_dir)
        && holds_runs(out_dir)
    {
        identity.check(&found, out_dir)?;
    }
    let expected: std::collections::BTreeSet<&str> = runs.iter().map(|r| r.id.as_str()).collect();
    // (run id, directory it comes from), in shard order.
    let mut sources: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut duplicated = 0;
    for shard_dir in shard_dirs {
        match ExperimentIdentity::read(shard_dir) {
            Some(found) => identity
                .check(&found, shard_dir)
                .map_err(|e| format!("{e} (not a shard of {})", path.display()))?,
            None => {
                return Err(format!(
                    "{} has no experiment.json: it is not the output directory of a `lightlab \
                     run` (give SHARD_RESULTS/<name>)",
                    shard_dir.display()
                ));
            }
        }
        let dir = shard_dir.join("runs");
        let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for entry in entries {
            let entry = entry.map_err(|e| e.to_string())?;
            let from = entry.path();
            if !from.join("metrics.json").is_file() {
                continue;
            }
            let id = entry.file_name().to_string_lossy().into_owned();
            if !expected.contains(id.as_str()) {
                return Err(format!(
                    "{} holds run {id}, which is not a run of {}",
                    shard_dir.display(),
                    path.display()
                ));
            }
            match sources.entry(id) {
                std::collections::btree_map::Entry::Occupied(_) => duplicated += 1,
                std::collections::btree_map::Entry::Vacant(v) => {
                    v.insert(from);
                }
            }
        }
    }
    let missing: Vec<String> = runs
        .iter()
        .filter(|r| {
            !sources.contains_key(&r.id)
                && !out_dir
                    .join("runs")
                    .join(&r.id)
                    .join("metrics.json")
                    .is_file()
        })
        .map(|r| r.id.clone())
        .collect();
    if !missing.is_empty() && !partial {
        return Err(format!(
            "{} of the experiment's {} runs are in none of the shards (first: {}); nothing was \
             merged — run the missing shards, or merge with --partial",
            missing.len(),
            runs.len(),
            missing[0]
        ));
    }
    let json = serde_json::to_string_pretty(&identity).map_err(|e| e.to_string())?;
    write_atomic(&out_dir.join("experiment.json"), json.as_bytes())
        .map_err(|e| format!("{}: {e}", out_dir.display()))?;
    write_source(path, out_dir)?;
    // The references the runs were measured against (kept by each shard), before the runs that
    // name them.
    for shard_dir in shard_dirs {
        let Ok(entries) = std::fs::read_dir(shard_dir.join("reference")) else {
            continue;
        };
        for entry in entries {
            let from = entry.map_err(|e| e.to_string())?.path();
            let to = out_dir
                .join("reference")
                .join(from.file_name().unwrap_or_default());
            if from.extension().is_some_and(|e| e == "exr") && !to.is_file() && from != to {
                let bytes = std::fs::read(&from).map_err(|e| format!("{}: {e}", from.display()))?;
                write_atomic(&to, &bytes).map_err(|e| format!("{}: {e}", to.display()))?;
            }
        }
    }
    let mut copied = 0;
    for (id, from) in &sources {
        let to = out_dir.join("runs").join(id);
        if to.join("metrics.json").is_file() || *from == to {
            continue;
        }
        std::fs::create_dir_all(&to).map_err(|e| format!("{}: {e}", to.display()))?;
        // metrics.json last, as in a run, so an interrupted merge never leaves a half run.
        for name in ["image.exr", "run.ron", "metrics.json"] {
            let bytes = std::fs::read(from.join(name))
                .map_err(|e| format!("{}: {e}", from.join(name).display()))?;
            write_atomic(&to.join(name), &bytes).map_err(|e| format!("{}: {e}", to.display()))?;
        }
        copied += 1;
    }
    write_report(out_dir).map_err(|e| e.to_string())?;
    Ok(MergeOutcome {
        copied,
        duplicated,
        missing,
    })
}
