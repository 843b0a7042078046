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
//! the photons per pass). M counts the photons the visible point can use: on a surface facing the
//! same way and arriving where its BSDF is not zero (as Hachisuka's own smallppm tests the
//! normals; pbrt-v4 counts every photon in the disk). Photons that cannot contribute then do not
//! shrink the radius; both rules are consistent, and they differ in the radius a pixel reaches. The photons a pass brings fall with the disk's area, M_i ≈ λπr_i², and
//! then r_i² ∝ i^(α−1) (were M constant, the rate would be i^((α−1)/α) instead). That is the rate
//! of the schedule `Global` applies to every pixel exactly, r²_{i+1} = r²_i (i + α)/(i + 1)
//! (Knaus & Zwicker 2011, eq. 19), with the image the mean of the independent per-pass estimates.
//! The constants differ: `Local` shrinks by α at the first pass already (N = 0), and its r²
//! settles at about α times `Global`'s from the same r₁ (0.667–0.679 in a simulation with
//! 5–500 photons per disk expected at r₁ and α = 2/3), so the two compare at equal radii with
//! `Global`'s r₁ smaller by √α. For `Global` Knaus and Zwicker predict MSE ∝ i^(−α)
//! asymptotically where variance dominates, and the best rate, i^(−2/3), at α = 2/3.
//!
//! What it converges to. `Sppm` converges to the pixel's measurement (the radiance integrated over
//! the pixel's box filter and the lens). `Ppm` keeps one camera path per pixel, so it converges to
//! the radiance along that path — a point sample of the pixel, not its box-filtered value — and
//! against a reference of the pixel integral the difference at edges and texture never vanishes.
//!
//! The film's per-pixel mean is the progressive estimate Eᵢ, kept by the shared pass driver as the
//! running mean of the increments vᵢ = i·Eᵢ − (i − 1)·Eᵢ₋₁ (under `Global`, vᵢ is the pass's own
//! estimate: its direct light plus its photons at the pass's radius), and its "variance" is their
//! spread over n. It is not the variance of the pixel mean: the passes are not identically
//! distributed (the radius shrinks, so variance grows and bias falls
//! pass by pass), and under `Local` they are not independent (each radius depends on the photons
//! before). Experiments measure SPPM's variance across independent trials instead.

use super::camera::{self, CameraWalk};
use super::config::{ProgressiveConfig, RadiusUpdate};
use super::grid::HashGrid;
use super::map::{Kernel, PhotonMap};
use super::trace::{
    Keep, Photon, PhotonTracing, Traced, stored_per_path, trace_photons, tracing_bytes,
};
use crate::film::Film;
use crate::passes::{PassSpec, Schedule, run_progressive_passes};
use crate::paths::Router;
use crate::render::{Counters, PixelLimit, PixelVariance, Technique, named};
use crate::shutter::pass_time;
use crate::sink::Sink;
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use lightlab_core::{INV_PI, Progress, Rgb};
use lightlab_scene::Scene;
use std::sync::{Mutex, RwLock};

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
#[derive(Clone)]
struct PixelState {
    radius_sq: f32,
    /// Accumulated photon count N (fractional under `Local`).
    n: f64,
    /// Accumulated flux τ (`Local`) or sum of per-pass photon estimates (`Global`).
    tau: Vec<[f64; 3]>,
    /// Sum of per-pass camera-side estimates (emission, direct light).
    direct: Vec<[f64; 3]>,
    /// The estimate after the previous pass, Eᵢ₋₁.
    estimate: Vec<[f64; 3]>,
}

/// What every pixel of a pass shares: the pass's photons and the `Global` radius.
struct Pass {
    map: Option<Index>,
    global_radius_sq: f32,
    /// The pass's instant, shared by its photons and visible points.
    time: f32,
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

    /// The images the driver keeps: the full image and the router's layers.
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        PassSpec {
            independent: false,
            ..PassSpec::layers(scene, &self.router)
        }
    }

    /// How a pass's photons are traced: every non-specular vertex kept.
    fn tracing(&self) -> PhotonTracing {
        PhotonTracing {
            max_bounces: self.config.max_bounces.unwrap_or(u32::MAX),
            roulette: self.config.roulette(),
            keep: Keep::All,
        }
    }

    fn name(&self) -> &'static str {
        match self.variant {
            Variant::Ppm => "Ppm",
            Variant::Sppm => "Sppm",
        }
    }

    /// Renders passes until `budget` is spent, calling `on_pass(passes_done, film)` after each
    /// and stopping early when it returns false. Each pass traces its photons (the driver's
    /// `begin`), then every pixel its camera path and gather. The film holds, per pixel, the mean
    /// of the increments vᵢ = i·Eᵢ − (i − 1)·Eᵢ₋₁ of the progressive estimate Eᵢ, which is Eᵢ
    /// itself; under `Global` vᵢ is the pass's own estimate (Knaus & Zwicker's mean of passes).
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
        let (width, height) = (scene.camera.width, scene.camera.height);
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let walk = CameraWalk {
            max_bounces: max,
            min_bounces: c.min_bounces,
            roulette: c.roulette(),
            trace_glossy: c.trace_glossy,
            direct: true,
        };
        let tracing = self.tracing();
        let r1 = c.radius.resolve(scene.radius);
        let pixels: Vec<Mutex<PixelState>> = (0..width as usize * height as usize)
            .map(|_| {
                Mutex::new(PixelState {
                    radius_sq: r1 * r1,
                    n: 0.0,
                    tau: vec![[0.0; 3]; slots],
                    direct: vec![[0.0; 3]; slots],
                    estimate: vec![[0.0; 3]; slots],
                })
            })
            .collect();
        let pass = RwLock::new(Pass {
            map: None,
            global_radius_sq: r1 * r1,
            time: 0.0,
        });
        let mut photons_stored = 0u64;
        let spec = self.pass_spec(scene);
        let mut begin = |i: u32, counters: &mut Counters| {
            let mut pass = pass.write().expect("no pass panicked");
            if i > 0 {
                let i = i as f32;
                pass.global_radius_sq *= (i + c.alpha) / (i + 1.0);
            }
            // One instant per pass for its photons and visible points (`shutter`).
            pass.time = pass_time(&scene.camera, seed, i as u64);
            let photons = trace_photons(
                scene,
                seed,
                (i as u64 * c.photons_per_pass, c.photons_per_pass),
                pass.time,
                tracing,
                counters,
            )
            .photons;
            photons_stored += photons.len() as u64;
            // One radius for every query: the hash grid is faster (BENCHMARKS.md, "Photon maps").
            pass.map = Some(match c.update {
                RadiusUpdate::Local => Index::Tree(PhotonMap::new(Traced::ungrouped(photons))),
                RadiusUpdate::Global => {
                    Index::Grid(HashGrid::new(&photons, pass.global_radius_sq.sqrt()))
                }
            });
        };
        let out = run_progressive_passes(
            &spec,
            router,
            &mut schedule,
            on_pass,
            &mut begin,
            |x, y, index, sink, counters, _: &mut ()| {
                let pass = pass.read().expect("no pass panicked");
                let Some(map) = &pass.map else { return };
                let pixel = y as u64 * width as u64 + x as u64;
                let mut px = pixels[pixel as usize].lock().expect("no pixel panicked");
                let camera_index = match self.variant {
                    Variant::Ppm => 0,
                    Variant::Sppm => index,
                };
                let (vp, _) = camera::trace_pixel(
                    scene,
                    &walk,
                    (seed, pass.time),
                    (x, y, width),
                    camera_index,
                    index,
                    sink,
                    counters,
                );
                // The camera side's estimate joins the pixel's sum; the sink then gathers flux.
                for (sum, &d) in px.direct.iter_mut().zip(&sink.values) {
                    let d = to_f64(d);
                    for ch in 0..3 {
                        sum[ch] += d[ch];
                    }
                }
                sink.clear();
                let radius_sq = match c.update {
                    RadiusUpdate::Local => px.radius_sq,
                    RadiusUpdate::Global => pass.global_radius_sq,
                };
                let mut m = match &vp {
                    Some(vp) => {
                        let (lo, hi) = vp.photon_bounces(c.min_bounces, max);
                        gather(map, vp, radius_sq, c.kernel, (lo.max(2), hi), sink)
                    }
                    None => 0,
                };
                if !sink.values[0].is_finite() {
                    counters.count_non_finite(Technique::Photon);
                    sink.clear();
                    m = 0;
                }
                let flux = |k: usize| to_f64(sink.values[k]);
                let norm = (INV_PI / radius_sq) as f64;
                match c.update {
                    RadiusUpdate::Global => {
                        for k in 0..slots {
                            for ch in 0..3 {
                                px.tau[k][ch] += flux(k)[ch] * norm;
                            }
                        }
                    }
                    RadiusUpdate::Local if m > 0 => {
                        let (n, m) = (px.n, m as f64);
                        let n_new = n + c.alpha as f64 * m;
                        let shrink = n_new / (n + m);
                        for k in 0..slots {
                            for ch in 0..3 {
                                px.tau[k][ch] = (px.tau[k][ch] + flux(k)[ch]) * shrink;
                            }
                        }
                        px.n = n_new;
                        px.radius_sq = (px.radius_sq as f64 * shrink) as f32;
                    }
                    RadiusUpdate::Local => {}
                }
                // Eᵢ and the increment i·Eᵢ − (i − 1)·Eᵢ₋₁ whose running mean the film keeps.
                let i = index as f64 + 1.0;
                let photon_scale = match c.update {
                    RadiusUpdate::Global => 1.0 / i,
                    RadiusUpdate::Local => 1.0 / (i * std::f64::consts::PI * px.radius_sq as f64),
                };
                for k in 0..slots {
                    let e = [0, 1, 2].map(|ch| px.direct[k][ch] / i + px.tau[k][ch] * photon_scale);
                    let v = [0, 1, 2].map(|ch| i * e[ch] - (i - 1.0) * px.estimate[k][ch]);
                    px.estimate[k] = e;
                    sink.values[k] = Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32);
                }
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let passes = out.spp;
        let mut stats = RenderStats::new(
            self.name(),
            &film,
            passes,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * passes as u64,
            &out.counters,
            &[Technique::Camera, Technique::Photon],
            PixelVariance::NotAnEstimate(
                "the spread of per-pass increments at a shrinking radius, which are not \
                 identically distributed (and under Local radii not independent): measure the \
                 variance across trials"
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
    /// The images, each pixel's progressive state (radius, photon count and three sums per
    /// slot), and a pass's photons traced while the last pass's map is still held, their count
    /// estimated from a pilot.
    fn memory_bytes(&self, scene: &Scene) -> u64 {
        let spec = self.pass_spec(scene);
        let state = size_of::<Mutex<PixelState>>() + 3 * spec.slots * size_of::<[f64; 3]>();
        let pixels = spec.width as u64 * spec.height as u64;
        let photons = self.config.photons_per_pass as f64
            * stored_per_path(scene, scene.camera.shutter.0, self.tracing());
        let maps = PhotonMap::bytes_for(photons) + tracing_bytes(photons);
        spec.bytes()
            .saturating_add(pixels.saturating_mul(state as u64))
            .saturating_add(maps as u64)
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

    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        super::config::check_radius("radius", self.config.radius, scene)
    }
}
