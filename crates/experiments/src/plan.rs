//! Expansion of an experiment into fully resolved runs: scene × method × setting × trial, each with
//! its integrator settings as canonical RON, its budget, its seed and a stable id (a hash of all of
//! these), so that a resumed or sharded sweep names every run the same way.

use crate::desc::{BudgetDesc, ExperimentDesc, ExperimentError, Value};
use lightlab_integrators::IntegratorConfig;
use serde::Serialize;
use std::path::{Component, Path, PathBuf};

/// One run of an experiment, everything resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunSpec {
    /// Position in the expansion order (shards take `index % n == i`).
    pub index: usize,
    /// Directory name under `runs/`: scene, method and a hash of the resolved run.
    pub id: String,
    pub scene: PathBuf,
    /// The scene file's stem, used in tables.
    pub scene_name: String,
    pub method: String,
    /// The integrator with every field resolved, as RON.
    pub integrator: String,
    /// The swept values of this run, as `field=value` joined by `, ` (empty without a sweep).
    pub setting: String,
    pub budget: BudgetDesc,
    pub trial: u32,
    pub seed: u64,
}

/// An error in a method's integrator, placed in the experiment file: at the setting the error's
/// column falls in (the swept axis, if the value came from one, else the method's own setting),
/// or at the method.
fn method_error(
    desc: &ExperimentDesc,
    path: &Path,
    method: &crate::desc::MethodDesc,
    setting: &[(String, Value)],
    spans: &[(String, usize, usize)],
    e: &lightlab_integrators::ConfigError,
) -> ExperimentError {
    let (col, message) = match e {
        lightlab_integrators::ConfigError::Syntax { col, message, .. } => {
            (Some(*col), message.clone())
        }
        lightlab_integrators::ConfigError::Invalid(message) => (None, message.clone()),
    };
    let field = col.and_then(|c| spans.iter().find(|(_, a, b)| (*a..=*b).contains(&c)));
    let anchor = format!("\"{}\"", method.label);
    let (line, col, what) = match field {
        Some((k, _, _)) if setting.iter().any(|(f, _)| f == k) => {
            let (l, c) = crate::desc::locate_after(&desc.source, "sweep", &format!("\"{k}\""));
            (l, c, format!("swept setting {k}"))
        }
        Some((k, _, _)) => {
            let (l, c) = crate::desc::locate_after(&desc.source, &anchor, &format!("\"{k}\""));
            (l, c, format!("setting {k}"))
        }
        None => {
            let (l, c) = crate::desc::locate(&desc.source, &anchor);
            (l, c, format!("integrator {}", method.integrator))
        }
    };
    ExperimentError(format!(
        "{}:{line}:{col}: method {:?}, {what}: {message}",
        path.display(),
        method.label
    ))
}

/// 64-bit FNV-1a: a stable hash for run ids, seeds and reference cache keys (not for security).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The name of each scene in tables, run ids, seeds and file names: its file stem
/// (`cornell-box`), or its file name where two listed scenes share a stem (`box.ron`, `box.xml`),
/// or where they share that too the fewest last components of its path as listed that tell it
/// apart, joined by '-' (`a/box.ron` and `b/box.ron`: `a-box.ron`, `b-box.ron`; never a path
/// separator, which put files outside the results), and its place in the list if even the whole
/// path does not (the list names no file twice: `ExperimentDesc::check`).
fn scene_names(desc: &ExperimentDesc) -> Vec<String> {
    let scenes = &desc.scenes;
    let part = |s: &Path, f: fn(&Path) -> Option<&std::ffi::OsStr>| {
        f(s).map_or("scene".into(), |s| s.to_string_lossy().into_owned())
    };
    let sharing = |s: &Path, f: fn(&Path) -> Option<&std::ffi::OsStr>| -> Vec<&PathBuf> {
        scenes.iter().filter(|o| part(o, f) == part(s, f)).collect()
    };
    // The last k components of a path, joined by '-' (a root or drive is no name).
    let tail = |p: &Path, k: usize| {
        let parts: Vec<String> = p
            .components()
            .filter(|c| !matches!(c, Component::RootDir | Component::Prefix(_)))
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        parts[parts.len().saturating_sub(k)..].join("-")
    };
    let names: Vec<String> = scenes
        .iter()
        .map(|s| {
            if sharing(s, Path::file_stem).len() == 1 {
                part(s, Path::file_stem)
            } else if sharing(s, Path::file_name).len() == 1 {
                part(s, Path::file_name)
            } else {
                let group = sharing(s, Path::file_name);
                let deepest = group.iter().map(|p| p.components().count()).max();
                let k = (1..=deepest.unwrap_or(1))
                    .find(|&k| {
                        let tails: std::collections::BTreeSet<String> =
                            group.iter().map(|p| tail(p, k)).collect();
                        tails.len() == group.len()
                    })
                    .unwrap_or(usize::MAX);
                tail(s, k)
            }
        })
        .collect();
    // Names joined from parts can still meet (`a/c.ron` beside `a-c.ron`): those get their place.
    names
        .iter()
        .enumerate()
        .map(|(i, n)| match names.iter().filter(|m| *m == n).count() {
            1 => n.clone(),
            _ => format!("{n}-{}", i + 1),
        })
        .collect()
}

/// All runs of `desc` (loaded from `path`) in a fixed order: scenes, then methods, then settings
/// (the first axis varying slowest), then trials.
pub fn expand(desc: &ExperimentDesc, path: &Path) -> Result<Vec<RunSpec>, ExperimentError> {
    let base = path.parent().unwrap_or(Path::new("."));
    // Cartesian product of the axes.
    let mut settings: Vec<Vec<(String, Value)>> = vec![Vec::new()];
    for axis in &desc.sweep {
        let values = axis.values();
        settings = settings
            .into_iter()
            .flat_map(|s| {
                values
                    .iter()
                    .map(move |v| [s.clone(), vec![(axis.field().to_string(), v.clone())]].concat())
            })
            .collect();
    }
    let mut runs = Vec::new();
    for (scene, scene_name) in desc.scenes.iter().zip(scene_names(desc)) {
        let scene_path = base.join(scene);
        for method in &desc.methods {
            for setting in &settings {
                let mut fields = method.settings.clone();
                let mut budget = desc.budget;
                for (field, value) in setting {
                    match (field.as_str(), value) {
                        ("spp", Value::Int(n)) => budget = BudgetDesc::Samples(*n as u32),
                        ("seconds", Value::Int(n)) => budget = BudgetDesc::Seconds(*n as f64),
                        ("seconds", Value::Float(s)) => budget = BudgetDesc::Seconds(*s),
                        _ => {
                            fields.insert(field.clone(), value.clone());
                        }
                    }
                }
                // The integrator's RON, and the column span of each field in it.
                let mut text = format!("{}(", method.integrator);
                let mut spans = Vec::new();
                for (i, (k, v)) in fields.iter().enumerate() {
                    if i > 0 {
                        text += ", ";
                    }
                    let start = text.len() + 1;
                    text += &format!("{k}: {}", v.ron());
                    spans.push((k.clone(), start, text.len() + 1));
                }
                text += ")";
                let config = IntegratorConfig::from_ron(&text)
                    .map_err(|e| method_error(desc, path, method, setting, &spans, &e))?;
                // A budget the settings cannot take (a sample count that is no multiple of the
                // replicates) is an error now, not after the runs before it.
                config
                    .build()
                    .and_then(|i| {
                        i.check_budget(&budget.into())
                            .map_err(lightlab_integrators::ConfigError::Invalid)
                    })
                    .map_err(|e| method_error(desc, path, method, setting, &spans, &e))?;
                let integrator = config.to_ron();
                let setting_text = setting
                    .iter()
                    .map(|(k, v)| format!("{k}={}", v.ron()))
                    .collect::<Vec<_>>()
                    .join(", ");
                for trial in 0..desc.trials {
                    let key = format!(
                        "{}|{scene_name}|{}|{integrator}|{budget:?}|{trial}",
                        desc.seed, method.label
                    );
                    let seed = fnv1a(key.as_bytes());
                    let id = format!(
                        "{}-{}-{:016x}",
                        sanitize(&scene_name),
                        sanitize(&method.label),
                        fnv1a(format!("{key}|{seed}").as_bytes())
                    );
                    runs.push(RunSpec {
                        index: runs.len(),
                        id,
                        scene: scene_path.clone(),
                        scene_name: scene_name.clone(),
                        method: method.label.clone(),
                        integrator: integrator.clone(),
                        setting: setting_text.clone(),
                        budget,
                        trial,
                        seed,
                    });
                }
            }
        }
    }
    Ok(runs)
}

/// The runs of shard `i` of `n` (0-based): those with `index % n == i`.
pub fn shard(runs: Vec<RunSpec>, i: u32, n: u32) -> Vec<RunSpec> {
    runs.into_iter()
        .filter(|r| r.index % n as usize == i as usize)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::desc::parse_experiment;

    fn desc(sweep: &str) -> ExperimentDesc {
        let text = format!(
            r#"Experiment(name: "t", scenes: ["a.ron", "b.ron"], reference: Render(integrator: "Path()", spp: 8),
               methods: [(label: "pt", integrator: "Path", settings: {{"max_bounces": 2}}),
                         (label: "bsdf", integrator: "Path", settings: {{"strategy": "BsdfOnly"}})],
               sweep: [{sweep}], trials: 3)"#
        );
        parse_experiment(&text, Path::new("exp/e.ron")).unwrap()
    }

    #[test]
    fn cartesian_product_with_resolved_values() {
        let d = desc(
            r#"Values(field: "spp", values: [1, 4]), Values(field: "max_bounces", values: [0, 5, "None"])"#,
        );
        let runs = expand(&d, Path::new("exp/e.ron")).unwrap();
        assert_eq!(runs.len(), 2 * 2 * 2 * 3 * 3);
        assert!(runs.iter().enumerate().all(|(i, r)| r.index == i));
        let r = &runs[3 * 4 + 1]; // scene a, method pt, setting 4 = (spp 4, max_bounces 5), trial 1
        assert_eq!(r.scene, Path::new("exp/a.ron"));
        assert_eq!(r.setting, "spp=4, max_bounces=5");
        assert_eq!(r.budget, BudgetDesc::Samples(4));
        assert!(
            r.integrator.starts_with("Path(max_bounces: 5,"),
            "{}",
            r.integrator
        );
        assert_eq!(r.trial, 1);
        // The axis overrides the method's own setting; unswept fields keep the method's values.
        let bsdf = runs
            .iter()
            .find(|r| r.method == "bsdf" && r.setting == "spp=1, max_bounces=None")
            .unwrap();
        assert!(
            bsdf.integrator.contains("max_bounces: None")
                && bsdf.integrator.contains("strategy: BsdfOnly")
        );
        // Ids and seeds are distinct, and stable across expansions.
        let ids: std::collections::HashSet<_> = runs.iter().map(|r| r.id.clone()).collect();
        let seeds: std::collections::HashSet<_> = runs.iter().map(|r| r.seed).collect();
        assert_eq!((ids.len(), seeds.len()), (runs.len(), runs.len()));
        assert_eq!(runs, expand(&d, Path::new("exp/e.ron")).unwrap());
    }

    #[test]
    fn bad_settings_name_the_method() {
        let d = desc(r#"Values(field: "max_bounce", values: [1])"#);
        let e = expand(&d, Path::new("exp/e.ron")).unwrap_err().0;
        assert!(
            e.contains("exp/e.ron") && e.contains("\"pt\"") && e.contains("max_bounce"),
            "{e}"
        );
    }

    /// Scene names never hold a path separator: scenes sharing a file name are told apart by
    /// their last path components (the path as listed went into file names, and `..` in it put
    /// references and plots outside the results). One file listed under two paths is refused.
    #[test]
    fn scene_names_are_file_names_and_files_are_listed_once() {
        let names = |scenes: &str| {
            let text = format!(
                r#"Experiment(name: "t", scenes: [{scenes}], reference: Render(integrator: "Path()", spp: 8),
                   methods: [(label: "pt", integrator: "Path")], trials: 2)"#
            );
            let d = parse_experiment(&text, Path::new("exp/e.ron")).unwrap();
            scene_names(&d)
        };
        assert_eq!(
            names(r#""a/box.ron", "b/box.ron", "box.xml", "c.ron""#),
            ["a-box.ron", "b-box.ron", "box.xml", "c"]
        );
        assert_eq!(
            names(r#""../../x/s/box.ron", "../y/s/box.ron", "box.ron""#),
            ["x-s-box.ron", "y-s-box.ron", "box.ron"]
        );
        assert_eq!(
            names(r#""/box.ron", "box.ron""#),
            ["box.ron-1", "box.ron-2"]
        );
        assert_eq!(
            names(r#""a/c.ron", "b/c.ron", "a-c.ron", "a-c.xml""#),
            ["a-c.ron-1", "b-c.ron", "a-c.ron-3", "a-c.xml"]
        );
        let text = r#"Experiment(name: "t", scenes: ["s/box.ron", "./s/../s/box.ron"],
            reference: Render(integrator: "Path()", spp: 8), methods: [(label: "pt", integrator: "Path")])"#;
        let dir = std::env::temp_dir().join(format!("lightlab-names-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("s")).unwrap();
        std::fs::write(dir.join("s/box.ron"), "").unwrap();
        let e = parse_experiment(text, &dir.join("e.ron")).unwrap_err().0;
        assert!(
            e.contains("\"s/box.ron\" and \"./s/../s/box.ron\" are the same file"),
            "{e}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn shards_partition_the_runs() {
        let runs = expand(
            &desc(r#"LogRange(field: "spp", from: 1, to: 16, factor: 2)"#),
            Path::new("e.ron"),
        )
        .unwrap();
        let mut all: Vec<usize> = (0..3)
            .flat_map(|i| shard(runs.clone(), i, 3))
            .map(|r| r.index)
            .collect();
        all.sort();
        assert_eq!(all, (0..runs.len()).collect::<Vec<_>>());
    }

    /// A bad method setting is reported at its line in the experiment file, not at a column of the
    /// integrator text the runner generates: an unknown field at the method's setting, a bad
    /// swept value at the sweep, a bad combination on the method's line.
    #[test]
    fn setting_errors_point_into_the_experiment_file() {
        let text = r#"Experiment(
    name: "t",
    scenes: ["a.ron"],
    reference: Render(integrator: "Path()", spp: 8),
    methods: [
        (label: "pt", integrator: "Path", settings: {"max_bounces": 2}),
        (label: "typo", integrator: "Path", settings: {"max_bounce": 2}),
    ],
    trials: 2,
)"#;
        let path = Path::new("exp/e.ron");
        let e = expand(&parse_experiment(text, path).unwrap(), path)
            .unwrap_err()
            .0;
        assert!(
            e.starts_with("exp/e.ron:7:56: method \"typo\", setting max_bounce:"),
            "{e}"
        );
        assert!(e.contains("max_bounce") && !e.contains("1:"), "{e}");
        let swept = text.replace(
            "    trials: 2,",
            "    sweep: [Values(field: \"strategy\", values: [\"Mis\", \"Bogus\"])],\n    trials: 2,",
        ).replace(r#"{"max_bounce": 2}"#, r#"{"max_bounces": 2}"#);
        let e = expand(&parse_experiment(&swept, path).unwrap(), path)
            .unwrap_err()
            .0;
        assert!(
            e.starts_with("exp/e.ron:9:27: method \"pt\", swept setting strategy:"),
            "{e}"
        );
        let combo = text.replace(
            r#"{"max_bounce": 2}"#,
            r#"{"max_bounces": 2, "min_bounces": 3}"#,
        );
        let e = expand(&parse_experiment(&combo, path).unwrap(), path)
            .unwrap_err()
            .0;
        assert!(
            e.starts_with("exp/e.ron:7:") && e.contains("min_bounces (3) exceeds max_bounces (2)"),
            "{e}"
        );
    }
}
