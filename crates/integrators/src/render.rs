//! What every integrator takes (a budget) and returns (a film with statistics), and the tile loop that
//! runs a per-pixel estimator over the image on the rayon pool.

use crate::film::{Film, PixelSums};
use lightlab_core::Progress;
use serde::Serialize;
use std::time::Instant;

/// How much work a render may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Samples per pixel (camera paths per pixel), ≥ 1.
    pub spp: u32,
}

/// Counters gathered while rendering.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RenderStats {
    pub integrator: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    pub threads: usize,
    pub wall_seconds: f64,
    /// Camera paths traced.
    pub samples: u64,
    /// Rays cast: closest-hit and shadow rays together.
    pub rays: u64,
    pub rays_per_second: f64,
    pub samples_per_second: f64,
    /// Photon paths traced (photon-mapping integrators).
    pub photons: u64,
    /// Photons stored in photon maps, summed over maps and passes.
    pub photons_stored: u64,
    /// Contributions that were NaN or infinite and were left out of the film, by technique.
    pub non_finite: Vec<(String, u64)>,
    /// Logged outliers (and non-finite contributions), by strategy (`Bdpt`'s `outliers` setting).
    pub outliers: Vec<(String, u64)>,
}

impl RenderStats {
    /// The statistics of a finished render: `samples` camera (or light) paths in `wall` seconds,
    /// with the non-finite counters named by `techniques` (the integrator's technique numbers).
    pub(crate) fn new(
        integrator: &str,
        (width, height): (u32, u32),
        budget: &Budget,
        seed: u64,
        wall: f64,
        samples: u64,
        counters: &Counters,
        techniques: &[&str],
    ) -> RenderStats {
        RenderStats {
            integrator: integrator.into(),
            width,
            height,
            spp: budget.spp,
            seed,
            threads: rayon::current_num_threads(),
            wall_seconds: wall,
            samples,
            rays: counters.rays,
            rays_per_second: counters.rays as f64 / wall.max(1e-9),
            samples_per_second: samples as f64 / wall.max(1e-9),
            photons: 0,
            photons_stored: 0,
            outliers: Vec::new(),
            non_finite: techniques
                .iter()
                .zip(counters.non_finite)
                .map(|(t, n)| (t.to_string(), n))
                .collect(),
        }
    }

    pub fn non_finite_total(&self) -> u64 {
        self.non_finite.iter().map(|(_, n)| n).sum()
    }
}

pub struct RenderOutput {
    /// The full image (only the paths the integrator's `paths` expression selects, if it has one).
    pub film: Film,
    /// The layers the integrator's `layers` setting asked for, named; they sum to `film`.
    pub layers: Vec<(String, Film)>,
    /// Contributions logged for provenance (`Bdpt` with `outliers`, and every non-finite one).
    pub outliers: Vec<crate::bdpt::Outlier>,
    pub stats: RenderStats,
}

/// Counters kept per tile and summed; `non_finite` is indexed by the integrator's technique number.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    pub rays: u64,
    pub non_finite: [u64; 2],
}

impl Counters {
    pub fn merge(&mut self, o: &Counters) {
        self.rays += o.rays;
        for (a, b) in self.non_finite.iter_mut().zip(o.non_finite) {
            *a += b;
        }
    }
}

/// Tile edge in pixels: small enough to balance two cores on small images, large enough to amortise
/// scheduling.
const TILE: u32 = 16;

/// Runs `pixel(x, y, sums, counters)` for every pixel, tiles in parallel, and returns the film, the
/// `layers` layer films, the summed counters and the wall time. `sums[0]` is the pixel of the full
/// image, `sums[1 + l]` its pixel in layer l. Each pixel's samples are summed in sample order by one
/// thread, so the films are bit-identical whatever the thread count.
pub(crate) fn render_tiles<F>(
    width: u32,
    height: u32,
    layers: usize,
    progress: &dyn Progress,
    pixel: F,
) -> (Film, Vec<Film>, Counters, f64)
where
    F: Fn(u32, u32, &mut [PixelSums], &mut Counters) + Sync,
{
    use rayon::prelude::*;
    let start = Instant::now();
    let per_pixel = 1 + layers;
    let tiles: Vec<(u32, u32)> = (0..height.div_ceil(TILE))
        .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    progress.start(width as u64 * height as u64);
    let done: Vec<(Vec<PixelSums>, Counters)> = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            let (w, h) = (TILE.min(width - x0), TILE.min(height - y0));
            let mut counters = Counters::default();
            let mut sums = vec![PixelSums::default(); (w * h) as usize * per_pixel];
            for y in 0..h {
                for x in 0..w {
                    let k = (y * w + x) as usize * per_pixel;
                    pixel(x0 + x, y0 + y, &mut sums[k..k + per_pixel], &mut counters);
                }
            }
            progress.advance((w * h) as u64);
            (sums, counters)
        })
        .collect();
    let mut films: Vec<Film> = (0..per_pixel).map(|_| Film::new(width, height)).collect();
    let mut counters = Counters::default();
    for (&(x0, y0), (sums, c)) in tiles.iter().zip(&done) {
        let w = TILE.min(width - x0);
        for (k, s) in sums.chunks(per_pixel).enumerate() {
            let (x, y) = (x0 + k as u32 % w, y0 + k as u32 / w);
            for (film, s) in films.iter_mut().zip(s) {
                film.pixels[(y * width + x) as usize] = *s;
            }
        }
        counters.merge(c);
    }
    let film = films.remove(0);
    (film, films, counters, start.elapsed().as_secs_f64())
}

/// Names the layer films.
pub(crate) fn named(names: Vec<String>, films: Vec<Film>) -> Vec<(String, Film)> {
    names.into_iter().zip(films).collect()
}
