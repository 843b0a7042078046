//! Experiment files (`experiments/*.ron`): which scenes, which methods with which settings, which
//! sweep, how many independent trials, and the reference every run is compared with. Every field is
//! documented here and in `experiments/README.md`; unknown fields are errors with file, line and column.

use lightlab_scene::MAX_RESOLUTION;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One experiment.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Experiment")]
pub struct ExperimentDesc {
    /// Output directory name: results go to `results/<name>/`. Letters, digits, `-` and `_`.
    pub name: String,
    /// Scene files, relative to the experiment file. At least one.
    pub scenes: Vec<PathBuf>,
    /// Overrides every scene's image size (the field of view along the smaller axis is kept), so
    /// sweeps of many runs stay cheap. Default: each scene's own resolution.
    #[serde(default)]
    pub resolution: Option<(u32, u32)>,
    /// What every run is compared with.
    pub reference: ReferenceDesc,
    /// The methods compared. At least one; labels must be unique.
    pub methods: Vec<MethodDesc>,
    /// Axes swept for every method; the runs are the Cartesian product of all axes. A method
    /// setting named by an axis is overridden by it. Default: no axis (one setting).
    #[serde(default)]
    pub sweep: Vec<Axis>,
    /// Budget of a run when no axis sets `spp` or `seconds`. Default: `Samples(16)`.
    #[serde(default)]
    pub budget: BudgetDesc,
    /// Independent repetitions of every setting (distinct seeds). Default 4, at least 2 so that
    /// variance across trials is defined.
    #[serde(default = "default_trials")]
    pub trials: u32,
    /// Base seed: trial t of run setting s uses a seed derived from (seed, scene, method, setting, t).
    /// Default 0.
    #[serde(default)]
    pub seed: u64,
    /// Path classes (Heckbert expressions such as `"LS+DE"`) whose error is reported separately:
    /// every run and the reference write one layer per class (the paths it matches first) and a
    /// `rest` layer, and each gets its own metrics and plots. Default: none.
    #[serde(default)]
    pub classes: Vec<String>,
    /// Convergence fits use only the settings with at least this many samples per pixel (mean
    /// over trials; all are plotted): rates are asymptotic. Default: every setting.
    #[serde(default)]
    pub fit_from: Option<u32>,
    /// The file's text, to locate errors found later (when runs are expanded).
    #[serde(skip)]
    pub source: String,
}

fn default_trials() -> u32 {
    4
}

/// The reference image.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ReferenceDesc {
    /// Rendered once with this integrator (RON text, as `lightlab render --integrator`) at `spp`
    /// samples per pixel and cached under `results/references/` by a hash of the scene text,
    /// resolution, these settings and the Lightlab version.
    Render { integrator: String, spp: u32 },
    /// Loaded from an EXR file another program (or Lightlab) wrote, relative to the experiment
    /// file; its size must match the runs'. The image is the layer named `layer` if given,
    /// otherwise a layer `radiance` (Lightlab's own files), otherwise the unnamed R, G, B channels
    /// of a single-part file (Mitsuba 3, pbrt-v4), otherwise its only RGB layer; channels may be
    /// plain `R, G, B` or prefixed, `radiance.R`. Its variance of the pixel mean is the layer
    /// `variance` (or pbrt's `Variance`) of the same file, or the image of the separate file
    /// `variance`; without one nothing is subtracted from the errors. A variance given this way
    /// is trusted to be the variance of the mean of independent samples.
    Exr {
        path: PathBuf,
        #[serde(default)]
        layer: Option<String>,
        #[serde(default)]
        variance: Option<PathBuf>,
    },
}

/// A method: an integrator and its settings.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Method")]
pub struct MethodDesc {
    /// Name in tables and plot legends.
    pub label: String,
    /// Integrator name, e.g. `"Path"`.
    pub integrator: String,
    /// Integrator fields, e.g. `{"max_bounces": 8, "strategy": "Mis"}`. Numbers are written as
    /// numbers; strings are inserted verbatim as RON, so `"Mis"` or `"None"` name enum values.
    /// Each field at most once.
    #[serde(default, deserialize_with = "unique_keys")]
    pub settings: BTreeMap<String, Value>,
}

/// A map whose keys are all distinct (serde's own map keeps the last of a repeated key).
fn unique_keys<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<BTreeMap<String, Value>, D::Error> {
    struct Unique;
    impl<'de> serde::de::Visitor<'de> for Unique {
        type Value = BTreeMap<String, Value>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a map of integrator fields to values")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(
            self,
            mut map: A,
        ) -> Result<Self::Value, A::Error> {
            let mut out = BTreeMap::new();
            while let Some((key, value)) = map.next_entry::<String, Value>()? {
                if out.contains_key(&key) {
                    return Err(serde::de::Error::custom(format!(
                        "setting {key:?} is given twice"
                    )));
                }
                out.insert(key, value);
            }
            Ok(out)
        }
    }
    d.deserialize_map(Unique)
}

/// A setting's value.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Value {
    Int(i64),
    Float(f64),
    /// RON text inserted verbatim (an enum variant such as `Mis`, or `None`).
    Text(String),
}

impl Value {
    /// The value as RON text.
    pub fn ron(&self) -> String {
        match self {
            Value::Int(i) => i.to_string(),
            Value::Float(f) => format!("{f:?}"),
            Value::Text(t) => t.clone(),
        }
    }
}

/// One sweep axis. The field `spp` sweeps the sample budget, `seconds` the time budget (equal-time
/// comparisons); any other name is an integrator field.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Axis {
    /// An explicit list of values.
    Values { field: String, values: Vec<Value> },
    /// Geometric progression `from, from·factor, …` up to and including `to` (integers are rounded
    /// and deduplicated when `from` and `to` are integers).
    LogRange {
        field: String,
        from: f64,
        to: f64,
        factor: f64,
    },
}

/// How long a run may work.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum BudgetDesc {
    /// Samples per pixel.
    Samples(u32),
    /// Wall-clock seconds, for equal-time comparisons: the render continues its sample sequence
    /// until the time is spent, so it is the same estimator as the sample budget it reaches (see
    /// `lightlab_integrators::Integrator::render`; stratified samplers calibrate with a pilot).
    Seconds(f64),
}

impl From<BudgetDesc> for lightlab_integrators::Budget {
    fn from(b: BudgetDesc) -> Self {
        match b {
            BudgetDesc::Samples(n) => lightlab_integrators::Budget::Samples(n),
            BudgetDesc::Seconds(s) => lightlab_integrators::Budget::Seconds(s),
        }
    }
}

impl Default for BudgetDesc {
    fn default() -> Self {
        BudgetDesc::Samples(16)
    }
}

/// An experiment file that failed to load: the message names file, line and column.
#[derive(Debug)]
pub struct ExperimentError(pub String);

impl std::fmt::Display for ExperimentError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ExperimentError {}

/// Reads and checks an experiment file.
pub fn load_experiment(path: &Path) -> Result<ExperimentDesc, ExperimentError> {
    let text =
        lightlab_scene::text::read_text(path).map_err(|e| ExperimentError(e.located(path)))?;
    parse_experiment(&text, path)
}

/// Parses and checks experiment text; `path` names it in errors.
pub fn parse_experiment(text: &str, path: &Path) -> Result<ExperimentDesc, ExperimentError> {
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut desc: ExperimentDesc = options.from_str(text).map_err(|e| {
        ExperimentError(format!(
            "{}:{}:{}: {}",
            path.display(),
            e.span.start.line,
            e.span.start.col,
            lightlab_scene::ron_message(&e.code)
        ))
    })?;
    desc.check(path.parent().unwrap_or(Path::new(".")))
        .map_err(|(needle, message)| {
            let (line, col) = locate(text, &needle);
            ExperimentError(format!("{}:{line}:{col}: {message}", path.display()))
        })?;
    desc.source = text.to_string();
    Ok(desc)
}

/// Line and column (1-based) of the first occurrence of `needle`, or of the start.
pub(crate) fn locate(text: &str, needle: &str) -> (usize, usize) {
    locate_after(text, "", needle)
}

/// Line and column (1-based) of the first `needle` after the first `anchor` (or of `anchor`, or
/// of the start, when not found), comments left out.
pub(crate) fn locate_after(text: &str, anchor: &str, needle: &str) -> (usize, usize) {
    let code = lightlab_scene::text::without_comments(text);
    let from = code.find(anchor).unwrap_or(0);
    let at = code[from..].find(needle).map_or(from, |i| from + i);
    let line = text[..at].matches('\n').count() + 1;
    let col = at - text[..at].rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, col)
}

impl ExperimentDesc {
    /// Semantic checks, with scene paths relative to `base` (the experiment file's directory); on
    /// failure returns (text to locate, message).
    fn check(&self, base: &Path) -> Result<(), (String, String)> {
        let err = |needle: &str, m: String| Err((needle.to_string(), m));
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return err(
                "name",
                format!(
                    "name must be non-empty letters, digits, '-' or '_', got {:?}",
                    self.name
                ),
            );
        }
        if self.name == REFERENCE_CACHE {
            return err(
                "name",
                format!(
                    "name {REFERENCE_CACHE:?} is the directory beside the experiments' results \
                     where rendered references are cached: choose another name"
                ),
            );
        }
        if self.scenes.is_empty() {
            return err("scenes", "scenes must list at least one scene file".into());
        }
        // The same file however its path is written (`a.ron`, `./a.ron`, `../exp/a.ron`).
        let file =
            |s: &PathBuf| std::fs::canonicalize(base.join(s)).unwrap_or_else(|_| base.join(s));
        for (i, s) in self.scenes.iter().enumerate() {
            if let Some(earlier) = self.scenes[..i].iter().find(|e| file(e) == file(s)) {
                return err(
                    &format!("\"{}\"", s.display()),
                    if earlier == s {
                        format!(
                            "scene \"{}\" is listed twice: its runs would be the same runs",
                            s.display()
                        )
                    } else {
                        format!(
                            "scenes \"{}\" and \"{}\" are the same file: its runs would be the \
                             same runs",
                            earlier.display(),
                            s.display()
                        )
                    },
                );
            }
        }
        if let Some((w, h)) = self.resolution
            && !((1..=MAX_RESOLUTION).contains(&w) && (1..=MAX_RESOLUTION).contains(&h))
        {
            return err(
                "resolution",
                format!("resolution must be 1…{MAX_RESOLUTION} in each axis, got ({w}, {h})"),
            );
        }
        match &self.reference {
            ReferenceDesc::Render { spp, .. } if *spp == 0 => {
                return err("reference", "reference spp must be ≥ 1".into());
            }
            // Checked here, where the error can point into the file, not when it first renders.
            ReferenceDesc::Render { integrator, .. } => {
                let checked = lightlab_integrators::IntegratorConfig::from_ron(integrator)
                    .and_then(|c| c.build().map(|_| ()));
                if let Err(e) = checked {
                    return err(
                        &format!("{integrator:?}"),
                        format!("reference integrator {integrator}: {e}"),
                    );
                }
            }
            _ => {}
        }
        if self.methods.is_empty() {
            return err("methods", "methods must list at least one method".into());
        }
        for (i, m) in self.methods.iter().enumerate() {
            if m.label.trim().is_empty() {
                return err(
                    &format!("\"{}\"", m.label),
                    "a method label must be non-empty: it names the method in tables and plots"
                        .into(),
                );
            }
            if self.methods[..i].iter().any(|o| o.label == m.label) {
                return err(
                    &format!("\"{}\"", m.label),
                    format!("method label {:?} is used twice", m.label),
                );
            }
        }
        for class in &self.classes {
            if let Err(e) = lightlab_integrators::paths::PathRegex::new(class) {
                return err(&format!("\"{class}\""), format!("classes: {e}"));
            }
        }
        // Each class is a layer named by its expression (a repeated one fails here, not after
        // the reference has rendered).
        if !self.classes.is_empty()
            && let Err(e) = lightlab_integrators::paths::Router::check(
                None,
                &lightlab_integrators::paths::Layers::Classes(self.classes.clone()),
                0,
                None,
            )
        {
            return err("classes", format!("classes: {e}"));
        }
        if self.trials < 2 {
            return err(
                "trials",
                format!(
                    "trials must be ≥ 2 (variance across trials needs two), got {}",
                    self.trials
                ),
            );
        }
        check_budget(&self.budget).or_else(|m| err("budget", m))?;
        for (i, a) in self.sweep.iter().enumerate() {
            if self.sweep[..i].iter().any(|o| o.field() == a.field()) {
                return err(
                    "sweep",
                    format!(
                        "two axes sweep {:?}: give its values on one axis",
                        a.field()
                    ),
                );
            }
            if let Axis::Values { field, values } = a
                && let Some(v) = values
                    .iter()
                    .enumerate()
                    .find_map(|(j, v)| values[..j].contains(v).then_some(v))
            {
                return err(
                    &format!("\"{field}\""),
                    format!(
                        "axis {field:?} lists {} twice: its runs would be the same runs",
                        v.ron()
                    ),
                );
            }
            match a {
                Axis::Values { field, values } if values.is_empty() => {
                    return err(
                        &format!("\"{field}\""),
                        format!("axis {field:?} has no values"),
                    );
                }
                Axis::LogRange {
                    field,
                    from,
                    to,
                    factor,
                } if !(*from > 0.0 && to >= from && *factor > 1.0 && to.is_finite()) => {
                    return err(
                        &format!("\"{field}\""),
                        format!(
                            "LogRange {field:?} needs 0 < from ≤ to and factor > 1, got from {from}, to {to}, factor {factor}"
                        ),
                    );
                }
                Axis::LogRange {
                    field,
                    from,
                    to,
                    factor,
                } if (to / from).ln() / factor.ln() >= MAX_AXIS_VALUES as f64 => {
                    return err(
                        &format!("\"{field}\""),
                        format!(
                            "LogRange {field:?} from {from} to {to} by {factor} has more than \
                             {MAX_AXIS_VALUES} values: raise the factor"
                        ),
                    );
                }
                _ => {}
            }
            for v in a.values() {
                let budget = match (a.field(), &v) {
                    ("spp", Value::Int(n)) if *n >= 1 && *n <= u32::MAX as i64 => {
                        Some(BudgetDesc::Samples(*n as u32))
                    }
                    ("seconds", Value::Int(n)) => Some(BudgetDesc::Seconds(*n as f64)),
                    ("seconds", Value::Float(s)) => Some(BudgetDesc::Seconds(*s)),
                    ("spp" | "seconds", v) => {
                        return err(
                            &format!("\"{}\"", a.field()),
                            format!(
                                "axis {:?}: {} is not a valid budget (spp: integers ≥ 1; seconds: numbers > 0)",
                                a.field(),
                                v.ron()
                            ),
                        );
                    }
                    _ => None,
                };
                if let Some(b) = budget {
                    check_budget(&b).or_else(|m| err(&format!("\"{}\"", a.field()), m))?;
                }
            }
        }
        let budget_axes = self
            .sweep
            .iter()
            .filter(|a| matches!(a.field(), "spp" | "seconds"))
            .count();
        if budget_axes > 1 {
            return err(
                "sweep",
                "at most one budget axis (spp or seconds) per experiment".into(),
            );
        }
        let settings = self
            .sweep
            .iter()
            .fold(1f64, |n, a| n * a.values().len() as f64);
        let runs = self.scenes.len() as f64 * self.methods.len() as f64 * settings;
        if runs * self.trials as f64 > MAX_RUNS as f64 {
            return err(
                "trials",
                format!(
                    "{} trials of {runs} settings make more than {MAX_RUNS} runs: an experiment \
                     holds at most that many (split it, or take fewer trials or sweep values)",
                    self.trials
                ),
            );
        }
        Ok(())
    }
}

fn check_budget(b: &BudgetDesc) -> Result<(), String> {
    match *b {
        BudgetDesc::Samples(0) => Err("a sample budget must be ≥ 1 sample per pixel".into()),
        BudgetDesc::Seconds(s) if !(s > 0.0 && s.is_finite()) => {
            Err(format!("a time budget must be > 0 seconds, got {s}"))
        }
        _ => Ok(()),
    }
}

/// The directory under the results directory where rendered references are cached.
pub const REFERENCE_CACHE: &str = "references";

/// Most values an axis may take (`validate` refuses more; `values` stops just past it).
const MAX_AXIS_VALUES: usize = 10_000;
/// Most runs an experiment may hold (each run is a directory of files).
const MAX_RUNS: usize = 1_000_000;

impl Axis {
    pub fn field(&self) -> &str {
        match self {
            Axis::Values { field, .. } | Axis::LogRange { field, .. } => field,
        }
    }

    /// The axis' values in order.
    pub fn values(&self) -> Vec<Value> {
        match self {
            Axis::Values { values, .. } => values.clone(),
            &Axis::LogRange {
                from, to, factor, ..
            } => {
                let integer = from.fract() == 0.0 && to.fract() == 0.0;
                let mut out: Vec<Value> = Vec::new();
                let mut x = from;
                // Relative slack so that e.g. 1·2¹² still counts as ≤ 4096 after rounding.
                while x <= to * (1.0 + 1e-9) && out.len() <= MAX_AXIS_VALUES {
                    let v = if integer {
                        Value::Int(x.round() as i64)
                    } else {
                        Value::Float(x)
                    };
                    if out.last() != Some(&v) {
                        out.push(v);
                    }
                    x *= factor;
                }
                out
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"Experiment(
        name: "t",
        scenes: ["../scenes/furnace.ron"],
        reference: Render(integrator: "Path()", spp: 64),
        methods: [
            (label: "mis", integrator: "Path", settings: {"strategy": "Mis", "max_bounces": 3}),
            (label: "bsdf", integrator: "Path", settings: {"strategy": "BsdfOnly"}),
        ],
        sweep: [LogRange(field: "spp", from: 1, to: 64, factor: 4)],
        trials: 3,
    )"#;

    #[test]
    fn parses_with_defaults() {
        let d = parse_experiment(GOOD, Path::new("e.ron")).unwrap();
        assert_eq!(d.trials, 3);
        assert_eq!(d.seed, 0);
        assert_eq!(d.budget, BudgetDesc::Samples(16));
        assert_eq!(
            d.sweep[0].values(),
            vec![Value::Int(1), Value::Int(4), Value::Int(16), Value::Int(64)]
        );
        assert_eq!(d.methods[0].settings["max_bounces"], Value::Int(3));
    }

    /// Every experiment shipped in `experiments/` passes the checks (a check added later must not
    /// refuse a bundled file).
    #[test]
    fn bundled_experiments_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
        let mut n = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "ron") {
                load_experiment(&path).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
        assert!(n >= 10, "{n} experiment files");
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let cases = [
            (
                GOOD.replace("trials: 3", "trails: 3"),
                "e.ron:10:",
                "trails",
            ),
            (
                GOOD.replace("trials: 3", "trials: 1"),
                "e.ron:10:",
                "trials must be ≥ 2",
            ),
            // A comment that names the field is not where the error is (it was).
            (
                GOOD.replace("name: \"t\",", "name: \"t\", // four trials, a reference")
                    .replace("trials: 3", "trials: 1"),
                "e.ron:10:",
                "trials must be ≥ 2",
            ),
            (
                GOOD.replace("label: \"bsdf\"", "label: \"mis\""),
                "e.ron:6:",
                "used twice",
            ),
            (
                GOOD.replace("factor: 4", "factor: 1"),
                "e.ron:9:",
                "factor > 1",
            ),
            // The reference's integrator is located in the file too (it was reported without a
            // position when the reference first rendered).
            (
                GOOD.replace("\"Path()\", spp: 64", "\"Path(\", spp: 64"),
                "e.ron:4:",
                "reference integrator Path(",
            ),
            (
                GOOD.replace("\"Path()\", spp: 64", "\"Path(max_bounces: -1)\", spp: 64"),
                "e.ron:4:",
                "reference integrator",
            ),
            // A sweep too long to hold (values() once stopped at 10 000 without a word), and
            // more runs than an experiment holds (10⁸ trials aborted on a 1.5 GB allocation).
            (
                GOOD.replace("to: 64, factor: 4", "to: 1e9, factor: 1.001"),
                "e.ron:9:",
                "more than 10000 values",
            ),
            (
                GOOD.replace("trials: 3", "trials: 100000000"),
                "e.ron:10:",
                "more than 1000000 runs",
            ),
            (
                GOOD.replace("spp: 64)", "spp: 0)"),
                "e.ron:4:",
                "reference spp",
            ),
            (
                GOOD.replace(
                    "LogRange(field: \"spp\", from: 1, to: 64, factor: 4)",
                    "Values(field: \"spp\", values: [0])",
                ),
                "e.ron:9:",
                "not a valid budget",
            ),
            (
                GOOD.replace(
                    "trials: 3,",
                    "trials: 3,\n        classes: [\"LE\", \"LS+DE\", \"LE\"],",
                ),
                "e.ron:11:",
                "LE is given twice",
            ),
            // Accepted before: a name that is the reference cache's directory, an empty label,
            // a repeated setting (the last one won), a value or a field swept twice.
            (
                GOOD.replace("name: \"t\"", "name: \"references\""),
                "e.ron:2:",
                "where rendered references are cached",
            ),
            (
                GOOD.replace("label: \"bsdf\"", "label: \" \""),
                "e.ron:7:",
                "label must be non-empty",
            ),
            (
                GOOD.replace(
                    "\"max_bounces\": 3",
                    "\"max_bounces\": 3, \"max_bounces\": 4",
                ),
                "e.ron:6:",
                "setting \"max_bounces\" is given twice",
            ),
            (
                GOOD.replace(
                    "LogRange(field: \"spp\", from: 1, to: 64, factor: 4)",
                    "Values(field: \"spp\", values: [4, 16, 4])",
                ),
                "e.ron:9:",
                "lists 4 twice",
            ),
            (
                GOOD.replace(
                    "LogRange(field: \"spp\", from: 1, to: 64, factor: 4)",
                    "Values(field: \"max_bounces\", values: [1]), \
                     Values(field: \"max_bounces\", values: [2])",
                ),
                "e.ron:9:",
                "two axes sweep \"max_bounces\"",
            ),
        ];
        for (text, at, words) in cases {
            let e = parse_experiment(&text, Path::new("e.ron")).unwrap_err().0;
            assert!(
                e.starts_with(at) && e.contains(words),
                "expected {at} … {words}: {e}"
            );
        }
    }
}
