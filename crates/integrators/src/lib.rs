//! Light-transport integrators. Each estimates the pixel measurements I_j = ∫ W_j L dA dω of a scene
//! and returns a [`Film`] with per-pixel means and variances plus [`RenderStats`].
//!
//! Conventions (design.md): `max_bounces` counts scattering vertices between light and eye, so 0 is
//! emission seen directly, 1 direct lighting, k the Neumann series truncated after k terms;
//! `min_bounces` drops the lower terms. Non-finite contributions are counted and kept out of the film.
//! Nothing here does I/O.
//!
//! Settings come as RON (the text `lightlab render --integrator` and experiment files take), are
//! checked once, and build an [`Integrator`]; every integrator renders a scene into a [`Film`] of
//! per-pixel means and variances. The white furnace, rendered with four bounces, is Lₑ·Σ_{k≤4} ρᵏ
//! in every pixel:
//!
//! ```
//! use lightlab_integrators::{Budget, IntegratorConfig};
//! use std::path::Path;
//!
//! let scene = lightlab_scene::parse_scene(
//!     r#"Scene(
//!         camera: Camera(eye: (0, 0, 0), target: (0, 0, -1), fov: 60, resolution: (8, 8)),
//!         materials: { "wall": Diffuse(albedo: (0.8, 0.8, 0.8)) },
//!         shapes: [Shape(
//!             geometry: Sphere(center: (0, 0, 0), radius: 1),
//!             material: "wall",
//!             emission: (radiance: (0.5, 0.5, 0.5), two_sided: true),
//!         )],
//!     )"#,
//!     Path::new("furnace.ron"),
//! )?;
//! let integrator = IntegratorConfig::from_ron("Path(max_bounces: 4)")?.build()?;
//! let out = integrator.render(&scene, &Budget::Samples(16), 1, &lightlab_core::NoProgress);
//!
//! let expected = 0.5 * (0..=4).map(|k| 0.8f64.powi(k)).sum::<f64>();
//! let se = out.stats.image_mean_se.expect("independent passes")[0];
//! assert!((out.stats.image_mean[0] - expected).abs() < 4.0 * se + 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

pub mod bdpt;
pub mod cone;
mod config;
mod film;
mod light;
pub mod memory;
mod nee;
mod passes;
mod path;
pub mod paths;
pub mod photon;
mod provenance;
pub mod radiosity;
mod render;
mod shutter;
mod sink;
pub mod vcm;
mod walk;

pub use bdpt::{BdptConfig, Mis};
pub use cone::ConeConfig;
pub use config::{ConfigError, IntegratorConfig, Validate};
pub use film::{Film, PixelSums};
pub use light::LightConfig;
pub use passes::Budget;
pub use path::{PathConfig, Strategy};
pub use photon::config::{
    Gather, Indirect, Length, PhotonMapConfig, ProgressiveConfig, RadiusUpdate,
};
pub use photon::map::Kernel;
pub use provenance::Outlier;
pub use radiosity::{RadiosityConfig, RadiosityStats, Solver};
pub use render::{Counters, PixelLimit, PixelVariance, RenderOutput, RenderStats, Technique};
pub use sink::Sink;
pub use vcm::{Heuristic, Variant as VcmVariant, Vcm, VcmConfig};
pub use walk::RoulettePolicy;

use lightlab_core::{NoProgress, Progress};
use lightlab_samplers::SamplerConfig;
use lightlab_scene::Scene;
use std::time::Instant;

/// A rendering algorithm, configured and ready to run.
pub trait Integrator: Send + Sync {
    /// Renders `scene` pass after pass until `budget` is spent, calling `on_pass(samples_done,
    /// film)` with the image so far after every pass; `on_pass` returning false stops there.
    /// Random numbers depend only on `seed` and what is being sampled, so the result is
    /// bit-identical for any thread count, and a render stopped after N samples per pixel (by
    /// the clock or by `on_pass`) is the render of `Budget::Samples(N)`.
    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput;

    /// The sampler of its camera paths, if the settings choose one (`None`: independent
    /// samples throughout).
    fn sampler(&self) -> Option<&SamplerConfig> {
        None
    }

    /// Independent replicates the sampler's samples are split into (`replicates`: randomised
    /// quasi-Monte Carlo, [`lightlab_samplers::replicate_sample`]); 1 for none. Sample counts are
    /// then multiples of it.
    fn replicates(&self) -> u32 {
        1
    }

    /// Whether the sampler must know the number of samples before the first one (`Stratified`,
    /// `LatinHypercube`), so that a time budget cannot simply continue the sequence.
    fn needs_sample_count(&self) -> bool {
        self.sampler().is_some_and(|s| s.needs_sample_count())
    }

    /// The sample count up to `n` that the sampler handles best (a time budget's calibrated count
    /// is rounded down to it): a multiple of the replicates, each of a count the sampler
    /// stratifies well; at least one sample per replicate.
    fn best_sample_count(&self, n: u32) -> u32 {
        let r = self.replicates();
        let per_replicate = (n / r).max(1);
        r * self
            .sampler()
            .map_or(per_replicate, |s| s.best_count_up_to(per_replicate))
    }

    /// Bytes the render of `scene` will hold at its peak, as far as is known before it starts:
    /// its images (films, layers, the driver's buffers), what the settings and the image size fix
    /// (VCM's light vertices, at least one per subpath), and photon maps, estimated from a pilot of
    /// 4096 photon paths (`photon::trace::stored_per_path`). Checked against the memory available
    /// before a render starts ([`memory::check`]).
    fn memory_bytes(&self, scene: &Scene) -> u64;

    /// Whether the integrator, as configured, can render `scene` (an error says why not).
    fn check_scene(&self, _scene: &Scene) -> Result<(), String> {
        Ok(())
    }

    /// Whether the sampler can take `budget`'s samples per pixel (an error says why not): with
    /// replicates, a multiple of them.
    fn check_budget(&self, budget: &Budget) -> Result<(), String> {
        let r = self.replicates();
        match (budget, self.sampler()) {
            (Budget::Samples(n), _) if n % r != 0 => Err(format!(
                "{n} samples per pixel cannot be split into {r} equal replicates \
                 (`replicates: {r}`): give a multiple of {r}, e.g. {}",
                (n / r).max(1) * r
            )),
            (Budget::Samples(n), Some(s)) if n / r > s.max_samples() => Err(format!(
                "the {s:?} sampler takes at most {} samples per pixel{} (f32 separates no \
                 more strata of [0, 1)), got {}: use Independent, Halton or Sobol",
                s.max_samples(),
                if r > 1 { " in each replicate" } else { "" },
                n / r
            )),
            _ => Ok(()),
        }
    }

    /// What the integrator, as configured, leaves out of `scene`'s image although it renders it
    /// (said before a render, as the scene's own warnings are).
    fn scene_warnings(&self, _scene: &Scene) -> Vec<String> {
        Vec::new()
    }

    /// Renders `scene` within `budget`. A time budget continues the sample sequence until the
    /// time is spent (the same estimator as the sample budget it reaches); with a sampler that
    /// needs its sample count up front, a calibrated pilot (renders of 1, 2, 4, … samples per
    /// pixel with another seed, until one takes 2 % of the budget or all 4 %, and at least 10 ms
    /// or all 20 ms, below which timing noise dominated) measures the time
    /// per sample, and the render is `Budget::Samples(N)` with the N that fills the rest of the
    /// budget, rounded down to a count the sampler stratifies well (`best_sample_count`: no
    /// N-rooks fallback for `Stratified`, a multiple of the replicates; the pilot's counts are
    /// too). The pilot's time counts in `wall_seconds` (and is reported as `pilot_seconds`).
    fn render(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
    ) -> RenderOutput {
        match *budget {
            Budget::Seconds(seconds) if self.needs_sample_count() => {
                let start = Instant::now();
                let mut spp = self.replicates();
                let per_sample = loop {
                    let t0 = Instant::now();
                    self.render_passes(
                        scene,
                        &Budget::Samples(spp),
                        seed ^ PILOT_SEED,
                        &NoProgress,
                        &mut |_, _| true,
                    );
                    let dt = t0.elapsed().as_secs_f64();
                    if dt >= (0.02 * seconds).max(0.01)
                        || start.elapsed().as_secs_f64() >= (0.04 * seconds).max(0.02)
                        || spp >= 1 << 20
                    {
                        break dt / spp as f64;
                    }
                    spp *= 2;
                };
                let pilot = start.elapsed().as_secs_f64();
                let n = ((seconds - pilot) / per_sample.max(1e-12))
                    .round()
                    .clamp(1.0, u32::MAX as f64) as u32;
                let n = self.best_sample_count(n);
                let mut out =
                    self.render_passes(scene, &Budget::Samples(n), seed, progress, &mut |_, _| {
                        true
                    });
                out.stats.wall_seconds = start.elapsed().as_secs_f64();
                out.stats.pilot_seconds = pilot;
                out
            }
            _ => self.render_passes(scene, budget, seed, progress, &mut |_, _| true),
        }
    }
}

/// Seed offset of the pilot renders of a time budget.
const PILOT_SEED: u64 = 0x7069_6c6f_7421;
