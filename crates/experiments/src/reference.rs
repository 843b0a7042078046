//! Reference images: rendered once and cached under `results/references/`, keyed by a hash of what
//! produced them (scene text, image size, integrator settings, sample count, Lightlab version), or
//! loaded from a user's EXR. Stored with their variance layer, which the metrics subtract.

use crate::desc::ReferenceDesc;
use crate::image_io::{output_layers, read_exr, write_exr};
use crate::metrics::Image;
use crate::plan::fnv1a;
use lightlab_core::Progress;
use lightlab_integrators::paths::Layers;
use lightlab_integrators::{Budget, IntegratorConfig};
use lightlab_scene::Scene;
use std::path::{Path, PathBuf};

/// Seed of every rendered reference (runs use seeds hashed from the experiment, so they never share it).
const REFERENCE_SEED: u64 = 0x0005_EED0_F2EF;

/// A reference and where it came from.
pub struct Reference {
    pub image: Image,
    /// The layer of each path class the experiment asks for, then `rest`, by name.
    pub classes: Vec<(String, Image)>,
    pub path: PathBuf,
    /// Whether it was found in the cache (or given as a file) rather than rendered now.
    pub cached: bool,
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
        "scene:{scene_text}\nresolution:{resolution:?}\nintegrator:{integrator}\nspp:{spp}\nseed:{REFERENCE_SEED}\nlightlab:{}",
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
) -> Result<Reference, String> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let (path, cached) = match desc {
        ReferenceDesc::Exr { path } => (experiment_dir.join(path), true),
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
            if path.is_file() {
                (path, true)
            } else {
                let out =
                    config
                        .build()
                        .render(scene, &Budget { spp: *spp }, REFERENCE_SEED, progress);
                write_exr(&path, w, h, &output_layers(&out)).map_err(|e| e.to_string())?;
                (path, false)
            }
        }
    };
    let image = load_image(&path)?;
    if (image.width, image.height) != (w, h) {
        return Err(format!(
            "reference {} is {}×{}, but the runs are {w}×{h}",
            path.display(),
            image.width,
            image.height
        ));
    }
    let classes = class_names(classes)
        .into_iter()
        .map(|name| Ok((name.clone(), load_layer(&path, &name)?)))
        .collect::<Result<_, String>>()?;
    Ok(Reference {
        image,
        classes,
        path,
        cached,
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

/// Reads layer `name` of an EXR and its variance (`name.variance`, zero when absent).
pub fn load_layer(path: &Path, name: &str) -> Result<Image, String> {
    let (width, height, layers) = read_exr(path).map_err(|e| e.to_string())?;
    let layer = |n: &str| {
        layers
            .iter()
            .find(|l| l.name == n)
            .map(|l| l.pixels.clone())
    };
    let mean = layer(name).ok_or_else(|| {
        format!(
            "{}: no layer named \"{name}\" (a reference for path classes needs one per class)",
            path.display()
        )
    })?;
    let variance = layer(&format!("{name}.variance")).unwrap_or_else(|| vec![[0.0; 3]; mean.len()]);
    Ok(Image {
        width,
        height,
        mean,
        variance,
    })
}

/// Reads an EXR with a `radiance` layer and optionally a `variance` layer (zero when absent).
pub fn load_image(path: &Path) -> Result<Image, String> {
    let (width, height, layers) = read_exr(path).map_err(|e| e.to_string())?;
    let layer = |name: &str| {
        layers
            .iter()
            .find(|l| l.name == name)
            .map(|l| l.pixels.clone())
    };
    let mean = layer("radiance")
        .ok_or_else(|| format!("{}: no layer named \"radiance\"", path.display()))?;
    let variance = layer("variance").unwrap_or_else(|| vec![[0.0; 3]; mean.len()]);
    Ok(Image {
        width,
        height,
        mean,
        variance,
    })
}
