//! Light-transport integrators. Each estimates the pixel measurements I_j = ∫ W_j L dA dω of a scene
//! and returns a [`Film`] with per-pixel means and variances plus [`RenderStats`].
//!
//! Conventions (design.md): `max_bounces` counts scattering vertices between light and eye, so 0 is
//! emission seen directly, 1 direct lighting, k the Neumann series truncated after k terms;
//! `min_bounces` drops the lower terms. Non-finite contributions are counted and kept out of the film.
//! Nothing here does I/O.

pub mod bdpt;
mod config;
mod film;
pub mod light;
mod nee;
pub mod path;
pub mod paths;
pub mod photon;
mod render;
mod roulette;

pub use config::{BdptConfig, IntegratorConfig, LightConfig, Mis, Strategy};
pub use film::{Film, PixelSums};
pub use photon::config::{
    Gather, Indirect, Length, PhotonMapConfig, ProgressiveConfig, RadiusUpdate,
};
pub use photon::map::Kernel;
pub use render::{Budget, Counters, RenderOutput, RenderStats};

use lightlab_core::Progress;
use lightlab_scene::Scene;

/// A rendering algorithm, configured and ready to run.
pub trait Integrator: Send + Sync {
    /// Renders `scene` within `budget`. Random numbers depend only on `seed` and what is being
    /// sampled, so the result is bit-identical for any thread count.
    fn render(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
    ) -> RenderOutput;

    /// Whether the image improves pass by pass from one state (progressive photon mapping), so
    /// that [`Integrator::render_passes`] is the way to give it more time; otherwise independent
    /// renders can simply be merged.
    fn progressive(&self) -> bool {
        false
    }

    /// Renders like [`Integrator::render`], calling `on_pass(samples_done, film)` with the image
    /// so far whenever the integrator has one — after every pass for progressive photon mapping,
    /// so that a convergence curve or an equal-time run comes from one render; `on_pass`
    /// returning false stops there. The default reports the final image only.
    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let out = self.render(scene, budget, seed, progress);
        on_pass(budget.spp, &out.film);
        out
    }
}
