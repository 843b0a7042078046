//! The memory a render will hold, checked before it starts: a request the machine cannot hold (a
//! 16384² film with path-class layers, billions of photons, a thousand light subpaths per pixel)
//! is refused with an error that says what to lower, instead of ending in the kernel's
//! out-of-memory kill halfway.

use crate::{Budget, Integrator};
use lightlab_scene::Scene;

/// What a render needs checked before it starts: that `integrator` can render `scene`
/// ([`Integrator::check_scene`]) within `budget` ([`Integrator::check_budget`]) and that the
/// machine can hold it ([`check`]).
pub fn check_render(
    integrator: &dyn Integrator,
    scene: &Scene,
    budget: &Budget,
) -> Result<(), String> {
    integrator.check_scene(scene)?;
    integrator.check_budget(budget)?;
    check(integrator, scene)
}

/// `Err` when `integrator` would need more memory for `scene` than the machine has available now,
/// by its [`Integrator::memory_bytes`]. Where the available memory cannot be read (no
/// `/proc/meminfo`), nothing is checked.
pub fn check(integrator: &dyn Integrator, scene: &Scene) -> Result<(), String> {
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| mem_available(&text));
    check_against(integrator.memory_bytes(scene), available, scene)
}

fn check_against(need: u64, available: Option<u64>, scene: &Scene) -> Result<(), String> {
    match available {
        Some(available) if need > available => Err(format!(
            "this render needs about {} at {}×{} pixels (its film, every layer, the render's \
             buffers, photon maps as a pilot of their photon paths predicts, and at least a \
             pass's light vertices for VCM), but {} of memory are available: lower the \
             resolution, the layers (`paths`, `layers`, `strategy_layers`), the photons or \
             `light_paths`",
            gigabytes(need),
            scene.camera.width,
            scene.camera.height,
            gigabytes(available)
        )),
        _ => Ok(()),
    }
}

fn gigabytes(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// Bytes the kernel reports it can give new allocations without swapping (`MemAvailable`,
/// Linux 3.14 and later) in the text of `/proc/meminfo`.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => value.checked_mul(1024),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::IntegratorConfig;

    #[test]
    fn reads_meminfo() {
        let text =
            "MemTotal:       24576000 kB\nMemFree:         1000 kB\nMemAvailable:   20000000 kB\n";
        assert_eq!(mem_available(text), Some(20_000_000 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
        assert_eq!(mem_available("MemAvailable: lots\n"), None);
    }

    /// A 16384² path-traced film with bounce layers 0…8 needs 10 × 2 films of 80-byte pixels
    /// (image and layers, and the tiles' copies): 429 GB, refused on a machine with 20 GB available, with the sizes in the message; a
    /// 64² render passes. BDPT's strategy layers and VCM's light subpaths count too.
    #[test]
    fn refuses_what_does_not_fit() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.ron");
        let mut scene = lightlab_scene::load_scene(&path).unwrap();
        let available = Some(20_000_000_000);
        let tracer = IntegratorConfig::from_ron("Path(max_bounces: 8, layers: Bounces)")
            .unwrap()
            .build()
            .unwrap();
        scene.camera.width = 16384;
        scene.camera.height = 16384;
        let need = tracer.memory_bytes(&scene);
        let cells = 16384u64 * 16384 * 10;
        assert_eq!(need, cells * 2 * size_of::<crate::PixelSums>() as u64);
        let e = check_against(need, available, &scene).unwrap_err();
        assert!(e.contains("16384×16384") && e.contains("20.0 GB"), "{e}");
        let bdpt = IntegratorConfig::from_ron("Bdpt(max_bounces: 8, strategy_layers: true)")
            .unwrap()
            .build()
            .unwrap();
        let vcm = IntegratorConfig::from_ron("Vcm(max_bounces: 8, light_paths: 256)")
            .unwrap()
            .build()
            .unwrap();
        scene.camera.width = 1024;
        scene.camera.height = 1024;
        assert!(bdpt.memory_bytes(&scene) > 5 * tracer.memory_bytes(&scene));
        assert!(check_against(vcm.memory_bytes(&scene), available, &scene).is_err());
        scene.camera.width = 64;
        scene.camera.height = 64;
        for integrator in [&tracer, &bdpt, &vcm] {
            check_against(integrator.memory_bytes(&scene), available, &scene).unwrap();
        }
        check_against(u64::MAX, None, &scene).unwrap();
        // Four billion photon paths store about ten billion photons in this closed box.
        let photons = IntegratorConfig::from_ron("PhotonMap(photons: 4_000_000_000)")
            .unwrap()
            .build()
            .unwrap();
        assert!(photons.memory_bytes(&scene) > 500_000_000_000);
    }

    /// The pilot's photons per path predict what a map of 100 000 paths stores, for the global
    /// map (≈ 2.6 photons a path) and the caustic one (≈ 3 % of paths store one). A count of k
    /// pilot photons has a relative standard error of about 1/√k (Poisson), up to 1.5× that
    /// where a path stores several; the check allows four of those (fixed seeds; false failures
    /// below 10⁻⁴): 6 % for the global map, 50 % for the caustic one.
    #[test]
    fn pilot_predicts_the_photons_stored() {
        use crate::photon::trace::{Keep, PhotonTracing, stored_per_path, trace_photons};
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes/caustic-sphere.ron");
        let scene = lightlab_scene::load_scene(&path).unwrap();
        for keep in [
            Keep::All,
            Keep::Caustic {
                through_glossy: true,
            },
        ] {
            let how = PhotonTracing {
                max_bounces: u32::MAX,
                roulette: crate::RoulettePolicy {
                    start: Some(1),
                    threshold: 0.5,
                },
                keep,
            };
            let n = 100_000;
            let stored = trace_photons(&scene, 5, (0, n), 0.0, how, &mut Default::default())
                .photons
                .len() as f64;
            let per_path = stored_per_path(&scene, 0.0, how);
            let predicted = n as f64 * per_path;
            let pilot_photons = per_path * 4096.0;
            assert!(
                (predicted / stored - 1.0).abs() < 4.0 * 1.5 / pilot_photons.sqrt(),
                "{keep:?}: predicted {predicted}, stored {stored}"
            );
        }
    }
}
