//! Robust spawning of rays from surface points (pbrt-v4 §6.8.6, "Robust Spawned Ray Origins"): the
//! origin is pushed off the surface by the point's own error bound, never by a fixed epsilon, so the
//! same scene behaves the same at any scale and any distance from the world origin.

use glam::Vec3A;
use lightlab_core::{Ray, Vec3};

/// Fraction of a segment left out at its far end by [`spawn_ray_to`] and [`spawn_ray_to_point`]
/// (pbrt-v4's `ShadowEpsilon`). Relative to the segment, so scale-invariant.
const SHADOW_EPSILON: f32 = 1e-4;

/// pbrt-v4's `OffsetRayOrigin`: moves `p` along ±`ng` (to the side of `d`) by dot(|ng|, p_error),
/// the largest displacement of the true point along the normal that the error box allows, then
/// rounds each offset coordinate one float further away so the rounding of the addition cannot pull
/// the origin back into the error box.
#[inline]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, ng: Vec3, d: Vec3) -> Vec3 {
    let dist = ng.abs().dot(p_error);
    // −(dist·ng) = (−dist)·ng bit for bit: the sign is chosen without a branch.
    let dist = if d.dot(ng) < 0.0 { -dist } else { dist };
    // In four lanes (the fourth a zero offset, kept as is), so the compiler does the three
    // coordinates' bit steps side by side in one SIMD register.
    let offset = dist * Vec3A::from(ng);
    let po = Vec3A::from(p) + offset;
    let (po, offset) = (po.extend(0.0).to_array(), offset.extend(0.0).to_array());
    let stepped: [f32; 4] = std::array::from_fn(|i| step_away(po[i], offset[i]));
    Vec3::new(stepped[0], stepped[1], stepped[2])
}

/// `x.next_up()` for a positive `offset`, `x.next_down()` for a negative one, `x` for a zero
/// one, without branches: the coordinate's bits step by one away from zero when `x` has the
/// offset's sign (a zero `x` is taken with that sign), toward it otherwise. Non-finite `x` is
/// kept, as `next_up`/`next_down` keep +∞/−∞ and NaN (and −∞ → −MAX never arises: the offset
/// then points away from it).
#[inline(always)]
fn step_away(x: f32, offset: f32) -> f32 {
    let sign = offset.to_bits() & 0x8000_0000;
    let x_bits = if x == 0.0 { sign } else { x.to_bits() };
    let same_sign = (x_bits & 0x8000_0000) == sign;
    let stepped = f32::from_bits(if same_sign {
        x_bits.wrapping_add(1)
    } else {
        x_bits.wrapping_sub(1)
    });
    if offset == 0.0 || !x.is_finite() {
        x
    } else {
        stepped
    }
}

/// A ray leaving the surface point `p` (error bound `p_error`, geometric normal `ng`) in direction
/// `d`, with `t_max = ∞`.
#[inline]
pub fn spawn_ray(p: Vec3, p_error: Vec3, ng: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, p_error, ng, d), d)
}

/// The segment between two surface points for a visibility test, both ends offset off their
/// surfaces (pbrt-v4 `SpawnRayTo` between two interactions): `d = p1' − p0'`,
/// `t_max = 1 − ShadowEpsilon`.
#[inline]
pub fn spawn_ray_to(p0: Vec3, p0_error: Vec3, n0: Vec3, p1: Vec3, p1_error: Vec3, n1: Vec3) -> Ray {
    let from = offset_ray_origin(p0, p0_error, n0, p1 - p0);
    let to = offset_ray_origin(p1, p1_error, n1, from - p1);
    Ray::segment(from, to - from, 1.0 - SHADOW_EPSILON)
}

/// The segment from a surface point to a point with no surface (a point light):
/// `d = p1 − p0'`, `t_max = 1 − ShadowEpsilon`.
#[inline]
pub fn spawn_ray_to_point(p0: Vec3, p0_error: Vec3, n0: Vec3, p1: Vec3) -> Ray {
    let from = offset_ray_origin(p0, p0_error, n0, p1 - p0);
    Ray::segment(from, p1 - from, 1.0 - SHADOW_EPSILON)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_to_the_side_of_the_direction_by_the_error() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let err = Vec3::splat(1e-3);
        let up = offset_ray_origin(p, err, Vec3::Z, Vec3::new(0.3, 0.0, 1.0));
        assert!(up.z > p.z + 1e-3 && up.z < p.z + 1.1e-3);
        assert_eq!((up.x, up.y), (p.x, p.y));
        let down = offset_ray_origin(p, err, Vec3::Z, Vec3::new(0.3, 0.0, -1.0));
        assert!(down.z < p.z - 1e-3);
    }

    /// The branch-free step is `next_up` / `next_down` bit for bit, zeros, subnormals, the largest
    /// floats and infinities included.
    #[test]
    fn step_away_is_next_up_or_next_down() {
        let specials = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1.0,
            -1.0,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let randoms = (0..100_000).map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            f32::from_bits(state as u32)
        });
        for x in specials.into_iter().chain(randoms).filter(|x| !x.is_nan()) {
            for offset in [1e-3, -1e-3, 0.0, -0.0] {
                let expected = if offset > 0.0 {
                    x.next_up()
                } else if offset < 0.0 {
                    x.next_down()
                } else {
                    x
                };
                let expected = if x.is_infinite() { x } else { expected };
                assert_eq!(
                    step_away(x, offset).to_bits(),
                    expected.to_bits(),
                    "x = {x:e}, offset {offset}"
                );
            }
        }
    }

    #[test]
    fn segments_stop_short_of_their_end() {
        let r = spawn_ray_to(
            Vec3::ZERO,
            Vec3::splat(1e-6),
            Vec3::Y,
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::splat(1e-6),
            Vec3::NEG_Y,
        );
        assert!(r.o.y > 0.0 && r.at(1.0).y < 4.0);
        assert!(r.t_max < 1.0 && r.t_max > 0.999);
        let r = spawn_ray_to_point(Vec3::ZERO, Vec3::splat(1e-6), Vec3::Y, Vec3::Y);
        assert!((r.at(1.0) - Vec3::Y).length() < 1e-6);
    }
}
