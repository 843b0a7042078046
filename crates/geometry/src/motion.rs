//! Rigid motion of a shape over the shutter (distributed ray tracing's time dimension, Cook et al.
//! 1984; keyframed transforms as in pbrt-v4 §3.10 `AnimatedTransform`, restricted to rotation and
//! translation): a shape is stored once, at rest, and a ray at time t is moved into that rest frame.
//!
//! At time t the shape's rest points x are at M(t)·x = R(t)·(x − pivot) + pivot + T(t), with
//! T linearly interpolated and R spherically (slerp, the shorter arc) between the two keys around
//! t, and clamped to the first or last key outside them.

use crate::hit::Hit;
use crate::rotation::slerp;
use glam::{Mat3, Quat};
use lightlab_core::{Ray, Vec3, gamma};

/// One keyframe: the rigid transform that applies at `time`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionKey {
    pub time: f32,
    pub translate: Vec3,
    pub rotate: Quat,
}

/// Keyframed rigid motion; keys in strictly increasing time, at least two.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// The point rotations turn about (render space).
    pub pivot: Vec3,
    pub keys: Vec<MotionKey>,
}

/// The rigid map x ↦ r·x + c of one instant.
#[derive(Clone, Copy, Debug)]
pub struct RigidTransform {
    r: Mat3,
    c: Vec3,
}

impl Motion {
    /// `None` unless there are at least two keys with finite, strictly increasing times and finite
    /// transforms.
    pub fn new(pivot: Vec3, keys: Vec<MotionKey>) -> Option<Motion> {
        let finite = keys
            .iter()
            .all(|k| k.time.is_finite() && k.translate.is_finite() && k.rotate.is_finite());
        let increasing = keys.windows(2).all(|w| w[0].time < w[1].time);
        (keys.len() >= 2 && finite && increasing && pivot.is_finite())
            .then_some(Motion { pivot, keys })
    }

    /// The transform at time `t`. Its offset pivot + T − R·pivot is formed in f64: in f32 a pivot
    /// far from the shape (the file's origin, with the scene 10⁷ away) cancelled the translation
    /// to its float steps there (a 0.5 drop moved in steps of 1–2 units).
    pub fn at(&self, t: f32) -> RigidTransform {
        let (translate, rotate) = self.state(t);
        let r = Mat3::from_quat(rotate);
        let pivot = self.pivot.as_dvec3();
        RigidTransform {
            r,
            c: (pivot + translate.as_dvec3() - r.as_dmat3() * pivot).as_vec3(),
        }
    }

    /// Translation and rotation at time `t`, interpolated between the keys around it.
    fn state(&self, t: f32) -> (Vec3, Quat) {
        let keys = &self.keys;
        match keys.partition_point(|k| k.time <= t) {
            0 => (keys[0].translate, keys[0].rotate),
            i if i == keys.len() => (keys[i - 1].translate, keys[i - 1].rotate),
            i => {
                let (a, b) = (&keys[i - 1], &keys[i]);
                let s = (t - a.time) / (b.time - a.time);
                (
                    a.translate.lerp(b.translate, s),
                    slerp(a.rotate, b.rotate, s),
                )
            }
        }
    }

    /// A box containing every position of a rest-frame ball (centre `center`, radius `radius`) at
    /// any time in `[open, close]` (the shutter: keys outside it never show, so they must not
    /// widen the box, nor the scene's extent and the photon radii taken from it): rotations keep
    /// its centre at distance |center − pivot| from the pivot, and the translation, piecewise
    /// linear, stays in the box of its values at `open`, at `close` and at the keys between.
    pub fn swept_bounds(
        &self,
        center: Vec3,
        radius: f32,
        (open, close): (f32, f32),
    ) -> (Vec3, Vec3) {
        let inside = self.keys.iter().filter(|k| k.time > open && k.time < close);
        let at_open = self.state(open).0;
        let (lo, hi) = [at_open, self.state(close).0]
            .into_iter()
            .chain(inside.map(|k| k.translate))
            .fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), t| (lo.min(t), hi.max(t)),
            );
        // The interpolation rounds relative to the keys it starts from: those of the segments
        // that overlap the shutter, whose translations also bound every interpolated one.
        let first = self
            .keys
            .partition_point(|k| k.time <= open)
            .saturating_sub(1);
        let last = self
            .keys
            .partition_point(|k| k.time < close)
            .min(self.keys.len() - 1);
        let translations = self.keys[first..=last]
            .iter()
            .fold(Vec3::ZERO, |m, k| m.max(k.translate.abs()));
        let arm = (center - self.pivot).length();
        let turns = self.keys[first..=last]
            .windows(2)
            .any(|w| w[0].rotate != w[1].rotate);
        // Each box is padded for the rounding of the sums and of the rotation, relative to the
        // magnitudes involved.
        if turns {
            // The centre stays on the sphere of radius `arm` about the translated pivot.
            let pad = Vec3::splat(arm + radius) + self.pivot.abs() + translations;
            let reach = Vec3::splat(arm + radius) + pad * (4.0 * f32::EPSILON);
            (self.pivot + lo - reach, self.pivot + hi + reach)
        } else {
            // One rotation throughout: the centre only translates, R·centre + c(t) with c moving
            // as T does (a far pivot must not widen the box, nor the scene's extent and the
            // photon radii taken from it).
            let start = self.at(open);
            let at_rest = start.point(center) - at_open;
            let pad = center.abs() + Vec3::splat(radius) + start.c.abs() + translations;
            let reach = Vec3::splat(radius) + pad * (4.0 * f32::EPSILON);
            (at_rest + lo - reach, at_rest + hi + reach)
        }
    }
}

impl RigidTransform {
    /// M·x for a rest-frame point.
    #[inline]
    pub fn point(&self, x: Vec3) -> Vec3 {
        self.r * x + self.c
    }

    /// The rotation alone, for directions and normals.
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.r * v
    }

    /// The rotation as a quaternion.
    pub fn rotation(&self) -> Quat {
        Quat::from_mat3(&self.r).normalize()
    }

    /// The world ray `ray` in the rest frame: o' = rᵀ(o − c), d' = rᵀd (the same |d|, so the
    /// same t).
    #[inline]
    pub fn ray_to_rest(&self, ray: &Ray) -> Ray {
        let rt = self.r.transpose();
        Ray {
            o: rt * (ray.o - self.c),
            d: rt * ray.d,
            ..*ray
        }
    }

    /// A rest-frame hit moved to the world at this instant. The point's error bound grows by the
    /// rounding of this map and of the inverse map a ray spawned from it goes through (pbrt-v4
    /// §6.8.5 bounds transformed points the same way), so spawned rays stay off the surface.
    #[inline]
    pub fn hit_to_world(&self, h: Hit) -> Hit {
        let p = self.r * h.p + self.c;
        let abs_r = Mat3::from_cols(
            self.r.x_axis.abs(),
            self.r.y_axis.abs(),
            self.r.z_axis.abs(),
        );
        let magnitude = abs_r * h.p.abs() + self.c.abs() + p.abs();
        let p_error = abs_r * h.p_error + magnitude * gamma(8);
        Hit {
            p,
            p_error,
            ng: (self.r * h.ng).normalize(),
            ns: (self.r * h.ns).normalize(),
            dpdu: self.r * h.dpdu,
            ..h
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(time: f32, translate: Vec3, degrees: f32) -> MotionKey {
        MotionKey {
            time,
            translate,
            rotate: Quat::from_axis_angle(Vec3::Y, degrees.to_radians()),
        }
    }

    #[test]
    fn interpolates_between_keys_and_clamps_outside() {
        let m = Motion::new(
            Vec3::new(1.0, 0.0, 0.0),
            vec![
                key(0.0, Vec3::ZERO, 0.0),
                key(2.0, Vec3::new(0.0, 4.0, 0.0), 90.0),
            ],
        )
        .unwrap();
        let x = Vec3::new(2.0, 0.0, 0.0);
        let at = |t: f32| m.at(t).point(x);
        assert!((at(-1.0) - x).length() < 1e-6);
        // Halfway: 45° about y through the pivot, half the translation.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!(
            (at(1.0) - Vec3::new(1.0 + h, 2.0, -h)).length() < 1e-6,
            "{}",
            at(1.0)
        );
        assert!(
            (at(5.0) - Vec3::new(1.0, 4.0, -1.0)).length() < 1e-6,
            "{}",
            at(5.0)
        );
    }

    #[test]
    fn rejects_too_few_unordered_or_infinite_keys() {
        let k = key(0.0, Vec3::ZERO, 0.0);
        assert!(Motion::new(Vec3::ZERO, vec![k]).is_none());
        assert!(Motion::new(Vec3::ZERO, vec![k, k]).is_none());
        assert!(Motion::new(Vec3::ZERO, vec![k, key(f32::NAN, Vec3::ZERO, 0.0)]).is_none());
        assert!(Motion::new(Vec3::ZERO, vec![k, key(1.0, Vec3::ZERO, 0.0)]).is_some());
    }

    #[test]
    fn swept_bounds_contain_every_instant() {
        let m = Motion::new(
            Vec3::new(0.0, 1.0, 0.0),
            vec![
                key(0.0, Vec3::ZERO, 0.0),
                key(0.5, Vec3::new(3.0, 0.0, -1.0), 170.0),
                key(1.0, Vec3::new(-2.0, 1.0, 0.0), -90.0),
            ],
        )
        .unwrap();
        let (c, r) = (Vec3::new(2.0, 1.0, 0.5), 0.25);
        let (lo, hi) = m.swept_bounds(c, r, (0.0, 1.0));
        for i in 0..=1000 {
            let w = m.at(i as f32 / 1000.0).point(c);
            assert!((w - Vec3::splat(r)).cmpge(lo).all() && (w + Vec3::splat(r)).cmple(hi).all());
        }
    }

    /// Over part of the keys' time span (a shutter shorter than the animation) the box bounds
    /// every instant of that part and leaves out where the shape goes afterwards.
    #[test]
    fn swept_bounds_cover_only_the_shutter() {
        let m = Motion::new(
            Vec3::ZERO,
            vec![
                key(0.0, Vec3::ZERO, 0.0),
                key(1.0, Vec3::new(0.0, -0.5, 0.0), 60.0),
                key(2.0, Vec3::new(0.0, -0.5, 0.0), 60.0),
                key(3.0, Vec3::new(1000.0, -0.5, 0.0), 0.0),
            ],
        )
        .unwrap();
        let (c, r) = (Vec3::new(0.3, 0.2, 0.1), 0.1);
        for shutter in [
            (0.0, 1.0),
            (0.25, 0.75),
            (0.5, 2.5),
            (2.5, 2.5),
            (-1.0, 0.0),
        ] {
            let (lo, hi) = m.swept_bounds(c, r, shutter);
            for i in 0..=1000 {
                let t = shutter.0 + (shutter.1 - shutter.0) * i as f32 / 1000.0;
                let w = m.at(t).point(c);
                assert!(
                    (w - Vec3::splat(r)).cmpge(lo).all() && (w + Vec3::splat(r)).cmple(hi).all(),
                    "{shutter:?} at {t}: {w} outside {lo}..{hi}"
                );
            }
            let far = m.at(shutter.1).point(c).x + r + 0.5;
            assert!(
                hi.x < far.max(1.0),
                "{shutter:?}: reaches {} (the last key's 1000)",
                hi.x
            );
        }
    }

    /// A pivot far from the shape changes nothing for a motion that does not turn: the offset is
    /// exact (in f32 a pivot 10⁷ away rounded a 0.5 drop away), and the swept box hugs the shape's
    /// path instead of reaching around the pivot.
    #[test]
    fn a_far_pivot_neither_rounds_nor_widens_a_translation() {
        let pivot = Vec3::new(0.0, 1e7, 0.0);
        let m = Motion::new(
            pivot,
            vec![
                key(0.0, Vec3::ZERO, 30.0),
                key(1.0, Vec3::new(0.0, -0.5, 0.0), 30.0),
            ],
        )
        .unwrap();
        let c = Vec3::new(0.5, 0.0, 0.0);
        let drop = m.at(0.0).point(c) - m.at(1.0).point(c);
        assert!((drop - Vec3::new(0.0, 0.5, 0.0)).length() < 1e-6, "{drop}");
        let (lo, hi) = m.swept_bounds(c, 0.25, (0.0, 1.0));
        for i in 0..=100 {
            let w = m.at(i as f32 / 100.0).point(c);
            assert!(
                (w - Vec3::splat(0.25)).cmpge(lo).all() && (w + Vec3::splat(0.25)).cmple(hi).all()
            );
        }
        assert!((hi - lo).max_element() < 2.0, "{lo}..{hi}");
    }
}
