//! Experiments and everything that touches files: the samplers' convergence study ([`convergence`]); experiment files and their expansion into runs
//! ([`desc`], [`plan`]), cached references ([`reference`]), error metrics ([`metrics`], ꟻLIP in [`perceptual`]), the
//! resumable, shardable runner ([`runner`]), tables, plots and the HTML report ([`report`], [`plot`], [`html`]), image
//! input/output (OpenEXR, PNG previews) and atomic writes.

pub mod atomic;
pub mod compare;
pub mod convergence;
pub mod desc;
pub mod html;
pub mod image_io;
pub mod metrics;
pub mod perceptual;
pub mod plan;
pub mod plot;
pub mod reference;
pub mod report;
pub mod runner;
