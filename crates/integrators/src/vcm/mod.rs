//! Vertex connection and merging (VCM; Georgiev, Křivánek, Davidovič & Slusallek 2012, "Light
//! transport simulation with vertex connection and merging"; the same estimator as Hachisuka,
//! Pantaleoni & Jensen 2012, "A path space extension for robust light transport simulation"):
//! bidirectional path tracing's connections and photon mapping's density estimates ("merges")
//! combined by one multiple importance sampling.
//!
//! Each pass (Georgiev et al., Alg. 1) traces one light subpath per pixel and stores it once
//! (`pass`): its vertices are the connection vertices of that pixel's camera path and, the
//! non-delta surface ones, the photons every camera path of the pass merges with. Then each pixel
//! traces a camera subpath and forms every connection (s, t) with its light subpath as BDPT does
//! (`bdpt::connection`: s = 0 emission found, s = 1 next-event estimation, t = 1 the light vertex
//! splatted through the lens, s, t ≥ 2 a shadow ray), and at every non-delta camera vertex
//! merges with the light vertices of all light paths within the pass's radius (`merge`). The MIS
//! weights come from two numbers per subpath vertex, computed recursively along each subpath
//! (`mis`; Georgiev 2012, the technical report's dVCM/dVC), so each technique costs O(1).
//!
//! Radius schedule: pass i (1-based) merges within r_i = r₁·i^((α−1)/2) (Georgiev et al.,
//! eq. 15, after Knaus & Zwicker 2011): the merges' bias falls as r_i² ∝ i^(α−1) while their
//! variance grows as i^(1−α), and the image is the mean of the passes' estimates. α = 1 keeps the
//! radius (a biased, not consistent, estimator); SmallVCM's default is α = 0.75. Connections are
//! unbiased at any radius, and where they carry a path well the weights hand it to them: MSE
//! falls as O(1/N) for what connections render and more slowly for what only merges can (Georgiev
//! et al., §5: `L S+ D S+ E`, caustics seen in mirrors).
//!
//! Variants: `Vcm` (everything), `Vc` (connections only: BDPT with its balance or power
//! heuristic, one light path per camera path — the same image as `Bdpt` in expectation) and
//! `Bpm` (merges only, with camera paths that hit lights: bidirectional photon mapping, Vorba
//! 2011), the techniques left out simply missing from the weights.
//!
//! Sample dimensions per pass and pixel: the camera subpath from the camera sampler (pixel 2,
//! lens 2, per vertex lobe 1, direction 2, roulette 1), the connection samples from a second
//! stream (per camera vertex: light 1, light point 2, lens 2), and light path p from a stream
//! keyed by (p, pass) alone.

mod merge;
mod mis;
mod pass;
mod provenance;
#[cfg(test)]
mod tests;

pub use mis::Heuristic;

use crate::bdpt::{
    Reverse, camera_subpath, connection, joined_class, reverse_densities, used_vertices,
};
use crate::config::{ConfigError, Validate, check_replicates, invalid, settings};
use crate::film::Film;
use crate::passes::{
    PassSpec, RenderArgs, SampledRender, Schedule, render_sampled, run_progressive_passes,
};
use crate::paths::Router;
use crate::photon::config::{Length, check_radius};
use crate::provenance::{Logged, Outlier, SplatSource};
use crate::render::{Counters, PixelVariance, Technique};
use crate::shutter::pass_time;
use crate::walk::{Directions, PathVertex, Walk};
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{Progress, TransportMode};
use lightlab_samplers::{Independent, Sampler, SamplerConfig, replicate_sample};
use lightlab_scene::Scene;
use mis::{Quantities, Techniques};
use pass::LightPass;
use serde::{Deserialize, Serialize};
use std::sync::RwLock;

settings! {
    /// Settings of vertex connection and merging: `Vcm(radius: Relative(0.005), alpha: 0.75)`;
    /// every field optional. The budget's samples per pixel are passes, each one light subpath
    /// and one camera subpath per pixel.
    VcmConfig as "Vcm" {
        /// Sampler of the camera subpaths (light subpaths and connections use independent
        /// samples). Default `Independent`.
        sampler: SamplerConfig = SamplerConfig::Independent,
        /// With `variant: Vc`: split each pixel's passes into this many independent replicates
        /// (the camera sampler and the passes' shutter instants randomised anew in each), so that
        /// the spread of the replicate means gives the variance of the pixel mean for any sampler
        /// (`lightlab_samplers::replicate_sample`). Sample counts must be multiples of it. 1 (no
        /// replicates) to 4096. Default 1, which is left out when the settings are written.
        #[serde(skip_serializing_if = "crate::config::is_one")]
        replicates: u32 = 1,
        /// Techniques: `Vcm` (connections and merges), `Vc` (connections only, i.e. BDPT) or `Bpm`
        /// (merges only, bidirectional photon mapping). Default `Vcm`.
        variant: Variant = Variant::Vcm,
        /// Technique weights: `Balance` or `Power`. Default `Balance`.
        mis: Heuristic = Heuristic::Balance,
        /// Merge radius r₁ of the first pass. Default `Relative(0.005)` (0.5 % of the scene's
        /// bounding radius).
        radius: Length = Length::Relative(0.005),
        /// Radius schedule exponent: pass i merges within r₁·i^((α−1)/2), 0 < α ≤ 1 (1 keeps the
        /// radius). Default 0.75.
        alpha: f32 = 0.75,
        /// Light subpaths per pixel and pass, ℓ ≥ 1: every one is splatted through the lens
        /// (light tracing, t = 1) and merged with, one per pixel is connected to its camera
        /// subpath; the weights count light tracing ℓ times and merges ℓ·pixels times. Default 1
        /// (Georgiev et al.).
        light_paths: u32 = 1,
        /// Also write every technique as layers — connections `s{s}t{t}`, merges at the t-th
        /// camera vertex `m{t}` — MIS-weighted (they sum to the image) and `.unweighted` (the
        /// technique's own estimate of its paths). Needs `max_bounces`. Default false.
        strategy_layers: bool = false,
        /// Log every contribution larger (in its largest channel) than this multiple of its
        /// pixel's mean, with its provenance (pixel, pass, technique, path class, densities, MIS
        /// weight), for replay with `lightlab replay`. Non-finite contributions are always logged.
        /// Default `None` (only non-finite ones).
        outliers: Option<f32> = None,
    }
}

/// Which of VCM's techniques are combined.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Variant {
    /// Vertex connection and merging (Georgiev et al. 2012).
    #[default]
    Vcm,
    /// Vertex connection only: bidirectional path tracing.
    Vc,
    /// Vertex merging only (and camera paths hitting lights): bidirectional photon mapping
    /// (Vorba 2011).
    Bpm,
}

impl Validate for VcmConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.check_common()?;
        check_replicates(self.replicates)?;
        if self.replicates > 1 && self.variant != Variant::Vc {
            return invalid(format!(
                "replicates need variant: Vc: merging shrinks its radius pass after pass, so \
                 neither the passes of {:?} nor replicates of them are identically distributed \
                 (measure its variance across trials)",
                self.variant
            ));
        }
        self.radius.check("radius").map_err(ConfigError::Invalid)?;
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return invalid(format!(
                "alpha must lie in (0, 1] (the radius after i passes is r₁·i^((α−1)/2)), got {}",
                self.alpha
            ));
        }
        if !(1..=1024).contains(&self.light_paths) {
            return invalid(format!(
                "light_paths (light subpaths per pixel and pass) must be between 1 and 1024, got {}",
                self.light_paths
            ));
        }
        if let Some(f) = self.outliers
            && !(f > 1.0 && f.is_finite())
        {
            return invalid(format!(
                "outliers is a multiple of the pixel's mean and must be finite and > 1, got {f}"
            ));
        }
        crate::bdpt::check_strategy_layers(
            self.strategy_layers,
            self.max_bounces,
            ("technique", "techniques"),
        )
    }
}

/// One technique's pair of layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layer {
    /// Connection (s, t).
    Connect(usize, usize),
    /// Merge at the t-th camera vertex.
    Merge(usize),
}

/// Vertex connection and merging, built from checked [`VcmConfig`] settings.
pub struct Vcm {
    config: VcmConfig,
    router: Router,
    /// With `strategy_layers`: every technique, in layer order.
    layers: Vec<Layer>,
}

impl Vcm {
    /// VCM with `config` (checked).
    pub fn new(config: VcmConfig) -> Result<Self, ConfigError> {
        let router = config.checked_router()?;
        let (connect, merge) = Self::techniques_of(config.variant);
        let layers = match (config.strategy_layers, config.max_bounces) {
            (true, Some(max)) => {
                let max = max as usize;
                let connections = (2..=max + 2)
                    .flat_map(|n| (0..n).map(move |s| (s, n - s)))
                    .filter(|&(s, t)| t >= 1 && (connect || s == 0))
                    .map(|(s, t)| Layer::Connect(s, t));
                let merges = (2..=max + 1).filter(|_| merge).map(Layer::Merge);
                connections.chain(merges).collect()
            }
            _ => Vec::new(),
        };
        Ok(Vcm {
            config,
            router,
            layers,
        })
    }

    /// Whether `variant` connects (s ≥ 1) and merges.
    fn techniques_of(variant: Variant) -> (bool, bool) {
        match variant {
            Variant::Vcm => (true, true),
            Variant::Vc => (true, false),
            Variant::Bpm => (false, true),
        }
    }

    /// The techniques of a pass whose merges use radius `radius` with `paths` light paths.
    fn techniques(&self, radius: f32, paths: usize) -> Techniques {
        let (connect, merge) = Self::techniques_of(self.config.variant);
        let mis = self.config.mis;
        let eta = std::f64::consts::PI * (radius as f64).powi(2) * paths as f64;
        Techniques {
            connect,
            merge,
            heuristic: mis,
            eta: if merge { mis.of(eta) } else { 0.0 },
            light_tracing: mis.of(self.config.light_paths as f64),
        }
    }

    /// The merge radius of 0-based pass `pass`: r₁·(pass + 1)^((α−1)/2).
    fn radius(&self, scene: &Scene, pass: u32) -> f32 {
        let r1 = self.config.radius.resolve(scene.radius) as f64;
        let exponent = (self.config.alpha as f64 - 1.0) / 2.0;
        (r1 * (pass as f64 + 1.0).powf(exponent)) as f32
    }

    fn walk(&self, mode: TransportMode, max_depth: u32) -> Walk {
        Walk {
            mode,
            max_depth,
            roulette: self.config.roulette(),
            directions: Directions::Bsdf,
        }
    }

    /// Slot of the weighted layer of `layer` (the unweighted one follows), counted from the first
    /// technique layer.
    fn layer_slot(&self, layer: Layer) -> Option<usize> {
        self.layers.iter().position(|&l| l == layer).map(|i| 2 * i)
    }
}

impl Integrator for Vcm {
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

    /// The images, and a pass's light subpaths: at least their first vertex, on the light, with
    /// its MIS quantities and its index.
    fn memory_bytes(&self, scene: &Scene) -> u64 {
        let paths =
            scene.camera.width as u64 * scene.camera.height as u64 * self.config.light_paths as u64;
        let per_path = size_of::<PathVertex>() + size_of::<Quantities>() + size_of::<u32>();
        self.pass_spec(scene)
            .bytes()
            .saturating_add(paths.saturating_mul(per_path as u64))
    }

    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        if self.config.variant == Variant::Vc {
            return Ok(());
        }
        check_radius("radius", self.config.radius, scene)
    }
}

/// Seed offset of the connection samples' stream.
const CONNECT_STREAM: u64 = 0x7663_6d5f_636f_6e6e;

/// What every pixel of a pass shares.
struct Pass {
    light: LightPass,
    /// The pass's instant, shared by its light and camera subpaths (`shutter`).
    time: f32,
    techniques: Techniques,
    /// 1 / (π r² N), the merges' density-estimation normalisation.
    merge_scale: f32,
}

/// What one work item keeps: the camera subpath buffers it reuses, and the outliers and splat
/// provenance it logged.
#[derive(Default)]
struct WorkItem {
    camera: Vec<PathVertex>,
    quantities: Vec<Quantities>,
    outliers: Vec<Outlier>,
    /// Where each splat of the full image came from (only with `outliers`).
    splat_sources: Vec<SplatSource>,
}

impl SampledRender for Vcm {
    fn render_with<S: Sampler + Clone + Send + Sync + 'static>(
        &self,
        prototype: S,
        args: RenderArgs,
    ) -> RenderOutput {
        let vcm = self;
        let RenderArgs {
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = args;
        let cfg = &vcm.config;
        let router = &vcm.router;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let pixels = width as usize * height as usize;
        let first_layer = 1 + router.layer_count();
        let spec = vcm.pass_spec(scene);
        let mut schedule = Schedule::new(*budget, progress, pixels as u64);
        let state: RwLock<Option<Pass>> = RwLock::new(None);
        let (mut light_paths, mut stored) = (0u64, 0u64);
        let mut begin = |i: u32, counters: &mut Counters| {
            let pass = vcm.pass(scene, seed, i, counters);
            light_paths += (pixels * cfg.light_paths as usize) as u64;
            stored += pass.light.mergeable() as u64;
            *state.write().expect("no pass panicked") = Some(pass);
        };
        let out = run_progressive_passes(
            &spec,
            router,
            &mut schedule,
            on_pass,
            &mut begin,
            |x, y, index, sink, counters, item: &mut WorkItem| {
                let pass = state.read().expect("no pass panicked");
                let Some(pass) = pass.as_ref() else { return };
                let mut non_finite = Counters::default();
                let running = sink.running_mean();
                let WorkItem {
                    camera,
                    quantities,
                    outliers,
                    splat_sources,
                } = item;
                vcm.pixel_sample(
                    scene,
                    seed,
                    (x, y),
                    index,
                    prototype.clone(),
                    pass,
                    (camera, quantities),
                    counters,
                    |technique, layer, c, light, camera| {
                        let value = c.unweighted * c.weight;
                        let finite = value.is_finite();
                        if !finite {
                            non_finite.count_non_finite(match (c.merge, c.raster) {
                                (true, _) => Technique::Merge,
                                (_, Some(_)) => Technique::CameraConnection,
                                _ => Technique::Connection,
                            });
                        }
                        // Camera-side contributions are compared with their pixel's mean over
                        // the passes before this one; splats, which land in other pixels, with
                        // their pixel's final mean after the render.
                        let outlier = match cfg.outliers {
                            Some(factor) if c.raster.is_none() => {
                                Outlier::exceeds(value, running, factor)
                            }
                            _ => false,
                        };
                        if !finite || outlier {
                            outliers.push(Outlier::logged(
                                (x, y),
                                index,
                                c,
                                running.0,
                                light.iter().chain(camera.iter().rev()),
                            ));
                        }
                        if !finite {
                            return;
                        }
                        let slot = vcm
                            .layer_slot(technique)
                            .filter(|_| c.unweighted.is_finite())
                            .map(|k| first_layer + k);
                        match c.raster {
                            Some(r) => {
                                let pixel = sink.pixel_at(r);
                                sink.splat_routed(pixel, layer, value);
                                if let Some(k) = slot {
                                    sink.splat_slot(pixel, k, value);
                                    sink.splat_slot(pixel, k + 1, c.unweighted);
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
                                sink.add_routed(layer, value);
                                if let Some(k) = slot {
                                    sink.add_slot(k, value);
                                    sink.add_slot(k + 1, c.unweighted);
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
        let passes = out.spp;
        let name = match cfg.variant {
            Variant::Vcm => "Vcm",
            Variant::Vc => "Vcm(Vc)",
            Variant::Bpm => "Vcm(Bpm)",
        };
        let mut stats = RenderStats::new(
            name,
            &film,
            passes,
            seed,
            schedule.elapsed(),
            pixels as u64 * passes as u64,
            &out.counters,
            &[
                Technique::Connection,
                Technique::CameraConnection,
                Technique::Merge,
            ],
            if spec.replicates > 1 {
                spec.pixel_variance(&cfg.sampler, "camera subpaths")
            } else if spec.independent && scene.motion_blur() {
                // Each pass's one instant is a stratum of the shutter (`shutter`).
                crate::shutter::instants_variance()
            } else if spec.independent {
                PixelVariance::Independent
            } else if cfg.variant == Variant::Vc {
                PixelVariance::NotAnEstimate(cfg.sampler.correlation_note("camera subpaths"))
            } else {
                PixelVariance::NotAnEstimate(
                    "the spread of per-pass estimates at a shrinking merge radius, which are not \
                     identically distributed: measure the variance across trials"
                        .into(),
                )
            },
        );
        stats.photons = light_paths;
        stats.photons_stored = stored;
        let names = router
            .layer_names()
            .into_iter()
            .chain(vcm.layers.iter().flat_map(|l| {
                let name = match *l {
                    Layer::Connect(s, t) => format!("s{s}t{t}"),
                    Layer::Merge(t) => format!("m{t}"),
                };
                [name.clone(), format!("{name}.unweighted")]
            }));
        let mut outliers: Vec<Outlier> = out
            .extras
            .iter()
            .flat_map(|r| r.outliers.iter().cloned())
            .collect();
        if let Some(factor) = cfg.outliers {
            let sources = out.extras.iter().flat_map(|r| r.splat_sources.iter());
            outliers.extend(vcm.splat_outliers(scene, seed, passes, sources, &film, factor));
        }
        stats.outliers = provenance::count_by_technique(&outliers);
        RenderOutput {
            film,
            layers: names.zip(films).collect(),
            outliers,
            stats,
        }
    }
}

impl Vcm {
    /// The images the driver keeps: per pixel the full image, the class or bounce layers, then
    /// two per technique layer; splatted into when light subpaths connect to the camera.
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        let cfg = &self.config;
        let image = PassSpec::layers(scene, &self.router);
        PassSpec {
            slots: image.slots + 2 * self.layers.len(),
            splats: Vcm::techniques_of(cfg.variant).0,
            independent: cfg.variant == Variant::Vc && cfg.sampler.independent(),
            replicates: cfg.replicates,
            ..image
        }
    }

    /// The light side of 0-based pass `i`: its light subpaths, their index and the techniques'
    /// weights at its radius.
    fn pass(&self, scene: &Scene, seed: u64, i: u32, counters: &mut Counters) -> Pass {
        let paths = scene.camera.width as usize
            * scene.camera.height as usize
            * self.config.light_paths as usize;
        let max = self.config.max_bounces.unwrap_or(u32::MAX - 2);
        let radius = self.radius(scene, i);
        let techniques = self.techniques(radius, paths);
        // In replicates, each its own scramble of the instants (so that replicates are i.i.d.).
        let (time_seed, time_index) = replicate_sample(seed, i as u64, self.config.replicates);
        let time = pass_time(&scene.camera, time_seed, time_index);
        let light = LightPass::trace(
            scene,
            &self.walk(TransportMode::Importance, max),
            &techniques,
            (seed, i),
            time,
            paths,
            radius,
            counters,
        );
        let merge_scale =
            (1.0 / (std::f64::consts::PI * (radius as f64).powi(2) * paths as f64)) as f32;
        Pass {
            light,
            time,
            techniques,
            merge_scale,
        }
    }

    /// Traces pixel sample (pass) `index` of `pixel` against the light side of `pass` (in the
    /// reused buffers `camera`) and calls `visit(technique, layer, contribution, light path,
    /// camera path)` for every technique that contributes, in a fixed order; the paths are the
    /// vertices the technique joined (a merge's camera path without the merged vertex). Rendering
    /// and [`Vcm::replay`] both go through here.
    #[allow(clippy::too_many_arguments)]
    fn pixel_sample<S: Sampler>(
        &self,
        scene: &Scene,
        seed: u64,
        (x, y): (u32, u32),
        index: u64,
        mut sampler: S,
        pass: &Pass,
        (camera, quantities): (&mut Vec<PathVertex>, &mut Vec<Quantities>),
        counters: &mut Counters,
        mut visit: impl FnMut(Layer, usize, &Logged, &[PathVertex], &[PathVertex]),
    ) {
        let cfg = &self.config;
        let max = cfg.max_bounces.unwrap_or(u32::MAX - 2);
        let bounces = (cfg.min_bounces, max);
        let techniques = &pass.techniques;
        let pixel = y as usize * scene.camera.width as usize + x as usize;
        let (seed, index) = replicate_sample(seed, index, cfg.replicates);
        sampler.start_pixel_sample(seed, pixel as u64, index);
        let mut connect = Independent::new();
        connect.start_pixel_sample(seed ^ CONNECT_STREAM, pixel as u64, index);
        let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
        camera.clear();
        quantities.clear();
        let camera_walk = self.walk(TransportMode::Radiance, max.saturating_add(1));
        camera_subpath(
            scene,
            &camera_walk,
            film,
            pass.time,
            &mut sampler,
            camera,
            counters,
        );
        techniques.subpath(camera, false, false, quantities);
        let (light, light_q) = pass.light.path(pixel);
        let pixels = scene.camera.width as usize * scene.camera.height as usize;
        let splat_scale = 1.0 / cfg.light_paths as f32;
        for t in 1..=camera.len() {
            let (u_light, u_point, u_lens) =
                (connect.next_1d(), connect.next_2d(), connect.next_2d());
            for s in 0..=light.len() {
                let depth = (s + t) as i64 - 2;
                if depth < bounces.0 as i64 || depth > bounces.1 as i64 {
                    continue;
                }
                if s > 0 && !techniques.connect {
                    break;
                }
                let Some((layer, logged)) = self.connect(
                    scene,
                    techniques,
                    (light, light_q),
                    (camera, quantities),
                    (s, t),
                    (u_light, u_point, u_lens),
                    splat_scale,
                    counters,
                ) else {
                    continue;
                };
                visit(
                    Layer::Connect(s, t),
                    layer,
                    &logged,
                    &light[..s.min(light.len())],
                    &camera[..t],
                );
            }
            if t >= 2 && techniques.merges_at(&camera[t - 1]) {
                merge::merge(
                    &pass.light,
                    techniques,
                    camera,
                    t,
                    quantities[t - 1],
                    pass.merge_scale,
                    bounces,
                    |m| {
                        let class = m.light.class.then(camera[t - 1].arrival_class().reversed());
                        if let Some(layer) = self.router.route(&class) {
                            let logged = Logged {
                                s: m.light_path.len(),
                                t,
                                merge: true,
                                class,
                                unweighted: m.unweighted,
                                weight: m.weight,
                                raster: None,
                            };
                            visit(
                                Layer::Merge(t),
                                layer,
                                &logged,
                                m.light_path,
                                &camera[..t - 1],
                            );
                        }
                    },
                );
            }
        }
        // The pixel's other light paths are splatted through the lens too (light tracing, t = 1).
        for copy in (1..cfg.light_paths as usize).filter(|_| techniques.connect) {
            let (light, light_q) = pass.light.path(copy * pixels + pixel);
            let u_lens = connect.next_2d();
            for s in 1..=light.len() {
                // A path of s − 1 scattering vertices.
                if s < bounces.0 as usize + 1 || s > bounces.1 as usize + 1 {
                    continue;
                }
                let Some((layer, logged)) = self.connect(
                    scene,
                    techniques,
                    (light, light_q),
                    (camera, quantities),
                    (s, 1),
                    (0.0, Vec2::ZERO, u_lens),
                    splat_scale,
                    counters,
                ) else {
                    continue;
                };
                visit(Layer::Connect(s, 1), layer, &logged, light, &camera[..1]);
            }
        }
    }

    /// Connection (s, t) of `light` and `camera` with the samples `u` (light, light point, lens),
    /// as its layer and what is logged of it (light tracing's estimate scaled by `splat_scale`,
    /// 1/ℓ); `None` when it is routed nowhere or carries no light.
    #[allow(clippy::too_many_arguments)]
    fn connect(
        &self,
        scene: &Scene,
        techniques: &Techniques,
        (light, light_q): (&[PathVertex], &[Quantities]),
        (camera, camera_q): (&[PathVertex], &[Quantities]),
        (s, t): (usize, usize),
        (u_light, u_point, u_lens): (f32, Vec2, Vec2),
        splat_scale: f32,
        counters: &mut Counters,
    ) -> Option<(usize, Logged)> {
        let class = joined_class(light, camera, s, t);
        let layer = self.router.route(&class)?;
        let c = connection(
            scene, light, camera, s, t, u_light, u_point, u_lens, counters,
        )?;
        let weight = Self::connection_weight(
            scene,
            techniques,
            (light, light_q),
            (camera, camera_q),
            c.sampled,
            s,
            t,
        );
        let logged = Logged {
            s,
            t,
            merge: false,
            class,
            // Light tracing averages the pixel's ℓ light paths.
            unweighted: if t == 1 {
                c.unweighted * splat_scale
            } else {
                c.unweighted
            },
            weight,
            raster: c.raster,
        };
        Some((layer, logged))
    }

    /// The MIS weight of connection (s, t), `sampled` the endpoint the strategy sampled anew.
    fn connection_weight(
        scene: &Scene,
        techniques: &Techniques,
        (light, light_q): (&[PathVertex], &[Quantities]),
        (camera, camera_q): (&[PathVertex], &[Quantities]),
        sampled: Option<PathVertex>,
        s: usize,
        t: usize,
    ) -> f32 {
        let delta_light = |v: &PathVertex| {
            v.light()
                .is_some_and(|l| scene.lights[l as usize].is_delta())
        };
        let (light_used, camera_used) = used_vertices(light, camera, &sampled, s, t);
        let rev: Reverse = reverse_densities(scene, light_used, camera_used, s, t);
        let light_end = (s > 0).then(|| {
            let v = &light_used[s - 1];
            let q = if s == 1 && t > 1 {
                techniques.sampled_light(v, delta_light(v))
            } else {
                light_q[s - 1]
            };
            (q, techniques.merges_at(v))
        });
        let camera_end = (t > 1).then(|| {
            (
                camera_q[t - 1],
                s > 0 && techniques.merges_at(&camera[t - 1]),
            )
        });
        techniques.connection(light_end, camera_end, &rev)
    }
}
