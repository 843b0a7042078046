//! Progressive photon mapping: `Ppm` (Hachisuka, Ogaki & Jensen 2008) and stochastic progressive
//! photon mapping, `Sppm` (Hachisuka & Jensen 2009). Each pass traces one camera path per pixel to
//! a visible point (`Sppm`: a new one every pass, which brings anti-aliasing, depth of field and
//! glossy reflection; `Ppm`: the same path every pass), then `photons_per_pass` photon paths, and
//! adds the photons within each visible point's radius to its statistics. Direct light and
//! emission seen through specular chains come from the camera walk by next-event estimation; the
//! photons contribute paths of two or more bounces from the light.
//!
//! Radius schedule. With `Local` (the papers' update, eqs. 7–10 of Hachisuka et al. 2008), a
//! visible point with N accumulated photons that receives M new ones keeps a fraction α of them:
//!
//!   N' = N + αM,   r'² = r² · (N + αM)/(N + M),   τ' = (τ + Φ_new) · r'²/r²,
//!
//! and its photon estimate after i passes is τ / (i · π r²) (photon fluxes are already divided by
//! the photons per pass). If every pass brings about the same M, N_i ≈ αMi and
//! r_i² = r₁² Π_j (1 + α(j − 1))/(α(j − 1) + 1 + (1 − α)) ∝ i^(α−1), which is the schedule
//! `Global` applies to every pixel exactly: r²_{i+1} = r²_i (i + α)/(i + 1) (Knaus & Zwicker 2011,
//! eq. 19), with the image the mean of the independent per-pass estimates. For `Global` Knaus and
//! Zwicker predict MSE ∝ i^(−α) asymptotically where variance dominates, and the best rate,
//! i^(−2/3), at α = 2/3.
//!
//! The film's per-pixel variance is the spread of the per-pass estimates (the pass's direct light
//! plus its photons at the pass's radius). For `Global` that is the variance of the mean up to the
//! shrinking radius; for `Local` it is only an indication.

use super::camera::{self, Walk};
use super::config::{ProgressiveConfig, RadiusUpdate};
use super::grid::HashGrid;
use super::map::{Kernel, PhotonMap};
use super::trace::{Keep, PHOTON_FLUX, Photon, PhotonTracing, trace_photons};
use crate::film::{Film, PixelSums};
use crate::render::Counters;
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{INV_PI, Progress, Rgb};
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Seed offset of the next-event-estimation stream.
const LIGHT_STREAM: u64 = 0x5851_f42d_4c95_7f2d;

/// Which progressive variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    Ppm,
    Sppm,
}

pub struct Progressive {
    config: ProgressiveConfig,
    variant: Variant,
}

/// What one pixel carries from pass to pass.
#[derive(Clone, Copy, Debug)]
struct PixelState {
    radius_sq: f32,
    /// Accumulated photon count N (fractional under `Local`).
    n: f64,
    /// Accumulated flux τ (`Local`) or sum of per-pass photon estimates (`Global`).
    tau: [f64; 3],
    /// Sum of per-pass camera-side estimates (emission, direct light).
    direct: [f64; 3],
    /// Statistics of the per-pass estimates.
    passes: PixelSums,
}

impl Progressive {
    pub fn new(config: ProgressiveConfig, variant: Variant) -> Self {
        Progressive { config, variant }
    }

    fn name(&self) -> &'static str {
        match self.variant {
            Variant::Ppm => "Ppm",
            Variant::Sppm => "Sppm",
        }
    }

    /// Renders up to `budget.spp` passes, calling `on_pass(passes_done, film)` after each and
    /// stopping early when it returns false.
    fn run(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let c = &self.config;
        let start = Instant::now();
        let (width, height) = (scene.camera.width, scene.camera.height);
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let walk = Walk {
            max_bounces: max,
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            trace_glossy: c.trace_glossy,
            direct: true,
        };
        let tracing = PhotonTracing {
            max_bounces: max,
            russian_roulette: c.russian_roulette,
            keep: Keep::All,
        };
        let r1 = c.radius.resolve(scene.radius);
        let mut state = vec![
            PixelState {
                radius_sq: r1 * r1,
                n: 0.0,
                tau: [0.0; 3],
                direct: [0.0; 3],
                passes: PixelSums::default(),
            };
            (width * height) as usize
        ];
        let mut counters = Counters::default();
        let mut photons_stored = 0u64;
        let mut global_radius_sq = r1 * r1;
        progress.start(budget.spp as u64);
        let mut film = Film::new(width, height);
        let mut passes = 0;
        for pass in 0..budget.spp {
            let photons = trace_photons(
                scene,
                seed,
                pass as u64 * c.photons_per_pass,
                c.photons_per_pass,
                tracing,
                &mut counters,
            );
            photons_stored += photons.len() as u64;
            // One radius for every query: the hash grid is faster (BENCHMARKS.md, "Photon maps").
            let map = match c.update {
                RadiusUpdate::Local => Index::Tree(PhotonMap::new(photons)),
                RadiusUpdate::Global => {
                    Index::Grid(HashGrid::new(&photons, global_radius_sq.sqrt()))
                }
            };
            let camera_index = match self.variant {
                Variant::Ppm => 0,
                Variant::Sppm => pass as u64,
            };
            let pass_counters: Vec<Counters> = state
                .par_chunks_mut(width as usize)
                .enumerate()
                .map(|(y, row)| {
                    let mut counters = Counters::default();
                    for (x, px) in row.iter_mut().enumerate() {
                        let pixel = y as u64 * width as u64 + x as u64;
                        let mut sampler = Independent::new();
                        sampler.start_pixel_sample(seed, pixel, camera_index);
                        let mut lights = Independent::new();
                        lights.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, pass as u64);
                        let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                        let r = camera::walk(
                            scene,
                            &walk,
                            film,
                            &mut sampler,
                            &mut lights,
                            &mut counters,
                        );
                        let radius_sq = match c.update {
                            RadiusUpdate::Local => px.radius_sq,
                            RadiusUpdate::Global => global_radius_sq,
                        };
                        let (flux, m) = match &r.visible {
                            Some(vp) => {
                                let (lo, hi) = vp.photon_bounces(c.min_bounces, max);
                                let (lo, hi) = (lo.max(2), hi);
                                gather(&map, vp, radius_sq, c.kernel, lo, hi)
                            }
                            None => (Rgb::BLACK, 0),
                        };
                        if !flux.is_finite() {
                            counters.non_finite[PHOTON_FLUX] += 1;
                            continue;
                        }
                        let photon_estimate = flux * (INV_PI / radius_sq);
                        let pass_estimate = r.l + photon_estimate;
                        px.passes.add(to_f64(pass_estimate));
                        for k in 0..3 {
                            px.direct[k] += to_f64(r.l)[k];
                        }
                        match c.update {
                            RadiusUpdate::Global => {
                                for k in 0..3 {
                                    px.tau[k] += to_f64(photon_estimate)[k];
                                }
                            }
                            RadiusUpdate::Local if m > 0 => {
                                let (n, m) = (px.n, m as f64);
                                let n_new = n + c.alpha as f64 * m;
                                let shrink = n_new / (n + m);
                                for k in 0..3 {
                                    px.tau[k] = (px.tau[k] + to_f64(flux)[k]) * shrink;
                                }
                                px.n = n_new;
                                px.radius_sq = (px.radius_sq as f64 * shrink) as f32;
                            }
                            RadiusUpdate::Local => {}
                        }
                    }
                    counters
                })
                .collect();
            for pc in &pass_counters {
                counters.merge(pc);
            }
            let i = pass as u64 + 1;
            global_radius_sq *= (i as f32 + c.alpha) / (i as f32 + 1.0);
            for (p, px) in film.pixels.iter_mut().zip(&state) {
                let mut out = px.passes;
                let photons = match c.update {
                    RadiusUpdate::Global => px.tau.map(|t| t / i as f64),
                    RadiusUpdate::Local => px
                        .tau
                        .map(|t| t / (i as f64 * std::f64::consts::PI * px.radius_sq as f64)),
                };
                for k in 0..3 {
                    out.mean[k] = px.direct[k] / i as f64 + photons[k];
                }
                *p = out;
            }
            passes = i as u32;
            progress.advance(1);
            if !on_pass(passes, &film) {
                break;
            }
        }
        let wall = start.elapsed().as_secs_f64();
        let mut stats = RenderStats::new(
            self.name(),
            (width, height),
            &Budget { spp: passes },
            seed,
            wall,
            width as u64 * height as u64 * passes as u64,
            &counters,
            &["camera", "photon"],
        );
        stats.photons = c.photons_per_pass * passes as u64;
        stats.photons_stored = photons_stored;
        RenderOutput { film, stats }
    }
}

fn to_f64(c: Rgb) -> [f64; 3] {
    [c.r as f64, c.g as f64, c.b as f64]
}

/// The photons of one pass, searchable within a radius.
enum Index {
    /// Per-pixel radii (`Local`).
    Tree(PhotonMap),
    /// One radius, the grid's own (`Global`).
    Grid(HashGrid),
}

impl Index {
    #[inline]
    fn within(&self, p: glam::Vec3, radius_sq: f32, visit: impl FnMut(&Photon, f32)) {
        match self {
            Index::Tree(map) => map.within(p, radius_sq, visit),
            Index::Grid(grid) => grid.within(p, visit),
        }
    }
}

/// β · Σ K·f·Φ over the photons of bounce count in `lo..=hi` within the radius, and their number.
fn gather(
    map: &Index,
    vp: &camera::VisiblePoint,
    radius_sq: f32,
    kernel: Kernel,
    lo: u32,
    hi: u32,
) -> (Rgb, u32) {
    let mut sum = Rgb::BLACK;
    let mut m = 0u32;
    map.within(vp.gather.p, radius_sq, |ph, d2| {
        if (lo..=hi).contains(&(ph.bounces as u32)) {
            let c = super::map::contribution(&vp.gather, ph);
            if !c.is_black() {
                m += 1;
                sum += kernel.weight(d2 / radius_sq) * c;
            }
        }
    });
    (vp.beta * sum, m)
}

impl Integrator for Progressive {
    fn render(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
    ) -> RenderOutput {
        self.run(scene, budget, seed, progress, &mut |_, _| true)
    }

    fn progressive(&self) -> bool {
        true
    }

    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        self.run(scene, budget, seed, progress, on_pass)
    }
}
