//! Warps from the unit square to sampling domains, each as a triple: `square_to_x`, its density
//! `square_to_x_pdf` (in the measure of the target domain), and the inverse `x_to_square` where one
//! exists. Directions are in a local frame with the normal (or cone axis) on +z.

use glam::{Vec2, Vec3};
use lightlab_core::{INV_2PI, INV_4PI, INV_PI, PI};

/// Uniform point on the unit disk by Shirley and Chiu's concentric map (1997), which keeps
/// strata compact and is continuous, so stratification survives the warp.
#[inline]
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // θ = π/4·(y/x), or π/2 − φ with φ = π/4·(x/y), whose cosine and sine are φ's sine and
    // cosine: both from an angle in [−π/4, π/4].
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(PI / 4.0 * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_quarter(PI / 4.0 * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// Sine and cosine of |x| ≤ π/4 by the minimax polynomials of Cephes' `sinf`/`cosf` (Moshier
/// 1989) on that interval: within 2 ulps of the exact values (tested), and branch-free and
/// inlined, where the library's `sincosf` reduces any argument (it took 2.5 % of path tracing's
/// time in the concentric map of cosine sampling).
#[inline(always)]
fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let cos = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (sin, cos)
}

/// Density of [`square_to_concentric_disk`] per unit area.
#[inline]
pub fn square_to_concentric_disk_pdf(p: Vec2) -> f32 {
    if p.length_squared() <= 1.0 {
        INV_PI
    } else {
        0.0
    }
}

/// Inverse of [`square_to_concentric_disk`].
#[inline]
pub fn concentric_disk_to_square(p: Vec2) -> Vec2 {
    let r = p.length();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    let mut phi = p.y.atan2(p.x);
    if phi < -PI / 4.0 {
        phi += 2.0 * PI;
    }
    let (a, b) = if phi < PI / 4.0 {
        (r, phi * 4.0 / PI * r)
    } else if phi < 3.0 * PI / 4.0 {
        (-(phi - PI / 2.0) * 4.0 / PI * r, r)
    } else if phi < 5.0 * PI / 4.0 {
        (-r, -(phi - PI) * 4.0 / PI * r)
    } else {
        ((phi - 3.0 * PI / 2.0) * 4.0 / PI * r, -r)
    };
    (Vec2::new(a, b) + Vec2::ONE) * 0.5
}

/// Cosine-weighted hemisphere by Malley's method: project a uniform disk point up (pdf cos θ / π).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn square_to_cosine_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z > 0.0 { v.z * INV_PI } else { 0.0 }
}

#[inline]
pub fn cosine_hemisphere_to_square(v: Vec3) -> Vec2 {
    concentric_disk_to_square(Vec2::new(v.x, v.y))
}

/// Uniform direction on the upper hemisphere (pdf 1 / 2π): the "blind" strategy.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[inline]
pub fn square_to_uniform_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z >= 0.0 { INV_2PI } else { 0.0 }
}

#[inline]
pub fn uniform_hemisphere_to_square(v: Vec3) -> Vec2 {
    Vec2::new(v.z, wrap_phi(v) * INV_2PI)
}

/// Uniform direction on the unit sphere (pdf 1 / 4π).
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[inline]
pub fn square_to_uniform_sphere_pdf(_v: Vec3) -> f32 {
    INV_4PI
}

#[inline]
pub fn uniform_sphere_to_square(v: Vec3) -> Vec2 {
    Vec2::new((1.0 - v.z) * 0.5, wrap_phi(v) * INV_2PI)
}

/// Uniform direction in the cone of half-angle θmax around +z (pdf 1 / (2π(1 − cos θmax))).
/// Written with 1 − cos θ computed directly so that tiny cones (a far light) keep their precision.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let one_minus_cos = u.x * (1.0 - cos_theta_max);
    let z = 1.0 - one_minus_cos;
    let sin2 = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0);
    let r = sin2.sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[inline]
pub fn square_to_uniform_cone_pdf(v: Vec3, cos_theta_max: f32) -> f32 {
    // Membership by 1 − cos θ = (x² + y²)/(1 + z), as in the inverse: the rounded z alone has only a
    // few distinct values inside a tiny cone.
    let inside = if v.z > 0.0 {
        (v.x * v.x + v.y * v.y) / (1.0 + v.z) <= 1.0 - cos_theta_max
    } else {
        v.z >= cos_theta_max
    };
    if inside {
        1.0 / (2.0 * PI * (1.0 - cos_theta_max))
    } else {
        0.0
    }
}

/// 1 − cos θ is recovered as sin²θ / (1 + cos θ) = (x² + y²)/(1 + z) in the forward hemisphere:
/// 1 − z from the rounded z has only a few distinct values in a tiny cone.
#[inline]
pub fn uniform_cone_to_square(v: Vec3, cos_theta_max: f32) -> Vec2 {
    let one_minus_cos = if v.z > 0.0 {
        (v.x * v.x + v.y * v.y) / (1.0 + v.z)
    } else {
        1.0 - v.z
    };
    Vec2::new(one_minus_cos / (1.0 - cos_theta_max), wrap_phi(v) * INV_2PI)
}

/// Uniform barycentrics (b1, b2) on a triangle; b0 = 1 − b1 − b2 (pdf 2 per unit of barycentric
/// area, i.e. 1 / area on the triangle). Uses the square-root parameterisation (Osada et al. 2002).
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

#[inline]
pub fn square_to_uniform_triangle_pdf(b: Vec2) -> f32 {
    if b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 {
        2.0
    } else {
        0.0
    }
}

#[inline]
pub fn uniform_triangle_to_square(b: Vec2) -> Vec2 {
    let su = 1.0 - b.x;
    Vec2::new(su * su, if su > 0.0 { b.y / su } else { 0.5 })
}

/// Azimuth of `v` in [0, 2π).
#[inline]
fn wrap_phi(v: Vec3) -> f32 {
    let phi = v.y.atan2(v.x);
    if phi < 0.0 { phi + 2.0 * PI } else { phi }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> impl Iterator<Item = Vec2> {
        (0..32).flat_map(|i| {
            (0..32).map(move |j| Vec2::new((i as f32 + 0.37) / 32.0, (j as f32 + 0.61) / 32.0))
        })
    }

    /// The polynomials are within 2 ulps of f64's sine and cosine over [−π/4, π/4].
    #[test]
    fn sin_cos_quarter_is_accurate() {
        let n = 200_000;
        for k in 0..=n {
            let x = (-PI / 4.0) + (PI / 2.0) * k as f32 / n as f32;
            let (s, c) = sin_cos_quarter(x);
            let (es, ec) = (f64::from(x).sin(), f64::from(x).cos());
            // One ulp of a value in (2⁻ᵏ⁻¹, 2⁻ᵏ] … near 0 the sine's ulp is that of x.
            let ulp = |v: f64| f64::from(f32::EPSILON) * v.abs().max(f64::from(f32::MIN_POSITIVE));
            assert!(
                (f64::from(s) - es).abs() <= 2.0 * ulp(es),
                "sin {x}: {s} vs {es}"
            );
            assert!(
                (f64::from(c) - ec).abs() <= 2.0 * ulp(ec),
                "cos {x}: {c} vs {ec}"
            );
        }
    }

    #[test]
    fn inverses_round_trip() {
        for u in grid() {
            let close = |a: Vec2, what: &str| {
                assert!((a - u).abs().max_element() < 2e-4, "{what}: {u} -> {a}")
            };
            close(
                concentric_disk_to_square(square_to_concentric_disk(u)),
                "disk",
            );
            close(
                cosine_hemisphere_to_square(square_to_cosine_hemisphere(u)),
                "cosine hemisphere",
            );
            close(
                uniform_hemisphere_to_square(square_to_uniform_hemisphere(u)),
                "uniform hemisphere",
            );
            close(
                uniform_sphere_to_square(square_to_uniform_sphere(u)),
                "uniform sphere",
            );
            close(
                uniform_cone_to_square(square_to_uniform_cone(u, 0.3), 0.3),
                "cone",
            );
            close(
                uniform_triangle_to_square(square_to_uniform_triangle(u)),
                "triangle",
            );
        }
    }

    #[test]
    fn outputs_are_in_domain() {
        for u in grid() {
            assert!(square_to_concentric_disk(u).length() <= 1.0 + 1e-6);
            for v in [
                square_to_cosine_hemisphere(u),
                square_to_uniform_hemisphere(u),
                square_to_uniform_sphere(u),
            ] {
                assert!((v.length() - 1.0).abs() < 1e-5);
            }
            assert!(square_to_cosine_hemisphere(u).z >= 0.0);
            assert!(square_to_uniform_cone(u, 0.9).z >= 0.9 - 1e-6);
            let b = square_to_uniform_triangle(u);
            assert!(square_to_uniform_triangle_pdf(b) > 0.0);
        }
        // Tiny cone: the sampled direction stays inside and unit length.
        let v = square_to_uniform_cone(Vec2::new(0.999, 0.3), 1.0 - 1e-7);
        assert!((v.length() - 1.0).abs() < 1e-6 && v.z >= 1.0 - 2e-7);
    }
}
