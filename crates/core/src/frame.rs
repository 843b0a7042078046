//! Orthonormal shading frames. Local coordinates put the normal on +z, so cos θ = w.z.

use glam::Vec3;

/// An orthonormal basis (s, t, n).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around the unit vector `n` without branches on near-degenerate cases
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited", Listing 3).
    #[inline]
    pub fn from_z(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame with normal `n` whose first axis follows the tangent `dpdu` (Gram–Schmidt), so that
    /// anisotropic roughness has a defined orientation. Falls back to [`Frame::from_z`] for a
    /// degenerate tangent.
    #[inline]
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Frame {
        let s = dpdu - n * n.dot(dpdu);
        let len2 = s.length_squared();
        if !(len2 > 1e-12 * dpdu.length_squared().max(f32::MIN_POSITIVE)) || !len2.is_finite() {
            return Frame::from_z(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Awkward normals: poles, axes, and the near-(0,0,-1) case that breaks Frisvad's original method.
    const NORMALS: [Vec3; 6] = [
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::X,
        Vec3::Y,
        Vec3::new(0.0, 0.00049999994, -0.999_999_9),
        Vec3::new(0.57735026, -0.57735026, 0.57735026),
    ];

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in NORMALS {
            let n = n.normalize();
            let f = Frame::from_z(n);
            for (a, b) in [(f.s, f.t), (f.t, f.n), (f.s, f.n)] {
                assert!(a.dot(b).abs() < 1e-5, "not orthogonal for n = {n}");
            }
            for v in [f.s, f.t, f.n] {
                assert!((v.length() - 1.0).abs() < 1e-5, "not unit for n = {n}");
            }
            assert!(f.s.cross(f.t).dot(f.n) > 0.99, "left-handed for n = {n}");
            let w = Vec3::new(0.3, -0.5, 0.81).normalize();
            assert!((f.to_world(f.to_local(w)) - w).length() < 1e-5);
            assert!((f.to_local(n).z - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn tangent_frame_follows_tangent() {
        let f = Frame::from_normal_tangent(Vec3::Z, Vec3::new(2.0, 0.0, 0.5));
        assert!((f.s - Vec3::X).length() < 1e-6);
        assert!((f.t - Vec3::Y).length() < 1e-6);
        let g = Frame::from_normal_tangent(Vec3::Z, Vec3::Z);
        assert!(g.s.dot(Vec3::Z).abs() < 1e-6);
    }
}
