//! Spheres: robust intersection (pbrt-v4 §6.2.2 with the accurate discriminant of §6.8.3, from Haines
//! et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7), the surface at a hit with a
//! conservative error bound, and area / solid-angle (visible cone) sampling (pbrt-v4 §6.2.4).

use crate::sampling::{SurfaceSample, area_sample_to_solid_angle, pdf_area_to_solid_angle};
use glam::{DVec3, Mat3, Quat};
use lightlab_core::{Frame, PI, Vec2, Vec3, gamma};
use lightlab_samplers::warp;

/// A full sphere, oriented outwards.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    /// The rotation from the sphere's own frame to world space. It orients only the surface
    /// parameterisation (u, v) and ∂p/∂u — what textures and anisotropic roughness see.
    pub orientation: Quat,
}

/// Surface attributes at a sphere hit.
pub(crate) struct SphereSurface {
    pub p: Vec3,
    pub p_error: Vec3,
    pub n: Vec3,
    pub dpdu: Vec3,
    pub uv: Vec2,
}

impl Sphere {
    /// A sphere whose own frame is the world's.
    pub const fn new(center: Vec3, radius: f32) -> Sphere {
        Sphere {
            center,
            radius,
            orientation: Quat::IDENTITY,
        }
    }

    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    /// World-space point `center + p_obj` for a point `p_obj` on the sphere relative to its centre,
    /// with its error bound: γ₅·|p_obj| for the point in object space (pbrt-v4 §6.8.5, sphere), then
    /// the bound pbrt-v4 gives for applying the object-to-world translation to an inexact point
    /// (§6.8.5, "Effect of transformations"): (1 + γ₃)·err + γ₃·(|p_obj| + |center|). The |center| term keeps spheres far from
    /// the origin safe.
    pub fn world_point(&self, p_obj: Vec3) -> (Vec3, Vec3) {
        let obj_error = gamma(5) * p_obj.abs();
        let p_error = (1.0 + gamma(3)) * obj_error + gamma(3) * (p_obj.abs() + self.center.abs());
        (self.center + p_obj, p_error)
    }

    /// Closest root of the ray–sphere quadratic with `tol < t < t_max`, in double precision.
    /// Returns t and the ray origin relative to the centre.
    ///
    /// The discriminant is computed as 4a(r + |v|)(r − |v|), with v the vector from the centre to
    /// the closest point on the line (Ray Tracing Gems ch. 7), which stays accurate for far spheres
    /// and grazing rays. Roots within `tol` (10⁻⁹ of the scale of the problem, far above the f64
    /// rounding error and far below the f32 offsets of spawned rays) count as the origin itself, so
    /// a ray leaving the surface never re-hits it at t ≈ 0 (the role of pbrt's interval bounds).
    fn intersect_f64(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f64, DVec3, DVec3)> {
        let oi = o.as_dvec3() - self.center.as_dvec3();
        let d = d.as_dvec3();
        let r = self.radius as f64;
        let a = d.length_squared();
        if a.is_nan() || r.is_nan() || a <= 0.0 || r <= 0.0 {
            return None;
        }
        let b = 2.0 * d.dot(oi);
        let c = oi.length_squared() - r * r;
        let v = oi - (b / (2.0 * a)) * d;
        let len = v.length();
        let discrim = 4.0 * a * (r + len) * (r - len);
        if discrim.is_nan() || discrim < 0.0 {
            return None;
        }
        let root = discrim.sqrt();
        let q = if b < 0.0 {
            -0.5 * (b - root)
        } else {
            -0.5 * (b + root)
        };
        if q == 0.0 {
            return None;
        }
        let (t0, t1) = {
            let (x, y) = (q / a, c / q);
            if x <= y { (x, y) } else { (y, x) }
        };
        let tol = 1e-9 * (oi.length() + r) / a.sqrt();
        let t = if t0 > tol { t0 } else { t1 };
        (t > tol && t < t_max as f64 && (t as f32) < t_max).then_some((t, oi, d))
    }

    /// Ray parameter of the closest hit with `0 < t < t_max`.
    #[inline]
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
        self.intersect_f64(o, d, t_max).map(|(t, _, _)| t as f32)
    }

    /// The hit of ray (o, d) with `t < t_max` and its surface: the point is reprojected onto the
    /// sphere (pbrt-v4 §6.8.5) in double precision before rounding to f32.
    pub(crate) fn hit_surface(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, SphereSurface)> {
        let (t, oi, d) = self.intersect_f64(o, d, t_max)?;
        let r = self.radius as f64;
        let p64 = oi + t * d;
        let length = p64.length();
        let p_obj = (p64 * (r / length)).as_vec3();
        let (p, p_error) = self.world_point(p_obj);
        let n = (p64 / length).as_vec3();
        // Parameterisation in the sphere's own frame (Mitsuba 3's): u = φ / 2π, v = θ / π, so
        // v = 0 at the +z pole, and ∂p/∂u = 2π·(−y, x, 0) (pbrt-v4 §6.2.4 with φ_max = 2π).
        // The frame's matrix, built once for both rotations (as `crate::rotate` and `unrotate`
        // apply it: no fused multiply-adds, the same bits in every build).
        let frame = Mat3::from_quat(self.orientation);
        let mut q = frame.transpose() * p_obj;
        if q.x == 0.0 && q.y == 0.0 {
            q.x = 1e-5 * self.radius;
        }
        let mut phi = q.y.atan2(q.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let theta = (q.z / self.radius).clamp(-1.0, 1.0).acos();
        let surface = SphereSurface {
            p,
            p_error,
            n,
            dpdu: frame * Vec3::new(-2.0 * PI * q.y, 2.0 * PI * q.x, 0.0),
            uv: Vec2::new(phi / (2.0 * PI), theta / PI),
        };
        Some((t as f32, surface))
    }

    /// A point uniform on the sphere (pdf 1 / area).
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        let n = warp::square_to_uniform_sphere(u).normalize();
        let (p, p_error) = self.world_point(self.radius * n);
        SurfaceSample {
            p,
            p_error,
            n,
            pdf: 1.0 / self.area(),
        }
    }

    pub fn pdf_area(&self) -> f32 {
        1.0 / self.area()
    }

    /// The cone of directions from `ref_p` that hit the sphere: (sin² θmax, 1 − cos θmax, unit
    /// direction to the centre), or `None` when `ref_p` is inside the sphere or within 0.05 % of its
    /// radius from the surface. Points on the sphere itself (a hit rounded to just outside) must not
    /// take the cone: from there the cone's near intersections collapse onto `ref_p`, and the far
    /// side, which is what such a point sees, would never be sampled. Area sampling is valid there.
    /// 1 − cos θmax is computed as sin² θmax / (1 + cos θmax), exact in form for tiny cones of far
    /// spheres where 1 − cos θmax would cancel to zero.
    fn cone(&self, ref_p: Vec3) -> Option<(f32, f32, Vec3)> {
        let to_center = self.center - ref_p;
        let dc_sq = to_center.length_squared();
        let sin2_theta_max = self.radius * self.radius / dc_sq;
        if sin2_theta_max.is_nan() || sin2_theta_max >= 0.999 {
            return None;
        }
        let cos_theta_max = (1.0 - sin2_theta_max).sqrt();
        let one_minus_cos_theta_max = sin2_theta_max / (1.0 + cos_theta_max);
        Some((
            sin2_theta_max,
            one_minus_cos_theta_max,
            to_center / dc_sq.sqrt(),
        ))
    }

    /// A point on the sphere with its density in solid angle at `ref_p`: uniform over the cone of
    /// visible directions when `ref_p` is outside (pbrt-v4 §6.2.4), area sampling otherwise.
    pub fn sample_solid_angle(&self, ref_p: Vec3, u: Vec2) -> Option<SurfaceSample> {
        let Some((sin2_theta_max, one_minus_cos_theta_max, wc)) = self.cone(ref_p) else {
            return area_sample_to_solid_angle(self.sample_area(u), ref_p);
        };
        // Direction at angle θ from the axis, uniform in the cone; sin² θ from 1 − cos θ so that
        // tiny cones keep their precision.
        let one_minus_cos_theta = u.x * one_minus_cos_theta_max;
        let cos_theta = 1.0 - one_minus_cos_theta;
        let sin2_theta = one_minus_cos_theta * (2.0 - one_minus_cos_theta);
        let sin_theta = sin2_theta.sqrt();
        let sin_theta_max = sin2_theta_max.sqrt();
        // Angle α at the centre between −wc and the point where that direction first meets the
        // sphere. cos α is pbrt-v4's expression; sin α = (d_s / d_c)·sin θ / sin θmax (law of sines)
        // with d_s/d_c = cos θ − √(sin²θmax − sin²θ) = cos²θmax / (cos θ + √(sin²θmax − sin²θ)),
        // free of cancellation for both near and far spheres.
        let root = (sin2_theta_max - sin2_theta).max(0.0).sqrt();
        let cos_alpha = (sin2_theta + cos_theta * root) / sin_theta_max;
        let ds_over_dc = (1.0 - sin2_theta_max) / (cos_theta + root);
        let sin_alpha = ds_over_dc * sin_theta / sin_theta_max;
        let phi = 2.0 * PI * u.y;
        let frame = Frame::from_z(wc);
        let n = -frame
            .to_world(Vec3::new(
                sin_alpha * phi.cos(),
                sin_alpha * phi.sin(),
                cos_alpha,
            ))
            .normalize();
        let (p, p_error) = self.world_point(self.radius * n);
        Some(SurfaceSample {
            p,
            p_error,
            n,
            pdf: 1.0 / (2.0 * PI * one_minus_cos_theta_max),
        })
    }

    /// Density [`Sphere::sample_solid_angle`] has for the point `p` (normal `n`) seen from `ref_p`.
    pub fn pdf_solid_angle(&self, ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        match self.cone(ref_p) {
            Some((_, one_minus_cos_theta_max, _)) => 1.0 / (2.0 * PI * one_minus_cos_theta_max),
            None => pdf_area_to_solid_angle(self.pdf_area(), ref_p, p, n),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNIT: Sphere = Sphere::new(Vec3::ZERO, 1.0);

    #[test]
    fn hits_from_outside_and_inside() {
        let t = UNIT
            .intersect(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, f32::INFINITY)
            .unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        // Non-unit direction: t is in units of |d|.
        let t = UNIT
            .intersect(Vec3::new(0.0, 0.0, -3.0), 2.0 * Vec3::Z, f32::INFINITY)
            .unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        let t = UNIT
            .intersect(Vec3::new(0.0, 0.5, 0.0), Vec3::X, f32::INFINITY)
            .unwrap();
        assert!((t - 0.75f32.sqrt()).abs() < 1e-6);
        assert!(
            UNIT.intersect(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, 1.9)
                .is_none()
        );
        assert!(
            UNIT.intersect(Vec3::new(0.0, 0.0, 3.0), Vec3::Z, f32::INFINITY)
                .is_none()
        );
        let (_, s) = UNIT
            .hit_surface(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, f32::INFINITY)
            .unwrap();
        assert!((s.n - Vec3::NEG_Z).length() < 1e-6);
        assert!((s.uv.y - 1.0).abs() < 1e-6);
    }

    /// Mitsuba 3.9.1's sphere parameterisation, read off `ray_intersect` (benches/peers/mitsuba_texture_probe.py
    /// prints them): (o, d) → (u, v), ∂p/∂u; then a sphere rotated 90° about x.
    #[test]
    fn parameterisation_is_mitsubas() {
        let cases = [
            (
                Vec3::new(3.0, 0.01, 0.3),
                -Vec3::X,
                Vec2::new(0.0017, 0.403),
            ),
            (
                Vec3::new(0.01, 3.0, -0.3),
                -Vec3::Y,
                Vec2::new(0.2483, 0.597),
            ),
            (Vec3::new(-3.0, 0.01, 0.0), Vec3::X, Vec2::new(0.4984, 0.5)),
        ];
        for (o, d, uv) in cases {
            let (_, s) = UNIT.hit_surface(o, d, f32::INFINITY).unwrap();
            assert!((s.uv - uv).abs().max_element() < 1e-4, "{o}: {}", s.uv);
        }
        let (_, s) = UNIT
            .hit_surface(Vec3::new(-3.0, 0.01, 0.0), Vec3::X, f32::INFINITY)
            .unwrap();
        assert!((s.dpdu - Vec3::new(-0.0628, -6.2829, 0.0)).length() < 1e-3);
        let rotated = Sphere {
            orientation: Quat::from_rotation_x(0.5 * PI),
            ..UNIT
        };
        let (_, s) = rotated
            .hit_surface(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, f32::INFINITY)
            .unwrap();
        assert!((s.uv - Vec2::new(0.25, 0.5)).abs().max_element() < 1e-4);
        assert!((s.dpdu - Vec3::new(-2.0 * PI, 0.0, 0.0)).length() < 1e-4);
        let (_, s) = rotated
            .hit_surface(Vec3::new(3.0, 0.3, 0.01), -Vec3::X, f32::INFINITY)
            .unwrap();
        assert!((s.uv - Vec2::new(0.0017, 0.597)).abs().max_element() < 1e-4);
        assert!((s.dpdu - Vec3::new(-0.0628, 0.0, 5.9934)).length() < 1e-3);
    }

    #[test]
    fn grazing_rays_hit_or_miss_by_their_distance() {
        for k in (1..200).filter(|&k| k != 100) {
            let h = 1.0 + (k as f32 - 100.0) * 1e-4;
            let hit = UNIT
                .intersect(Vec3::new(-5.0, h, 0.0), Vec3::X, f32::INFINITY)
                .is_some();
            assert_eq!(hit, h < 1.0, "offset {h}");
        }
    }

    #[test]
    fn far_sphere_and_far_origin() {
        let s = Sphere::new(Vec3::splat(1e4), 1.0);
        let o = Vec3::new(1e4, 1e4, 1e4 - 1e6);
        let t = s.intersect(o, Vec3::Z, f32::INFINITY).unwrap();
        assert!((t - (1e6 - 1.0)).abs() < 0.1, "t = {t}");
        let (_, surf) = s.hit_surface(o, Vec3::Z, f32::INFINITY).unwrap();
        assert!(((surf.p - s.center).length() - 1.0).abs() <= surf.p_error.length());
        assert!((surf.n - Vec3::NEG_Z).length() < 1e-5);
        assert!(
            s.intersect(o + Vec3::new(1.01, 0.0, 0.0), Vec3::Z, f32::INFINITY)
                .is_none()
        );
    }

    /// From a point on the surface (rounded to either side), sampling must cover the inside of the
    /// sphere: ∫ cos θ dω over the visible sphere = π. A cone around the centre would cover nothing.
    #[test]
    fn solid_angle_sampling_from_the_surface_sees_the_inside() {
        let s = Sphere::new(Vec3::new(0.3, -0.2, 0.1), 1.0);
        for dir in [Vec3::X, Vec3::new(0.3, 0.4, -0.5).normalize()] {
            for nudge in [1.0f32 - 1e-6, 1.0, 1.0 + 1e-6] {
                let ref_p = s.center + dir * nudge;
                let n_in = -dir;
                let n = 64;
                let mut sum = 0.0f64;
                for i in 0..n {
                    for j in 0..n {
                        let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                        if let Some(q) = s.sample_solid_angle(ref_p, u) {
                            let cos = (q.p - ref_p).normalize().dot(n_in).max(0.0);
                            sum += (cos / q.pdf) as f64;
                        }
                    }
                }
                let estimate = sum / (n * n) as f64;
                assert!(
                    (estimate - PI as f64).abs() < 1e-2,
                    "{dir} × {nudge}: {estimate}"
                );
            }
        }
    }
}
