//! Area and solid-angle sampling of shapes: samples lie on the shape, densities are the ones
//! reported, and Monte Carlo estimates built from them match analytic values and independent
//! estimates by ray casting (all within 5σ, fixed seeds).

use glam::DVec3;
use lightlab_core::{Ray, Vec2, Vec3};
use lightlab_geometry::{Accel, Geometry, NO_LIGHT, Shape, Sphere, TriangleMesh};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// Running mean and standard error.
#[derive(Default)]
struct Estimate {
    n: f64,
    sum: f64,
    sum_sq: f64,
}

impl Estimate {
    fn add(&mut self, x: f64) {
        self.n += 1.0;
        self.sum += x;
        self.sum_sq += x * x;
    }
    fn mean(&self) -> f64 {
        self.sum / self.n
    }
    fn std_error(&self) -> f64 {
        let var = (self.sum_sq / self.n - self.mean().powi(2)).max(0.0);
        (var / self.n).sqrt()
    }
    /// |mean − expected| ≤ 5σ (+ a tiny relative floor for zero-variance estimates).
    fn assert_near(&self, expected: f64, what: &str) {
        let tol = 5.0 * self.std_error() + 1e-5 * expected.abs();
        assert!(
            (self.mean() - expected).abs() <= tol,
            "{what}: {} ± {} vs {expected}",
            self.mean(),
            self.std_error()
        );
    }
}

fn u2(rng: &mut Pcg64) -> Vec2 {
    Vec2::new(rng.random::<f32>(), rng.random::<f32>())
}

fn mesh_shape(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Shape {
    Shape {
        geometry: Geometry::Mesh(TriangleMesh::new(positions, None, None, indices).unwrap()),
        material: 0,
        light: NO_LIGHT,
    }
}

fn sphere_shape(center: Vec3, radius: f32) -> Shape {
    Shape {
        geometry: Geometry::Sphere(Sphere::new(center, radius)),
        material: 0,
        light: 3,
    }
}

/// Two unequal, non-coplanar triangles that never hide each other from the reference points used.
fn two_triangles() -> (Shape, [[DVec3; 3]; 2]) {
    let t = [
        [Vec3::ZERO, Vec3::X, Vec3::Y],
        [
            Vec3::new(1.5, 0.0, 0.1),
            Vec3::new(2.5, 0.0, 0.6),
            Vec3::new(1.5, 1.0, 1.1),
        ],
    ];
    let shape = mesh_shape(t.concat(), vec![[0, 1, 2], [3, 4, 5]]);
    (shape, t.map(|v| v.map(|p| p.as_dvec3())))
}

fn tri_area(v: &[DVec3; 3]) -> f64 {
    0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length()
}

/// Solid angle of a triangle seen from `o` (Van Oosterom and Strackee 1983).
fn tri_solid_angle(v: &[DVec3; 3], o: DVec3) -> f64 {
    let [a, b, c] = v.map(|p| p - o);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// A tilted 2 × 1 rectangle far from the origin as two triangles sharing a diagonal, in the order
/// a `Quad` is loaded (`flipped`: as a mirrored transform loads it): sampled as a parallelogram.
fn rectangle(flipped: bool) -> (Shape, [[DVec3; 3]; 2]) {
    let c = Vec3::new(300.3, -0.2, 40.5);
    let u = Vec3::new(0.8, 0.6, 0.0);
    let v = Vec3::new(-0.36, 0.48, 0.8) * 0.5;
    let p = [c - u - v, c + u - v, c + u + v, c - u + v];
    let indices = if flipped {
        [[0, 2, 1], [0, 3, 2]]
    } else {
        [[0, 1, 2], [0, 2, 3]]
    };
    two_triangle_mesh(p, indices)
}

/// Two triangles sharing a diagonal that do not make a parallelogram (a kite): sampled by
/// triangle.
fn kite() -> (Shape, [[DVec3; 3]; 2]) {
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, -0.3, 0.0),
        Vec3::new(2.5, 0.0, 0.0),
        Vec3::new(1.0, 0.9, 0.0),
    ];
    two_triangle_mesh(p, [[0, 1, 2], [0, 2, 3]])
}

/// The mesh of two triangles over the corners `p`, and its triangles in f64.
fn two_triangle_mesh(p: [Vec3; 4], indices: [[u32; 3]; 2]) -> (Shape, [[DVec3; 3]; 2]) {
    let tris = indices.map(|t| t.map(|k| p[k as usize].as_dvec3()));
    (mesh_shape(p.to_vec(), indices.to_vec()), tris)
}

/// Area samples of a two-triangle mesh lie on one of its triangles (within their error bound),
/// carry its normal and pdf 1/area, fall in each triangle in proportion to its area and average
/// to the area centroid: for separate triangles, a rectangle in both vertex orders (the
/// parallelogram sampler) and a kite (which must not take it). z-tests at 5σ.
#[test]
fn mesh_area_samples_are_uniform() {
    for (what, (shape, tris)) in [
        ("two triangles", two_triangles()),
        ("rectangle", rectangle(false)),
        ("flipped rectangle", rectangle(true)),
        ("kite", kite()),
    ] {
        area_samples_are_uniform(what, &shape, &tris);
    }
}

fn area_samples_are_uniform(what: &str, shape: &Shape, tris: &[[DVec3; 3]; 2]) {
    let areas = tris.map(|t| tri_area(&t));
    let total = areas[0] + areas[1];
    assert!((shape.area() as f64 - total).abs() < 1e-6 * total, "{what}");
    let centroid = (areas[0] * (tris[0][0] + tris[0][1] + tris[0][2])
        + areas[1] * (tris[1][0] + tris[1][1] + tris[1][2]))
        / (3.0 * total);
    let scale = tris
        .as_flattened()
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);

    let mut rng = Pcg64::seed_from_u64(1);
    let mut mean = [
        Estimate::default(),
        Estimate::default(),
        Estimate::default(),
    ];
    let mut in_first = Estimate::default();
    for _ in 0..400_000 {
        let s = shape.sample_area(u2(&mut rng));
        assert_eq!(s.pdf, shape.pdf_area());
        assert!((s.pdf as f64 * total - 1.0).abs() < 1e-6);
        let p = s.p.as_dvec3();
        // On one of the triangles: off its plane by no more than the error bound allows.
        let on = tris.iter().position(|t| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            let b0 = (t[1] - p).cross(t[2] - p).dot(n) / n.length_squared();
            let b1 = (t[2] - p).cross(t[0] - p).dot(n) / n.length_squared();
            // A point off an edge by δ changes a barycentric by at most δ·(longest edge)/(2·area).
            let longest = (0..3)
                .map(|k| (t[(k + 1) % 3] - t[k]).length())
                .fold(0.0, f64::max);
            let slack = 1e-6 + 2.0 * s.p_error.as_dvec3().length() * longest / n.length();
            let inside = b0 >= -slack && b1 >= -slack && b0 + b1 <= 1.0 + slack;
            let n = n.normalize();
            let allowed = n.abs().dot(s.p_error.as_dvec3()) + 1e-12 * scale;
            inside && (p - t[0]).dot(n).abs() <= allowed
        });
        let i = on.unwrap_or_else(|| panic!("{what}: sample {s:?} is on neither triangle"));
        let n = (tris[i][1] - tris[i][0])
            .cross(tris[i][2] - tris[i][0])
            .normalize();
        assert!((s.n.as_dvec3() - n).length() < 1e-6, "{what}");
        assert!(
            s.p_error.max_element() < 1e-6 * scale.max(1.0) as f32,
            "{what}"
        );
        in_first.add((i == 0) as u8 as f64);
        for (m, x) in mean.iter_mut().zip(p.to_array()) {
            m.add(x);
        }
    }
    in_first.assert_near(
        areas[0] / total,
        &format!("{what}: share of the first triangle"),
    );
    for k in 0..3 {
        mean[k].assert_near(centroid[k], &format!("{what}: mean position"));
    }
}

#[test]
fn sphere_area_samples_are_uniform() {
    let (c, r) = (Vec3::new(1.0, -2.0, 3.0), 0.5f32);
    let shape = sphere_shape(c, r);
    assert!((shape.area() - 4.0 * std::f32::consts::PI * 0.25).abs() < 1e-6);
    let mut rng = Pcg64::seed_from_u64(2);
    let mut mean = [
        Estimate::default(),
        Estimate::default(),
        Estimate::default(),
    ];
    let mut z2 = Estimate::default();
    for _ in 0..400_000 {
        let s = shape.sample_area(u2(&mut rng));
        assert_eq!(s.pdf, shape.pdf_area());
        let d = (s.p - c).as_dvec3();
        assert!((d.length() - r as f64).abs() <= s.p_error.length() as f64);
        assert!((s.n.as_dvec3() - d / r as f64).length() < 1e-5);
        for (m, x) in mean.iter_mut().zip(s.p.to_array()) {
            m.add(x as f64);
        }
        z2.add(d.z * d.z);
    }
    for k in 0..3 {
        mean[k].assert_near(c[k] as f64, "mean position");
    }
    z2.assert_near((r * r) as f64 / 3.0, "mean z²");
}

/// Directions uniform in the cone of half-angle θ around `axis`, with 1 − cos θ given directly
/// (2 for the whole sphere).
struct Cone {
    axis: DVec3,
    one_minus_cos: f64,
}

impl Cone {
    fn sample(&self, rng: &mut Pcg64) -> DVec3 {
        let omc = rng.random::<f64>() * self.one_minus_cos;
        let sin = (omc * (2.0 - omc)).sqrt();
        let phi = 2.0 * PI * rng.random::<f64>();
        let a = self.axis;
        let s = if a.x.abs() > 0.5 { DVec3::Y } else { DVec3::X };
        let e1 = a.cross(s).normalize();
        let e2 = a.cross(e1);
        (sin * phi.cos() * e1 + sin * phi.sin() * e2 + (1.0 - omc) * a).normalize()
    }
    fn pdf(&self) -> f64 {
        1.0 / (2.0 * PI * self.one_minus_cos)
    }
}

/// Checks `sample_solid_angle` / `pdf_solid_angle` of `shape` from `ref_p` against ray casting with
/// directions from `proposal` (which must cover every direction that hits the shape):
/// - ∫ pdf dω over directions hitting the shape is 1;
/// - E[1/pdf] over samples and the ray-cast ∫ 1 dω both equal `solid_angle`;
/// - E[f/pdf] over samples equals the ray-cast ∫ f dω for f = [1 − w·axis < `split`] +
///   2·[w on one side of a plane through the axis], which detects radial and angular distortions.
///
/// With `visible`, every sampled point must face `ref_p` (a convex shape seen from outside).
fn check_solid_angle(
    what: &str,
    shape: &Shape,
    ref_p: Vec3,
    solid_angle: f64,
    proposal: Cone,
    split: f64,
    visible: bool,
) {
    let accel = Accel::new(vec![shape.clone()]);
    let r = ref_p.as_dvec3();
    let axis = proposal.axis;
    let side = axis.cross(DVec3::new(0.3, 0.5, 0.8)).normalize();
    let f = |w: DVec3| {
        let inner = (1.0 - w.dot(axis) < split) as u8 as f64;
        let half = ((w - axis).dot(side) > 0.0) as u8 as f64;
        inner + 2.0 * half
    };
    let mut rng = Pcg64::seed_from_u64(what.len() as u64 * 7919);

    let (mut inv_pdf, mut f_over_pdf) = (Estimate::default(), Estimate::default());
    for _ in 0..1_000_000 {
        let Some(s) = shape.sample_solid_angle(ref_p, u2(&mut rng)) else {
            inv_pdf.add(0.0);
            f_over_pdf.add(0.0);
            continue;
        };
        let pdf = shape.pdf_solid_angle(ref_p, s.p, s.n);
        assert!(
            (pdf / s.pdf - 1.0).abs() < 1e-5,
            "{what}: sample pdf {} vs pdf_solid_angle {pdf}",
            s.pdf
        );
        let to_ref = r - s.p.as_dvec3();
        assert!(
            !visible || s.n.as_dvec3().dot(to_ref) >= -1e-3 * to_ref.length(),
            "{what}: sampled a point facing away: {s:?}"
        );
        let w = -to_ref.normalize();
        inv_pdf.add(1.0 / s.pdf as f64);
        f_over_pdf.add(f(w) / s.pdf as f64);
    }

    let (mut pdf_integral, mut cast_solid_angle, mut cast_f) = (
        Estimate::default(),
        Estimate::default(),
        Estimate::default(),
    );
    for _ in 0..4_000_000 {
        let w = proposal.sample(&mut rng);
        let q = proposal.pdf();
        match accel.intersect(&Ray::new(ref_p, w.as_vec3())) {
            Some(h) => {
                pdf_integral.add(shape.pdf_solid_angle(ref_p, h.p, h.ng) as f64 / q);
                cast_solid_angle.add(1.0 / q);
                cast_f.add(f(w) / q);
            }
            None => {
                pdf_integral.add(0.0);
                cast_solid_angle.add(0.0);
                cast_f.add(0.0);
            }
        }
    }
    assert!(pdf_integral.std_error() < 0.01, "{what}: test too noisy");
    pdf_integral.assert_near(1.0, &format!("{what}: ∫ pdf dω"));
    inv_pdf.assert_near(solid_angle, &format!("{what}: E[1/pdf]"));
    cast_solid_angle.assert_near(solid_angle, &format!("{what}: ray-cast solid angle"));
    let sigma = (f_over_pdf.std_error().powi(2) + cast_f.std_error().powi(2)).sqrt();
    assert!(
        (f_over_pdf.mean() - cast_f.mean()).abs() <= 5.0 * sigma + 1e-5 * cast_f.mean(),
        "{what}: E[f/pdf] = {} ± {} vs ray-cast {} ± {}",
        f_over_pdf.mean(),
        f_over_pdf.std_error(),
        cast_f.mean(),
        cast_f.std_error()
    );
}

#[test]
fn sphere_solid_angle_sampling() {
    let (c, r) = (Vec3::new(1.0, -2.0, 3.0), 0.5f32);
    let shape = sphere_shape(c, r);
    let towards = DVec3::new(0.3, -0.8, 0.52).normalize();
    for (what, dist) in [("sphere near", 1.001), ("sphere far", 1e4)] {
        let ref_p = c + (towards * dist * r as f64).as_vec3();
        let to_center = (c - ref_p).as_dvec3();
        let sin2 = (r as f64).powi(2) / to_center.length_squared();
        let one_minus_cos = sin2 / (1.0 + (1.0 - sin2).sqrt());
        let solid_angle = 2.0 * PI * one_minus_cos;
        // Proposal: the cone of twice the half-angle (1 − cos 2θ = 2 sin²θ), or the whole sphere.
        let proposal = Cone {
            axis: to_center.normalize(),
            one_minus_cos: (2.0 * sin2).min(2.0),
        };
        let split = 0.5 * one_minus_cos;
        check_solid_angle(what, &shape, ref_p, solid_angle, proposal, split, true);
    }
    // From inside, area sampling converted: all directions.
    let inside = c + Vec3::new(0.1, 0.2, -0.15);
    let proposal = Cone {
        axis: DVec3::Z,
        one_minus_cos: 2.0,
    };
    check_solid_angle(
        "sphere inside",
        &shape,
        inside,
        4.0 * PI,
        proposal,
        0.7,
        false,
    );
}

#[test]
fn mesh_solid_angle_sampling() {
    let (shape, tris) = two_triangles();
    let center = DVec3::new(1.25, 0.5, 0.4);
    let radius = 1.8;
    for (what, ref_p) in [
        ("mesh near", DVec3::new(0.25, 0.25, 0.1)),
        (
            "mesh far",
            center + 1e4 * DVec3::new(0.3, 0.4, 1.0).normalize(),
        ),
    ] {
        let ref_p = ref_p.as_vec3();
        let r = ref_p.as_dvec3();
        let solid_angle = tri_solid_angle(&tris[0], r) + tri_solid_angle(&tris[1], r);
        let to_center = center - r;
        let sin = radius / to_center.length();
        let one_minus_cos = if sin < 0.5 {
            sin * sin / (1.0 + (1.0 - sin * sin).sqrt())
        } else {
            2.0
        };
        let proposal = Cone {
            axis: to_center.normalize(),
            one_minus_cos,
        };
        let split = 0.2 * one_minus_cos.min(0.5);
        check_solid_angle(what, &shape, ref_p, solid_angle, proposal, split, false);
    }
}
