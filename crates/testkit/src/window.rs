//! Gnomonic windows: a rectangle of directions around a centre direction, mapped onto the unit
//! square so that a narrow or elongated set of directions — a near-specular lobe, the cone of a
//! distant sphere, a camera frustum — can be chi-square tested on [`Domain::Square`] at full
//! resolution instead of falling into a few cells of [`Domain::Sphere`].
//!
//! The gnomonic (central) projection maps a direction ω with ω·c > 0 to the point
//! (s, t) = (ω·e₁, ω·e₂) / (ω·c) of the plane tangent to the unit sphere at c. The window is the
//! rectangle |s| ≤ h₁, |t| ≤ h₂, mapped affinely onto the unit square:
//! p = ((s/h₁ + 1)/2, (t/h₂ + 1)/2). A plane point at distance r = √(1 + s² + t²) from the origin
//! is seen at cos = 1/r from the plane's normal, so dω = cos/r² ds dt = ds dt / (1 + s² + t²)^{3/2},
//! and a solid-angle density p_ω becomes p_ω · 4h₁h₂ / (1 + s² + t²)^{3/2} per unit area of the
//! square ([`DirectionWindow::density`]). Great circles are straight lines in this chart, so the
//! edges of a frustum or of a polygon seen from a point stay straight.
//!
//! Directions outside the window are mapped to `None`: a test treats them as rejected draws, so
//! the window's pdf integral must equal the fraction of draws that land in it — which it does
//! when the density is right. All arithmetic is in f64; only the sample and the direction handed
//! to the pdf are f32.
//!
//! ```
//! use glam::{DVec3, Vec2};
//! use lightlab_samplers::warp::{square_to_uniform_cone, square_to_uniform_cone_pdf};
//! use lightlab_testkit::{Chi2Test, Domain, DirectionWindow};
//!
//! // A cone of half-angle 0.05 rad around +z: the window is its bounding square.
//! let cos_max = 0.05f32.cos();
//! let window = DirectionWindow::new(DVec3::Z, DVec3::X, (0.06, 0.06));
//! Chi2Test::new(Domain::Square)
//!     .samples(100_000)
//!     .run(
//!         "window_doc",
//!         |u: Vec2| window.to_square(square_to_uniform_cone(u, cos_max)),
//!         |p: Vec2| window.density(p, |w| square_to_uniform_cone_pdf(w, cos_max)),
//!     )
//!     .assert_ok();
//! ```
//!
//! [`Domain::Square`]: crate::Domain::Square
//! [`Domain::Sphere`]: crate::Domain::Sphere

use glam::{DMat2, DVec2, DVec3, Vec2, Vec3};

/// A rectangle of directions in the gnomonic chart around a centre direction. See the
/// [module docs](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionWindow {
    c: DVec3,
    e1: DVec3,
    e2: DVec3,
    half: DVec2,
}

impl DirectionWindow {
    /// The window around `centre` whose first axis is `axis` projected onto the tangent plane
    /// (any tangent when `axis` is parallel to `centre`), with half-widths (h₁, h₂) in the
    /// tangent plane (tangents of the angles from the centre along the axes). Panics on a zero
    /// centre or a half-width that is not positive and finite.
    pub fn new(centre: DVec3, axis: DVec3, half_widths: (f64, f64)) -> DirectionWindow {
        let c = centre.normalize();
        assert!(c.is_finite(), "window centre {centre} has no direction");
        let (h1, h2) = half_widths;
        assert!(
            h1 > 0.0 && h2 > 0.0 && h1.is_finite() && h2.is_finite(),
            "window half-widths must be positive, got ({h1}, {h2})"
        );
        let e1 = (axis - c * c.dot(axis))
            .try_normalize()
            .unwrap_or_else(|| c.any_orthonormal_vector());
        DirectionWindow {
            c,
            e1,
            e2: c.cross(e1),
            half: DVec2::new(h1, h2),
        }
    }

    /// The window that frames the lobe of a direction map ω(δ) of a 2D parameter δ (such as a
    /// microfacet slope) spread with scale `scales` (such as (αx, αy)) around δ = 0: centred on
    /// ω(0), with axes along the principal axes of J·diag(scales), J = ∂(s, t)/∂δ at 0 (central
    /// differences in f64), and half-widths `k` times the principal scales, capped at 1 (45°).
    /// `None` when ω(0) does not exist or the lobe is degenerate.
    pub fn around_lobe(
        map: impl Fn(DVec2) -> Option<DVec3>,
        scales: (f64, f64),
        k: f64,
    ) -> Option<DirectionWindow> {
        let c = map(DVec2::ZERO)?.normalize();
        let (b1, b2) = c.any_orthonormal_pair();
        let chart = |w: DVec3| {
            let z = w.dot(c);
            DVec2::new(w.dot(b1), w.dot(b2)) / z
        };
        let h = 1e-7 * scales.0.max(scales.1).max(1e-6);
        let derivative = |d: DVec2| -> Option<DVec2> {
            let plus = chart(map(d * h)?.normalize());
            let minus = chart(map(-d * h)?.normalize());
            Some((plus - minus) / (2.0 * h))
        };
        let j = DMat2::from_cols(derivative(DVec2::X)?, derivative(DVec2::Y)?);
        let m = j * DMat2::from_diagonal(DVec2::new(scales.0, scales.1));
        // Principal axes: eigenvectors of the symmetric M·Mᵀ.
        let s = m * m.transpose();
        let (a, b, d) = (s.x_axis.x, s.x_axis.y, s.y_axis.y);
        let mean = 0.5 * (a + d);
        let root = (0.25 * (a - d) * (a - d) + b * b).sqrt();
        let (l1, l2) = (mean + root, (mean - root).max(0.0));
        let v1 = if b.abs() > 1e-300 {
            DVec2::new(l1 - d, b).normalize()
        } else if a >= d {
            DVec2::X
        } else {
            DVec2::Y
        };
        let (h1, h2) = ((k * l1.sqrt()).min(1.0), (k * l2.sqrt()).min(1.0));
        if !(h1 > 0.0 && h2 > 0.0 && v1.is_finite()) {
            return None;
        }
        Some(DirectionWindow::new(c, b1 * v1.x + b2 * v1.y, (h1, h2)))
    }

    /// The centre direction.
    pub fn centre(&self) -> DVec3 {
        self.c
    }

    /// The window's axes in the tangent plane.
    pub fn axes(&self) -> (DVec3, DVec3) {
        (self.e1, self.e2)
    }

    /// (h₁, h₂).
    pub fn half_widths(&self) -> (f64, f64) {
        (self.half.x, self.half.y)
    }

    /// The point of the unit square for direction `w` (need not be unit length), or `None` when
    /// `w` is outside the window or not finite.
    pub fn to_square(&self, w: Vec3) -> Option<Vec2> {
        let w = w.as_dvec3();
        let z = w.dot(self.c);
        if !(z > 0.0) {
            return None;
        }
        let st = DVec2::new(w.dot(self.e1), w.dot(self.e2)) / (z * self.half);
        (st.abs().max_element() <= 1.0).then(|| ((st + 1.0) * 0.5).as_vec2())
    }

    /// The unit direction at point `p` of the unit square, and dω/dA there (solid angle per unit
    /// area of the square).
    pub fn direction(&self, p: Vec2) -> (Vec3, f64) {
        let (w, jacobian) = self.direction_f64(p);
        (w.as_vec3(), jacobian)
    }

    /// [`direction`](DirectionWindow::direction) before rounding to f32: for densities that vary
    /// faster than an f32 direction can resolve (a lobe a few ulps wide in some component).
    pub fn direction_f64(&self, p: Vec2) -> (DVec3, f64) {
        let st = (p.as_dvec2() * 2.0 - 1.0) * self.half;
        let r2 = 1.0 + st.length_squared();
        let w = (self.c + self.e1 * st.x + self.e2 * st.y) / r2.sqrt();
        (w, 4.0 * self.half.x * self.half.y / (r2 * r2.sqrt()))
    }

    /// The density per unit area of the square of directions distributed with solid-angle density
    /// `pdf_w`: `pdf_w(ω(p)) · dω/dA`.
    pub fn density(&self, p: Vec2, pdf_w: impl Fn(Vec3) -> f32) -> f32 {
        let (w, jacobian) = self.direction(p);
        (pdf_w(w) as f64 * jacobian) as f32
    }

    /// [`density`](DirectionWindow::density) for a solid-angle density evaluated in f64.
    pub fn density_f64(&self, p: Vec2, pdf_w: impl Fn(DVec3) -> f64) -> f32 {
        let (w, jacobian) = self.direction_f64(p);
        (pdf_w(w) * jacobian) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_solid_angle() {
        let window = DirectionWindow::new(
            DVec3::new(0.3, -0.5, 0.8),
            DVec3::new(1.0, 1.0, 0.0),
            (0.4, 0.1),
        );
        for p in [Vec2::splat(0.5), Vec2::new(0.1, 0.9), Vec2::new(0.99, 0.01)] {
            let (w, _) = window.direction(p);
            assert!((w.length() - 1.0).abs() < 1e-6);
            let back = window.to_square(w).unwrap();
            assert!((back - p).length() < 1e-5, "{p} -> {w} -> {back}");
        }
        assert!(window.to_square(-window.centre().as_vec3()).is_none());
        // ∫ dω over the window = the solid angle of the rectangle 4·atan(h₁h₂ / √(1 + h₁² + h₂²)).
        let n = 400;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let p = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                sum += window.direction(p).1 / (n * n) as f64;
            }
        }
        let want = 4.0 * (0.4f64 * 0.1 / (1.0f64 + 0.16 + 0.01).sqrt()).atan();
        assert!((sum - want).abs() < 1e-5 * want, "{sum} vs {want}");
    }

    /// The lobe of reflection about slopes δ of a mirror normal at 60° incidence: the window
    /// follows the compression of the lobe across the plane of incidence.
    #[test]
    fn lobe_window_follows_the_reflection_jacobian() {
        let wo = DVec3::new(60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos());
        let reflect = |d: DVec2| {
            let m = DVec3::new(-d.x, -d.y, 1.0).normalize();
            Some(2.0 * wo.dot(m) * m - wo)
        };
        let window = DirectionWindow::around_lobe(reflect, (1e-3, 1e-3), 3.0).unwrap();
        let (h1, h2) = window.half_widths();
        // In the plane of incidence the reflection turns by 2δ, across it by 2δ·cos θo.
        assert!(
            (h1 - 6e-3).abs() < 1e-8 && (h2 - 3e-3).abs() < 1e-8,
            "{h1} {h2}"
        );
        assert!(
            window
                .centre()
                .abs_diff_eq(DVec3::new(-wo.x, 0.0, wo.z), 1e-12)
        );
    }
}
