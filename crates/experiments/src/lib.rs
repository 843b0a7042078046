//! Everything that touches files: image input/output (OpenEXR, PNG previews) and atomic writes.
//! The experiment runner (sweeps, references, metrics, plots) grows here.

pub mod atomic;
pub mod image_io;
