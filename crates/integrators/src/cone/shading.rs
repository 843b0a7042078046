//! Direct light at a point for cone tracing: the unoccluded irradiance of each area light, exact
//! (Lambert's polygon formula for mesh lights, clipped to the horizon; a quadrature of the
//! spherical cap for sphere lights), times the fraction of a shadow cone toward the light that no
//! other surface blocks (Amanatides 1984 §4) — the fraction of the light's *solid angle* left
//! visible, with the blockers' fractions combined as if independent, Π (1 − fᵢ). Both are the
//! method's approximations: the true visibility weights the light's solid angle by cos θ and by
//! which parts are hidden, and overlapping blockers are not independent.

use super::regions::{Projection, Region, cap_fraction, clip_depth};
use glam::Vec3;
use lightlab_core::Rgb;
use lightlab_geometry::Geometry;
use lightlab_scene::{Light, Scene};

/// A shape as the cone tracer sees it.
pub(crate) enum Solid {
    /// Triangles with their unit geometric normals (counter-clockwise front).
    Mesh(Vec<([Vec3; 3], Vec3)>),
    Sphere {
        centre: Vec3,
        radius: f32,
    },
}

impl Solid {
    pub fn of(scene: &Scene) -> Vec<Solid> {
        scene
            .shapes()
            .iter()
            .map(|s| match &s.geometry {
                Geometry::Mesh(m) => Solid::Mesh(
                    (0..m.len())
                        .filter_map(|i| {
                            let v = m.vertices(i);
                            lightlab_geometry::geometric_normal(&v).map(|n| (v, n))
                        })
                        .collect(),
                ),
                Geometry::Sphere(s) => Solid::Sphere {
                    centre: s.center,
                    radius: s.radius,
                },
            })
            .collect()
    }
}

/// An area light: its shape and radiance.
pub(crate) struct Emitter {
    pub shape: usize,
    pub radiance: Rgb,
    pub two_sided: bool,
}

impl Emitter {
    pub fn of(scene: &Scene) -> Vec<Emitter> {
        scene
            .lights
            .iter()
            .filter_map(|l| match *l {
                Light::Area {
                    shape,
                    radiance,
                    two_sided,
                } => Some(Emitter {
                    shape: shape as usize,
                    radiance,
                    two_sided,
                }),
                _ => None,
            })
            .collect()
    }
}

/// Depth below which nothing counts as in front of a point, relative to the scene's size.
const NEAR: f32 = 1e-5;

/// Irradiance at `x` (unit normal `n` on the side being lit) from light `e`, and the fraction of
/// it the shadow cone finds unblocked when `shadows`; shapes `receiver` and the light's own do not
/// block.
pub(crate) fn direct(
    solids: &[Solid],
    e: &Emitter,
    x: Vec3,
    n: Vec3,
    receiver: usize,
    shadows: bool,
    scale: f32,
) -> Rgb {
    let irradiance = match &solids[e.shape] {
        Solid::Mesh(tris) => {
            let mut sum = 0.0;
            for (v, nl) in tris {
                if !e.two_sided && nl.dot(x - v[0]) <= 0.0 {
                    continue;
                }
                // The part of the light above x's horizon.
                let above = clip_depth(v, x, n, 0.0, f32::INFINITY);
                sum += projected_solid_angle(&above, x, n);
            }
            sum
        }
        &Solid::Sphere { centre, radius } => cap_projected_solid_angle(centre - x, radius, n),
    };
    if !(irradiance > 0.0) {
        return Rgb::BLACK;
    }
    let visible = if shadows {
        unblocked(solids, e.shape, receiver, x, scale)
    } else {
        1.0
    };
    e.radiance * (irradiance * visible)
}

/// Lambert's formula (Lambert 1760; Arvo 1995, eq. 3): the projected solid angle of the polygon
/// `p` seen from `x` about `n`, ½ Σᵢ θᵢ n · normalize(vᵢ × vᵢ₊₁), vᵢ = pᵢ − x.
fn projected_solid_angle(p: &[Vec3], x: Vec3, n: Vec3) -> f32 {
    let k = p.len();
    if k < 3 {
        return 0.0;
    }
    let mut s = 0.0f64;
    for i in 0..k {
        let (a, b) = ((p[i] - x).normalize(), (p[(i + 1) % k] - x).normalize());
        let c = a.cross(b);
        let len = c.length();
        if len > 0.0 {
            let theta = len.atan2(a.dot(b)) as f64;
            s += theta * (n.dot(c) / len) as f64;
        }
    }
    (0.5 * s).abs() as f32
}

/// ∫ max(0, n·ω) dω over the cap of the sphere of `radius` at offset `to_centre`: π sin²β cos θ
/// when the cap is above the horizon, else a 32 × 64 midpoint quadrature over the cap.
fn cap_projected_solid_angle(to_centre: Vec3, radius: f32, n: Vec3) -> f32 {
    let d = to_centre.length();
    if d <= radius {
        return std::f32::consts::PI;
    }
    let sin_b = radius / d;
    let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
    let axis = to_centre / d;
    let cos_t = n.dot(axis);
    // Above the horizon when θ + β ≤ π/2, i.e. cos θ ≥ sin β.
    if cos_t >= sin_b {
        return std::f32::consts::PI * sin_b * sin_b * cos_t;
    }
    if cos_t <= -sin_b {
        return 0.0;
    }
    let frame = lightlab_core::Frame::from_z(axis);
    let local_n = frame.to_local(n);
    let (nu, nv) = (32, 64);
    let mut s = 0.0f64;
    for i in 0..nu {
        let z = 1.0 - (1.0 - cos_b) * (i as f32 + 0.5) / nu as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..nv {
            let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / nv as f32;
            let w = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            s += local_n.dot(w).max(0.0) as f64;
        }
    }
    // Each cell's solid angle: 2π(1 − cos β) / (nu·nv).
    (s * 2.0 * std::f64::consts::PI * (1.0 - cos_b as f64) / (nu * nv) as f64) as f32
}

/// The fraction of the light `light`'s cross-section, seen from `x`, that no shape other than it
/// and `receiver` blocks: Π over shapes of (1 − blocked area / light area), each shape's blocked
/// area the larger of its triangles facing x and facing away (one set is empty for a planar
/// shape; both are the silhouette for a closed convex one).
fn unblocked(solids: &[Solid], light: usize, receiver: usize, x: Vec3, scale: f32) -> f32 {
    let (axis, lights, far) = match &solids[light] {
        Solid::Mesh(tris) => {
            let c = tris.iter().flat_map(|(v, _)| v.iter()).sum::<Vec3>() / (3 * tris.len()) as f32;
            let Some(axis) = (c - x).try_normalize() else {
                return 1.0;
            };
            let pr = Projection::new(x, axis);
            let regions: Vec<Region> = tris
                .iter()
                .filter_map(|(v, _)| pr.polygon(v, NEAR * scale, f32::INFINITY))
                .collect();
            let far = tris
                .iter()
                .flat_map(|(v, _)| v.iter())
                .map(|&v| axis.dot(v - x))
                .fold(f32::INFINITY, f32::min);
            (axis, regions, far)
        }
        &Solid::Sphere { centre, radius } => {
            let Some(axis) = (centre - x).try_normalize() else {
                return 1.0;
            };
            let pr = Projection::new(x, axis);
            let Some(disk) = pr.sphere(centre, radius) else {
                return 1.0;
            };
            (axis, vec![disk], axis.dot(centre - x) - radius)
        }
    };
    let area: f32 = lights.iter().map(Region::area).sum();
    if !(area > 0.0) || !(far > NEAR * scale) {
        return 1.0;
    }
    let pr = Projection::new(x, axis);
    let mut visible = 1.0;
    for (s, solid) in solids.iter().enumerate() {
        if s == light || s == receiver {
            continue;
        }
        let blocked = match solid {
            Solid::Mesh(tris) => {
                let (mut front, mut back) = (0.0, 0.0);
                for (v, n) in tris {
                    let Some(r) = pr.polygon(v, NEAR * scale, far) else {
                        continue;
                    };
                    let a: f32 = lights.iter().map(|l| l.overlap(&r)).sum();
                    if n.dot(x - v[0]) > 0.0 {
                        front += a;
                    } else {
                        back += a;
                    }
                }
                f32::max(front, back)
            }
            &Solid::Sphere { centre, radius } => {
                let depth = axis.dot(centre - x);
                if depth + radius < NEAR * scale || depth - radius > far {
                    continue;
                }
                match pr.sphere(centre, radius) {
                    Some(d) => lights.iter().map(|l| l.overlap(&d)).sum(),
                    // A silhouette reaching 90° from the axis: the light as a disk of its
                    // solid angle against the cap, in angle.
                    None => {
                        let alpha = (area / std::f32::consts::PI).sqrt().atan();
                        area * cap_fraction(alpha, x, axis, centre, radius)
                    }
                }
            }
        };
        visible *= 1.0 - (blocked / area).min(1.0);
        if visible <= 0.0 {
            return 0.0;
        }
    }
    visible
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lambert's formula against a 400² midpoint quadrature of cos θ cos θ' / r² over a tilted
    /// quad that the point's tangent plane does not cut.
    #[test]
    fn polygon_irradiance_matches_quadrature() {
        let x = Vec3::new(0.1, 0.0, -0.2);
        let n = Vec3::new(0.2, 1.0, 0.1).normalize();
        let quad = [
            Vec3::new(-0.5, 1.0, -0.5),
            Vec3::new(0.7, 1.1, -0.5),
            Vec3::new(0.7, 1.2, 0.6),
            Vec3::new(-0.5, 1.1, 0.6),
        ];
        let exact = projected_solid_angle(&quad, x, n);
        let (e1, e2) = (quad[1] - quad[0], quad[3] - quad[0]);
        let nl = e1.cross(e2);
        let k = 400;
        let mut s = 0.0f64;
        for i in 0..k {
            for j in 0..k {
                let p = quad[0]
                    + e1 * ((i as f32 + 0.5) / k as f32)
                    + e2 * ((j as f32 + 0.5) / k as f32);
                let w = p - x;
                let r2 = w.length_squared();
                let wn = w / r2.sqrt();
                s += (n.dot(wn).max(0.0) * nl.dot(wn).abs() / r2) as f64;
            }
        }
        // The quad is planar (e1 × e2 spans it); cell area |e1 × e2| / k², folded into nl.
        let quadrature = s / (k * k) as f64;
        assert!(
            (exact as f64 - quadrature).abs() < 1e-4 * quadrature,
            "{exact} vs {quadrature}"
        );
    }

    #[test]
    fn cap_irradiance_is_continuous_across_the_horizon() {
        let n = Vec3::Y;
        let (r, d) = (0.3f32, 1.0f32);
        // Just above the horizon limit the closed form, just below the quadrature: they meet.
        let sin_b = r / d;
        let t_edge = (sin_b).acos();
        let above = cap_projected_solid_angle(
            Vec3::new(t_edge.sin(), t_edge.cos() + 1e-4, 0.0).normalize() * d,
            r,
            n,
        );
        let below = cap_projected_solid_angle(
            Vec3::new(t_edge.sin(), t_edge.cos() - 1e-4, 0.0).normalize() * d,
            r,
            n,
        );
        assert!((above - below).abs() < 2e-3 * above, "{above} vs {below}");
        assert_eq!(
            cap_projected_solid_angle(Vec3::new(0.0, -1.0, 0.0), r, n),
            0.0
        );
    }
}
