//! Property tests of every `Bsdf` variant through the public API: sample/eval/pdf consistency,
//! normalisation, energy, reciprocity, chi-square tests of the sampled distributions (`chi2`),
//! exact tests of the delta BSDFs' samples (`delta`), robustness at extreme inputs, and the
//! `SurfaceBsdf` wrapper.
//!
//! All random numbers come from fixed seeds, so each test is deterministic; where a test is
//! statistical, its comment states the probability that a correct implementation would fail it for
//! a random seed.

mod chi2;
mod common;
mod consistency;
mod delta;
mod energy;
mod normalisation;
mod reciprocity;
mod robustness;
mod surface;
