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
pub mod path;
mod render;

pub use config::{BdptConfig, IntegratorConfig, LightConfig, Mis, Strategy};
pub use film::{Film, PixelSums};
pub use render::{Budget, RenderOutput, RenderStats};

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
}
