//! Sample generation for Monte Carlo integration: the [`Sampler`] trait and its implementations
//! ([`Independent`], [`Stratified`], [`LatinHypercube`], [`Halton`], [`Sobol`], chosen in settings by
//! [`SamplerConfig`]), deterministic seeding, warps from the unit square to the domains integrators
//! need, discrete and piecewise-constant distributions ([`Distribution1D`], [`Distribution2D`],
//! [`AliasTable`]), multiple-importance-sampling heuristics, and independent replicates of a
//! sampler for randomised quasi-Monte Carlo variance estimates ([`replicate_sample`]).
//!
//! Determinism (design.md): every value depends only on (seed, pixel, sample index, dimension) — or
//! (seed, photon index) — never on thread or tile order.

mod alias;
mod config;
mod distribution;
mod distribution2d;
pub mod halton;
mod independent;
pub mod latin;
pub mod lowdiscrepancy;
pub mod mis;
mod replicates;
mod seeding;
pub mod sobol;
pub mod stratified;
pub mod warp;

pub use alias::AliasTable;
pub use config::{SamplerConfig, SamplerVisitor};
pub use distribution::Distribution1D;
pub use distribution2d::Distribution2D;
pub use halton::Halton;
pub use independent::Independent;
pub use latin::LatinHypercube;
pub use replicates::replicate_sample;
pub use seeding::{hash_step, hash_u64s, pixel_stream, splitmix64};
pub use sobol::Sobol;
pub use stratified::Stratified;

use glam::Vec2;

/// A source of sample values in [0, 1). Used as a generic parameter so the hot calls inline.
///
/// Dimension layout of a camera path: pixel position (2D), lens (2D), then per bounce a fixed number
/// of dimensions in the order the integrator documents. Independent samplers ignore the layout; the
/// stratified and low-discrepancy samplers rely on it: `next_1d` consumes one dimension number and
/// `next_2d` two, a 2D pair being stratified jointly (a grid, a net) where the sampler can. Values
/// of sample i of a pixel are stratified across i = 0 … spp−1, so call `start_pixel_sample` with
/// every index of that range.
pub trait Sampler {
    /// Starts sample `sample_index` of `pixel` (an index into the film, row-major) for the run `seed`.
    fn start_pixel_sample(&mut self, seed: u64, pixel: u64, sample_index: u64);
    /// The next dimension, in [0, 1).
    fn next_1d(&mut self) -> f32;
    /// The next two dimensions, in [0, 1)².
    fn next_2d(&mut self) -> Vec2;
}
