//! Plane regions and the areas of their intersections, for the cross-sections cone tracing
//! measures: a cone of half-angle α cut by the plane at unit distance perpendicular to its axis is
//! the disk of radius tan α, and a polygon seen from the apex projects there (gnomonic projection:
//! straight edges stay straight) to a polygon, exactly. A sphere's silhouette projects to an
//! ellipse, which [`Frame::sphere`] approximates by the disk with the same radial extent.

use glam::{Vec2, Vec3};
use lightlab_core::Frame;

/// A convex region of the projection plane.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Region {
    Disk {
        centre: Vec2,
        radius: f32,
    },
    /// Counter-clockwise convex polygon.
    Polygon(Vec<Vec2>),
}

impl Region {
    pub fn area(&self) -> f32 {
        match self {
            Region::Disk { radius, .. } => std::f32::consts::PI * radius * radius,
            Region::Polygon(p) => polygon_area(p),
        }
    }

    /// Area of the intersection of two regions.
    pub fn overlap(&self, other: &Region) -> f32 {
        match (self, other) {
            (
                Region::Disk {
                    centre: a,
                    radius: ra,
                },
                Region::Disk {
                    centre: b,
                    radius: rb,
                },
            ) => lens_area(*ra, *rb, a.distance(*b)),
            (Region::Disk { centre, radius }, Region::Polygon(p))
            | (Region::Polygon(p), Region::Disk { centre, radius }) => {
                disk_polygon_area(*centre, *radius, p)
            }
            (Region::Polygon(a), Region::Polygon(b)) => polygon_area(&clip_polygon(a, b)),
        }
    }
}

/// Signed area (counter-clockwise positive) of a polygon (the shoelace formula).
pub(crate) fn signed_area(p: &[Vec2]) -> f32 {
    let n = p.len();
    (0..n).map(|i| p[i].perp_dot(p[(i + 1) % n])).sum::<f32>() * 0.5
}

fn polygon_area(p: &[Vec2]) -> f32 {
    signed_area(p).abs()
}

/// Area of the intersection of disks of radii r₁, r₂ whose centres are d apart (the lens).
pub(crate) fn lens_area(r1: f32, r2: f32, d: f32) -> f32 {
    let (r1, r2, d) = (r1 as f64, r2 as f64, d as f64);
    let pi = std::f64::consts::PI;
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        return (pi * r1.min(r2).powi(2)) as f32;
    }
    let a1 = ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1))
        .clamp(-1.0, 1.0)
        .acos();
    let a2 = ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2))
        .clamp(-1.0, 1.0)
        .acos();
    let k = ((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2)).max(0.0);
    (r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * k.sqrt()) as f32
}

/// Area of a disk ∩ a convex polygon: the signed areas of the disk ∩ triangle (centre, pᵢ, pᵢ₊₁)
/// summed over the edges.
pub(crate) fn disk_polygon_area(centre: Vec2, r: f32, p: &[Vec2]) -> f32 {
    let n = p.len();
    let s: f64 = (0..n)
        .map(|i| {
            disk_triangle_signed(
                r as f64,
                (p[i] - centre).as_dvec2(),
                (p[(i + 1) % n] - centre).as_dvec2(),
            )
        })
        .sum();
    s.abs() as f32
}

/// Signed area of the disk of radius r about the origin ∩ the triangle (0, a, b): straight pieces
/// of the segment ab inside the disk contribute triangles, pieces outside circular sectors.
fn disk_triangle_signed(r: f64, a: glam::DVec2, b: glam::DVec2) -> f64 {
    let sector = |u: glam::DVec2, v: glam::DVec2| 0.5 * r * r * u.perp_dot(v).atan2(u.dot(v));
    let triangle = |u: glam::DVec2, v: glam::DVec2| 0.5 * u.perp_dot(v);
    let d = b - a;
    let (qa, qb, qc) = (d.dot(d), 2.0 * a.dot(d), a.dot(a) - r * r);
    if qa <= 0.0 {
        return 0.0;
    }
    let disc = qb * qb - 4.0 * qa * qc;
    if disc <= 0.0 {
        return sector(a, b);
    }
    let sq = disc.sqrt();
    let (t1, t2) = ((-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa));
    if t2 <= 0.0 || t1 >= 1.0 {
        return sector(a, b);
    }
    let (t1, t2) = (t1.max(0.0), t2.min(1.0));
    let (p1, p2) = (a + d * t1, a + d * t2);
    sector(a, p1) + triangle(p1, p2) + sector(p2, b)
}

/// `subject` clipped by the convex `clip` polygon (Sutherland & Hodgman 1974); both
/// counter-clockwise.
pub(crate) fn clip_polygon(subject: &[Vec2], clip: &[Vec2]) -> Vec<Vec2> {
    let mut out = subject.to_vec();
    let n = clip.len();
    for i in 0..n {
        if out.is_empty() {
            break;
        }
        let (a, b) = (clip[i], clip[(i + 1) % n]);
        let inside = |p: Vec2| (b - a).perp_dot(p - a) >= 0.0;
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let (p, q) = (input[j], input[(j + 1) % input.len()]);
            let (ip, iq) = (inside(p), inside(q));
            if ip {
                out.push(p);
            }
            if ip != iq {
                let (dp, dq) = ((b - a).perp_dot(p - a), (b - a).perp_dot(q - a));
                out.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
    }
    out
}

/// The part of a 3D polygon with `axis · (v − apex)` in (near, far), as points.
pub(crate) fn clip_depth(poly: &[Vec3], apex: Vec3, axis: Vec3, near: f32, far: f32) -> Vec<Vec3> {
    let mut out = poly.to_vec();
    for (plane, keep_above) in [(near, true), (far, false)] {
        let side = |p: Vec3| {
            let d = axis.dot(p - apex) - plane;
            if keep_above { d } else { -d }
        };
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let (p, q) = (input[j], input[(j + 1) % input.len()]);
            let (dp, dq) = (side(p), side(q));
            if dp >= 0.0 {
                out.push(p);
            }
            if (dp >= 0.0) != (dq >= 0.0) {
                out.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
    }
    out
}

/// The projection plane of a cone: unit distance from `apex` along the frame's z axis.
pub(crate) struct Projection {
    pub apex: Vec3,
    pub frame: Frame,
}

impl Projection {
    pub fn new(apex: Vec3, axis: Vec3) -> Projection {
        Projection {
            apex,
            frame: Frame::from_z(axis),
        }
    }

    pub fn axis(&self) -> Vec3 {
        self.frame.to_world(Vec3::Z)
    }

    /// Where the direction (or point) `p` projects; `None` at or behind the apex's plane.
    pub fn point(&self, p: Vec3) -> Option<Vec2> {
        let l = self.frame.to_local(p - self.apex);
        (l.z > 0.0).then(|| Vec2::new(l.x / l.z, l.y / l.z))
    }

    /// The unit direction from the apex through projected point `q`.
    pub fn direction(&self, q: Vec2) -> Vec3 {
        self.frame.to_world(Vec3::new(q.x, q.y, 1.0)).normalize()
    }

    /// The projection of a 3D polygon's part at depths (near, far) along the axis, made
    /// counter-clockwise; `None` if nothing of it is left.
    pub fn polygon(&self, poly: &[Vec3], near: f32, far: f32) -> Option<Region> {
        let clipped = clip_depth(poly, self.apex, self.axis(), near, far);
        let mut q: Vec<Vec2> = clipped.iter().filter_map(|&p| self.point(p)).collect();
        if q.len() < 3 || q.len() != clipped.len() {
            return None;
        }
        if signed_area(&q) < 0.0 {
            q.reverse();
        }
        Some(Region::Polygon(q))
    }

    /// The disk standing for the silhouette of the sphere (centre, radius) seen from the apex:
    /// its angular radius β = asin(R/D) about the direction to the centre at angle γ from the
    /// axis spans tan(γ − β) … tan(γ + β) radially, which the disk keeps (the true outline, an
    /// ellipse, is narrower across by a factor cos γ-ish). `None` when the apex is inside the
    /// sphere or the silhouette reaches 90° from the axis.
    pub fn sphere(&self, centre: Vec3, radius: f32) -> Option<Region> {
        let l = self.frame.to_local(centre - self.apex);
        let dist = l.length();
        if dist <= radius {
            return None;
        }
        let beta = (radius / dist).asin();
        let gamma = (l.z / dist).clamp(-1.0, 1.0).acos();
        if gamma + beta >= 0.5 * std::f32::consts::PI - 1e-3 {
            return None;
        }
        let (lo, hi) = ((gamma - beta).tan(), (gamma + beta).tan());
        let e = Vec2::new(l.x, l.y).normalize_or(Vec2::X);
        Some(Region::Disk {
            centre: e * (0.5 * (lo + hi)),
            radius: 0.5 * (hi - lo),
        })
    }
}

/// The fraction of a disk of angular radius α about the axis that a sphere's cap covers, the
/// cap of angular radius β about a direction γ from the axis: the lens of the two as planar
/// disks in angle — the fallback for silhouettes that reach 90° from the axis, where the
/// projection plane cannot hold them (accurate for small α).
pub(crate) fn cap_fraction(alpha: f32, apex: Vec3, axis: Vec3, centre: Vec3, radius: f32) -> f32 {
    let to = centre - apex;
    let dist = to.length();
    if dist <= radius {
        return 1.0;
    }
    let beta = (radius / dist).asin();
    let gamma = (axis.dot(to) / dist).clamp(-1.0, 1.0).acos();
    lens_area(alpha, beta, gamma) / (std::f32::consts::PI * alpha * alpha)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(lo: f32, hi: f32) -> Vec<Vec2> {
        vec![
            Vec2::new(lo, lo),
            Vec2::new(hi, lo),
            Vec2::new(hi, hi),
            Vec2::new(lo, hi),
        ]
    }

    #[test]
    fn intersection_areas_match_closed_forms() {
        let pi = std::f32::consts::PI;
        // A disk inside a square, a square inside a disk.
        assert!((disk_polygon_area(Vec2::ZERO, 0.5, &square(-1.0, 1.0)) - pi * 0.25).abs() < 1e-6);
        assert!((disk_polygon_area(Vec2::ZERO, 2.0, &square(-1.0, 1.0)) - 4.0).abs() < 1e-6);
        // A half-plane through the centre takes half the disk; a chord at distance h the
        // segment r²·acos(h/r) − h·√(r² − h²).
        let half = [
            Vec2::new(0.0, -5.0),
            Vec2::new(5.0, -5.0),
            Vec2::new(5.0, 5.0),
            Vec2::new(0.0, 5.0),
        ];
        assert!((disk_polygon_area(Vec2::ZERO, 1.0, &half) - pi / 2.0).abs() < 1e-6);
        let h = 0.3f32;
        let cut = [
            Vec2::new(h, -5.0),
            Vec2::new(5.0, -5.0),
            Vec2::new(5.0, 5.0),
            Vec2::new(h, 5.0),
        ];
        let segment = h.acos() - h * (1.0 - h * h).sqrt();
        assert!((disk_polygon_area(Vec2::ZERO, 1.0, &cut) - segment).abs() < 1e-6);
        // Two unit disks one radius apart: 2π/3 − √3/2.
        assert!((lens_area(1.0, 1.0, 1.0) - (2.0 * pi / 3.0 - 3f32.sqrt() / 2.0)).abs() < 1e-6);
        assert_eq!(lens_area(1.0, 0.2, 0.5), pi * 0.04);
        assert_eq!(lens_area(1.0, 1.0, 2.5), 0.0);
        // Overlapping squares.
        let a = Region::Polygon(square(0.0, 2.0));
        let b = Region::Polygon(square(1.0, 3.0));
        assert!((a.overlap(&b) - 1.0).abs() < 1e-6);
    }

    /// Disk ∩ triangle against counting the points of a 400² midpoint grid over [−2, 2]² (cells
    /// of 10⁻⁴; the counts' error, measured at ≤ 3.5·10⁻⁴ here, is the boundary's rounding).
    #[test]
    fn disk_polygon_area_matches_counting_points() {
        let tri = [
            Vec2::new(-0.7, -0.4),
            Vec2::new(0.9, -0.1),
            Vec2::new(0.1, 0.8),
        ];
        for (c, r) in [
            (Vec2::new(0.2, 0.1), 0.5),
            (Vec2::new(0.8, 0.4), 0.6),
            (Vec2::new(-0.3, 0.6), 0.9),
        ] {
            let n = 400;
            let mut inside = 0;
            for i in 0..n {
                for j in 0..n {
                    let p = Vec2::new(
                        -2.0 + 4.0 * (i as f32 + 0.5) / n as f32,
                        -2.0 + 4.0 * (j as f32 + 0.5) / n as f32,
                    );
                    let in_tri =
                        (0..3).all(|k| (tri[(k + 1) % 3] - tri[k]).perp_dot(p - tri[k]) >= 0.0);
                    if in_tri && p.distance(c) <= r {
                        inside += 1;
                    }
                }
            }
            let counted = inside as f32 * 16.0 / (n * n) as f32;
            let exact = disk_polygon_area(c, r, &tri);
            assert!(
                (counted - exact).abs() < 1.5e-3,
                "{c} {r}: {counted} vs {exact}"
            );
        }
    }

    #[test]
    fn projection_keeps_lines_and_clips_behind_the_apex() {
        let pr = Projection::new(Vec3::ZERO, Vec3::Z);
        let quad = [
            Vec3::new(-1.0, -1.0, 2.0),
            Vec3::new(1.0, -1.0, 2.0),
            Vec3::new(1.0, 1.0, 2.0),
            Vec3::new(-1.0, 1.0, 2.0),
        ];
        let Some(Region::Polygon(q)) = pr.polygon(&quad, 1e-4, f32::INFINITY) else {
            panic!()
        };
        assert!((signed_area(&q) - 1.0).abs() < 1e-6);
        // A triangle straddling the apex's plane keeps only its front part.
        let tri = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        assert!(pr.polygon(&tri, 0.5, f32::INFINITY).is_some());
        assert!(pr.polygon(&tri, 1.5, f32::INFINITY).is_none());
        // A sphere straight ahead: the disk of radius tan β.
        let Some(Region::Disk { centre, radius }) = pr.sphere(Vec3::new(0.0, 0.0, 5.0), 1.0) else {
            panic!()
        };
        assert!(centre.length() < 1e-6 && (radius - (0.2f32).asin().tan()).abs() < 1e-6);
    }
}
