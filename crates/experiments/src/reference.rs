//! Reference images: rendered once and cached under `results/references/`, keyed by a hash of what
//! produced them (scene text, image size, integrator settings, sample count, Lightlab version and
//! the format of the statistics), or loaded from an EXR another renderer wrote. Stored with their
//! variance layer and, beside it, the render's statistics (`<reference>.json`), which say whether
//! that variance estimates the variance of the mean — only then do the metrics subtract it.

use crate::atomic::write_atomic;
use crate::desc::ReferenceDesc;
use crate::image_io::{RgbLayer, output_layers, read_exr, write_exr};
use crate::metrics::Image;
use crate::plan::fnv1a;
use lightlab_core::Progress;
use lightlab_integrators::paths::Layers;
use lightlab_integrators::{Budget, IntegratorConfig, PixelVariance};
use lightlab_scene::Scene;
use std::path::{Path, PathBuf};

/// Seed of every rendered reference (runs use seeds hashed from the experiment, so they never share it).
const REFERENCE_SEED: u64 = 0x0005_EED0_F2EF;
/// Version of what a cached reference holds: 2 since light-traced variances are per sample pass,
/// k-nearest photon estimates leave out the k-th photon, and the statistics are saved beside; 3
/// since BDPT and VCM give an environment seen directly its whole MIS weight (earlier references
/// of such scenes are too dark there); 4 since one-sample references and motion-blurred
/// `PhotonMap`, `Radiosity` and `Cone` references say their variance is no estimate of the
/// variance of the mean (it was subtracted from the errors).
pub(crate) const REFERENCE_FORMAT: u32 = 4;

/// A reference and where it came from.
pub struct Reference {
    pub image: Image,
    /// The layer of each path class the experiment asks for, then `rest`, by name.
    pub classes: Vec<(String, Image)>,
    pub path: PathBuf,
    /// Whether it was found in the cache (or given as a file) rather than rendered now.
    pub cached: bool,
    /// Why the reference's variance is not subtracted from the errors, if it is not.
    pub variance_note: Option<String>,
}

/// The cache file of a rendered reference: `<dir>/<scene>-<hash>.exr`.
pub fn cache_path(
    dir: &Path,
    scene_name: &str,
    scene_text: &str,
    resolution: (u32, u32),
    integrator: &str,
    spp: u32,
) -> PathBuf {
    let key = format!(
        "scene:{scene_text}\nresolution:{resolution:?}\nintegrator:{integrator}\nspp:{spp}\nseed:{REFERENCE_SEED}\nlightlab:{}\nformat:{REFERENCE_FORMAT}",
        env!("CARGO_PKG_VERSION")
    );
    dir.join(format!("{scene_name}-{:016x}.exr", fnv1a(key.as_bytes())))
}

/// The reference for one scene: cached, rendered (and cached), or loaded.
pub fn reference(
    desc: &ReferenceDesc,
    experiment_dir: &Path,
    cache_dir: &Path,
    scene_name: &str,
    scene_text: &str,
    scene: &Scene,
    classes: &[String],
    progress: &dyn Progress,
    log: &dyn Fn(&str),
) -> Result<Reference, String> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (path, cached, image, variance_note) = match desc {
        ReferenceDesc::Exr {
            path,
            layer,
            variance,
        } => {
            let path = experiment_dir.join(path);
            let variance = variance.as_ref().map(|v| experiment_dir.join(v));
            let image = load_foreign(&path, layer.as_deref(), variance.as_deref())?;
            let note = image.variance.is_none().then(|| {
                format!(
                    "{} has no variance layer (and none was given), so nothing is subtracted from the errors",
                    path.display()
                )
            });
            (path, true, image, note)
        }
        ReferenceDesc::Render { integrator, spp } => {
            let config = IntegratorConfig::from_ron(integrator)
                .and_then(|c| c.with_paths_and_layers(None, class_layers(classes)))
                .map_err(|e| format!("reference integrator {integrator}: {e}"))?;
            let path = cache_path(
                cache_dir,
                scene_name,
                scene_text,
                (w, h),
                &config.to_ron(),
                *spp,
            );
            let stats_path = path.with_extension("json");
            let done = || path.is_file() && stats_path.is_file();
            let cached = done();
            let mut waited = false;
            while !done() {
                // One process renders a missing reference; others (shards sharing the cache)
                // wait for it instead of rendering it again.
                let Some(_lock) = Lock::take(&path.with_extension("lock"))? else {
                    if !waited {
                        log(&format!(
                            "  waiting for {}: another process is rendering this reference",
                            path.with_extension("lock").display()
                        ));
                        waited = true;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(500));
                    continue;
                };
                if done() {
                    break;
                }
                let integrator = config
                    .build()
                    .map_err(|e| format!("reference integrator {}: {e}", config.to_ron()))?;
                lightlab_integrators::memory::check_render(
                    &*integrator,
                    scene,
                    &Budget::Samples(*spp),
                )
                .map_err(|e| format!("reference integrator {}: {e}", config.to_ron()))?;
                let out =
                    integrator.render(scene, &Budget::Samples(*spp), REFERENCE_SEED, progress);
                write_exr(&path, w, h, &output_layers(&out)).map_err(|e| e.to_string())?;
                let json = serde_json::to_string_pretty(&out.stats).map_err(|e| e.to_string())?;
                write_atomic(&stats_path, json.as_bytes())
                    .map_err(|e| format!("{}: {e}", stats_path.display()))?;
            }
            let stats: serde_json::Value = std::fs::read_to_string(&stats_path)
                .ok()
                .and_then(|t| serde_json::from_str(&t).ok())
                .ok_or_else(|| {
                    format!(
                        "{}: cannot read the reference's statistics",
                        stats_path.display()
                    )
                })?;
            let variance: PixelVariance =
                serde_json::from_value(stats["pixel_variance"].clone())
                    .map_err(|e| format!("{}: pixel_variance: {e}", stats_path.display()))?;
            let mut image = load_image(&path)?;
            let note = match variance {
                PixelVariance::NotAnEstimate(why) => {
                    image.variance = None;
                    Some(format!(
                        "the reference's variance is not subtracted from the errors: {why}; render the reference with an independent sampler, or with `replicates` (e.g. `sampler: Sobol, replicates: 16`), to have it subtracted"
                    ))
                }
                _ => None,
            };
            (path, cached, image, note)
        }
    };
    if (image.width, image.height) != (w, h) {
        return Err(format!(
            "reference {} is {}×{}, but the runs are {w}×{h}",
            path.display(),
            image.width,
            image.height
        ));
    }
    let mut classes: Vec<(String, Image)> = class_names(classes)
        .into_iter()
        .map(|name| Ok((name.clone(), load_layer(&path, &name)?)))
        .collect::<Result<_, String>>()?;
    if matches!(desc, ReferenceDesc::Render { .. }) && variance_note.is_some() {
        for (_, c) in &mut classes {
            c.variance = None;
        }
    }
    // Errors against a NaN or an infinity are not numbers: refuse before any run is measured.
    let unusable = |file: &Path, what: &str, e: String| {
        format!(
            "reference {}{what}: {e}; a reference must be finite everywhere (fix or replace the \
             file, or the scene whose lights overflow 32-bit floats)",
            file.display()
        )
    };
    // A variance from a separate file is that file's fault.
    let variance_file = match desc {
        ReferenceDesc::Exr {
            variance: Some(v), ..
        } => Some(experiment_dir.join(v)),
        _ => None,
    };
    image.check_finite().map_err(|e| match &variance_file {
        Some(v) if e.starts_with("the variance") => unusable(v, " (its variance file)", e),
        _ => unusable(&path, "", e),
    })?;
    for (name, c) in &classes {
        c.check_finite()
            .map_err(|e| unusable(&path, &format!(", layer {name}"), e))?;
    }
    Ok(Reference {
        image,
        classes,
        path,
        cached,
        variance_note,
    })
}

/// The `layers` setting that splits a render into `classes` (none when there are no classes).
pub fn class_layers(classes: &[String]) -> Option<Layers> {
    (!classes.is_empty()).then(|| Layers::Classes(classes.to_vec()))
}

/// Names of the class layers: the expressions, then `rest` (none when there are no classes).
pub fn class_names(classes: &[String]) -> Vec<String> {
    if classes.is_empty() {
        return Vec::new();
    }
    classes
        .iter()
        .cloned()
        .chain(["rest".to_string()])
        .collect()
}

/// Reads layer `name` of an EXR and its variance (`name.variance`; `None` when absent).
pub fn load_layer(path: &Path, name: &str) -> Result<Image, String> {
    let (width, height, layers) = read_exr(path).map_err(|e| e.to_string())?;
    let mean = find(&layers, name).ok_or_else(|| {
        format!(
            "{}: no layer named \"{name}\" (a reference for path classes needs one per class)",
            path.display()
        )
    })?;
    Ok(Image {
        width,
        height,
        mean,
        variance: find(&layers, &format!("{name}.variance")),
    })
}

fn find(layers: &[RgbLayer], name: &str) -> Option<Vec<[f32; 3]>> {
    layers
        .iter()
        .find(|l| l.name == name)
        .map(|l| l.pixels.clone())
}

fn names(layers: &[RgbLayer]) -> String {
    layers
        .iter()
        .map(|l| format!("\"{}\"", l.name))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Reads an EXR Lightlab wrote: layer `radiance` and, if present, `variance`.
pub fn load_image(path: &Path) -> Result<Image, String> {
    load_foreign(path, Some("radiance"), None)
}

/// Reads an image from an EXR another program may have written (see `ReferenceDesc::Exr`): the
/// layer `layer`, or `radiance`, or the unnamed R, G, B channels, or the only RGB layer; its
/// variance of the mean from the layer `variance`, or from the image of `variance_file`.
pub fn load_foreign(
    path: &Path,
    layer: Option<&str>,
    variance_file: Option<&Path>,
) -> Result<Image, String> {
    let (width, height, layers) = read_exr(path).map_err(|e| e.to_string())?;
    let mean = match layer {
        Some(name) => find(&layers, name).ok_or_else(|| {
            format!(
                "{}: no RGB layer named \"{name}\" (it has {})",
                path.display(),
                names(&layers)
            )
        })?,
        None => find(&layers, "radiance")
            .or_else(|| find(&layers, ""))
            .or_else(|| (layers.len() == 1).then(|| layers[0].pixels.clone()))
            .ok_or_else(|| {
                format!(
                    "{}: which layer is the image? It has {}; name one with `layer`",
                    path.display(),
                    names(&layers)
                )
            })?,
    };
    let variance = match variance_file {
        Some(v) => {
            let var = load_foreign(v, None, None).map_err(|e| format!("variance file: {e}"))?;
            if (var.width, var.height) != (width, height) {
                return Err(format!(
                    "variance file {} is {}×{}, the image {width}×{height}",
                    v.display(),
                    var.width,
                    var.height
                ));
            }
            Some(var.mean)
        }
        // The chosen layer's own: `<name>.variance` beside a named layer, `variance` beside the
        // image (none for a variance layer itself). Not pbrt-v4's `Variance` layer: it is the
        // variance of one sample (S/(n − 1)), not of the pixel mean, and the file does not say n.
        None => match layer {
            None | Some("radiance") | Some("") => find(&layers, "variance"),
            Some(name) if name == "variance" || name.ends_with(".variance") => None,
            Some(name) => find(&layers, &format!("{name}.variance")),
        },
    };
    Ok(Image {
        width,
        height,
        mean,
        variance,
    })
}

/// A lock held while a reference renders: an exclusive advisory lock (`flock`) on a file beside
/// it. The operating system releases it when its holder exits, however it exits, so a render
/// killed halfway leaves no lock behind that blocks the next run. The file stays (a few bytes
/// naming the last holder): removing it while locked would let one waiter lock the removed file
/// and another a new one, both at once. Callers check again after taking the lock whether the
/// reference was written meanwhile, so no reference renders twice.
struct Lock {
    /// Held open: closing it releases the lock.
    _file: std::fs::File,
}

impl Lock {
    /// Takes the lock at `path`; `None` if another process (or another handle) holds it.
    fn take(path: &Path) -> Result<Option<Lock>, String> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let err = |e: std::io::Error| format!("{}: {e}", path.display());
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(err)?;
        match file.try_lock() {
            Ok(()) => {
                use std::io::Write;
                // Who holds it, for a user looking at the cache directory.
                file.set_len(0).map_err(err)?;
                let _ = writeln!(file, "pid {}", std::process::id());
                Ok(Some(Lock { _file: file }))
            }
            Err(std::fs::TryLockError::WouldBlock) => Ok(None),
            // A file system without locks: render without one. Processes sharing the cache may
            // then render the same reference twice; each writes it atomically, so none is lost.
            Err(std::fs::TryLockError::Error(e)) if e.kind() == std::io::ErrorKind::Unsupported => {
                Ok(Some(Lock { _file: file }))
            }
            Err(std::fs::TryLockError::Error(e)) => Err(err(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Lock;

    #[test]
    fn a_lock_excludes_others_until_dropped_and_a_left_over_file_is_taken() {
        let dir = std::env::temp_dir().join(format!("lightlab-lock-{}", std::process::id()));
        let path = dir.join("reference.lock");
        let _ = std::fs::remove_dir_all(&dir);
        // A file left by a killed render: nobody holds a lock on it, so it is taken.
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(&path, "pid 999999\n").unwrap();
        let held = Lock::take(&path)
            .unwrap()
            .expect("a left-over file is taken");
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            format!("pid {}\n", std::process::id())
        );
        // Held: another handle (as another process would) is refused.
        assert!(Lock::take(&path).unwrap().is_none());
        drop(held);
        assert!(
            Lock::take(&path).unwrap().is_some(),
            "dropping the lock releases it"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
