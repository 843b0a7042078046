//! Radiosity (Goral, Torrance, Greenberg & Battaile 1984; Cohen & Wallace 1993): the rendering
//! equation for Lambertian surfaces projected onto piecewise-constant patches,
//! B_a = E_a + ρ_a Σ_b F_ab B_b, solved once per render and shown through the camera.
//!
//! Pipeline. The scene's triangles and spheres are cut into about `patches` patches of equal area
//! (`patches`), each with two sides; the form factors are estimated by casting `rays` rays from
//! every side that reflects (`form_factors`: unbiased, binomial noise); one of three solvers
//! iterates (`solve`: Jacobi, whose iterate k is the Neumann series after k bounces; Gauss–Seidel;
//! progressive shooting); then every pixel sample casts a camera ray and takes L = B/π of the patch
//! side it hits, so the image lines up pixel for pixel with the Monte Carlo integrators'.
//!
//! What it approximates. Radiance is constant over a patch (no interpolation at vertices: the
//! image shows the patches) and the form factors are estimates, so the image converges, as spp
//! grows, to the pixel integral of the discrete solution, not of the true radiance: the difference
//! is the discretisation error (falling as patches shrink) plus the form factors' noise (falling
//! as `rays` grows, and varying with the seed), and, for a fixed iteration count, the truncation
//! of the series. Geometric normals are used (a mesh's shading normals are ignored).
//!
//! Sample dimensions per pixel sample: the film position (2), the lens (2). The form factors use the render's
//! seed under their own key, so one seed gives one solution and one image, bit for bit, on any
//! number of threads.

mod form_factors;
mod patches;
mod solve;
#[cfg(test)]
mod tests;

pub use solve::Solver;

use crate::config::{ConfigError, Settings, Validate, invalid};
use crate::passes::{
    PassSpec, RenderArgs, SampledRender, Schedule, render_sampled, run_passes,
    run_progressive_passes,
};
use crate::paths::{Layers, PathClass, Router};
use crate::render::{Counters, PixelLimit, PixelVariance, named};
use crate::shutter::pass_time;
use crate::{Budget, Film, Integrator, RenderOutput, RenderStats};
use form_factors::FormFactors;
use glam::Vec2;
use lightlab_core::{PI, Progress, Rgb};
use lightlab_materials::{Bsdf, LobeClass};
use lightlab_samplers::{Sampler, SamplerConfig};
use lightlab_scene::{Light, Scene};
use patches::Patches;
use serde::{Deserialize, Serialize};
use solve::{Solved, Stop, System};
use std::sync::RwLock;
use std::time::Instant;

/// Settings of the radiosity method: `Radiosity(patches: 4096, solver: GaussSeidel)`; every
/// field optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, rename = "Radiosity")]
pub struct RadiosityConfig {
    /// Jacobi only: the last term of the Neumann series kept, so that iterate k holds the paths
    /// `L Dʲ E` with j ≤ k (`max_bounces: 0` is emission alone); `None` iterates to the
    /// tolerance. Default `None`.
    pub max_bounces: Option<u32>,
    /// Jacobi only: the first term kept (`min_bounces: k, max_bounces: k` is the k-th term).
    /// Default 0.
    pub min_bounces: u32,
    /// Target number of patches over the whole scene (≥ 1); patches have about equal area, each
    /// triangle cut into m² and each sphere into 2b² cells, so the count reached differs a little
    /// (`radiosity.patches` in the statistics). Default 1024.
    pub patches: u32,
    /// Form-factor rays per patch side (≥ 1). Default 1024.
    pub rays: u32,
    /// `Jacobi`, `GaussSeidel` or `Shooting`. Default `Jacobi`.
    pub solver: Solver,
    /// Exactly this many iterations (Jacobi: bounces, capped by `max_bounces`; Gauss–Seidel:
    /// sweeps; Shooting: rounds of as many shots as there are reflecting patch sides); `None`
    /// iterates until the relative residual is below `tolerance`. Default `None`.
    pub iterations: Option<u32>,
    /// Relative residual ‖E + ρF̂B − B‖ / ‖E‖ at which an iteration without a fixed count stops,
    /// in (0, 1). Default 1e-6.
    pub tolerance: f64,
    /// Shooting only: show the unshot radiosity as Cohen et al.'s ambient term. Default false.
    pub ambient: bool,
    /// The camera samples' sampler: `Independent`, `Stratified`, `LatinHypercube`, `Halton` or
    /// `Sobol` (see `lightlab_samplers::SamplerConfig`); a stratified one resolves edges (the
    /// lights' above all) with far fewer samples. Default `Independent`.
    pub sampler: SamplerConfig,
    /// Jacobi only: render only the terms whose paths `L Dᵏ E` this expression matches; `None`
    /// renders every term. Default `None`.
    pub paths: Option<String>,
    /// Jacobi only: image layers besides the full image (`Off`, `Bounces`, `Classes([...])`).
    /// Default `Off`.
    pub layers: Layers,
}

impl Default for RadiosityConfig {
    fn default() -> Self {
        RadiosityConfig {
            max_bounces: None,
            min_bounces: 0,
            patches: 1024,
            rays: 1024,
            solver: Solver::Jacobi,
            iterations: None,
            tolerance: 1e-6,
            ambient: false,
            sampler: SamplerConfig::Independent,
            paths: None,
            layers: Layers::Off,
        }
    }
}

/// Patches and form-factor rays allowed at most (memory: a row per patch side).
const MAX_PATCHES: u32 = 1 << 20;
const MAX_RAYS: u32 = 1 << 24;

impl Validate for RadiosityConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        if !(1..=MAX_PATCHES).contains(&self.patches) {
            return invalid(format!(
                "patches must lie in 1…{MAX_PATCHES}, got {}",
                self.patches
            ));
        }
        if !(1..=MAX_RAYS).contains(&self.rays) {
            return invalid(format!("rays must lie in 1…{MAX_RAYS}, got {}", self.rays));
        }
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return invalid(format!(
                "tolerance must lie in (0, 1), got {}",
                self.tolerance
            ));
        }
        if let Some(max) = self.max_bounces
            && self.min_bounces > max
        {
            return invalid(format!(
                "min_bounces ({}) exceeds max_bounces ({max})",
                self.min_bounces
            ));
        }
        let terms = self.max_bounces.is_some()
            || self.min_bounces > 0
            || self.paths.is_some()
            || self.layers != Layers::Off;
        if self.solver != Solver::Jacobi && terms {
            return invalid(format!(
                "max_bounces, min_bounces, paths and layers select terms of the Neumann series, \
                 which only the Jacobi solver computes one by one; {:?} does not",
                self.solver
            ));
        }
        if self.ambient && self.solver != Solver::Shooting {
            return invalid(
                "ambient is the display term of progressive shooting: use solver: Shooting",
            );
        }
        Router::check(
            self.paths.as_deref(),
            &self.layers,
            self.min_bounces,
            self.max_bounces,
        )
        .map_err(ConfigError::Invalid)
    }
}

impl Settings for RadiosityConfig {
    fn paths_and_layers(&mut self) -> (&mut Option<String>, &mut Layers) {
        (&mut self.paths, &mut self.layers)
    }
}

/// What a radiosity render reports besides the image (`radiosity` in the statistics).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RadiosityStats {
    /// Patches made.
    pub patches: usize,
    /// Patch sides that reflect (rows of F̂ estimated).
    pub reflecting_sides: usize,
    /// Form-factor rays cast.
    pub form_factor_rays: u64,
    /// Non-zero entries of F̂.
    pub form_factor_entries: usize,
    /// Seconds spent estimating F̂.
    pub form_factor_seconds: f64,
    /// Seconds spent solving.
    pub solve_seconds: f64,
    /// The solver.
    pub solver: Solver,
    /// Iterations done.
    pub iterations: u32,
    /// Shots fired (Shooting).
    pub shots: u64,
    /// Relative residual ‖E + ρF̂B − B‖ / ‖E‖ after 0, 1, … iterations.
    pub residuals: Vec<f64>,
    /// Whether an iteration without a fixed count reached the tolerance (`None` with a fixed
    /// count).
    pub converged: Option<bool>,
    /// The ambient radiosity added for display (Shooting with `ambient: true`).
    pub ambient: Option<[f64; 3]>,
}

/// Radiosity, built from checked [`RadiosityConfig`] settings.
pub struct Radiosity {
    config: RadiosityConfig,
    router: Router,
}

impl Radiosity {
    /// A radiosity method with `config` (checked).
    pub fn new(config: RadiosityConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let router = Router::new(config.paths.as_deref(), &config.layers, config.max_bounces)
            .map_err(ConfigError::Invalid)?;
        Ok(Radiosity { config, router })
    }

    /// Patches, form factors and the solution: the radiance L = B/π of every unknown for each
    /// image slot (the full image, then the router's layers), and the statistics.
    fn solve(&self, scene: &Scene, seed: u64) -> (Patches, Vec<Vec<Rgb>>, RadiosityStats, u64) {
        let cfg = &self.config;
        let t0 = Instant::now();
        let patches = Patches::new(scene, cfg.patches);
        let n = 2 * patches.list.len();
        let mut rho = vec![[0.0; 3]; n];
        let mut emission = vec![[0.0; 3]; n];
        let mut area = vec![0.0; n];
        for (i, patch) in patches.list.iter().enumerate() {
            let shape = &scene.shapes()[patch.shape as usize];
            let material = &scene.materials[shape.material as usize];
            area[2 * i] = patch.area;
            area[2 * i + 1] = patch.area;
            if let Bsdf::Diffuse { albedo } = material.bsdf {
                let albedo = albedo.to_array().map(f64::from);
                rho[2 * i] = albedo;
                if !material.one_sided {
                    rho[2 * i + 1] = albedo;
                }
            }
            if let Some(Light::Area {
                radiance,
                two_sided,
                ..
            }) = scene.lights.get(shape.light as usize)
            {
                let e = radiance.to_array().map(|l| PI as f64 * l as f64);
                emission[2 * i] = e;
                if *two_sided {
                    emission[2 * i + 1] = e;
                }
            }
        }
        let active: Vec<bool> = rho.iter().map(|r| r.iter().any(|&v| v > 0.0)).collect();
        let rows = FormFactors::estimate(scene, &patches, &active, cfg.rays, seed);
        let form_factor_seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let system = System {
            rows: &rows,
            rho,
            emission,
            area,
        };
        let stop = Stop {
            iterations: match (cfg.iterations, cfg.max_bounces) {
                (Some(i), Some(m)) => Some(i.min(m)),
                (i, m) => i.or(m),
            },
            tolerance: cfg.tolerance,
        };
        let slots = 1 + self.router.layer_count();
        let mut values = vec![vec![[0.0f64; 3]; n]; slots];
        let mut ambient = None;
        let solved: Solved = match cfg.solver {
            Solver::Jacobi => {
                let mut class = PathClass::EMPTY;
                let (min, router) = (cfg.min_bounces, &self.router);
                system.jacobi(stop, &mut |k, term| {
                    if k > 0 {
                        class = class.push(LobeClass::Diffuse);
                    }
                    let Some(layer) = router.route(&class).filter(|_| k >= min) else {
                        return;
                    };
                    for slot in [0].into_iter().chain((slots > 1).then_some(1 + layer)) {
                        for (v, t) in values[slot].iter_mut().zip(term) {
                            for c in 0..3 {
                                v[c] += t[c];
                            }
                        }
                    }
                })
            }
            Solver::GaussSeidel => {
                let s = system.gauss_seidel(stop);
                values[0] = s.b.clone();
                s
            }
            Solver::Shooting => {
                let (s, unshot) = system.shoot(stop);
                values[0] = s.b.clone();
                if cfg.ambient {
                    let a = system.ambient(&unshot);
                    for (v, r) in values[0].iter_mut().zip(&system.rho) {
                        for c in 0..3 {
                            v[c] += r[c] * a[c];
                        }
                    }
                    ambient = Some(a);
                }
                s
            }
        };
        let radiance = values
            .iter()
            .map(|slot| {
                slot.iter()
                    .map(|b| Rgb::new(b[0] as f32, b[1] as f32, b[2] as f32) * (1.0 / PI))
                    .collect()
            })
            .collect();
        let stats = RadiosityStats {
            patches: patches.list.len(),
            reflecting_sides: active.iter().filter(|&&a| a).count(),
            form_factor_rays: rows.rays_cast,
            form_factor_entries: rows.entry_count(),
            form_factor_seconds,
            solve_seconds: t1.elapsed().as_secs_f64(),
            solver: cfg.solver,
            iterations: solved.iterations,
            shots: solved.shots,
            residuals: solved.residuals,
            converged: stop.iterations.is_none().then_some(solved.converged),
            ambient,
        };
        (patches, radiance, stats, rows.rays_cast)
    }
}

/// Why `scene` cannot be solved by radiosity, if it cannot: every surface Lambertian with a
/// constant albedo, every light an area light.
fn check(scene: &Scene) -> Result<(), String> {
    if let Some(light) = scene
        .lights
        .iter()
        .find(|l| !matches!(l, Light::Area { .. }))
    {
        let kind = light.kind();
        return Err(format!(
            "Radiosity exchanges light between patches with area, so it models area lights \
             (emissive shapes) only; the scene has {kind}"
        ));
    }
    for (shape, i) in scene.shapes().iter().zip(0..) {
        let material = &scene.materials[shape.material as usize];
        let name = &scene.material_names[shape.material as usize];
        match material.bsdf {
            Bsdf::Diffuse { .. } if material.textures.is_empty() => {}
            Bsdf::Diffuse { .. } => {
                return Err(format!(
                    "Radiosity needs a constant reflectance per patch: material '{name}' (shape \
                     {i}) has a textured albedo"
                ));
            }
            ref other => {
                let kind = format!("{other:?}");
                let kind = kind.split([' ', '(', '{']).next().unwrap_or("");
                return Err(format!(
                    "Radiosity solves for Lambertian surfaces only: material '{name}' (shape {i}) \
                     is {kind}, not Diffuse"
                ));
            }
        }
    }
    Ok(())
}

impl Integrator for Radiosity {
    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        check(scene)
    }

    /// Renders a scene [`Integrator::check_scene`] accepts; in another, surfaces that are not
    /// Lambertian count as black and lights without area are left out.
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

    fn memory_bytes(&self, scene: &Scene) -> u64 {
        self.pass_spec(scene).bytes()
    }
}

/// One instant's solution: the frozen scene, its patches and their radiance per output slot.
type Solution = (Scene, Patches, Vec<Vec<Rgb>>);

impl Radiosity {
    /// The images the driver keeps: the full image and the router's layers (one radiance per
    /// patch and slot).
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        PassSpec {
            independent: self.config.sampler.independent(),
            ..PassSpec::layers(scene, &self.router)
        }
    }

    /// Motion blur as an accumulation buffer (Haeberli & Akeley 1990): pass i solves the scene
    /// frozen at its instant (the passes' stratified times, `shutter`) with form factors of its
    /// own seed, and its camera samples see that solution. Passes are then independent samples of
    /// the time and form-factor integrals, and the spread over them is the pixel's variance
    /// (conservative where the instants' stratification helps).
    fn render_instants<S: Sampler + Clone + Send + Sync + 'static>(
        &self,
        prototype: S,
        scene: &Scene,
        seed: u64,
        schedule: &mut Schedule,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let current: RwLock<Option<Solution>> = RwLock::new(None);
        let mut last = None;
        let mut form_factor_rays = 0;
        let mut begin = |i: u32, _: &mut Counters| {
            let frozen = scene.at_instant(pass_time(&scene.camera, seed, i as u64));
            let pass_seed = seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            let (patches, radiance, stats, rays) = self.solve(&frozen, pass_seed);
            form_factor_rays += rays;
            last = Some(stats);
            *current.write().expect("no pass panicked") = Some((frozen, patches, radiance));
        };
        let spec = self.pass_spec(scene);
        let out = run_progressive_passes(
            &spec,
            &self.router,
            schedule,
            on_pass,
            &mut begin,
            |x, y, index, sink, counters, _: &mut ()| {
                let solution = current.read().expect("no pass panicked");
                let Some((frozen, patches, radiance)) = solution.as_ref() else {
                    return;
                };
                let mut sampler = prototype.clone();
                sampler.start_pixel_sample(seed, y as u64 * width as u64 + x as u64, index);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let ray = frozen.camera.generate_ray(film, sampler.next_2d());
                counters.rays += 1;
                if let Some(hit) = frozen.intersect(&ray) {
                    let back = ray.d.dot(hit.ng) > 0.0;
                    let u = (2 * patches.patch_of(&hit, frozen) + back as u32) as usize;
                    for (slot, values) in radiance.iter().enumerate() {
                        sink.add_slot(slot, values[u]);
                    }
                }
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let mut counters = out.counters;
        counters.rays += form_factor_rays;
        let mut stats = RenderStats::new(
            "Radiosity",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * out.spp as u64,
            &counters,
            &[],
            crate::shutter::instants_variance(),
        );
        stats.pixel_limit = PixelLimit::PatchRadiosity;
        stats.radiosity = last.map(|s| RadiosityStats {
            form_factor_rays,
            ..s
        });
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(self.router.layer_names(), films),
            stats,
        }
    }
}

impl SampledRender for Radiosity {
    fn render_with<S: Sampler + Clone + Send + Sync + 'static>(
        &self,
        prototype: S,
        args: RenderArgs,
    ) -> RenderOutput {
        let RenderArgs {
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = args;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        if scene.motion_blur() {
            return self.render_instants(prototype, scene, seed, &mut schedule, on_pass);
        }
        // A closed shutter over moving shapes: the one instant, where they are then.
        let frozen = scene
            .has_motion()
            .then(|| scene.at_instant(scene.camera.shutter.0));
        let scene = frozen.as_ref().unwrap_or(scene);
        let (patches, radiance, radiosity, form_factor_rays) = self.solve(scene, seed);
        let spec = PassSpec {
            width,
            height,
            slots: radiance.len(),
            splats: false,
            groups: 0,
            independent: false,
            replicates: 1,
        };
        let out = run_passes(
            &spec,
            &self.router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, _: &mut ()| {
                let mut sampler = prototype.clone();
                sampler.start_pixel_sample(seed, y as u64 * width as u64 + x as u64, index);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let ray = scene.camera.generate_ray(film, sampler.next_2d());
                counters.rays += 1;
                if let Some(hit) = scene.intersect(&ray) {
                    let back = ray.d.dot(hit.ng) > 0.0;
                    let u = (2 * patches.patch_of(&hit, scene) + back as u32) as usize;
                    for (slot, values) in radiance.iter().enumerate() {
                        sink.add_slot(slot, values[u]);
                    }
                }
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let mut counters = out.counters;
        counters.rays += form_factor_rays;
        let mut stats = RenderStats::new(
            "Radiosity",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * out.spp as u64,
            &counters,
            &[],
            PixelVariance::NotAnEstimate(
                "s²/n over the camera samples of one solution: the form factors' noise, shared by \
                 every pixel, is not in it (measure it across seeds)"
                    .into(),
            ),
        );
        stats.pixel_limit = PixelLimit::PatchRadiosity;
        stats.radiosity = Some(radiosity);
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(self.router.layer_names(), films),
            stats,
        }
    }
}
