//! Unidirectional path tracing (Kajiya 1986) with next-event estimation, combined with BSDF sampling
//! by multiple importance sampling (Veach 1997, §9.2; pbrt-v4 §13.4).
//!
//! The estimator of a pixel is a sum over path lengths k (scattering vertices) of
//! L_e · Π f·|cos|/p along a path of k vertices, where each length-k term is estimated twice — by
//! sampling the last direction from the BSDF and by sampling a point on a light — and the two are
//! weighted by the power heuristic. `min_bounces`/`max_bounces` keep only terms with k in that range.
//!
//! Sample dimensions per pixel sample (the layout stratified samplers rely on): 0–1 pixel position,
//! 2–3 lens, then per scattering vertex 7 values: light choice (1), point on the light (2), and the
//! walk's BSDF lobe (1), BSDF direction (2), Russian roulette (1) — consumed whether or not they
//! are used (see `walk`).

use crate::config::{ConfigError, Validate, check_replicates, invalid, settings};
use crate::nee::{Competition, emission_found, environment_found, sample_direct};
use crate::passes::{PassSpec, RenderArgs, SampledRender, Schedule, render_sampled, run_passes};
use crate::paths::Router;
use crate::render::{Counters, Technique, named};
use crate::sink::Sink;
use crate::walk::{Arrival, Directions, PathVertex, Visitor, Walk, from_camera};
use crate::{Budget, Film, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{Progress, Ray, Rgb, TransportMode};
use lightlab_samplers::{Sampler, SamplerConfig, replicate_sample};
use lightlab_scene::Scene;
use serde::{Deserialize, Serialize};

settings! {
    /// Settings of the path tracer: `Path(max_bounces: 8, strategy: Mis)`; every field optional.
    PathConfig as "Path" {
        /// How directions are chosen at each vertex. Default `Mis`.
        strategy: Strategy = Strategy::Mis,
        /// Test visibility for next-event estimation. `false` computes direct illumination without
        /// shadows (only with `Mis` or `LightOnly`, which sample lights). Default true.
        shadows: bool = true,
        /// Where the sample values come from: `Independent`, `Stratified`, `LatinHypercube`, `Halton`
        /// or `Sobol` (see `lightlab_samplers::SamplerConfig`). Default `Independent`.
        sampler: SamplerConfig = SamplerConfig::Independent,
        /// Split each pixel's samples into this many independent replicates of the sampler (each
        /// its own scramble or stratification), so that the spread of the replicate means gives
        /// the variance of the pixel mean for any sampler (randomised quasi-Monte Carlo;
        /// `lightlab_samplers::replicate_sample`). Sample counts must be multiples of it. 1 (no
        /// replicates) to 4096. Default 1, which is left out when the settings are written (so
        /// that settings without it keep their text, and experiments their run ids and seeds).
        #[serde(skip_serializing_if = "crate::config::is_one")]
        replicates: u32 = 1,
    }
}

impl Validate for PathConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.check_common()?;
        check_replicates(self.replicates)?;
        if !self.shadows && matches!(self.strategy, Strategy::BsdfOnly | Strategy::Uniform) {
            return invalid(format!(
                "shadows: false switches off the visibility test of next-event estimation, which \
                 strategy {:?} does not do (no light sampling); use it with Mis or LightOnly",
                self.strategy
            ));
        }
        Ok(())
    }
}

/// Sampling strategy of the path tracer, for comparing blind and informed Monte Carlo.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Strategy {
    /// Light sampling and BSDF sampling combined by the power heuristic (Veach 1997, §9.2).
    #[default]
    Mis,
    /// BSDF sampling only: emitters count when a sampled ray hits them.
    BsdfOnly,
    /// Light sampling only: emitters hit by BSDF-sampled rays count only after the camera or a
    /// specular vertex, where light sampling is impossible.
    LightOnly,
    /// Blind Monte Carlo: uniform directions on the hemisphere of the outgoing direction (the whole
    /// sphere for transmissive rough surfaces), no light sampling; specular vertices are sampled
    /// by their BSDF.
    Uniform,
}

/// Path tracing with next-event estimation (Kajiya 1986; Veach 1997 §9.2 for the weights), built
/// from checked [`PathConfig`] settings.
pub struct PathTracer {
    config: PathConfig,
    router: Router,
}

impl PathTracer {
    /// A path tracer with `config` (checked).
    pub fn new(config: PathConfig) -> Result<Self, ConfigError> {
        let router = config.checked_router()?;
        Ok(PathTracer { config, router })
    }

    /// The images the driver keeps: the full image and the router's layers.
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        PassSpec {
            independent: self.config.sampler.independent(),
            replicates: self.config.replicates,
            ..PassSpec::layers(scene, &self.router)
        }
    }

    /// Whether next-event estimation is done at non-specular vertices.
    fn samples_lights(&self) -> bool {
        matches!(self.config.strategy, Strategy::Mis | Strategy::LightOnly)
    }

    /// How emission found by BSDF sampling competes with next-event estimation.
    fn competition(&self) -> Competition {
        match (self.config.strategy, self.config.shadows) {
            (Strategy::BsdfOnly | Strategy::Uniform, _) => Competition::None,
            (Strategy::LightOnly, _) | (Strategy::Mis, false) => Competition::LightsOnly,
            (Strategy::Mis, true) => Competition::Power,
        }
    }

    /// One camera path through raster position `film`: adds its radiance estimate to `sink`, by
    /// path class.
    fn li<S: Sampler>(
        &self,
        scene: &Scene,
        film: Vec2,
        sampler: &mut S,
        sink: &mut Sink,
        counters: &mut Counters,
    ) {
        let cfg = &self.config;
        let max_bounces = cfg.max_bounces.unwrap_or(u32::MAX);
        let walk = Walk {
            mode: TransportMode::Radiance,
            // The vertex after the last bounce is visited for its emission.
            max_depth: max_bounces.saturating_add(1),
            roulette: cfg.roulette(),
            directions: if cfg.strategy == Strategy::Uniform {
                Directions::Uniform
            } else {
                Directions::Bsdf
            },
        };
        let mut visitor = CameraPath {
            tracer: self,
            scene,
            max_bounces,
            sink,
        };
        let time = scene.camera.sample_time(sampler);
        from_camera(scene, &walk, film, time, sampler, &mut visitor, counters);
    }
}

/// The path tracer's estimator along one camera walk.
struct CameraPath<'a, 'r, 's> {
    tracer: &'a PathTracer,
    scene: &'a Scene,
    max_bounces: u32,
    sink: &'s mut Sink<'r>,
}

impl Visitor for CameraPath<'_, '_, '_> {
    #[inline]
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        arrival: &Arrival,
        sampler: &mut S,
        counters: &mut Counters,
    ) -> bool {
        let (tracer, scene) = (self.tracer, self.scene);
        let cfg = &tracer.config;
        // Emission: a path of the vertices before this one.
        if arrival.class.len() >= cfg.min_bounces {
            let c = emission_found(scene, v, arrival, tracer.competition());
            if !c.is_black() {
                self.sink
                    .add_eye_or_count(&arrival.class, c, Technique::Emission, counters);
            }
        }
        if v.depth > self.max_bounces {
            return false;
        }
        // Next-event estimation: a path through this vertex ending on a light.
        let (u_light, u_light_point) = (sampler.next_1d(), sampler.next_2d());
        if tracer.samples_lights()
            && !v.delta
            && v.depth >= cfg.min_bounces
            && let Some(sb) = &v.sb
            && let Some(d) = sample_direct(
                scene,
                v,
                sb,
                v.wo,
                u_light,
                u_light_point,
                cfg.shadows,
                counters,
            )
        {
            let w = tracer.competition().direct_weight(&d);
            self.sink.add_eye_or_count(
                &v.class,
                v.beta * d.value * w,
                Technique::NextEvent,
                counters,
            );
        }
        true
    }

    #[inline]
    fn escaped(&mut self, ray: &Ray, beta: Rgb, arrival: &Arrival, counters: &mut Counters) {
        if arrival.class.len() >= self.tracer.config.min_bounces {
            let d = ray.d.normalize();
            let c = environment_found(self.scene, beta, d, arrival, self.tracer.competition());
            if !c.is_black() {
                self.sink
                    .add_eye_or_count(&arrival.class, c, Technique::Emission, counters);
            }
        }
    }
}

impl Integrator for PathTracer {
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

    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        if !self.samples_lights() && scene.lights.iter().any(|l| l.is_delta()) {
            return Err(format!(
                "strategy {:?} never samples lights, so it cannot see the scene's point, spot and \
                 directional lights (no ray hits a delta light): use Mis or LightOnly, or remove those lights",
                self.config.strategy
            ));
        }
        Ok(())
    }

    fn scene_warnings(&self, scene: &Scene) -> Vec<String> {
        let delta_lights = scene.lights.iter().filter(|l| l.is_delta()).count();
        let specular = scene
            .materials
            .iter()
            .any(|m| m.bsdf.is_delta() || m.bsdf.mixes_delta());
        if self.samples_lights() && delta_lights > 0 && specular {
            vec![format!(
                "path tracing reaches the scene's {delta_lights} point, spot or directional \
                 light(s) only by next-event estimation, which cannot pass its specular surfaces \
                 (mirrors, smooth glass, plastic's coating): paths L S+ … from those lights (their \
                 caustics, their images in mirrors) are missing from the image; Light, Bdpt, Vcm \
                 and the photon methods render them"
            )]
        } else {
            Vec::new()
        }
    }
}

impl SampledRender for PathTracer {
    fn render_with<S: Sampler + Clone + Send + Sync + 'static>(
        &self,
        prototype: S,
        args: RenderArgs,
    ) -> RenderOutput {
        let tracer = self;
        let RenderArgs {
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = args;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let spec = tracer.pass_spec(scene);
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        let out = run_passes(
            &spec,
            &tracer.router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, _: &mut ()| {
                let mut sampler = prototype.clone();
                let pixel = y as u64 * width as u64 + x as u64;
                let (seed, index) = replicate_sample(seed, index, tracer.config.replicates);
                sampler.start_pixel_sample(seed, pixel, index);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                tracer.li(scene, film, &mut sampler, sink, counters);
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let stats = RenderStats::new(
            "Path",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * out.spp as u64,
            &out.counters,
            &[Technique::Emission, Technique::NextEvent],
            spec.pixel_variance(&tracer.config.sampler, "samples"),
        );
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(tracer.router.layer_names(), films),
            stats,
        }
    }
}
