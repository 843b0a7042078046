//! Unidirectional path tracing (Kajiya 1986) with next-event estimation, combined with BSDF sampling
//! by multiple importance sampling (Veach 1997, §9.2; pbrt-v4 §13.4).
//!
//! The estimator of a pixel is a sum over path lengths k (scattering vertices) of
//! L_e · Π f·|cos|/p along a path of k vertices, where each length-k term is estimated twice — by
//! sampling the last direction from the BSDF and by sampling a point on a light — and the two are
//! weighted by the power heuristic. `min_bounces`/`max_bounces` keep only terms with k in that range.
//!
//! Sample dimensions per pixel sample (the layout stratified samplers rely on): 0–1 pixel position,
//! 2–3 lens, then per scattering vertex 7 values: light choice (1), point on the light (2), BSDF lobe
//! (1), BSDF direction (2), Russian roulette (1) — consumed whether or not they are used.

use crate::config::{ConfigError, Validate, check_common, default_rr, invalid};
use crate::nee::{emitted, environment_light_pdf, light_pdf_of_hit, sample_direct};
use crate::passes::{PassSpec, Schedule, run_passes};
use crate::paths::{Layers, PathClass, Router};
use crate::render::{Counters, PixelVariance, named};
use crate::roulette::survives;
use crate::sink::Sink;
use crate::{Budget, Film, Integrator, RenderOutput, RenderStats};
use glam::{Vec2, Vec3};
use lightlab_core::{INV_2PI, INV_4PI, Progress, Rgb, TransportMode};
use lightlab_geometry::{NO_LIGHT, spawn_ray};
use lightlab_materials::{Bsdf, SurfaceBsdf};
use lightlab_samplers::mis::power_heuristic;
use lightlab_samplers::warp::{square_to_uniform_hemisphere, square_to_uniform_sphere};
use lightlab_samplers::{Sampler, SamplerConfig, SamplerVisitor};
use lightlab_scene::Scene;
use serde::{Deserialize, Serialize};

/// Settings of the path tracer: `Path(max_bounces: 8, strategy: Mis)`; every field optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, rename = "Path")]
pub struct PathConfig {
    /// Largest number of scattering vertices on a path; `None` for no limit (Russian roulette ends
    /// paths). Default `None`.
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have: `min_bounces: k,
    /// max_bounces: k` isolates the k-th term of the Neumann series. Default 0.
    pub min_bounces: u32,
    /// Russian roulette from this many scattering vertices on (survival probability
    /// min(1, max channel of the throughput)); `None` turns it off. Default `Some(3)`.
    pub russian_roulette: Option<u32>,
    /// How directions are chosen at each vertex. Default `Mis`.
    pub strategy: Strategy,
    /// Test visibility for next-event estimation. `false` computes direct illumination without
    /// shadows (only with `Mis` or `LightOnly`, which sample lights). Default true.
    pub shadows: bool,
    /// Where the sample values come from: `Independent`, `Stratified`, `LatinHypercube`, `Halton`
    /// or `Sobol` (see `lightlab_samplers::SamplerConfig`). Default `Independent`.
    pub sampler: SamplerConfig,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    pub layers: Layers,
}

impl Default for PathConfig {
    fn default() -> Self {
        PathConfig {
            max_bounces: None,
            min_bounces: 0,
            russian_roulette: default_rr(),
            strategy: Strategy::Mis,
            shadows: true,
            sampler: SamplerConfig::Independent,
            paths: None,
            layers: Layers::Off,
        }
    }
}

impl Validate for PathConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_common(
            self.max_bounces,
            self.min_bounces,
            self.russian_roulette,
            self.paths.as_deref(),
            &self.layers,
        )?;
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

/// Technique numbers for the non-finite counters.
const EMISSION: usize = 0;
const NEXT_EVENT: usize = 1;

pub struct PathTracer {
    config: PathConfig,
    router: Router,
}

impl PathTracer {
    /// A path tracer with `config` (checked).
    pub fn new(config: PathConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let router = Router::new(config.paths.as_deref(), &config.layers, config.max_bounces)
            .map_err(ConfigError::Invalid)?;
        Ok(PathTracer { config, router })
    }

    /// Whether next-event estimation is done at non-specular vertices.
    fn samples_lights(&self) -> bool {
        matches!(self.config.strategy, Strategy::Mis | Strategy::LightOnly)
    }

    /// Weight of emission found by a BSDF-sampled ray (or the camera ray) against light sampling of the
    /// same path. `prev_delta`: the previous vertex was the camera or specular, where lights cannot be
    /// sampled.
    #[inline]
    fn emission_weight(
        &self,
        prev_delta: bool,
        bsdf_pdf: f32,
        light_pdf: impl FnOnce() -> f32,
    ) -> f32 {
        if prev_delta {
            return 1.0;
        }
        match (self.config.strategy, self.config.shadows) {
            (Strategy::BsdfOnly | Strategy::Uniform, _) => 1.0,
            (Strategy::LightOnly, _) | (Strategy::Mis, false) => 0.0,
            (Strategy::Mis, true) => power_heuristic(1.0, bsdf_pdf, 1.0, light_pdf()),
        }
    }

    /// One camera path through raster position `film`: adds its radiance estimate to `l`, by path
    /// class.
    fn li<S: Sampler>(
        &self,
        scene: &Scene,
        film: Vec2,
        sampler: &mut S,
        l: &mut Sink,
        counters: &mut Counters,
    ) {
        let cfg = &self.config;
        let max_bounces = cfg.max_bounces.unwrap_or(u32::MAX);
        let u_lens = sampler.next_2d();
        let mut ray = scene.camera.generate_ray(film, u_lens);
        // Scattering vertices so far, camera first.
        let mut class = PathClass::EMPTY;
        let mut beta = Rgb::WHITE;
        // Product of η² over refractions so far, which Russian roulette divides out (pbrt-v4 §13.4.4).
        let mut eta_scale = 1.0f32;
        let mut depth = 0u32; // scattering vertices so far
        let mut prev_delta = true;
        let mut prev_p = ray.o;
        let mut prev_bsdf_pdf = 0.0f32;
        loop {
            counters.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                let le = scene.environment_le();
                if depth >= cfg.min_bounces && !le.is_black() {
                    let w = self.emission_weight(prev_delta, prev_bsdf_pdf, || {
                        environment_light_pdf(scene)
                    });
                    add(l, &class, beta * le * w, EMISSION, counters);
                }
                break;
            };
            let wo = -ray.d.normalize();
            if hit.light != NO_LIGHT && depth >= cfg.min_bounces {
                let le = emitted(scene, &hit, wo);
                if !le.is_black() {
                    let w = self.emission_weight(prev_delta, prev_bsdf_pdf, || {
                        light_pdf_of_hit(scene, prev_p, &hit)
                    });
                    add(l, &class, beta * le * w, EMISSION, counters);
                }
            }
            if depth >= max_bounces {
                break;
            }
            let bsdf = scene.materials[hit.material as usize];
            let sb = SurfaceBsdf::new(hit.ns, hit.dpdu, hit.ng, bsdf);
            let delta = bsdf.is_delta();
            class = class.push(bsdf.lobe_class());

            // Next-event estimation: a path of depth + 1 scattering vertices ending on a light.
            let (u_light, u_light_point) = (sampler.next_1d(), sampler.next_2d());
            if self.samples_lights()
                && !delta
                && depth + 1 >= cfg.min_bounces
                && let Some(d) = sample_direct(
                    scene,
                    &hit,
                    &sb,
                    wo,
                    u_light,
                    u_light_point,
                    cfg.shadows,
                    counters,
                )
            {
                let w = if d.delta || cfg.strategy == Strategy::LightOnly || !cfg.shadows {
                    1.0
                } else {
                    power_heuristic(1.0, d.light_pdf, 1.0, d.bsdf_pdf)
                };
                add(l, &class, beta * d.value * w, NEXT_EVENT, counters);
            }

            // Continue the path.
            let (u_lobe, u_dir, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
            let step = if cfg.strategy == Strategy::Uniform && !delta {
                uniform_direction(&sb, wo, u_dir)
            } else {
                sb.sample(wo, u_lobe, u_dir, TransportMode::Radiance)
                    .map(|s| Step {
                        wi: s.wi,
                        weight: s.weight,
                        pdf: s.pdf,
                        delta: s.delta,
                        eta: if s.transmission { s.eta } else { 1.0 },
                    })
            };
            let Some(step) = step else { break };
            if step.weight.is_black() {
                break;
            }
            beta *= step.weight;
            eta_scale *= step.eta * step.eta;
            prev_delta = step.delta;
            prev_bsdf_pdf = step.pdf;
            prev_p = hit.p;
            depth += 1;
            let score = beta.max_component() * eta_scale;
            if !survives(cfg.russian_roulette, depth, score, u_rr, &mut beta) {
                break;
            }
            ray = spawn_ray(hit.p, hit.p_error, hit.ng, step.wi);
        }
    }
}

/// A sampled continuation of the path.
struct Step {
    wi: Vec3,
    weight: Rgb,
    pdf: f32,
    delta: bool,
    /// Relative IOR crossed (1 for reflection).
    eta: f32,
}

/// Blind sampling: a uniform direction on the hemisphere of `wo` (the whole sphere where the surface
/// transmits), weighted by f·|cos|/p.
fn uniform_direction(sb: &SurfaceBsdf, wo: Vec3, u: Vec2) -> Option<Step> {
    let (local, pdf) = if matches!(sb.bsdf, Bsdf::RoughDielectric { .. }) {
        (square_to_uniform_sphere(u), INV_4PI)
    } else {
        let mut d = square_to_uniform_hemisphere(u);
        if sb.frame.n.dot(wo) < 0.0 {
            d.z = -d.z;
        }
        (d, INV_2PI)
    };
    let wi = sb.frame.to_world(local);
    let f = sb.eval(wo, wi, TransportMode::Radiance).f;
    let transmits = wi.dot(sb.ng) * wo.dot(sb.ng) < 0.0;
    let eta = match sb.bsdf {
        Bsdf::RoughDielectric { eta, .. } if transmits => {
            if wo.dot(sb.ng) > 0.0 {
                eta
            } else {
                1.0 / eta
            }
        }
        _ => 1.0,
    };
    Some(Step {
        wi,
        weight: f * (local.z.abs() / pdf),
        pdf,
        delta: false,
        eta,
    })
}

/// Adds a contribution of a camera path with scattering vertices `eye` (camera first) unless it is
/// NaN or infinite, which is counted instead (design.md).
#[inline]
fn add(l: &mut Sink, eye: &PathClass, c: Rgb, technique: usize, counters: &mut Counters) {
    if c.is_finite() {
        l.add_eye(eye, c);
    } else {
        counters.non_finite[technique] += 1;
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
        let spp = match *budget {
            Budget::Samples(n) => n,
            Budget::Seconds(_) => 1,
        };
        self.config.sampler.dispatch(
            spp,
            RenderWith {
                tracer: self,
                scene,
                budget,
                seed,
                progress,
                on_pass,
            },
        )
    }

    fn needs_sample_count(&self) -> bool {
        self.config.sampler.needs_sample_count()
    }

    fn best_sample_count(&self, n: u32) -> u32 {
        self.config.sampler.best_count_up_to(n)
    }

    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        if !self.samples_lights() && scene.lights.iter().any(|l| l.is_delta()) {
            return Err(format!(
                "strategy {:?} never samples lights, so it cannot see the scene's point and spot \
                 lights (no ray hits them): use Mis or LightOnly, or remove those lights",
                self.config.strategy
            ));
        }
        Ok(())
    }
}

/// The render loop for the sampler type the configuration names (monomorphised per sampler).
struct RenderWith<'a, 'b> {
    tracer: &'a PathTracer,
    scene: &'a Scene,
    budget: &'a Budget,
    seed: u64,
    progress: &'a dyn Progress,
    on_pass: &'b mut dyn FnMut(u32, &Film) -> bool,
}

impl SamplerVisitor for RenderWith<'_, '_> {
    type Output = RenderOutput;

    fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, prototype: S) -> RenderOutput {
        let RenderWith {
            tracer,
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = self;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let spec = PassSpec {
            width,
            height,
            slots: 1 + tracer.router.layer_count(),
            splats: false,
            groups: 0,
            independent: tracer.config.sampler.independent(),
        };
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        let out = run_passes(
            &spec,
            &tracer.router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, _: &mut ()| {
                let mut sampler = prototype.clone();
                let pixel = y as u64 * width as u64 + x as u64;
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
            &["emission", "next_event"],
            if spec.independent {
                PixelVariance::Independent
            } else {
                PixelVariance::NotAnEstimate(format!(
                    "the {} sampler's samples are correlated (s²/n overestimates the variance of \
                     the mean)",
                    tracer.config.sampler.name()
                ))
            },
        );
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(tracer.router.layer_names(), films),
            stats,
        }
    }
}
