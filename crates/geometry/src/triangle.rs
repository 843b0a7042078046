//! Ray–triangle intersection: the watertight test of Woop, Benthin and Wald (2013, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1)) in the form of pbrt-v4 §6.5.3, with pbrt's conservative
//! check that t is positive, and the reconstruction of the surface point from barycentrics.

use lightlab_core::{Vec2, Vec3, gamma};

/// Per-ray constants of the watertight test: the axis permutation that makes the largest
/// direction component z, and the shear that maps the direction onto +z (Woop et al. §3).
#[derive(Clone, Copy, Debug)]
pub(crate) struct WatertightRay {
    o: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl WatertightRay {
    /// `None` for a zero or non-finite direction.
    #[inline]
    pub(crate) fn new(o: Vec3, d: Vec3) -> Option<WatertightRay> {
        let kz = d.abs().max_position();
        let kx = if kz == 2 { 0 } else { kz + 1 };
        let ky = if kx == 2 { 0 } else { kx + 1 };
        let dz = d[kz];
        if dz == 0.0 || !d.is_finite() || !o.is_finite() {
            return None;
        }
        Some(WatertightRay {
            o,
            kx,
            ky,
            kz,
            sx: -d[kx] / dz,
            sy: -d[ky] / dz,
            sz: 1.0 / dz,
        })
    }

    /// The axis permutation (x, y, z), the origin and the shear (sx, sy, sz), for the packet test.
    #[inline(always)]
    pub(crate) fn parts(&self) -> ([usize; 3], [f32; 3], [f32; 3]) {
        (
            [self.kx, self.ky, self.kz],
            self.o.to_array(),
            [self.sx, self.sy, self.sz],
        )
    }

    /// Vertex translated to the ray origin, permuted and sheared (z is left unscaled, as in pbrt).
    #[inline(always)]
    fn transform(&self, v: Vec3) -> Vec3 {
        let p = v - self.o;
        let z = p[self.kz];
        Vec3::new(p[self.kx] + self.sx * z, p[self.ky] + self.sy * z, z)
    }
}

/// Barycentric coordinates and parameter of a ray–triangle hit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriangleHit {
    pub t: f32,
    pub b: [f32; 3],
}

/// Watertight intersection with the triangle `v` for `t` in `(0, t_max]`; `t` is guaranteed
/// positive beyond its floating-point error (pbrt-v4 §6.8.7), so rays leaving a surface through
/// [`crate::spawn_ray`] never re-hit it. Degenerate (zero-area) triangles are never hit.
#[inline(always)]
pub(crate) fn intersect(ray: &WatertightRay, v: &[Vec3; 3], t_max: f32) -> Option<TriangleHit> {
    let mut p0 = ray.transform(v[0]);
    let mut p1 = ray.transform(v[1]);
    let mut p2 = ray.transform(v[2]);

    // Edge functions. Shared edges are evaluated identically by both triangles, which is what
    // makes the test watertight; exact zeros are re-evaluated in double precision (Woop §4).
    let mut e0 = p1.x * p2.y - p1.y * p2.x;
    let mut e1 = p2.x * p0.y - p2.y * p0.x;
    let mut e2 = p0.x * p1.y - p0.y * p1.x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        let dop = |a: Vec3, b: Vec3| (a.x as f64 * b.y as f64 - a.y as f64 * b.x as f64) as f32;
        e0 = dop(p1, p2);
        e1 = dop(p2, p0);
        e2 = dop(p0, p1);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }

    // The depths in length units, before they are scaled into units of t.
    let max_zl = p0.z.abs().max(p1.z.abs()).max(p2.z.abs());
    p0.z *= ray.sz;
    p1.z *= ray.sz;
    p2.z *= ray.sz;
    let t_scaled = e0 * p0.z + e1 * p1.z + e2 * p2.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }

    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;

    // Conservative check that t > 0 (pbrt-v4 §6.8.7, "Ensure that computed triangle t is
    // conservatively greater than zero"). The sheared x and y carry the rounding of x + Sx·z with
    // |Sx| ≤ 1 and z in length units, so their bounds take the unscaled depths `max_zl`; pbrt
    // takes the depths scaled by 1/d_z, the same for a unit direction but in units of t for a
    // segment d = p1 − p0, whose bound then held a fixed γ₅ and grew as 1/|d|: in a scene 10⁻⁶
    // across, shadow rays ignored occluders in the first tenth of their segment.
    let max_zt = p0.z.abs().max(p1.z.abs()).max(p2.z.abs());
    let delta_z = gamma(3) * max_zt;
    let max_xt = p0.x.abs().max(p1.x.abs()).max(p2.x.abs());
    let max_yt = p0.y.abs().max(p1.y.abs()).max(p2.y.abs());
    let delta_x = gamma(5) * (max_xt + max_zl);
    let delta_y = gamma(5) * (max_yt + max_zl);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t =
        3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    if t <= delta_t {
        return None;
    }

    Some(TriangleHit {
        t,
        b: [e0 * inv_det, e1 * inv_det, e2 * inv_det],
    })
}

/// Geometric normal `normalize(cross(p1 − p0, p2 − p0))`; `None` for a degenerate triangle.
#[inline]
pub fn geometric_normal(v: &[Vec3; 3]) -> Option<Vec3> {
    (v[1] - v[0]).cross(v[2] - v[0]).try_normalize()
}

/// Point at barycentrics `b` with its error bound γₙ·Σ|bᵢ pᵢ| (pbrt-v4 §6.8.5: n = 7 for hit points,
/// n = 6 for sampled points).
#[inline]
pub fn point_with_error(v: &[Vec3; 3], b: [f32; 3], n: i32) -> (Vec3, Vec3) {
    let (q0, q1, q2) = (b[0] * v[0], b[1] * v[1], b[2] * v[2]);
    let p = q0 + q1 + q2;
    let err = gamma(n) * (q0.abs() + q1.abs() + q2.abs());
    (p, err)
}

/// ∂p/∂u of the triangle under the parameterisation `uv` (pbrt-v4 §6.5.3, "Compute triangle
/// partial derivatives"); an arbitrary tangent of `ng` when the parameterisation is degenerate.
#[inline]
pub(crate) fn dpdu(v: &[Vec3; 3], uv: &[Vec2; 3], ng: Vec3) -> Vec3 {
    let duv02 = uv[0] - uv[2];
    let duv12 = uv[1] - uv[2];
    let dp02 = v[0] - v[2];
    let dp12 = v[1] - v[2];
    let determinant = duv02.x * duv12.y - duv02.y * duv12.x;
    if determinant.abs() >= 1e-9 {
        let inv = 1.0 / determinant;
        let dpdu = (duv12.y * dp02 - duv02.y * dp12) * inv;
        let dpdv = (duv02.x * dp12 - duv12.x * dp02) * inv;
        if dpdu.cross(dpdv).length_squared() > 0.0 && dpdu.is_finite() {
            return dpdu;
        }
    }
    lightlab_core::Frame::from_z(ng).s
}

/// The (u, v) of a triangle without texture coordinates: its barycentric coordinates (b₁, b₂), as
/// in Mitsuba 3 (pbrt's (1, 1) for the third vertex gives the same ∂p/∂u).
pub(crate) const DEFAULT_UV: [Vec2; 3] = [
    Vec2::new(0.0, 0.0),
    Vec2::new(1.0, 0.0),
    Vec2::new(0.0, 1.0),
];

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn hits_inside_and_reports_barycentrics() {
        let ray = WatertightRay::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0)).unwrap();
        let h = intersect(&ray, &tri(), f32::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!((h.b[0] - 0.25).abs() < 1e-6);
        assert!((h.b[1] - 0.25).abs() < 1e-6);
        assert!((h.b[2] - 0.5).abs() < 1e-6);
        // Beyond t_max, behind the origin, outside the edges.
        assert!(intersect(&ray, &tri(), 1.5).is_none());
        let back = WatertightRay::new(Vec3::new(0.25, 0.5, 2.0), Vec3::Z).unwrap();
        assert!(intersect(&back, &tri(), f32::INFINITY).is_none());
        let out = WatertightRay::new(Vec3::new(0.75, 0.5, 2.0), Vec3::NEG_Z).unwrap();
        assert!(intersect(&out, &tri(), f32::INFINITY).is_none());
    }

    #[test]
    fn degenerate_triangles_are_never_hit() {
        let line = [Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0)];
        let point = [Vec3::ONE; 3];
        for k in 0..200 {
            let a = k as f32 * 0.1;
            let d = Vec3::new(a.cos(), a.sin(), 0.3 * a.sin() - 0.9).normalize();
            let o = Vec3::new(0.5, 0.0, 0.0) - d;
            let ray = WatertightRay::new(o, d).unwrap();
            assert!(intersect(&ray, &line, f32::INFINITY).is_none());
            assert!(intersect(&ray, &point, f32::INFINITY).is_none());
        }
        assert!(geometric_normal(&line).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays aimed exactly at the diagonal
        // must hit at least one of them.
        let a = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let b = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        for k in 1..1000 {
            let s = k as f32 / 1000.0;
            let target = Vec3::new(s, s, 0.0);
            let o = Vec3::new(0.3, -0.7, 1.3) * (1.0 + s);
            let ray = WatertightRay::new(o, target - o).unwrap();
            let hit_a = intersect(&ray, &a, f32::INFINITY).is_some();
            let hit_b = intersect(&ray, &b, f32::INFINITY).is_some();
            assert!(hit_a || hit_b, "crack at s = {s}");
        }
    }
}
