//! Provenance of logged contributions: what a bidirectional estimator records of a contribution
//! far above its pixel's mean (or not finite), enough to find the strategy and path that made it
//! and to replay the pixel sample. Shared by the methods that combine strategies by MIS, whose
//! outliers are the research question ("which technique made this firefly?").

/// A logged contribution: where it came from (pixel, sample index: with the seed, enough to
/// replay it), which strategy and path, its value and MIS weight, and the area-measure densities
/// of the full path's vertices y₀ … y_{s−1} z_{t−1} … z₀ along the light and camera subpaths.
/// Bidirectional path tracing fills it today (`bdpt/provenance.rs`).
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
