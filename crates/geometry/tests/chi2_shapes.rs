//! Chi-square goodness-of-fit tests of shape sampling for lights, with the testkit harness:
//! `Shape::sample_solid_angle` against `Shape::pdf_solid_angle` over the directions from a
//! reference point, and `Shape::sample_area` against `Shape::pdf_area` over the surface.
//!
//! The density a test expects for a direction ω is computed by casting the ray (ref_p, ω) in f64
//! against the shape (independently of the crate's intersection code) and asking
//! `pdf_solid_angle` at the points found:
//!
//! - for area sampling converted to solid angle (meshes; spheres seen from inside or from within
//!   0.05 % of their radius), every point of the shape along the ray is a sample that produces ω,
//!   so the density of ω is the sum of `pdf_solid_angle` over all of them — `pdf_solid_angle` is
//!   the density of a sampled *point*, per unit solid angle;
//! - for the cone of a sphere seen from outside, only the first hit is ever sampled and
//!   `pdf_solid_angle` is the density of the *direction* (pbrt-v4's convention: it does not look
//!   at which point it is given), so only the first hit counts.
//!
//! Directions are histogrammed over the whole sphere ([`Domain::Sphere`]) when the shape fills a
//! large part of it, and on a gnomonic [`DirectionWindow`] around the shape (on
//! [`Domain::Square`]) when it subtends a small solid angle, so that it still spans the 41 × 40
//! cells; polygon edges are straight lines in that chart.
//!
//! False failures: 16 chi-square tests at the default α = sidak(0.01, 300) = 3.35 × 10⁻⁵ each
//! (counted per test function below), together 1 − (1 − α)¹⁶ ≈ 0.054 % over the choice of seed;
//! the seeds are fixed. The deterministic checks cannot fail by chance.

use glam::{DVec2, DVec3, Vec2, Vec3};
use lightlab_geometry::{Geometry, NO_LIGHT, Shape, Sphere, TriangleMesh};
use lightlab_testkit::{Chi2Test, DirectionWindow, Domain, chi2_discrete, default_alpha};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

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
        light: 0,
    }
}

/// A 2 × 1 rectangle centred at (0.3, −0.2, 0.5), tilted out of every coordinate plane, as two
/// triangles.
fn quad() -> Shape {
    let c = Vec3::new(0.3, -0.2, 0.5);
    let u = Vec3::new(0.8, 0.6, 0.0); // half-extent 1 along u
    let v = Vec3::new(-0.36, 0.48, 0.8) * 0.5; // half-extent 0.5 along v (unit ⟂ u)
    mesh_shape(
        vec![c - u - v, c + u - v, c + u + v, c - u + v],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

/// Three triangles of areas 2.5, 0.5 and 0.02 (ratio 125), in different planes, none hiding
/// another from the reference points used.
fn three_triangles() -> Shape {
    mesh_shape(
        vec![
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.5, 0.0, 0.0),
            Vec3::new(-1.0, 2.0, 0.0),
            Vec3::new(2.0, 0.0, 0.2),
            Vec3::new(3.0, 0.0, 0.7),
            Vec3::new(2.0, 1.0, 1.2),
            Vec3::new(0.5, 2.5, 0.5),
            Vec3::new(0.7, 2.5, 0.5),
            Vec3::new(0.5, 2.7, 0.6),
        ],
        vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
    )
}

fn triangles(shape: &Shape) -> Vec<[DVec3; 3]> {
    let Geometry::Mesh(mesh) = &shape.geometry else {
        panic!("not a mesh")
    };
    (0..mesh.len())
        .map(|i| mesh.vertices(i).map(|p| p.as_dvec3()))
        .collect()
}

/// Ray–triangle intersection in f64 (Möller and Trumbore 1997): the hit distance and the
/// triangle's unit normal.
fn hit_triangle(o: DVec3, d: DVec3, t: &[DVec3; 3]) -> Option<(f64, DVec3)> {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - t[0];
    let b1 = s.dot(p) / det;
    let q = s.cross(e1);
    let b2 = d.dot(q) / det;
    let dist = e2.dot(q) / det;
    (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && dist > 0.0)
        .then(|| (dist, e1.cross(e2).normalize()))
}

/// Both intersections (t > 0) of the ray with a sphere, in f64, nearest first.
fn hit_sphere(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Vec<f64> {
    let oc = o - c;
    let b = oc.dot(d);
    // Discriminant as r² − |oc − (oc·d)d|², accurate for far spheres.
    let perp = oc - b * d;
    let disc = r * r - perp.length_squared();
    if disc < 0.0 {
        return Vec::new();
    }
    let root = disc.sqrt();
    [-b - root, -b + root]
        .into_iter()
        .filter(|&t| t > 0.0)
        .collect()
}

/// Density of the directions `sample_solid_angle` produces from `ref_p`, by ray casting (see the
/// module docs): the sum over the points of the shape along the ray, or only the first one for a
/// sphere sampled by its cone (`first_only`).
fn direction_pdf(shape: &Shape, ref_p: Vec3, w: Vec3, first_only: bool) -> f32 {
    let (o, d) = (ref_p.as_dvec3(), w.as_dvec3().normalize());
    let mut hits: Vec<(f64, DVec3)> = match &shape.geometry {
        Geometry::Mesh(_) => triangles(shape)
            .iter()
            .filter_map(|t| hit_triangle(o, d, t))
            .collect(),
        Geometry::Sphere(s) => {
            let c = s.center.as_dvec3();
            hit_sphere(o, d, c, s.radius as f64)
                .into_iter()
                .map(|t| (t, (o + t * d - c).normalize()))
                .collect()
        }
    };
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    if first_only {
        hits.truncate(1);
    }
    hits.iter()
        .map(|&(t, n)| shape.pdf_solid_angle(ref_p, (o + t * d).as_vec3(), n.as_vec3()))
        .sum()
}

/// The unit direction from `ref_p` to a sampled point, in f64 before rounding.
fn direction_to(ref_p: Vec3, p: Vec3) -> Vec3 {
    (p.as_dvec3() - ref_p.as_dvec3()).normalize().as_vec3()
}

/// Chi-square test of `sample_solid_angle` over the sphere of directions from `ref_p`. Also checks
/// that every sample's pdf is `pdf_solid_angle` at its point.
fn chi2_solid_angle_sphere(name: &str, shape: &Shape, ref_p: Vec3, first_only: bool, seed: u64) {
    Chi2Test::new(Domain::Sphere)
        .seed(seed)
        .run(
            name,
            |u| {
                let s = shape.sample_solid_angle(ref_p, u)?;
                let pdf = shape.pdf_solid_angle(ref_p, s.p, s.n);
                assert!((s.pdf / pdf - 1.0).abs() < 1e-5, "{name}: {s:?} vs {pdf}");
                Some(direction_to(ref_p, s.p))
            },
            |w: Vec3| direction_pdf(shape, ref_p, w, first_only),
        )
        .assert_ok();
}

/// The same on a window of directions; samples outside it would be reported as rejected, so the
/// windows are made to contain the whole shape and the test also asserts that none is.
fn chi2_solid_angle_window(
    name: &str,
    shape: &Shape,
    ref_p: Vec3,
    window: &DirectionWindow,
    first_only: bool,
    seed: u64,
) {
    let result = Chi2Test::new(Domain::Square).seed(seed).run(
        name,
        |u| {
            let s = shape.sample_solid_angle(ref_p, u)?;
            let p = window.to_square(direction_to(ref_p, s.p));
            assert!(p.is_some(), "{name}: sample {s:?} outside the window");
            p
        },
        |p: Vec2| window.density(p, |w| direction_pdf(shape, ref_p, w, first_only)),
    );
    result.assert_ok();
    assert_eq!(result.accepted, result.samples, "{name}: lost samples");
}

/// The window around the directions from `ref_p` to the points `corners`, 5 % larger than their
/// bounding rectangle in the gnomonic chart around `centre`.
fn window_around(ref_p: Vec3, centre: DVec3, corners: &[DVec3]) -> DirectionWindow {
    let o = ref_p.as_dvec3();
    let probe = DirectionWindow::new(centre - o, corners[0] - corners[1], (1.0, 1.0));
    let (e1, e2) = probe.axes();
    let c = probe.centre();
    let mut half = DVec2::ZERO;
    for &p in corners {
        let w = p - o;
        half = half.max(DVec2::new(w.dot(e1), w.dot(e2)).abs() / w.dot(c));
    }
    DirectionWindow::new(c, e1, (1.05 * half.x, 1.05 * half.y))
}

// ---- Meshes ---------------------------------------------------------------------------------

/// 2 tests: the quad seen from 2 units in front and from 1.5 units behind (the density uses
/// |cos θ|, so both sides are sampled alike), on windows around it.
#[test]
fn chi2_quad_solid_angle_window() {
    let shape = quad();
    let corners: Vec<DVec3> = {
        let Geometry::Mesh(m) = &shape.geometry else {
            unreachable!()
        };
        m.positions.iter().map(|p| p.as_dvec3()).collect()
    };
    let centre = corners.iter().sum::<DVec3>() / 4.0;
    let normal = (corners[1] - corners[0])
        .cross(corners[2] - corners[0])
        .normalize();
    let oblique = (normal + DVec3::new(0.2, -0.3, 0.1)).normalize();
    for (k, (what, ref_p)) in [
        ("front", centre + 2.0 * oblique),
        ("behind", centre - 1.5 * oblique),
    ]
    .into_iter()
    .enumerate()
    {
        let ref_p = ref_p.as_vec3();
        let window = window_around(ref_p, centre, &corners);
        chi2_solid_angle_window(
            &format!("quad_solid_angle_{what}"),
            &shape,
            ref_p,
            &window,
            false,
            5100 + k as u64,
        );
    }
}

/// 4 tests: the quad from 10⁻³ above its centre and 10⁻³ above a point 10⁻³ inside a corner,
/// where it fills almost a hemisphere (resp. a quarter of one) and the density, h²/(A cos³θ) up to
/// cos θ ≈ h/d, is concentrated within 10⁻³ of the horizon: on the sphere of directions that is a
/// sliver of one row, which the harness's midpoint rule cannot integrate (it loses 1.3 % of the
/// mass), so these two use the gnomonic chart of the quad's own plane (a window around the
/// normal, ±1200 wide), where the density times dω/dA is constant on the quad's image if and only
/// if pdf_solid_angle = pdf_area · d²/|cos θ|. Then from 0.1 above a point near an edge and 0.3
/// above the centre, on the sphere of directions.
#[test]
fn chi2_quad_solid_angle_close() {
    let shape = quad();
    let Geometry::Mesh(m) = &shape.geometry else {
        unreachable!()
    };
    let corners: Vec<DVec3> = m.positions.iter().map(|p| p.as_dvec3()).collect();
    let [p0, p1, p2, p3] = [0, 1, 2, 3].map(|i| corners[i]);
    let centre = (p0 + p1 + p2 + p3) / 4.0;
    let normal = (p1 - p0).cross(p2 - p0).normalize();
    let near_corner = p0 + 1e-3 * ((p1 - p0).normalize() + (p3 - p0).normalize());
    for (k, (what, foot)) in [("centre_1e-3", centre), ("corner_1e-3", near_corner)]
        .into_iter()
        .enumerate()
    {
        let ref_p = (foot + 1e-3 * normal).as_vec3();
        let window = window_around(ref_p, foot, &corners);
        chi2_solid_angle_window(
            &format!("quad_solid_angle_{what}"),
            &shape,
            ref_p,
            &window,
            false,
            5110 + k as u64,
        );
    }
    let near_edge = p0 + 0.5 * (p1 - p0) + 0.05 * (p3 - p0);
    for (k, (what, ref_p)) in [
        ("edge_0.1", near_edge + 0.1 * normal),
        ("centre_0.3", centre + 0.3 * normal),
    ]
    .into_iter()
    .enumerate()
    {
        chi2_solid_angle_sphere(
            &format!("quad_solid_angle_{what}"),
            &shape,
            ref_p.as_vec3(),
            false,
            5112 + k as u64,
        );
    }
}

/// 2 tests: three triangles of areas in the ratio 125 : 25 : 1, from a point above the largest one
/// (it fills much of the sphere) and from 3 units away (all three within 60°), on the sphere.
#[test]
fn chi2_triangle_mesh_solid_angle() {
    let shape = three_triangles();
    for (k, ref_p) in [Vec3::new(0.0, 0.7, 0.4), Vec3::new(1.0, 1.0, 3.5)]
        .into_iter()
        .enumerate()
    {
        chi2_solid_angle_sphere(
            &format!("triangle_mesh_solid_angle_{k}"),
            &shape,
            ref_p,
            false,
            5120 + k as u64,
        );
    }
}

/// 2 tests: area sampling of a mesh of triangles of areas 0.18, 0.018 and 0.0018 (ratio 100)
/// in the plane z = 0 inside the unit square, with the square as the chart (its area measure is
/// the mesh's), and the choice of triangle of the three-triangle mesh in 3D, ∝ area.
#[test]
fn chi2_mesh_sample_area() {
    let planar = mesh_shape(
        vec![
            Vec3::new(0.1, 0.1, 0.0),
            Vec3::new(0.7, 0.1, 0.0),
            Vec3::new(0.1, 0.7, 0.0),
            Vec3::new(0.8, 0.6, 0.0),
            Vec3::new(0.92, 0.6, 0.0),
            Vec3::new(0.8, 0.9, 0.0) + Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.2, 0.85, 0.0),
            Vec3::new(0.26, 0.85, 0.0),
            Vec3::new(0.2, 0.91, 0.0),
        ],
        vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
    );
    let tris = triangles(&planar);
    let area = |t: &[DVec3; 3]| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
    let total: f64 = tris.iter().map(area).sum();
    assert!((planar.area() as f64 - total).abs() < 1e-6 * total);
    let inside = |p: DVec3| {
        tris.iter().any(|t| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            let b0 = (t[1] - p).cross(t[2] - p).dot(n);
            let b1 = (t[2] - p).cross(t[0] - p).dot(n);
            let b2 = (t[0] - p).cross(t[1] - p).dot(n);
            b0 >= 0.0 && b1 >= 0.0 && b2 >= 0.0
        })
    };
    Chi2Test::new(Domain::Square)
        .seed(5130)
        .run(
            "mesh_sample_area_planar",
            |u| {
                let s = planar.sample_area(u);
                assert_eq!(s.p.z, 0.0);
                assert_eq!(s.pdf, planar.pdf_area());
                Some(s.p.truncate())
            },
            |p: Vec2| {
                if inside(p.extend(0.0).as_dvec3()) {
                    planar.pdf_area()
                } else {
                    0.0
                }
            },
        )
        .assert_ok();

    // The 3D mesh: which triangle each sample lies on, against area / total area.
    let shape = three_triangles();
    let tris = triangles(&shape);
    let areas: Vec<f64> = tris.iter().map(area).collect();
    let total: f64 = areas.iter().sum();
    let mut rng = Pcg32::seed_from_u64(5131);
    let mut counts = vec![0u64; tris.len()];
    for _ in 0..1_000_000 {
        let s = shape.sample_area(Vec2::new(rng.random(), rng.random()));
        let p = s.p.as_dvec3();
        let on = tris
            .iter()
            .position(|t| {
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
                (p - t[0]).dot(n).abs() < 1e-6 && {
                    let b = [
                        (t[1] - p).cross(t[2] - p).dot(n),
                        (t[2] - p).cross(t[0] - p).dot(n),
                        (t[0] - p).cross(t[1] - p).dot(n),
                    ];
                    b.iter().all(|&x| x >= -1e-9)
                }
            })
            .unwrap_or_else(|| panic!("sample {s:?} on no triangle"));
        counts[on] += 1;
    }
    let probabilities: Vec<f64> = areas.iter().map(|a| a / total).collect();
    chi2_discrete(
        "mesh_sample_area_triangles",
        &counts,
        &probabilities,
        default_alpha(),
    )
    .assert_ok();
}

// ---- Spheres --------------------------------------------------------------------------------

const CENTER: Vec3 = Vec3::new(1.0, -2.0, 3.0);
const RADIUS: f32 = 0.5;

/// A direction from the centre, off every axis.
fn towards() -> DVec3 {
    DVec3::new(0.3, -0.8, 0.52).normalize()
}

fn point_at(distance_in_radii: f64) -> Vec3 {
    (CENTER.as_dvec3() + towards() * distance_in_radii * RADIUS as f64).as_vec3()
}

/// 2 tests: from 1.01 r (a cone of half-angle 81.9°, on the sphere of directions) and from 10⁴ r
/// (a cone of 10⁻⁴ rad, on a window 1.25 times its width; there an f32 sample point is resolved
/// to ~10⁻³ of the cone's radius).
#[test]
fn chi2_sphere_solid_angle_outside() {
    let shape = sphere_shape(CENTER, RADIUS);
    chi2_solid_angle_sphere(
        "sphere_solid_angle_1.01r",
        &shape,
        point_at(1.01),
        true,
        5140,
    );
    let ref_p = point_at(1e4);
    let to_center = (CENTER - ref_p).as_dvec3();
    let sin2 = (RADIUS as f64).powi(2) / to_center.length_squared();
    let tan = (sin2 / (1.0 - sin2)).sqrt();
    let window = DirectionWindow::new(to_center, DVec3::Z, (1.25 * tan, 1.25 * tan));
    chi2_solid_angle_window(
        "sphere_solid_angle_1e4r",
        &shape,
        ref_p,
        &window,
        true,
        5141,
    );
}

/// 3 tests: from the centre (uniform, 1/4π), from 0.9 r (d²/(A cos θ) varies by a factor of
/// ~400 between the near and far sides) and from 1.0002 r, just outside but within the 0.05 %
/// where the sphere switches from its cone to area sampling: there both the near and the far point
/// along a direction are sampled, and the density has an integrable 1/cos singularity at the
/// silhouette. On the sphere of directions.
#[test]
fn chi2_sphere_solid_angle_inside_and_surface() {
    let shape = sphere_shape(CENTER, RADIUS);
    for (k, (what, at)) in [("centre", 0.0), ("0.9r", 0.9), ("1.0002r", 1.0002)]
        .into_iter()
        .enumerate()
    {
        chi2_solid_angle_sphere(
            &format!("sphere_solid_angle_{what}"),
            &shape,
            point_at(at),
            false,
            5150 + k as u64,
        );
    }
}

/// 1 test: area sampling of the sphere, histogrammed by the normal at the sampled point
/// (dA = r² dω), and every point on the sphere to its error bound.
#[test]
fn chi2_sphere_sample_area() {
    let shape = sphere_shape(CENTER, RADIUS);
    let r2 = RADIUS * RADIUS;
    Chi2Test::new(Domain::Sphere)
        .seed(5160)
        .run(
            "sphere_sample_area",
            |u| {
                let s = shape.sample_area(u);
                let d = (s.p - CENTER).as_dvec3();
                assert!((d.length() - RADIUS as f64).abs() <= s.p_error.length() as f64);
                assert_eq!(s.pdf, shape.pdf_area());
                Some((d / d.length()).as_vec3())
            },
            |_| shape.pdf_area() * r2,
        )
        .assert_ok();
}

/// Sampled points of a sphere seen from outside are the first hit along their direction (the
/// direction test alone would not notice far-side points), also from just outside the 0.05 %
/// band. Deterministic.
#[test]
fn sphere_cone_samples_are_the_visible_points() {
    let shape = sphere_shape(CENTER, RADIUS);
    let mut rng = Pcg32::seed_from_u64(5170);
    for at in [1.001, 1.01, 3.0, 1e4] {
        let ref_p = point_at(at);
        let o = ref_p.as_dvec3();
        let mut compared = 0;
        for _ in 0..10_000 {
            let s = shape
                .sample_solid_angle(ref_p, Vec2::new(rng.random(), rng.random()))
                .unwrap();
            let d = s.p.as_dvec3() - o;
            let len = d.length();
            let hits = hit_sphere(o, d / len, CENTER.as_dvec3(), RADIUS as f64);
            // A direction at the silhouette may miss in f64: then there is nothing to compare.
            if let [near, far] = hits[..] {
                let tol = s.p_error.length() as f64 + 1e-6 * len;
                assert!(
                    (len - near).abs() <= (len - far).abs() + tol,
                    "{at} r: sample at distance {len}, hits at {near} and {far}"
                );
                compared += 1;
            }
        }
        // Silhouette misses are rare: nearly every sample must have been compared.
        assert!(
            compared >= 9_900,
            "{at} r: only {compared} samples compared"
        );
    }
}
