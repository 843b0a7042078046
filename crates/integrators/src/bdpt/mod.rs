//! Bidirectional path tracing (Veach & Guibas 1994; Lafortune & Willems 1993; Veach 1997 ch. 10)
//! with every (s, t) strategy combined by multiple importance sampling (Veach 1997 ch. 9).
//!
//! Each pixel sample traces a camera subpath z₀…z_{t−1} and a light subpath y₀…y_{s−1} and forms
//! every full path y₀…y_{s−1} z_{t−1}…z₀ with s + t − 2 scattering vertices within the bounce
//! limits: s = 0 (the camera path hits an emitter), s = 1 (a point sampled on a light, next-event
//! estimation), t = 1 (a light vertex connected to a point on the lens and splatted into the pixel it
//! lands on, as in light tracing — for s = 1 the light's own point, an emitter seen directly) and
//! s, t ≥ 2 (a deterministic connection of the two subpaths). An emitter seen directly (s + t = 2)
//! thus has two strategies, the camera ray hitting it (s = 0) and its point splatted through the lens
//! (s = 1): the second is what renders an emitter smaller than a pixel's footprint.
//!
//! MIS: the balance heuristic, computed by Veach's walk over ratios of the area-measure densities
//! with which neighbouring strategies would have produced the same path (Veach 1997 §10.2;
//! pbrt-v4 §16.3.4): each vertex stores `pdf_fwd` (density of its generation along its own subpath)
//! and `pdf_rev` (density of its generation from the other side), and the weight of (s, t) is
//! 1 / Σᵢ (pᵢ / p_s). Strategies that cannot produce a path (a delta vertex at a connection) are left
//! out of the sum. At a specular vertex the two directions' densities are the lobe's selection
//! probability times η²|cos θ| (`delta_densities`: the Dirac delta written in the throughput
//! measure, which refraction preserves, cancels from the ratios), unlike pbrt's
//! zero-then-remap-to-one, which loses the cos/d² conversions beside specular chains and the
//! solid-angle compression of a refraction.
//!
//! Research views: `strategy_layers` writes every strategy as a layer, weighted and unweighted;
//! `outliers` logs large contributions with their provenance, and [`Bdpt::replay`] recomputes any
//! pixel sample from (seed, pixel, sample index). Russian roulette decides how long subpaths are, not the densities in the weights,
//! so the weights of all strategies of a path still sum to one.
//!
//! Sample dimensions per pixel sample: pixel (2), lens (2), then the camera subpath (per vertex:
//! lobe 1, direction 2, roulette 1), then the light subpath (light 1, position 2, direction 2, per
//! vertex lobe 1, direction 2, roulette 1) and the connection samples (per camera vertex: light 1,
//! light point 2, lens 2). Light subpath values come from a second stream keyed by the pixel sample,
//! so the camera dimensions keep the layout stratified samplers expect.

mod connect;
mod mis;
mod provenance;
mod subpaths;
#[cfg(test)]
pub(crate) mod tests;

pub use connect::Contribution;
pub(crate) use connect::{connection, joined_class};
#[cfg(test)]
pub(crate) use mis::PathDensities;
pub(crate) use mis::{Reverse, reverse_densities, used_vertices};
pub(crate) use subpaths::{camera_subpath, light_subpath};

use crate::config::{ConfigError, Validate, check_replicates, invalid, settings};
use crate::film::Film;
use crate::passes::{PassSpec, RenderArgs, SampledRender, Schedule, render_sampled, run_passes};
use crate::paths::Router;
use crate::provenance::Outlier;
use crate::provenance::SplatSource;
use crate::render::{Counters, Technique};
use crate::walk::{Directions, PathVertex, Walk};
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use lightlab_core::{Progress, TransportMode};
use lightlab_samplers::{Independent, Sampler, SamplerConfig};
use lightlab_scene::Scene;
use serde::{Deserialize, Serialize};

settings! {
    /// Settings of bidirectional path tracing: `Bdpt(max_bounces: 8, mis: Balance)`; every field
    /// optional.
    BdptConfig as "Bdpt" {
        /// Sampler of the camera subpaths (the light subpaths use independent samples). Default
        /// `Independent`.
        sampler: SamplerConfig = SamplerConfig::Independent,
        /// Split each pixel's sample passes into this many independent replicates of the sampler
        /// (camera and light subpaths alike), so that the spread of the replicate means gives the
        /// variance of the pixel mean for any sampler (randomised quasi-Monte Carlo;
        /// `lightlab_samplers::replicate_sample`). Sample counts must be multiples of it. 1 (no
        /// replicates) to 4096. Default 1, which is left out when the settings are written (so
        /// that settings without it keep their text, and experiments their run ids and seeds).
        #[serde(skip_serializing_if = "crate::config::is_one")]
        replicates: u32 = 1,
        /// Strategy weights: `Balance`, `Power`, `Uniform` or `Only(s: S, t: T)`. Default `Balance`.
        mis: Mis = Mis::Balance,
        /// Also write every strategy (s, t) as layers `s{s}t{t}` (MIS-weighted; they sum to the image)
        /// and `s{s}t{t}.unweighted` (the strategy's own estimate of its paths). Needs `max_bounces`.
        /// Default false.
        strategy_layers: bool = false,
        /// Log every contribution larger (in its largest channel) than this multiple of its pixel's
        /// mean, with its provenance (pixel, sample index, strategy, path class, densities, MIS
        /// weight), for replay with `lightlab replay`. Non-finite contributions are always logged.
        /// Default `None` (only non-finite ones).
        outliers: Option<f32> = None,
    }
}

impl Validate for BdptConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.check_common()?;
        check_replicates(self.replicates)?;
        if let Mis::Only { s, t } = self.mis
            && t == 0
        {
            return invalid(format!(
                "Only(s: {s}, t: 0) is not a strategy: paths must reach the camera, so t ≥ 1"
            ));
        }
        if let Some(f) = self.outliers
            && !(f > 1.0 && f.is_finite())
        {
            return invalid(format!(
                "outliers is a multiple of the pixel's mean and must be finite and > 1, got {f}"
            ));
        }
        check_strategy_layers(
            self.strategy_layers,
            self.max_bounces,
            ("strategy", "strategies"),
        )
    }
}

/// The most bounces `strategy_layers` writes a layer pair for every strategy of.
const MAX_STRATEGY_LAYER_BOUNCES: u32 = 16;

/// `strategy_layers` (BDPT's strategies, VCM's techniques: `what`, singular and plural) needs
/// `max_bounces`, at most
/// [`MAX_STRATEGY_LAYER_BOUNCES`]: each strategy is a weighted and an unweighted full-image layer,
/// (m + 2)(m + 3)/2 − 1 strategies for BDPT, so 200 bounces made 40 000 layers, which ran out of
/// memory or took minutes to write.
pub(crate) fn check_strategy_layers(
    on: bool,
    max_bounces: Option<u32>,
    (what, whats): (&str, &str),
) -> Result<(), ConfigError> {
    match (on, max_bounces) {
        (true, None) => invalid(format!(
            "strategy_layers needs max_bounces (it bounds the number of {whats})"
        )),
        (true, Some(m)) if m > MAX_STRATEGY_LAYER_BOUNCES => invalid(format!(
            "strategy_layers allows max_bounces up to {MAX_STRATEGY_LAYER_BOUNCES} (each {what} \
             is a weighted and an unweighted full-image layer), got {m}"
        )),
        _ => Ok(()),
    }
}

/// How bidirectional path tracing weights its strategies (Veach 1997, ch. 9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mis {
    /// wᵢ = pᵢ / Σⱼ pⱼ (Veach's balance heuristic).
    #[default]
    Balance,
    /// wᵢ = pᵢ² / Σⱼ pⱼ² (the power heuristic with β = 2).
    Power,
    /// wᵢ = 1 / (number of strategies that can produce the path): unweighted averaging.
    Uniform,
    /// No MIS: only strategy (s, t), with weight 1 — the paths of s + t − 2 bounces that this one
    /// strategy samples, for looking at one technique alone.
    Only {
        /// Light subpath vertices of the strategy.
        s: u32,
        /// Camera subpath vertices of the strategy.
        t: u32,
    },
}

impl Mis {
    /// Whether strategy (s, t) is left out entirely.
    pub fn excludes(&self, s: usize, t: usize) -> bool {
        matches!(*self, Mis::Only { s: os, t: ot } if (os as usize, ot as usize) != (s, t))
    }
}

/// Bidirectional path tracing (Veach & Guibas 1994; Veach 1997, ch. 10), built from checked
/// [`BdptConfig`] settings.
pub struct Bdpt {
    config: BdptConfig,
    router: Router,
    /// With `strategy_layers`: every strategy (s, t), in layer order.
    strategies: Vec<(usize, usize)>,
}

impl Bdpt {
    /// BDPT with `config` (checked).
    pub fn new(config: BdptConfig) -> Result<Self, ConfigError> {
        let router = config.checked_router()?;
        let strategies = match (config.strategy_layers, config.max_bounces) {
            (true, Some(max)) => (2..=max as usize + 2)
                .flat_map(|n| (0..n).map(move |s| (s, n - s)))
                .filter(|&st| st.1 >= 1)
                .collect(),
            _ => Vec::new(),
        };
        Ok(Bdpt {
            config,
            router,
            strategies,
        })
    }

    /// Slot of the weighted layer of strategy (s, t) (the unweighted one follows it), counted from
    /// the first strategy layer.
    fn strategy_slot(&self, s: usize, t: usize) -> Option<usize> {
        self.strategies
            .iter()
            .position(|&x| x == (s, t))
            .map(|i| 2 * i)
    }

    /// The walk settings of a subpath of at most `max_depth` scattering vertices.
    fn walk(&self, mode: TransportMode, max_depth: u32) -> Walk {
        Walk {
            mode,
            max_depth,
            roulette: self.config.roulette(),
            directions: Directions::Bsdf,
        }
    }
}

/// Seed offset of the light subpaths' random-number stream.
const LIGHT_STREAM: u64 = 0x6c69_6768_7470_6174;

impl Integrator for Bdpt {
    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        render_sampled(self, scene, budget, seed, progress, on_pass)
    }

    fn sampler(&self) -> Option<&SamplerConfig> {
        Some(&self.config.sampler)
    }

    fn replicates(&self) -> u32 {
        self.config.replicates
    }

    fn memory_bytes(&self, scene: &Scene) -> u64 {
        self.pass_spec(scene).bytes()
    }

    /// `Only(s: 0, …)` keeps the camera subpaths that hit a light, which no point, spot or
    /// directional light can be: with only such lights the image would be black.
    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        match self.config.mis {
            Mis::Only { s: 0, t } if scene.lights.iter().all(|l| l.is_delta()) => Err(format!(
                "mis: Only(s: 0, t: {t}) keeps only camera paths that hit a light, and the scene's \
                 lights are all point, spot or directional lights, which no ray hits: choose a \
                 strategy with s ≥ 1"
            )),
            _ => Ok(()),
        }
    }
}

impl Bdpt {
    /// The images the driver keeps, splatted into: per pixel the full image, the class or bounce
    /// layers, then two per strategy.
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        let image = PassSpec::layers(scene, &self.router);
        PassSpec {
            slots: image.slots + 2 * self.strategies.len(),
            splats: true,
            independent: self.config.sampler.independent(),
            replicates: self.config.replicates,
            ..image
        }
    }
}

/// What one work item keeps besides its contributions: the subpath buffers it reuses, and the
/// outliers and splat provenance it logged.
#[derive(Default)]
struct WorkItem {
    camera: Vec<PathVertex>,
    light: Vec<PathVertex>,
    outliers: Vec<Outlier>,
    /// Where each splat of the full image came from (only with `outliers`).
    splat_sources: Vec<SplatSource>,
}

impl SampledRender for Bdpt {
    fn render_with<S: Sampler + Clone + Send + Sync + 'static>(
        &self,
        prototype: S,
        args: RenderArgs,
    ) -> RenderOutput {
        let bdpt = self;
        let RenderArgs {
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = args;
        let cfg = &bdpt.config;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let router = &bdpt.router;
        let first_strategy = 1 + router.layer_count();
        let spec = bdpt.pass_spec(scene);
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        let out = run_passes(
            &spec,
            router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, item: &mut WorkItem| {
                let mut sampler = prototype.clone();
                let mut light_sampler = Independent::new();
                // Non-finite counts of this sample (the sample holds `counters`).
                let mut non_finite = Counters::default();
                let running = sink.running_mean();
                let WorkItem {
                    camera,
                    light,
                    outliers,
                    splat_sources,
                } = item;
                bdpt.pixel_sample(
                    scene,
                    seed,
                    (x, y),
                    index,
                    &mut sampler,
                    &mut light_sampler,
                    (camera, light),
                    counters,
                    |c, light, camera| {
                        let value = c.unweighted * c.weight;
                        let finite = value.is_finite();
                        if !finite {
                            non_finite.count_non_finite(if c.raster.is_some() {
                                Technique::CameraConnection
                            } else {
                                Technique::Connection
                            });
                        }
                        // Camera-side contributions are compared with their pixel's mean over
                        // the passes before this one; splats (t = 1), which land in other
                        // pixels, with their pixel's final mean after the render (see
                        // `splat_outliers`).
                        let outlier = match cfg.outliers {
                            Some(factor) if c.raster.is_none() => {
                                Outlier::exceeds(value, running, factor)
                            }
                            _ => false,
                        };
                        if !finite || outlier {
                            outliers.push(Outlier::new((x, y), index, c, running.0, light, camera));
                        }
                        if !finite {
                            return;
                        }
                        let strategy = bdpt
                            .strategy_slot(c.s, c.t)
                            .filter(|_| c.unweighted.is_finite());
                        match c.raster {
                            Some(r) => {
                                let pixel = sink.pixel_at(r);
                                sink.splat_routed(pixel, c.layer, value);
                                if let Some(k) = strategy {
                                    sink.splat_slot(pixel, first_strategy + k, value);
                                    sink.splat_slot(pixel, first_strategy + k + 1, c.unweighted);
                                }
                                if cfg.outliers.is_some() {
                                    splat_sources.push(SplatSource {
                                        target: pixel,
                                        value,
                                        pixel: (x, y),
                                        sample: index,
                                        s: c.s as u16,
                                        t: c.t as u16,
                                    });
                                }
                            }
                            None => {
                                sink.add_routed(c.layer, value);
                                if let Some(k) = strategy {
                                    sink.add_slot(first_strategy + k, value);
                                    sink.add_slot(first_strategy + k + 1, c.unweighted);
                                }
                            }
                        }
                    },
                );
                counters.merge(&non_finite);
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let pixels = width as u64 * height as u64;
        let mut stats = RenderStats::new(
            "Bdpt",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            pixels * out.spp as u64,
            &out.counters,
            &[Technique::Connection, Technique::CameraConnection],
            spec.pixel_variance(&cfg.sampler, "camera subpaths"),
        );
        let mut outliers: Vec<Outlier> = out
            .extras
            .iter()
            .flat_map(|r| r.outliers.iter().cloned())
            .collect();
        if let Some(factor) = cfg.outliers {
            outliers.extend(bdpt.splat_outliers(scene, seed, out.spp, &out.extras, &film, factor));
        }
        let mut per_strategy: std::collections::BTreeMap<(u32, u32), u64> = Default::default();
        for o in &outliers {
            *per_strategy.entry((o.s, o.t)).or_default() += 1;
        }
        stats.outliers = per_strategy
            .into_iter()
            .map(|((s, t), n)| (format!("s{s}t{t}"), n))
            .collect();
        let names = router.layer_names().into_iter().chain(
            bdpt.strategies
                .iter()
                .flat_map(|(s, t)| [format!("s{s}t{t}"), format!("s{s}t{t}.unweighted")]),
        );
        RenderOutput {
            film,
            layers: names.zip(films).collect(),
            outliers,
            stats,
        }
    }
}
