//! Photon mapping: photon tracing into a kd-tree photon map (`trace`, `map`), the camera walk to
//! visible points (`camera`), Jensen's two-pass method (`pm`) and its progressive, consistent
//! variants PPM and SPPM (`progressive`).
//!
//! Bounces mean what they mean for every integrator: a photon that has made k scattering vertices
//! (the one it is stored at included), gathered at a visible point d vertices from the camera,
//! completes a path of k + d − 1 scattering vertices, and only photons whose completed path lies
//! within `min_bounces ..= max_bounces` are used.

pub(crate) mod camera;
pub mod config;
pub mod grid;
pub mod map;
pub(crate) mod pm;
pub(crate) mod progressive;
pub mod trace;
