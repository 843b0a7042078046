//! What every integrator returns: a film with statistics.

use crate::film::Film;
use serde::{Deserialize, Serialize};

/// What a film's per-pixel variance is, so that nobody uses it where it does not hold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum PixelVariance {
    /// s²/n over independent, identically distributed samples of each pixel (camera paths, or
    /// whole sample passes where light paths splat): an unbiased estimate of the variance of the
    /// pixel mean.
    Independent,
    /// The camera samples' s²/n plus the photon maps' share from `groups` independent photon
    /// groups (Jensen's photon mapping): exact for a fixed gather radius, an approximation for the
    /// k nearest photons, whose radius the groups set together (1–4 % low where tested).
    CameraAndPhotonGroups {
        /// Independent photon groups per map.
        groups: u32,
    },
    /// The spread of `replicates` independent replicates of the sampler: s²/R over each pixel's
    /// R replicate means, an unbiased estimate of the variance of the pixel mean with R − 1
    /// degrees of freedom, whatever the sampler (randomised quasi-Monte Carlo).
    Replicates {
        /// Independent replicates per pixel.
        replicates: u32,
    },
    /// Not the variance of the mean; why.
    NotAnEstimate(String),
}

impl PixelVariance {
    /// Whether the variance estimates the variance of the pixel mean.
    pub fn is_estimate(&self) -> bool {
        !matches!(self, PixelVariance::NotAnEstimate(_))
    }
}

/// What each pixel's value converges to as the budget grows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PixelLimit {
    /// The pixel's measurement: radiance integrated over the pixel's box filter (and the lens, and
    /// everything else sampled), which a reference render estimates too.
    #[default]
    PixelIntegral,
    /// The radiance along one fixed camera path per pixel (`Ppm`: its visible points never
    /// move), so the pixel's box-filtered value is not reached: against a reference that
    /// estimates it, the difference stays as aliasing at edges and texture, however many passes.
    OneCameraPath,
    /// A photon-map estimate blurred over a radius that never shrinks (`PhotonMap`): more camera
    /// samples converge to that blurred value, not to the pixel integral.
    FixedRadiusBlur,
    /// The pixel integral of a piecewise-constant radiosity solution (`Radiosity`): radiance
    /// constant over each patch and form factors estimated once, so against a reference of the
    /// true radiance the difference stays as discretisation error (and the form factors' noise),
    /// however many camera samples.
    PatchRadiosity,
    /// Cone tracing's composite of analytic coverages over a disk-shaped pixel footprint
    /// (`Cone`): a different filter and approximations (see `cone`), not the box-filtered pixel
    /// integral; deterministic, so no samples change it.
    ConeFootprint,
}

/// Counters gathered while rendering.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderStats {
    /// The integrator's name (`Path`, `Light`, `Bdpt`, `PhotonMap`, `Ppm`, `Sppm`).
    pub integrator: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel rendered (passes for progressive photon mapping).
    pub spp: u32,
    /// The seed every random number was derived from.
    pub seed: u64,
    /// Threads of the rayon pool it ran on (the image does not depend on it).
    pub threads: usize,
    /// Wall-clock time of the render.
    pub wall_seconds: f64,
    /// Of `wall_seconds`, the calibration renders a time budget needed with a sampler that must
    /// know its sample count in advance (see `Integrator::render`).
    pub pilot_seconds: f64,
    /// Camera paths traced (light paths for light tracing, subpath pairs for BDPT).
    pub samples: u64,
    /// Rays cast: closest-hit and shadow rays together.
    pub rays: u64,
    /// `rays / wall_seconds`.
    pub rays_per_second: f64,
    /// `samples / wall_seconds`.
    pub samples_per_second: f64,
    /// Photon paths traced (photon-mapping integrators).
    pub photons: u64,
    /// Photons stored in photon maps, summed over maps and passes.
    pub photons_stored: u64,
    /// Values that were NaN or infinite and were left out of the film, by technique (those the
    /// integrator uses, zeros included; see [`Technique`]).
    pub non_finite: Vec<(String, u64)>,
    /// Logged outliers (and non-finite contributions), by strategy (`Bdpt`'s `outliers` setting).
    pub outliers: Vec<(String, u64)>,
    /// What the film's variance layer is.
    pub pixel_variance: PixelVariance,
    /// What the pixel values converge to.
    pub pixel_limit: PixelLimit,
    /// Image-wide average radiance and its standard error (see [`Film::image_se`]).
    pub image_mean: [f64; 3],
    /// Its standard error; `None` where the sample passes are not independent.
    pub image_mean_se: Option<[f64; 3]>,
    /// The patches, form factors and solver iterations of a `Radiosity` render.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radiosity: Option<crate::radiosity::RadiosityStats>,
}

impl RenderStats {
    /// The statistics of a finished render of `film` at `spp` samples per pixel: `samples`
    /// camera (or light) paths in `wall` seconds, with the non-finite counts of the integrator's
    /// `techniques` (and of the walk's scattering step, which every integrator has).
    pub(crate) fn new(
        integrator: &str,
        film: &Film,
        spp: u32,
        seed: u64,
        wall: f64,
        samples: u64,
        counters: &Counters,
        techniques: &[Technique],
        pixel_variance: PixelVariance,
    ) -> RenderStats {
        // s²/n needs two samples: with one the film writes 0, which is no estimate.
        let pixel_variance = if spp < 2 && pixel_variance.is_estimate() {
            PixelVariance::NotAnEstimate(format!(
                "one sample per pixel: s²/n needs at least two, so the variance layer is 0 \
                 (it would have been {pixel_variance:?})"
            ))
        } else {
            pixel_variance
        };
        RenderStats {
            integrator: integrator.into(),
            width: film.width,
            height: film.height,
            spp,
            seed,
            threads: rayon::current_num_threads(),
            wall_seconds: wall,
            pilot_seconds: 0.0,
            samples,
            rays: counters.rays,
            rays_per_second: counters.rays as f64 / wall.max(1e-9),
            samples_per_second: samples as f64 / wall.max(1e-9),
            photons: 0,
            photons_stored: 0,
            outliers: Vec::new(),
            non_finite: techniques
                .iter()
                .chain([&Technique::Scattering])
                .map(|&t| (t.name().to_string(), counters.non_finite(t)))
                .collect(),
            pixel_variance,
            pixel_limit: PixelLimit::PixelIntegral,
            image_mean: film.average(),
            image_mean_se: film.image_se,
            radiosity: None,
        }
    }

    /// Non-finite values over all techniques.
    pub fn non_finite_total(&self) -> u64 {
        self.non_finite.iter().map(|(_, n)| n).sum()
    }
}

/// What a render returns: the image, its layers, logged outliers and statistics.
pub struct RenderOutput {
    /// The full image (only the paths the integrator's `paths` expression selects, if it has one).
    pub film: Film,
    /// The layers the integrator's `layers` setting asked for, named; they sum to `film`.
    pub layers: Vec<(String, Film)>,
    /// Contributions logged for provenance (`Bdpt` with `outliers`, and every non-finite one).
    pub outliers: Vec<crate::Outlier>,
    /// Counts, times and what the variance layer means.
    pub stats: RenderStats,
}

/// The estimators' techniques whose NaN or infinite values are counted (and kept out of the film),
/// named in one place. An integrator reports the ones it uses (see `RenderStats::new`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// Emission found by a camera path (a BSDF-sampled ray or the camera ray hitting an emitter).
    Emission,
    /// Next-event estimation (a light sampled from a camera-path vertex).
    NextEvent,
    /// A light-path vertex connected to the lens and splatted (light tracing, BDPT's t = 1).
    CameraConnection,
    /// A BDPT strategy with s ≥ 1 and t ≥ 2, or s = 0 (what lands in the sample's own pixel).
    Connection,
    /// Emission and next-event estimation of the photon mappers' camera walk.
    Camera,
    /// A photon's flux, or a photon-map estimate.
    Photon,
    /// A VCM merge of a camera vertex with a light vertex.
    Merge,
    /// A BSDF sample whose weight f·|cos|/p was not finite (the walk ends the path there).
    Scattering,
}

impl Technique {
    const COUNT: usize = 8;

    /// Its name in statistics and results (`non_finite` entries).
    pub fn name(self) -> &'static str {
        match self {
            Technique::Emission => "emission",
            Technique::NextEvent => "next_event",
            Technique::CameraConnection => "camera_connection",
            Technique::Connection => "connection",
            Technique::Camera => "camera",
            Technique::Photon => "photon",
            Technique::Merge => "merge",
            Technique::Scattering => "scattering",
        }
    }
}

/// Counters kept per tile and summed.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    /// Rays cast: closest-hit and shadow rays.
    pub rays: u64,
    non_finite: [u64; Technique::COUNT],
}

impl Counters {
    /// Adds `o`'s counts to these.
    pub fn merge(&mut self, o: &Counters) {
        self.rays += o.rays;
        for (a, b) in self.non_finite.iter_mut().zip(o.non_finite) {
            *a += b;
        }
    }

    /// Counts one non-finite value of `technique`.
    #[inline]
    pub fn count_non_finite(&mut self, technique: Technique) {
        self.non_finite[technique as usize] += 1;
    }

    /// Non-finite values of `technique` so far.
    pub fn non_finite(&self, technique: Technique) -> u64 {
        self.non_finite[technique as usize]
    }
}

/// Names the layer films.
pub(crate) fn named(names: Vec<String>, films: Vec<Film>) -> Vec<(String, Film)> {
    names.into_iter().zip(films).collect()
}
