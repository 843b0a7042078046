//! Light tracing (particle tracing; Arvo & Kirk 1990, Dutré et al. 1993; Veach 1997 §10.2, the
//! t = 1 strategies of bidirectional path tracing): paths start on the lights, and every vertex that
//! can scatter toward the camera — the emission point itself and each non-specular surface vertex —
//! is connected to the lens and splatted into the pixel that connection lands on.
//!
//! Estimator. N = spp × P light paths (P the pixel count); a connection from vertex x with
//! throughput β adds c = β · f(x, wo → camera) · |cos θ_x| · We / pdf_w to its pixel (pdf_w: the
//! camera's density of the direction, see `Camera::sample_wi`), and pixel j's estimate is
//! (P / N) Σ c, which is what the camera's normalisation of We over the whole film asks for.
//! Sample index i of the render is the P light paths iP … iP + P − 1: its sample of pixel j is
//! Y_ij = Σ c over every connection of those paths that lands in j, so the estimate is the mean
//! of Y_ij over i, and the Y_ij of different i are independent and identically distributed — the
//! film's s²/n is the variance of the pixel mean, with every path's splats into a pixel summed
//! before squaring (see `passes`).
//!
//! What it cannot see: paths whose last scattering vertex before the eye is specular (`…SE`, a
//! mirror or glass seen directly), and emitters at infinity seen directly. Those terms are missing
//! from its image by construction; experiments show it as bias against a path-traced reference.
//!
//! Sample dimensions per light path: light choice (1), position (2), direction (2), the emission
//! point's lens sample (2), then per surface vertex: lens (2) and the walk's BSDF lobe (1), BSDF
//! direction (2), Russian roulette (1). Paths are keyed by
//! (seed, path index), and the driver adds splats in a fixed order, so the image is bit-identical
//! on any number of threads.

use crate::config::{ConfigError, Validate, settings};
use crate::passes::{PassSpec, Schedule, run_passes};
use crate::paths::Router;
use crate::render::{Counters, PixelVariance, Technique, named};
use crate::sink::Sink;
use crate::walk::{Arrival, Directions, PathVertex, Visitor, Walk, connect_to_lens, from_light};
use crate::{Budget, Film, Integrator, RenderOutput, RenderStats};
use glam::{Vec2, Vec3};
use lightlab_core::{Progress, Rgb, TransportMode};
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;

settings! {
    /// Settings of the light tracer: `Light(max_bounces: 8)`; every field optional.
    LightConfig as "Light" {}
}

impl Validate for LightConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.check_common()
    }
}

/// Light tracing (Arvo & Kirk 1990; Veach 1997 §10.2's t = 1 strategy alone), built from checked
/// [`LightConfig`] settings.
pub struct LightTracer {
    config: LightConfig,
    router: Router,
}

impl LightTracer {
    /// A light tracer with `config` (checked).
    pub fn new(config: LightConfig) -> Result<Self, ConfigError> {
        let router = config.checked_router()?;
        Ok(LightTracer { config, router })
    }

    /// Traces light path `index` and records its camera connections.
    fn trace(
        &self,
        scene: &Scene,
        seed: u64,
        index: u64,
        sink: &mut Sink,
        counters: &mut Counters,
    ) {
        let cfg = &self.config;
        let mut sampler = Independent::new();
        sampler.start_pixel_sample(seed, index, 0);
        let walk = Walk {
            mode: TransportMode::Importance,
            max_depth: cfg.max_bounces.unwrap_or(u32::MAX),
            roulette: cfg.roulette(),
            directions: Directions::Bsdf,
        };
        let mut visitor = LightPath {
            scene,
            router: &self.router,
            min_bounces: cfg.min_bounces,
            sink,
        };
        let time = scene.camera.sample_time(&mut sampler);
        from_light(scene, &walk, time, &mut sampler, &mut visitor, counters);
    }
}

/// Connects light-path vertex `v` to the lens and splats what arrives, routed by `v`'s class;
/// `value` as [`connect_to_lens`] takes it.
fn connect(
    scene: &Scene,
    router: &Router,
    v: &PathVertex,
    u_lens: Vec2,
    sink: &mut Sink,
    counters: &mut Counters,
    value: impl FnOnce(&PathVertex, Vec3) -> Rgb,
) {
    let Some(layer) = router.route(&v.class) else {
        return;
    };
    let Some(c) = connect_to_lens(scene, v, u_lens, counters, value) else {
        return;
    };
    if !c.contribution.is_finite() {
        counters.count_non_finite(Technique::CameraConnection);
        return;
    }
    let pixel = sink.pixel_at(c.raster);
    sink.splat_routed(pixel, layer, c.contribution);
}

/// The light tracer's estimator along one light walk: every non-specular vertex is connected to
/// the lens.
struct LightPath<'a, 'r, 's> {
    scene: &'a Scene,
    router: &'a Router,
    min_bounces: u32,
    sink: &'s mut Sink<'r>,
}

impl Visitor for LightPath<'_, '_, '_> {
    /// The emission point seen by the camera: L E (0 scattering vertices). Point and spot lights
    /// have no area, so no camera sees them (as in path tracing); an emitter at infinity has no
    /// point to connect.
    #[inline]
    fn origin<S: Sampler>(
        &mut self,
        origin: &PathVertex,
        sampler: &mut S,
        counters: &mut Counters,
    ) {
        let u_lens = sampler.next_2d();
        if self.min_bounces == 0 && origin.on_surface() {
            let scene = self.scene;
            connect(
                scene,
                self.router,
                origin,
                u_lens,
                self.sink,
                counters,
                |_, wi| origin.le_toward(scene, wi) / origin.pdf_fwd,
            );
        }
    }

    #[inline]
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        _: &Arrival,
        sampler: &mut S,
        counters: &mut Counters,
    ) -> bool {
        let u_lens = sampler.next_2d();
        if !v.delta
            && v.depth >= self.min_bounces
            && let Some(sb) = &v.sb
        {
            connect(
                self.scene,
                self.router,
                v,
                u_lens,
                self.sink,
                counters,
                |_, wi| v.beta * sb.eval(v.wo, wi, TransportMode::Importance).f,
            );
        }
        true
    }
}

impl LightTracer {
    /// The images the driver keeps: the full image and the router's layers, splatted into.
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        PassSpec {
            splats: true,
            ..PassSpec::layers(scene, &self.router)
        }
    }
}

impl Integrator for LightTracer {
    fn memory_bytes(&self, scene: &Scene) -> u64 {
        self.pass_spec(scene).bytes()
    }

    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let pixels = width as u64 * height as u64;
        let spec = self.pass_spec(scene);
        let mut schedule = Schedule::new(*budget, progress, pixels);
        // The "pixel sample" (x, y, i) is light path iP + (y·width + x): the driver only uses it
        // to lay out the work.
        let out = run_passes(
            &spec,
            &self.router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, _: &mut ()| {
                let path = index * pixels + y as u64 * width as u64 + x as u64;
                self.trace(scene, seed, path, sink, counters);
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let stats = RenderStats::new(
            "Light",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            pixels * out.spp as u64,
            &out.counters,
            &[Technique::CameraConnection],
            PixelVariance::Independent,
        );
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(self.router.layer_names(), films),
            stats,
        }
    }
}
