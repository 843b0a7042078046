//! Rotations by unit quaternions in plain f32 arithmetic, so that every build rounds them alike.
//!
//! glam's own `Quat × Vec3`, `Quat::slerp` and `Vec3A::cross` use a fused multiply-add when the
//! target has one (`cfg(target_feature = "fma")`), so a build for an AVX2 or AVX-512 CPU rounded
//! motion blur and oriented spheres differently from the portable build. Here a rotation goes
//! through its matrix (glam's `Mat3` is scalar code: separate products and sums, which Rust never
//! fuses), and slerp is written out.

use glam::{Mat3, Quat, Vec3, Vec4};

/// `q` applied to `v` (q a unit quaternion).
#[inline]
pub fn rotate(q: Quat, v: Vec3) -> Vec3 {
    Mat3::from_quat(q) * v
}

/// The inverse rotation of [`rotate`]: the transposed matrix.
#[inline]
pub fn unrotate(q: Quat, v: Vec3) -> Vec3 {
    Mat3::from_quat(q).transpose() * v
}

/// Spherical linear interpolation from `a` (s = 0) to `b` (s = 1) along the shorter arc (Shoemake
/// 1985), with the weights written through sin(x)/x as pbrt-v4's `Slerp` writes them: they stay
/// accurate as the angle between the keys goes to zero, so no linear fallback is needed. The result
/// is normalised.
pub fn slerp(a: Quat, b: Quat, s: f32) -> Quat {
    let (a, mut b) = (Vec4::from(a), Vec4::from(b));
    let mut cos_theta = a.dot(b);
    // q and −q are the same rotation: take the one nearer a.
    if cos_theta < 0.0 {
        b = -b;
        cos_theta = -cos_theta;
    }
    let theta = cos_theta.min(1.0).acos();
    let norm = sin_x_over_x(theta);
    let wa = (1.0 - s) * sin_x_over_x((1.0 - s) * theta) / norm;
    let wb = s * sin_x_over_x(s * theta) / norm;
    Quat::from_vec4(a * wa + b * wb).normalize()
}

/// sin(x) / x, by its Taylor series 1 − x²/6 where that is exact in f32 (pbrt-v4's `SinXOverX`).
fn sin_x_over_x(x: f32) -> f32 {
    if 1.0 - x * x == 1.0 { 1.0 } else { x.sin() / x }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn rotations_match_glam_and_invert() {
        let q = Quat::from_axis_angle(Vec3::new(1.0, -2.0, 0.5).normalize(), 1.1);
        for v in [
            Vec3::X,
            Vec3::new(0.3, -4.0, 2.5),
            Vec3::new(-1e3, 2e-3, 7.0),
        ] {
            let tol = 4.0 * f32::EPSILON * v.abs().max_element();
            assert!(close(rotate(q, v), q * v, tol), "{v}");
            assert!(close(unrotate(q, v), q.inverse() * v, tol), "{v}");
            assert!(close(unrotate(q, rotate(q, v)), v, tol), "{v}");
        }
    }

    #[test]
    fn slerp_turns_at_a_constant_rate_along_the_shorter_arc() {
        let axis = Vec3::new(0.2, 1.0, -0.4).normalize();
        for angle in [0.0, 1e-6, 1e-3, 0.7, 2.0, 0.999 * PI] {
            let (a, b) = (Quat::IDENTITY, Quat::from_axis_angle(axis, angle));
            for s in [0.0, 0.25, 0.5, 1.0] {
                let want = Quat::from_axis_angle(axis, s * angle);
                let got = slerp(a, b, s);
                assert!(
                    got.dot(want).abs() > 1.0 - 1e-6,
                    "{angle} {s}: {got} {want}"
                );
                // −b is the same rotation: the same path.
                assert!(slerp(a, -b, s).dot(want).abs() > 1.0 - 1e-6, "{angle} {s}");
            }
        }
        // Keys a full turn apart in angle (3π/2 one way is π/2 the other): the shorter way.
        let b = Quat::from_axis_angle(axis, 1.5 * PI);
        let half = slerp(Quat::IDENTITY, b, 0.5);
        assert!(half.dot(Quat::from_axis_angle(axis, -0.25 * PI)).abs() > 1.0 - 1e-6);
    }
}
