//! Lightlab's core vocabulary: RGB radiometry, orthonormal frames, rays, the transport mode and the
//! progress hook that integrators report through.
//!
//! Every other crate speaks these types; none of them does I/O.

mod frame;
mod progress;
mod ray;
mod rgb;

pub use frame::Frame;
pub use glam::{Vec2, Vec3, Vec3A};
pub use progress::{NoProgress, Progress};
pub use ray::Ray;
pub use rgb::Rgb;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Which quantity a path carries (Veach 1997, §5.2). Radiance flows from lights to the eye along camera
/// paths; importance flows the other way along light paths. Refraction scaling and the shading-normal
/// correction differ between the two, so BSDFs take the mode as a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// Floating-point rounding bound γₙ = n·ε/(1 − n·ε) of Higham (2002), as used by pbrt-v4 §6.8.1 for
/// conservative error bounds on computed intersection points.
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}
