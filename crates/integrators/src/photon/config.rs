//! Settings of the photon-mapping integrators, as RON (`PhotonMap(...)`, `Ppm(...)`, `Sppm(...)`).

use super::map::{Kernel, Search};
use crate::paths::{Layers, Router};
use serde::{Deserialize, Serialize};

/// A length given absolutely (scene units) or as a fraction of the radius of the scene's bounding
/// sphere, so one setting fits scenes of any scale.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Length {
    Absolute(f32),
    Relative(f32),
}

impl Length {
    pub fn resolve(self, scene_radius: f32) -> f32 {
        match self {
            Length::Absolute(r) => r,
            Length::Relative(f) => f * scene_radius,
        }
    }

    fn check(self, what: &str) -> Result<(), String> {
        let v = match self {
            Length::Absolute(v) | Length::Relative(v) => v,
        };
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(format!(
                "{what} must be a positive finite length, got {v} (e.g. Relative(0.01) or Absolute(0.05))"
            ))
        }
    }
}

/// How the photons of one radiance estimate are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Gather {
    /// All photons within a fixed radius.
    Radius(Length),
    /// The k nearest photons (Jensen 2001, §7.1), no farther than `max_radius`.
    Nearest { k: u32, max_radius: Length },
}

/// The smallest gather radius the scene's f32 positions resolve: 256 float steps at its largest
/// coordinate, where photon positions are spaced by one step, so that a disk's area (and the hash
/// grid's cell index) is off by less than 1 % from rounding. Below it a density estimate loses
/// photons to rounding rather than to the radius.
pub fn smallest_radius(scene: &lightlab_scene::Scene) -> f32 {
    let extent = scene.center.abs().max_element() + scene.radius;
    256.0 * f32::EPSILON * extent
}

/// Checks that a gather radius of `what` (`length`) is one the scene can resolve.
pub(crate) fn check_radius(
    what: &str,
    length: Length,
    scene: &lightlab_scene::Scene,
) -> Result<(), String> {
    let (r, min) = (length.resolve(scene.radius), smallest_radius(scene));
    if r >= min {
        return Ok(());
    }
    Err(format!(
        "{what} {length:?} is {r:.3e} in this scene, below the smallest radius its f32 positions \
         resolve, {min:.3e} (256 float steps at its extent {:.3e}): photons would be lost to \
         rounding; use at least Absolute({min:.2e}) or Relative({:.2e})",
        scene.center.abs().max_element() + scene.radius,
        min / scene.radius
    ))
}

impl Gather {
    /// The radius that bounds this search.
    pub fn radius(self) -> Length {
        match self {
            Gather::Radius(r) => r,
            Gather::Nearest { max_radius, .. } => max_radius,
        }
    }

    pub fn search(self, scene_radius: f32) -> Search {
        match self {
            Gather::Radius(r) => {
                let r = r.resolve(scene_radius);
                Search::Radius { radius_sq: r * r }
            }
            Gather::Nearest { k, max_radius } => {
                let r = max_radius.resolve(scene_radius);
                Search::Nearest {
                    k: k as usize,
                    max_radius_sq: r * r,
                }
            }
        }
    }

    fn check(self, what: &str) -> Result<(), String> {
        match self {
            Gather::Radius(r) => r.check(&format!("{what} radius")),
            Gather::Nearest { k, max_radius } => {
                if k == 0 {
                    return Err(format!("{what}: k must be at least 1"));
                }
                max_radius.check(&format!("{what} max_radius"))
            }
        }
    }
}

/// How the photon-map integrator estimates indirect diffuse light (`L … X D S* E` with X not `L`
/// and not only specular vertices before it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Indirect {
    /// Left out.
    Off,
    /// Read from the global photon map at the visible point (fast, blotchy).
    Direct,
    /// Final gather (Jensen 2001, §9.3): `rays` BSDF-sampled rays from the visible point, each
    /// reading the global map where it lands (after any specular surfaces).
    FinalGather { rays: u32 },
}

/// Settings of Jensen's two-pass photon mapping.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    try_from = "PhotonMapConfigRaw",
    into = "PhotonMapConfigRaw"
)]
pub struct PhotonMapConfig {
    pub max_bounces: Option<u32>,
    pub min_bounces: u32,
    pub russian_roulette: Option<u32>,
    pub photons: u64,
    pub caustic_photons: u64,
    pub gather: Gather,
    pub caustic_gather: Gather,
    pub kernel: Kernel,
    pub direct: bool,
    pub caustics: bool,
    pub indirect: Indirect,
    pub trace_glossy: bool,
    pub paths: Option<String>,
    pub layers: Layers,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "PhotonMap")]
pub struct PhotonMapConfigRaw {
    /// Largest number of scattering vertices of a path, as for every integrator; `None` for no
    /// limit. Default `None`.
    #[serde(default)]
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    #[serde(default)]
    pub min_bounces: u32,
    /// Russian roulette on camera and photon paths from this many vertices on. Default `Some(3)`.
    #[serde(default = "default_rr")]
    pub russian_roulette: Option<u32>,
    /// Photon paths traced for the global map. Default 200 000.
    #[serde(default = "default_photons")]
    pub photons: u64,
    /// Photon paths traced for the caustic map (only their `L S+ X` photons are kept).
    /// Default 200 000.
    #[serde(default = "default_photons")]
    pub caustic_photons: u64,
    /// Gathering from the global map. Default `Nearest(k: 50, max_radius: Relative(0.1))`.
    #[serde(default = "default_gather")]
    pub gather: Gather,
    /// Gathering from the caustic map. Default `Nearest(k: 50, max_radius: Relative(0.02))`.
    #[serde(default = "default_caustic_gather")]
    pub caustic_gather: Gather,
    /// Density-estimation kernel: `Uniform`, `Cone` or `Epanechnikov`. Default `Uniform`.
    #[serde(default)]
    pub kernel: Kernel,
    /// Direct lighting by next-event estimation at the visible point (`L D S* E`). Default true.
    #[serde(default = "yes")]
    pub direct: bool,
    /// Caustics from the caustic map (`L S+ D S* E`). Default true.
    #[serde(default = "yes")]
    pub caustics: bool,
    /// Indirect diffuse light: `Off`, `Direct` or `FinalGather(rays: N)`.
    /// Default `FinalGather(rays: 16)`.
    #[serde(default = "default_indirect")]
    pub indirect: Indirect,
    /// Trace camera paths through glossy surfaces (path tracing there) instead of gathering
    /// photons on them. Default true.
    #[serde(default = "yes")]
    pub trace_glossy: bool,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    #[serde(default)]
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    #[serde(default)]
    pub layers: Layers,
}

/// Settings of progressive photon mapping (`Ppm`: visible points fixed, Hachisuka et al. 2008;
/// `Sppm`: new visible points every pass, Hachisuka & Jensen 2009). The budget's samples per pixel
/// are the number of passes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    try_from = "ProgressiveConfigRaw",
    into = "ProgressiveConfigRaw"
)]
pub struct ProgressiveConfig {
    pub max_bounces: Option<u32>,
    pub min_bounces: u32,
    pub russian_roulette: Option<u32>,
    pub photons_per_pass: u64,
    pub radius: Length,
    pub alpha: f32,
    pub update: RadiusUpdate,
    pub kernel: Kernel,
    pub trace_glossy: bool,
    pub paths: Option<String>,
    pub layers: Layers,
}

/// How the gather radius shrinks from pass to pass; both give r_i² ∝ i^(α−1) (see `progressive`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum RadiusUpdate {
    /// Per visible point from its photon statistics (Hachisuka et al. 2008, eqs. 7–10).
    #[default]
    Local,
    /// The same radius everywhere, r²_{i+1} = r²_i (i + α)/(i + 1), and the image is the mean of
    /// independent per-pass estimates (Knaus & Zwicker 2011, eq. 19).
    Global,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Sppm")]
pub struct ProgressiveConfigRaw {
    /// Largest number of scattering vertices of a path; `None` for no limit. Default `None`.
    #[serde(default)]
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    #[serde(default)]
    pub min_bounces: u32,
    /// Russian roulette on camera and photon paths from this many vertices on. Default `Some(3)`.
    #[serde(default = "default_rr")]
    pub russian_roulette: Option<u32>,
    /// Photon paths per pass. Default 100 000.
    #[serde(default = "default_photons_per_pass")]
    pub photons_per_pass: u64,
    /// Initial gather radius r₁. Default `Relative(0.02)` (2 % of the scene's bounding radius).
    #[serde(default = "default_radius")]
    pub radius: Length,
    /// Fraction of new photons kept per pass, 0 < α < 1. Default 2/3 (the asymptotically best
    /// trade of bias and variance, Knaus & Zwicker 2011).
    #[serde(default = "default_alpha")]
    pub alpha: f32,
    /// Radius schedule: `Local` or `Global`. Default `Local`.
    #[serde(default)]
    pub update: RadiusUpdate,
    /// Density-estimation kernel. Default `Uniform`.
    #[serde(default)]
    pub kernel: Kernel,
    /// Trace camera paths through glossy surfaces instead of gathering on them. Default true.
    #[serde(default = "yes")]
    pub trace_glossy: bool,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    #[serde(default)]
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    #[serde(default)]
    pub layers: Layers,
}

fn default_rr() -> Option<u32> {
    Some(3)
}
fn yes() -> bool {
    true
}
fn default_photons() -> u64 {
    200_000
}
fn default_photons_per_pass() -> u64 {
    100_000
}
fn default_gather() -> Gather {
    Gather::Nearest {
        k: 50,
        max_radius: Length::Relative(0.1),
    }
}
fn default_caustic_gather() -> Gather {
    Gather::Nearest {
        k: 50,
        max_radius: Length::Relative(0.02),
    }
}
fn default_indirect() -> Indirect {
    Indirect::FinalGather { rays: 16 }
}
fn default_radius() -> Length {
    Length::Relative(0.02)
}
fn default_alpha() -> f32 {
    2.0 / 3.0
}

fn check_photons(n: u64, what: &str) -> Result<(), String> {
    if n == 0 || n > u32::MAX as u64 {
        return Err(format!(
            "{what} must be between 1 and {}, got {n}",
            u32::MAX
        ));
    }
    Ok(())
}

impl TryFrom<PhotonMapConfigRaw> for PhotonMapConfig {
    type Error = String;
    fn try_from(r: PhotonMapConfigRaw) -> Result<Self, String> {
        crate::config::check_bounces(r.max_bounces, r.min_bounces, r.russian_roulette)?;
        check_photons(r.photons, "photons")?;
        check_photons(r.caustic_photons, "caustic_photons")?;
        r.gather.check("gather")?;
        r.caustic_gather.check("caustic_gather")?;
        if r.indirect == (Indirect::FinalGather { rays: 0 }) {
            return Err("FinalGather needs at least 1 ray (or use indirect: Direct or Off)".into());
        }
        Router::check(r.paths.as_deref(), &r.layers)?;
        Ok(PhotonMapConfig {
            max_bounces: r.max_bounces,
            min_bounces: r.min_bounces,
            russian_roulette: r.russian_roulette,
            photons: r.photons,
            caustic_photons: r.caustic_photons,
            gather: r.gather,
            caustic_gather: r.caustic_gather,
            kernel: r.kernel,
            direct: r.direct,
            caustics: r.caustics,
            indirect: r.indirect,
            trace_glossy: r.trace_glossy,
            paths: r.paths,
            layers: r.layers,
        })
    }
}

impl From<PhotonMapConfig> for PhotonMapConfigRaw {
    fn from(c: PhotonMapConfig) -> Self {
        PhotonMapConfigRaw {
            max_bounces: c.max_bounces,
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            photons: c.photons,
            caustic_photons: c.caustic_photons,
            gather: c.gather,
            caustic_gather: c.caustic_gather,
            kernel: c.kernel,
            direct: c.direct,
            caustics: c.caustics,
            indirect: c.indirect,
            trace_glossy: c.trace_glossy,
            paths: c.paths,
            layers: c.layers,
        }
    }
}

impl TryFrom<ProgressiveConfigRaw> for ProgressiveConfig {
    type Error = String;
    fn try_from(r: ProgressiveConfigRaw) -> Result<Self, String> {
        crate::config::check_bounces(r.max_bounces, r.min_bounces, r.russian_roulette)?;
        check_photons(r.photons_per_pass, "photons_per_pass")?;
        r.radius.check("radius")?;
        if !(r.alpha > 0.0 && r.alpha < 1.0) {
            return Err(format!(
                "alpha must lie strictly between 0 and 1 (the fraction of photons kept per pass), got {}",
                r.alpha
            ));
        }
        Router::check(r.paths.as_deref(), &r.layers)?;
        Ok(ProgressiveConfig {
            max_bounces: r.max_bounces,
            min_bounces: r.min_bounces,
            russian_roulette: r.russian_roulette,
            photons_per_pass: r.photons_per_pass,
            radius: r.radius,
            alpha: r.alpha,
            update: r.update,
            kernel: r.kernel,
            trace_glossy: r.trace_glossy,
            paths: r.paths,
            layers: r.layers,
        })
    }
}

impl From<ProgressiveConfig> for ProgressiveConfigRaw {
    fn from(c: ProgressiveConfig) -> Self {
        ProgressiveConfigRaw {
            max_bounces: c.max_bounces,
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            photons_per_pass: c.photons_per_pass,
            radius: c.radius,
            alpha: c.alpha,
            update: c.update,
            kernel: c.kernel,
            trace_glossy: c.trace_glossy,
            paths: c.paths,
            layers: c.layers,
        }
    }
}
