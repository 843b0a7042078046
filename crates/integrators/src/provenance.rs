//! Provenance of logged contributions: what a bidirectional estimator records of a contribution
//! far above its pixel's mean (or not finite), enough to find the strategy and path that made it
//! and to replay the pixel sample. Shared by the methods that combine strategies by MIS, whose
//! outliers are the research question ("which technique made this firefly?").

/// A logged contribution: where it came from (pixel, sample index: with the seed, enough to
/// replay it), which strategy and path, its value and MIS weight, and the area-measure densities
/// of the full path's vertices y₀ … y_{s−1} z_{t−1} … z₀ along the light and camera subpaths.
/// Bidirectional path tracing (`bdpt/provenance.rs`) and VCM (`vcm/provenance.rs`) fill it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Outlier {
    /// The pixel whose sample made it.
    pub pixel: [u32; 2],
    /// The sample's index within the pixel.
    pub sample: u64,
    /// Light subpath vertices of the strategy.
    pub s: u32,
    /// Camera subpath vertices of the strategy.
    pub t: u32,
    /// A VCM merge (the light vertex y_{s−1} merged with the camera vertex z_{t−1}: the path has
    /// s + t − 1 vertices), not a connection.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub merge: bool,
    /// The full path's class in Heckbert's notation, light first (e.g. `LSSDE`).
    pub class: String,
    /// Weighted contribution (what the image receives).
    pub value: [f32; 3],
    /// The strategy's own estimate, before the MIS weight.
    pub unweighted: [f32; 3],
    /// The MIS weight of the strategy for this path.
    pub mis_weight: f32,
    /// Raster position of a t = 1 splat.
    pub raster: Option<[f32; 2]>,
    /// The pixel's running mean before this sample.
    pub pixel_mean: [f64; 3],
    /// Area density of each vertex, light first, as its own subpath sampled it.
    pub pdf_fwd: Vec<f32>,
    /// Area density of each vertex, light first, had the other subpath sampled it.
    pub pdf_rev: Vec<f32>,
}

use crate::paths::PathClass;
use crate::walk::PathVertex;
use glam::Vec2;
use lightlab_core::Rgb;

/// Pixel samples before which no contribution is called an outlier (the running mean is too
/// uncertain before).
pub(crate) const OUTLIER_MIN_SAMPLES: u64 = 8;

/// One technique's contribution, with what an [`Outlier`] records of it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Logged {
    /// Light and camera subpath vertices of the technique.
    pub s: usize,
    pub t: usize,
    /// A merge rather than a connection.
    pub merge: bool,
    /// The full path's class, light first.
    pub class: PathClass,
    pub unweighted: Rgb,
    pub weight: f32,
    /// Where a t = 1 contribution lands.
    pub raster: Option<Vec2>,
}

impl Outlier {
    /// The outlier record of contribution `c` of pixel sample `sample` of `pixel`, whose pixel's
    /// running mean was `pixel_mean`; `path` are the full path's vertices, light first.
    pub(crate) fn logged<'a>(
        pixel: (u32, u32),
        sample: u64,
        c: &Logged,
        pixel_mean: [f64; 3],
        path: impl Iterator<Item = &'a PathVertex> + Clone,
    ) -> Outlier {
        let v = c.unweighted * c.weight;
        Outlier {
            pixel: [pixel.0, pixel.1],
            sample,
            s: c.s as u32,
            t: c.t as u32,
            merge: c.merge,
            class: c.class.to_heckbert(),
            value: [v.r, v.g, v.b],
            unweighted: [c.unweighted.r, c.unweighted.g, c.unweighted.b],
            mis_weight: c.weight,
            raster: c.raster.map(|r| [r.x, r.y]),
            pixel_mean,
            pdf_fwd: path.clone().map(|v| v.pdf_fwd).collect(),
            pdf_rev: path.map(|v| v.pdf_rev).collect(),
        }
    }

    /// Whether a camera-side contribution `value` is an outlier of a pixel whose running mean over
    /// `count` samples is `mean`: larger in its largest channel than `factor` times the mean's
    /// largest channel, once the mean has `OUTLIER_MIN_SAMPLES` samples.
    pub(crate) fn exceeds(value: Rgb, (mean, count): ([f64; 3], u64), factor: f32) -> bool {
        let scale = mean[0].max(mean[1]).max(mean[2]);
        count >= OUTLIER_MIN_SAMPLES
            && value.max_component() as f64 > factor as f64 * scale.max(f64::MIN_POSITIVE)
    }
}

/// A splat, and the pixel sample and strategy it came from, to replay it if it turns out an
/// outlier.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SplatSource {
    /// The pixel it lands in.
    pub target: u32,
    /// Its value.
    pub value: Rgb,
    /// The pixel sample that made it: pixel and sample index.
    pub pixel: (u32, u32),
    pub sample: u64,
    /// Its strategy.
    pub s: u16,
    pub t: u16,
}

impl SplatSource {
    /// Whether the splat exceeds `factor` times the final mean of the pixel it lands in.
    pub(crate) fn is_outlier(&self, film: &crate::Film, factor: f32) -> bool {
        let mean = film.mean(self.target as usize);
        let scale = mean[0].max(mean[1]).max(mean[2]);
        self.value.max_component() as f64 > factor as f64 * scale.max(f64::MIN_POSITIVE)
    }
}
