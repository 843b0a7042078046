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
//! Sample dimensions per light path: light choice (1), position (2), direction (2), then per surface
//! vertex: lens (2), BSDF lobe (1), BSDF direction (2), Russian roulette (1). Paths are keyed by
//! (seed, path index), and the driver adds splats in a fixed order, so the image is bit-identical
//! on any number of threads.

use crate::config::{ConfigError, Validate, check_common, default_rr};
use crate::passes::{PassSpec, Schedule, run_passes};
use crate::paths::{Layers, PathClass, Router};
use crate::render::{Counters, PixelVariance, named};
use crate::roulette::survives;
use crate::sink::Sink;
use crate::{Budget, Film, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{Progress, Rgb, TransportMode};
use lightlab_geometry::{spawn_ray, spawn_ray_to_point};
use lightlab_materials::SurfaceBsdf;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::{Light, Scene};
use serde::{Deserialize, Serialize};

/// Settings of the light tracer: `Light(max_bounces: 8)`; every field optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, rename = "Light")]
pub struct LightConfig {
    /// Largest number of scattering vertices (the vertex connected to the camera included); `None`
    /// for no limit. Default `None`.
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    pub min_bounces: u32,
    /// Russian roulette from this many scattering vertices on; `None` turns it off. Default `Some(3)`.
    pub russian_roulette: Option<u32>,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    pub layers: Layers,
}

impl Default for LightConfig {
    fn default() -> Self {
        LightConfig {
            max_bounces: None,
            min_bounces: 0,
            russian_roulette: default_rr(),
            paths: None,
            layers: Layers::Off,
        }
    }
}

impl Validate for LightConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_common(
            self.max_bounces,
            self.min_bounces,
            self.russian_roulette,
            self.paths.as_deref(),
            &self.layers,
        )
    }
}

/// Technique number for the non-finite counter.
const CONNECTION: usize = 0;

pub struct LightTracer {
    config: LightConfig,
    router: Router,
}

impl LightTracer {
    /// A light tracer with `config` (checked).
    pub fn new(config: LightConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let router = Router::new(config.paths.as_deref(), &config.layers, config.max_bounces)
            .map_err(ConfigError::Invalid)?;
        Ok(LightTracer { config, router })
    }

    /// Connects a vertex to the camera; `value_toward` gives what leaves the vertex toward the lens
    /// (f·β for surface vertices, Le for the emission point) given the direction to the lens.
    fn connect(
        &self,
        scene: &Scene,
        p: glam::Vec3,
        p_error: glam::Vec3,
        n: glam::Vec3,
        u_lens: Vec2,
        class: &PathClass,
        sink: &mut Sink,
        counters: &mut Counters,
        value_toward: impl FnOnce(glam::Vec3) -> (Rgb, f32),
    ) {
        let Some(layer) = self.router.route(class) else {
            return;
        };
        let Some(cs) = scene.camera.sample_wi(p, u_lens) else {
            return;
        };
        let (value, cos) = value_toward(cs.wi);
        if value.is_black() || !(cs.pdf_w > 0.0) {
            return;
        }
        counters.rays += 1;
        let ray = if p_error == glam::Vec3::ZERO && n == glam::Vec3::ZERO {
            lightlab_core::Ray::segment(p, cs.p_lens - p, 1.0 - 1e-4)
        } else {
            spawn_ray_to_point(p, p_error, n, cs.p_lens)
        };
        if scene.occluded(&ray) {
            return;
        }
        let c = value * (cos * cs.we / cs.pdf_w);
        if !c.is_finite() {
            counters.non_finite[CONNECTION] += 1;
            return;
        }
        let pixel = sink.pixel_at(cs.raster);
        sink.splat_routed(pixel, layer, c);
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
        let max_bounces = cfg.max_bounces.unwrap_or(u32::MAX);
        let mut sampler = Independent::new();
        sampler.start_pixel_sample(seed, index, 0);
        let (u_light, u_pos, u_dir) = (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
        let Some((light_index, pmf)) = scene.sample_light(u_light) else {
            return;
        };
        let light = &scene.lights[light_index as usize];
        let Some(em) = light.sample_le(scene.shapes(), scene.center, scene.radius, u_pos, u_dir)
        else {
            return;
        };

        // The emission point seen by the camera: L E (0 scattering vertices).
        if cfg.min_bounces == 0 {
            let u_lens = sampler.next_2d();
            match *light {
                Light::Area {
                    radiance,
                    two_sided,
                    ..
                } => self.connect(
                    scene,
                    em.p,
                    em.p_error,
                    em.n,
                    u_lens,
                    &PathClass::EMPTY,
                    sink,
                    counters,
                    |wi| {
                        (
                            Light::area_le(radiance, two_sided, em.n, wi) / (pmf * em.pdf_pos),
                            em.n.dot(wi).abs(),
                        )
                    },
                ),
                // Point and spot lights have no area, so no camera sees them (as in path tracing);
                // an emitter at infinity has no point to connect.
                Light::Point { .. } | Light::Spot { .. } | Light::Environment { .. } => {}
            }
        } else {
            sampler.next_2d();
        }

        let cos_emit = if em.delta_pos || matches!(light, Light::Environment { .. }) {
            1.0
        } else {
            em.n.dot(em.dir).abs()
        };
        let mut beta = em.le * (cos_emit / (pmf * em.pdf_pos * em.pdf_dir));
        let mut ray = if em.delta_pos || matches!(light, Light::Environment { .. }) {
            lightlab_core::Ray::new(em.p, em.dir)
        } else {
            spawn_ray(em.p, em.p_error, em.n, em.dir)
        };
        // Russian roulette scores the throughput relative to the emitted flux: β is in units of
        // power, which scale with the scene, so an absolute threshold would end every path of a
        // small scene (and let a large one's run long).
        let beta_start = beta.max_component();
        let mut depth = 0u32;
        // Scattering vertices so far, light first.
        let mut class = PathClass::EMPTY;
        loop {
            counters.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                break;
            };
            depth += 1;
            if depth > max_bounces {
                break;
            }
            let wo = -ray.d.normalize();
            let bsdf = scene.materials[hit.material as usize];
            let sb = SurfaceBsdf::new(hit.ns, hit.dpdu, hit.ng, bsdf);
            class = class.push(bsdf.lobe_class());
            let u_lens = sampler.next_2d();
            if !bsdf.is_delta() && depth >= cfg.min_bounces {
                self.connect(
                    scene,
                    hit.p,
                    hit.p_error,
                    hit.ng,
                    u_lens,
                    &class,
                    sink,
                    counters,
                    |wi| {
                        (
                            beta * sb.eval(wo, wi, TransportMode::Importance).f,
                            wi.dot(sb.frame.n).abs(),
                        )
                    },
                );
            }
            let (u_lobe, u_dir, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
            let Some(s) = sb.sample(wo, u_lobe, u_dir, TransportMode::Importance) else {
                break;
            };
            if s.weight.is_black() {
                break;
            }
            beta *= s.weight;
            let score = beta.max_component() / beta_start;
            if !survives(cfg.russian_roulette, depth, score, u_rr, &mut beta) {
                break;
            }
            ray = spawn_ray(hit.p, hit.p_error, hit.ng, s.wi);
        }
    }
}

impl Integrator for LightTracer {
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
        let spec = PassSpec {
            width,
            height,
            slots: 1 + self.router.layer_count(),
            splats: true,
            groups: 0,
            independent: true,
        };
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
            &["camera_connection"],
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
