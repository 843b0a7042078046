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
//! What it converges to. `Sppm` converges to the pixel's measurement (the radiance integrated over
//! the pixel's box filter and the lens). `Ppm` keeps one camera path per pixel, so it converges to
//! the radiance along that path — a point sample of the pixel, not its box-filtered value — and
//! against a reference of the pixel integral the difference at edges and texture never vanishes.
//!
//! The film's per-pixel "variance" is the spread of the per-pass estimates (the pass's direct light
//! plus its photons at the pass's radius) over n. It is not the variance of the pixel mean: the
//! passes are not identically distributed (the radius shrinks, so variance grows and bias falls
//! pass by pass), and under `Local` they are not independent (each radius depends on the photons
//! before). Experiments measure SPPM's variance across independent trials instead.

use super::camera::{self, CameraWalk};
use super::config::{ProgressiveConfig, RadiusUpdate};
use super::grid::HashGrid;
use super::map::{Kernel, PhotonMap};
use super::trace::{Keep, Photon, PhotonTracing, Traced, trace_photons};
use crate::film::{Film, PixelSums};
use crate::passes::Schedule;
use crate::paths::Router;
use crate::render::{Counters, PixelLimit, PixelVariance, Technique, named};
use crate::sink::Sink;
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{INV_PI, Progress, Rgb};
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;
use rayon::prelude::*;

/// Seed offset of the next-event-estimation stream.
const LIGHT_STREAM: u64 = 0x5851_f42d_4c95_7f2d;

/// Which progressive variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// Progressive photon mapping: the same visible point every pass (Hachisuka et al. 2008).
    Ppm,
    /// Stochastic progressive photon mapping: a new camera path every pass (Hachisuka & Jensen
    /// 2009).
    Sppm,
}

/// PPM or SPPM, built from checked [`ProgressiveConfig`] settings.
pub struct Progressive {
    config: ProgressiveConfig,
    variant: Variant,
    router: Router,
}

/// What one pixel carries from pass to pass, per slot (slot 0 the full image, 1 + l layer l).
#[derive(Clone, Debug)]
struct PixelState {
    radius_sq: f32,
    /// Accumulated photon count N (fractional under `Local`).
    n: f64,
    /// Accumulated flux τ (`Local`) or sum of per-pass photon estimates (`Global`).
    tau: Vec<[f64; 3]>,
    /// Sum of per-pass camera-side estimates (emission, direct light).
    direct: Vec<[f64; 3]>,
    /// Statistics of the per-pass estimates.
    passes: Vec<PixelSums>,
}

impl Progressive {
    /// Progressive photon mapping (`variant`) with `config` (checked).
    pub fn new(
        config: ProgressiveConfig,
        variant: Variant,
    ) -> Result<Self, crate::config::ConfigError> {
        let router = config.checked_router()?;
        Ok(Progressive {
            config,
            variant,
            router,
        })
    }

    fn name(&self) -> &'static str {
        match self.variant {
            Variant::Ppm => "Ppm",
            Variant::Sppm => "Sppm",
        }
    }

    /// Renders passes until `budget` is spent, calling `on_pass(passes_done, film)` after each
    /// and stopping early when it returns false.
    fn run(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let c = &self.config;
        let router = &self.router;
        let slots = 1 + router.layer_count();
        let mut schedule = Schedule::new(*budget, progress, 1);
        let (width, height) = (scene.camera.width, scene.camera.height);
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let walk = CameraWalk {
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
                tau: vec![[0.0; 3]; slots],
                direct: vec![[0.0; 3]; slots],
                passes: vec![PixelSums::default(); slots],
            };
            (width * height) as usize
        ];
        let mut counters = Counters::default();
        let mut photons_stored = 0u64;
        let mut global_radius_sq = r1 * r1;
        let mut films: Vec<Film> = (0..slots).map(|_| Film::new(width, height)).collect();
        let mut passes = 0;
        while schedule.next_pass(passes, 1).is_some() {
            let pass = passes;
            let photons = trace_photons(
                scene,
                seed,
                pass as u64 * c.photons_per_pass,
                c.photons_per_pass,
                tracing,
                &mut counters,
            )
            .photons;
            photons_stored += photons.len() as u64;
            // One radius for every query: the hash grid is faster (BENCHMARKS.md, "Photon maps").
            let map = match c.update {
                RadiusUpdate::Local => Index::Tree(PhotonMap::new(Traced::ungrouped(photons))),
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
                    let mut direct = Sink::new(router, (width, height), slots, 0);
                    let mut flux = Sink::new(router, (width, height), slots, 0);
                    for (x, px) in row.iter_mut().enumerate() {
                        let pixel = y as u64 * width as u64 + x as u64;
                        let mut sampler = Independent::new();
                        sampler.start_pixel_sample(seed, pixel, camera_index);
                        let mut lights = Independent::new();
                        lights.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, pass as u64);
                        let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                        direct.clear();
                        flux.clear();
                        let vp = camera::walk(
                            scene,
                            &walk,
                            film,
                            &mut sampler,
                            &mut lights,
                            &mut direct,
                            &mut counters,
                        );
                        let radius_sq = match c.update {
                            RadiusUpdate::Local => px.radius_sq,
                            RadiusUpdate::Global => global_radius_sq,
                        };
                        let m = match &vp {
                            Some(vp) => {
                                let (lo, hi) = vp.photon_bounces(c.min_bounces, max);
                                gather(&map, vp, radius_sq, c.kernel, (lo.max(2), hi), &mut flux)
                            }
                            None => 0,
                        };
                        if !flux.values[0].is_finite() {
                            counters.count_non_finite(Technique::Photon);
                            continue;
                        }
                        let norm = (INV_PI / radius_sq) as f64;
                        for k in 0..slots {
                            let (d, f) = (to_f64(direct.values[k]), to_f64(flux.values[k]));
                            px.passes[k].add([
                                d[0] + f[0] * norm,
                                d[1] + f[1] * norm,
                                d[2] + f[2] * norm,
                            ]);
                            for ch in 0..3 {
                                px.direct[k][ch] += d[ch];
                            }
                        }
                        match c.update {
                            RadiusUpdate::Global => {
                                for k in 0..slots {
                                    let f = to_f64(flux.values[k]);
                                    for ch in 0..3 {
                                        px.tau[k][ch] += f[ch] * norm;
                                    }
                                }
                            }
                            RadiusUpdate::Local if m > 0 => {
                                let (n, m) = (px.n, m as f64);
                                let n_new = n + c.alpha as f64 * m;
                                let shrink = n_new / (n + m);
                                for k in 0..slots {
                                    let f = to_f64(flux.values[k]);
                                    for ch in 0..3 {
                                        px.tau[k][ch] = (px.tau[k][ch] + f[ch]) * shrink;
                                    }
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
            for (k, film) in films.iter_mut().enumerate() {
                for (p, px) in film.pixels.iter_mut().zip(&state) {
                    let mut out = px.passes[k];
                    let photons = match c.update {
                        RadiusUpdate::Global => px.tau[k].map(|t| t / i as f64),
                        RadiusUpdate::Local => px.tau[k]
                            .map(|t| t / (i as f64 * std::f64::consts::PI * px.radius_sq as f64)),
                    };
                    for ch in 0..3 {
                        out.mean[ch] = px.direct[k][ch] / i as f64 + photons[ch];
                    }
                    *p = out;
                }
            }
            passes = i as u32;
            schedule.advance(1);
            if !on_pass(passes, &films[0]) {
                break;
            }
        }
        let film = films.remove(0);
        let mut stats = RenderStats::new(
            self.name(),
            &film,
            passes,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * passes as u64,
            &counters,
            &[Technique::Camera, Technique::Photon],
            PixelVariance::NotAnEstimate(
                "per-pass estimates at a shrinking radius are not identically distributed (and \
                 under Local radii not independent): measure the variance across trials"
                    .into(),
            ),
        );
        if self.variant == Variant::Ppm {
            stats.pixel_limit = PixelLimit::OneCameraPath;
        }
        stats.photons = c.photons_per_pass * passes as u64;
        stats.photons_stored = photons_stored;
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(router.layer_names(), films),
            stats,
        }
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
            Index::Tree(map) => {
                let mut visit = visit;
                map.within(p, radius_sq, |ph, _, d2| visit(ph, d2))
            }
            Index::Grid(grid) => grid.within(p, visit),
        }
    }
}

/// Adds β · K·f·Φ of every photon within the radius whose bounce count lies in `bounces` to
/// `flux`, by class, and returns how many there were.
fn gather(
    map: &Index,
    vp: &camera::VisiblePoint,
    radius_sq: f32,
    kernel: Kernel,
    bounces: (u32, u32),
    flux: &mut Sink,
) -> u32 {
    let mut m = 0u32;
    map.within(vp.gather.p, radius_sq, |ph, d2| {
        if (bounces.0..=bounces.1).contains(&ph.bounces()) {
            let c = super::map::contribution(&vp.gather, ph);
            if !c.is_black() {
                m += 1;
                flux.add(
                    &vp.class_with(&ph.class),
                    vp.beta * c * kernel.weight(d2 / radius_sq),
                );
            }
        }
    });
    m
}

impl Integrator for Progressive {
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

    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        super::config::check_radius("radius", self.config.radius, scene)
    }
}
