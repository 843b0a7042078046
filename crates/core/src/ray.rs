//! Rays with an explicit parametric extent.

use glam::Vec3;

/// A ray `o + t·d` for `t` in `(0, t_max)`. The origin is expected to be already offset off the surface
/// it leaves (see `lightlab_geometry::spawn_ray`), so no epsilon is applied at the near end.
/// `d` need not be normalised; `t` is in units of `|d|`. `time` is the instant within the camera's
/// shutter the ray samples (moving shapes are where they are then); rays spawned along a path keep
/// their path's time (see `Ray::at_time`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_max: f32,
    pub time: f32,
}

impl Ray {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray {
            o,
            d,
            t_max: f32::INFINITY,
            time: 0.0,
        }
    }
    #[inline]
    pub fn segment(o: Vec3, d: Vec3, t_max: f32) -> Ray {
        Ray {
            o,
            d,
            t_max,
            time: 0.0,
        }
    }
    /// The same ray at instant `time`.
    #[inline]
    pub fn at_time(self, time: f32) -> Ray {
        Ray { time, ..self }
    }
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}
