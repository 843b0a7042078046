//! Light tracing (particle tracing; Arvo & Kirk 1990, Dutré et al. 1993; Veach 1997 §10.2, the
//! t = 1 strategies of bidirectional path tracing): paths start on the lights, and every vertex that
//! can scatter toward the camera — the emission point itself and each non-specular surface vertex —
//! is connected to the lens and splatted into the pixel that connection lands on.
//!
//! Estimator. N = spp × pixels light paths; a connection from vertex x with throughput β adds
//! c = β · f(x, wo → camera) · |cos θ_x| · We / pdf_w to its pixel (pdf_w: the camera's density of
//! the direction, see `Camera::sample_wi`), and pixel j's estimate is (P / N) Σ c with P the pixel
//! count, which is what the camera's normalisation of We over the whole film asks for. The per-pixel
//! variance treats each light path as one sample of every pixel (zero where it lands nowhere); two
//! splats of one path into the same pixel are counted as if from different paths, a slight
//! overestimate of the variance.
//!
//! What it cannot see: paths whose last scattering vertex before the eye is specular (`…SE`, a
//! mirror or glass seen directly), and emitters at infinity seen directly. Those terms are missing
//! from its image by construction; experiments show it as bias against a path-traced reference.
//!
//! Sample dimensions per light path: light choice (1), position (2), direction (2), then per surface
//! vertex: lens (2), BSDF lobe (1), BSDF direction (2), Russian roulette (1). Paths are keyed by
//! (seed, path index), processed in fixed chunks whose splats are added in chunk order, so the image
//! is bit-identical on any number of threads.

use crate::config::LightConfig;
use crate::film::{Film, PixelSums};
use crate::paths::{PathClass, Router};
use crate::render::{Counters, named};
use crate::roulette::survives;
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{Progress, Rgb, TransportMode};
use lightlab_geometry::{spawn_ray, spawn_ray_to_point};
use lightlab_materials::SurfaceBsdf;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::{Light, Scene};
use rayon::prelude::*;
use std::time::Instant;

/// Technique number for the non-finite counter.
const CONNECTION: usize = 0;
/// Light paths per work item: each chunk's splats are summed separately and added in chunk order.
const CHUNK: u64 = 4096;
/// Chunks run in parallel before their splats are added to the image (bounds the memory).
const CHUNKS_PER_BATCH: u64 = 64;

pub struct LightTracer {
    config: LightConfig,
    router: Router,
}

/// One contribution to pixel `pixel`, of layer `layer`.
struct Splat {
    pixel: u32,
    layer: u32,
    value: Rgb,
}

impl LightTracer {
    pub fn new(config: LightConfig) -> Self {
        let router = Router::new(config.paths.as_deref(), &config.layers, config.max_bounces)
            .expect("light settings are validated when parsed");
        LightTracer { config, router }
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
        splats: &mut Vec<Splat>,
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
        let (w, x, y) = (scene.camera.width, cs.raster.x as u32, cs.raster.y as u32);
        splats.push(Splat {
            pixel: y.min(scene.camera.height - 1) * w + x.min(w - 1),
            layer: layer as u32,
            value: c,
        });
    }

    /// Traces light path `index` and records its camera connections.
    fn trace(
        &self,
        scene: &Scene,
        seed: u64,
        index: u64,
        splats: &mut Vec<Splat>,
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
                    splats,
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
                    splats,
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
            let score = beta.max_component();
            if !survives(cfg.russian_roulette, depth, score, u_rr, &mut beta) {
                break;
            }
            ray = spawn_ray(hit.p, hit.p_error, hit.ng, s.wi);
        }
    }
}

impl Integrator for LightTracer {
    fn render(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
    ) -> RenderOutput {
        let start = Instant::now();
        let (width, height) = (scene.camera.width, scene.camera.height);
        let pixels = width as u64 * height as u64;
        let paths = pixels * budget.spp as u64;
        let chunks = paths.div_ceil(CHUNK);
        // Per pixel: the full image, then each layer.
        let slots = 1 + self.router.layer_count();
        let mut sum = vec![[0.0f64; 3]; pixels as usize * slots];
        let mut sum_sq = vec![[0.0f64; 3]; pixels as usize * slots];
        let mut counters = Counters::default();
        // Sample k of pixel j is P·c_k (zero where light path k does not land in j).
        let scale = pixels as f64;
        progress.start(paths);
        for batch in (0..chunks).step_by(CHUNKS_PER_BATCH as usize) {
            let results: Vec<(Vec<Splat>, Counters)> = (batch
                ..(batch + CHUNKS_PER_BATCH).min(chunks))
                .into_par_iter()
                .map(|chunk| {
                    let mut splats = Vec::new();
                    let mut c = Counters::default();
                    let end = ((chunk + 1) * CHUNK).min(paths);
                    for index in chunk * CHUNK..end {
                        self.trace(scene, seed, index, &mut splats, &mut c);
                    }
                    progress.advance(end - chunk * CHUNK);
                    (splats, c)
                })
                .collect();
            for (splats, c) in results {
                counters.merge(&c);
                for s in splats {
                    let v = [
                        s.value.r as f64 * scale,
                        s.value.g as f64 * scale,
                        s.value.b as f64 * scale,
                    ];
                    let base = s.pixel as usize * slots;
                    let targets: &[usize] = if slots > 1 {
                        &[base, base + 1 + s.layer as usize]
                    } else {
                        &[base]
                    };
                    for &i in targets {
                        for k in 0..3 {
                            sum[i][k] += v[k];
                            sum_sq[i][k] += v[k] * v[k];
                        }
                    }
                }
            }
        }
        let mut films: Vec<Film> = (0..slots).map(|_| Film::new(width, height)).collect();
        for (slot, film) in films.iter_mut().enumerate() {
            for (i, p) in film.pixels.iter_mut().enumerate() {
                let j = i * slots + slot;
                *p = PixelSums::from_sums(sum[j], sum_sq[j], paths);
            }
        }
        let film = films.remove(0);
        let wall = start.elapsed().as_secs_f64();
        let stats = RenderStats::new(
            "Light",
            (width, height),
            budget,
            seed,
            wall,
            paths,
            &counters,
            &["camera_connection"],
        );
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(self.router.layer_names(), films),
            stats,
        }
    }
}
