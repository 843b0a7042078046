//! Settings of the photon-mapping integrators, as RON (`PhotonMap(...)`, `Ppm(...)`, `Sppm(...)`).

use super::map::{Kernel, Search};
use crate::config::{ConfigError, Validate, invalid, settings};
use serde::{Deserialize, Serialize};

/// A length given absolutely (scene units) or as a fraction of the radius of the scene's bounding
/// sphere, so one setting fits scenes of any scale.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Length {
    /// In scene units.
    Absolute(f32),
    /// This fraction of the scene's bounding radius.
    Relative(f32),
}

impl Length {
    /// The length in scene units for a scene of bounding radius `scene_radius`.
    pub fn resolve(self, scene_radius: f32) -> f32 {
        match self {
            Length::Absolute(r) => r,
            Length::Relative(f) => f * scene_radius,
        }
    }

    pub(crate) fn check(self, what: &str) -> Result<(), String> {
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
    Nearest {
        /// Photons gathered (the estimate uses the k − 1 inside the k-th one's distance), at
        /// least 3: for a constant density λ the estimate (k − 1)/(π r_k²) has mean λ and
        /// variance λ²/(k − 2), zero for k = 1 and unbounded for k = 2.
        k: u32,
        /// Largest search radius.
        max_radius: Length,
    },
}

/// The smallest gather radius the scene's f32 positions resolve: 256 float steps at its largest
/// coordinate, where photon positions are spaced by one step, so that a disk's area (and the hash
/// grid's cell index) is off by less than 1 % from rounding. Below it a density estimate loses
/// photons to rounding rather than to the radius.
pub fn smallest_radius(scene: &lightlab_scene::Scene) -> f32 {
    let extent = scene.center.abs().max_element() + scene.radius;
    256.0 * f32::EPSILON * extent
}

/// The smallest `alpha` of the `Local` radius update (measured on the Cornell box, 8 × 8, 300
/// passes, six seeds: −2 ± 3 % at 0.1, −7 % at 0.01; `Global` is unbiased at any α).
const MIN_LOCAL_ALPHA: f32 = 0.1;

/// Final-gather rays per visible point, at most: as many as 1024 light subpaths of VCM, a thousand
/// times the default; 2³² − 1 was accepted and rendered for hours.
const MAX_GATHER_RAYS: u32 = 16384;

/// Checks that a gather radius of `what` (`length`) is one the scene can resolve, and no wider
/// than the scene: a disk beyond its diameter (r² overflowing f32 at Relative(10²⁰)) gathered
/// nothing, and the photon term vanished from the image without a word.
pub(crate) fn check_radius(
    what: &str,
    length: Length,
    scene: &lightlab_scene::Scene,
) -> Result<(), String> {
    let (r, min) = (length.resolve(scene.radius), smallest_radius(scene));
    if r > 2.0 * scene.radius {
        return Err(format!(
            "{what} {length:?} is {r:.3e} in this scene, wider than the scene itself (its \
             diameter is {:.3e}): use at most Relative(2) or Absolute({:.2e})",
            2.0 * scene.radius,
            2.0 * scene.radius
        ));
    }
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

    /// The photon-map search for a scene of bounding radius `scene_radius`.
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
                if k < 3 {
                    return Err(format!(
                        "{what}: k must be at least 3, got {k}: the estimate sums the k − 1 \
                         photons inside the k-th one's distance (none for k = 1), and its \
                         variance λ²/(k − 2) is unbounded for k = 2"
                    ));
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
    FinalGather {
        /// Gather rays per visible point.
        rays: u32,
    },
}

settings! {
    /// Settings of Jensen's two-pass photon mapping: `PhotonMap(photons: 1_000_000)`; every field
    /// optional.
    PhotonMapConfig as "PhotonMap" {
        /// Photon paths traced for the global map. Default 200 000.
        photons: u64 = 200_000,
        /// Photon paths traced for the caustic map (only their `L S+ X` photons are kept, or with
        /// `trace_glossy` their `L (S|G)+ X` ones). Default 200 000.
        caustic_photons: u64 = 200_000,
        /// Gathering from the global map. Default `Nearest(k: 50, max_radius: Relative(0.1))`.
        gather: Gather = Gather::Nearest {
            k: 50,
            max_radius: Length::Relative(0.1),
        },
        /// Gathering from the caustic map. Default `Nearest(k: 50, max_radius: Relative(0.02))`.
        caustic_gather: Gather = Gather::Nearest {
            k: 50,
            max_radius: Length::Relative(0.02),
        },
        /// Density-estimation kernel: `Uniform`, `Cone` or `Epanechnikov`. Default `Uniform`.
        kernel: Kernel = Kernel::Uniform,
        /// Direct lighting by next-event estimation at the visible point (`L D S* E`). Default true.
        direct: bool = true,
        /// Caustics from the caustic map (`L S+ D S* E`, or with `trace_glossy` `L (S|G)+ D (S|G)* E`).
        /// Default true.
        caustics: bool = true,
        /// Indirect diffuse light: `Off`, `Direct` or `FinalGather(rays: N)`.
        /// Default `FinalGather(rays: 16)`.
        indirect: Indirect = Indirect::FinalGather { rays: 16 },
        /// Trace camera paths through glossy surfaces (path tracing there) instead of gathering
        /// photons on them; final-gather rays pass them too, and the caustic map keeps the photons
        /// that reach a diffuse surface through glossy ones, `L (S|G)+ X`. Default true.
        trace_glossy: bool = true,
    }
}

settings! {
    /// Settings of progressive photon mapping (`Ppm`: visible points fixed, Hachisuka et al. 2008;
    /// `Sppm`: new visible points every pass, Hachisuka & Jensen 2009): `Sppm(alpha: 0.7)`; every
    /// field optional. The budget's samples per pixel are the number of passes.
    ProgressiveConfig as "Sppm" {
        /// Photon paths per pass. Default 100 000.
        photons_per_pass: u64 = 100_000,
        /// Initial gather radius r₁. Default `Relative(0.02)` (2 % of the scene's bounding radius).
        radius: Length = Length::Relative(0.02),
        /// Fraction of new photons kept per pass, 0 < α < 1. Default 2/3 (the asymptotically best
        /// trade of bias and variance, Knaus & Zwicker 2011).
        alpha: f32 = 2.0 / 3.0,
        /// Radius schedule: `Local` or `Global`. Default `Local`.
        update: RadiusUpdate = RadiusUpdate::Local,
        /// Density-estimation kernel. Default `Uniform`.
        kernel: Kernel = Kernel::Uniform,
        /// Trace camera paths through glossy surfaces instead of gathering on them. Default true.
        trace_glossy: bool = true,
    }
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

fn check_photons(n: u64, what: &str) -> Result<(), ConfigError> {
    if n == 0 || n > u32::MAX as u64 {
        return invalid(format!(
            "{what} must be between 1 and {}, got {n}",
            u32::MAX
        ));
    }
    Ok(())
}

impl Validate for PhotonMapConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.check_common()?;
        check_photons(self.photons, "photons")?;
        check_photons(self.caustic_photons, "caustic_photons")?;
        self.gather.check("gather").map_err(ConfigError::Invalid)?;
        self.caustic_gather
            .check("caustic_gather")
            .map_err(ConfigError::Invalid)?;
        if let Indirect::FinalGather { rays } = self.indirect
            && !(1..=MAX_GATHER_RAYS).contains(&rays)
        {
            return invalid(format!(
                "FinalGather rays must be between 1 and {MAX_GATHER_RAYS} per visible point, got \
                 {rays} (or use indirect: Direct or Off)"
            ));
        }
        Ok(())
    }
}

impl Validate for ProgressiveConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.check_common()?;
        check_photons(self.photons_per_pass, "photons_per_pass")?;
        self.radius.check("radius").map_err(ConfigError::Invalid)?;
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return invalid(format!(
                "alpha must lie strictly between 0 and 1 (the fraction of photons kept per pass), got {}",
                self.alpha
            ));
        }
        if self.update == RadiusUpdate::Local && self.alpha < MIN_LOCAL_ALPHA {
            return invalid(format!(
                "with update: Local, alpha must be at least {MIN_LOCAL_ALPHA}: the first photons a \
                 visible point receives shrink its r² by α itself, so a small α leaves disks that \
                 photons seldom reach and the image renders dark for thousands of passes (−7 % at \
                 0.01, −25 % at 1e-6 after 300); got {}, use update: Global for a small α",
                self.alpha
            ));
        }
        Ok(())
    }
}
