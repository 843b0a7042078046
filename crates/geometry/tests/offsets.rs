//! Self-intersection (design.md): rays spawned from hit points with `spawn_ray` never re-hit their
//! own primitive at tiny t, and segments between mutually visible surface points are never
//! occluded by their own end surfaces, at scales 10⁻³, 1, 10³ and far from the origin.

use lightlab_core::{Ray, Vec2, Vec3};
use lightlab_geometry::{
    Accel, Geometry, Hit, NO_LIGHT, Shape, Sphere, TriangleMesh, spawn_ray, spawn_ray_to,
    spawn_ray_to_point,
};
use lightlab_samplers::warp::square_to_uniform_sphere;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

const VARIANTS: [(f32, Vec3); 4] = [
    (1e-3, Vec3::ZERO),
    (1.0, Vec3::ZERO),
    (1e3, Vec3::ZERO),
    (1.0, Vec3::splat(1e4)),
];

fn vec(rng: &mut Pcg64, lo: f32, hi: f32) -> Vec3 {
    Vec3::new(
        rng.random_range(lo..hi),
        rng.random_range(lo..hi),
        rng.random_range(lo..hi),
    )
}

fn dir(rng: &mut Pcg64) -> Vec3 {
    square_to_uniform_sphere(Vec2::new(rng.random::<f32>(), rng.random::<f32>()))
}

fn shape(geometry: Geometry) -> Shape {
    Shape {
        geometry,
        material: 0,
        light: NO_LIGHT,
    }
}

/// Large random triangles, a tessellated sphere (shared vertices, slightly non-planar
/// neighbourhoods) and analytic spheres, all `· scale + offset`.
fn scene(seed: u64, scale: f32, offset: Vec3) -> Vec<Shape> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let tf = |p: Vec3| p * scale + offset;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for i in 0..300u32 {
        let c = vec(&mut rng, -1.0, 1.0);
        let size = rng.random_range(0.1..0.6);
        for _ in 0..3 {
            positions.push(tf(c + size * vec(&mut rng, -1.0, 1.0)));
        }
        indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let mut shapes = vec![shape(Geometry::Mesh(
        TriangleMesh::new(positions, None, None, indices).unwrap(),
    ))];

    let (rings, segments) = (24u32, 48u32);
    let (center, radius) = (Vec3::new(0.3, -0.2, 0.1), 0.4);
    let mut positions = Vec::new();
    for j in 0..=rings {
        let theta = std::f32::consts::PI * j as f32 / rings as f32;
        for i in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * i as f32 / segments as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            positions.push(tf(center + radius * n));
        }
    }
    let mut indices = Vec::new();
    for j in 0..rings {
        for i in 0..segments {
            let k = |j: u32, i: u32| j * segments + i % segments;
            indices.push([k(j, i), k(j + 1, i), k(j + 1, i + 1)]);
            indices.push([k(j, i), k(j + 1, i + 1), k(j, i + 1)]);
        }
    }
    shapes.push(shape(Geometry::Mesh(
        TriangleMesh::new(positions, None, None, indices).unwrap(),
    )));

    for _ in 0..20 {
        shapes.push(shape(Geometry::Sphere(Sphere::new(
            tf(vec(&mut rng, -1.0, 1.0)),
            scale * rng.random_range(0.05..0.3),
        ))));
    }
    shapes
}

/// Spawns 5 rays in random directions (and of random lengths) from `hit` and checks that each
/// origin is strictly on the side of the surface its ray goes to (in f64) and that the ray does
/// not re-hit the primitive it left, except a sphere entered, at the far end of its chord.
fn check_spawns(v: &str, accel: &Accel, hit: &Hit, rng: &mut Pcg64) {
    let shape = &accel.shapes()[hit.shape as usize].geometry;
    for _ in 0..5 {
        let d = dir(rng) * rng.random_range(0.1..10.0);
        let ray = spawn_ray(hit.p, hit.p_error, hit.ng, d);
        let again = accel.intersect(&ray);
        let same = again.is_some_and(|h| (h.shape, h.primitive) == (hit.shape, hit.primitive));
        let o = ray.o.as_dvec3();
        let outward = d.dot(hit.ng) > 0.0;
        match shape {
            Geometry::Mesh(mesh) => {
                let [v0, v1, v2] = mesh.vertices(hit.primitive as usize).map(|v| v.as_dvec3());
                let n = (v1 - v0).cross(v2 - v0);
                let side = (o - v0).dot(n) * d.as_dvec3().dot(n);
                assert!(side > 0.0, "{v}: origin {o} not off the plane of {hit:?}");
                assert!(!same, "{v}: self-hit {again:?} from {hit:?} along {d}");
            }
            Geometry::Sphere(sphere) => {
                let (c, r) = (sphere.center.as_dvec3(), sphere.radius as f64);
                let inside = (o - c).length() < r;
                assert_eq!(
                    inside, !outward,
                    "{v}: origin {o} on the wrong side of {hit:?}"
                );
                if outward {
                    assert!(!same, "{v}: self-hit {again:?} from {hit:?} along {d}");
                    continue;
                }
                // Into the sphere: something is met no later than the far end of the chord, and
                // if it is the sphere, then there and not at t ≈ 0.
                let dd = d.as_dvec3();
                let (a, b) = (dd.length_squared(), dd.dot(o - c));
                let t_far = (-b + (b * b - a * ((o - c).length_squared() - r * r)).sqrt()) / a;
                let h = again.unwrap_or_else(|| panic!("{v}: escaped a sphere from {hit:?}"));
                let t = h.t as f64;
                assert!(
                    t <= t_far * (1.0 + 1e-4),
                    "{v}: went through the sphere: {hit:?} along {d} to {h:?}"
                );
                if same {
                    assert!(
                        (t - t_far).abs() <= 1e-4 * t_far,
                        "{v}: sphere re-hit at t = {t}, chord ends at {t_far}"
                    );
                }
            }
        }
    }
}

#[test]
fn spawned_rays_never_rehit_their_own_primitive() {
    let mut spawned = 0usize;
    for (v, &(scale, offset)) in VARIANTS.iter().enumerate() {
        let accel = Accel::new(scene(1, scale, offset));
        let mut rng = Pcg64::seed_from_u64(2 + v as u64);
        for _ in 0..25_000 {
            let o = vec(&mut rng, -1.5, 1.5) * scale + offset;
            let target = vec(&mut rng, -1.0, 1.0) * scale + offset;
            if let Some(hit) = accel.intersect(&Ray::new(o, target - o)) {
                check_spawns(
                    &format!("scale {scale} offset {offset}"),
                    &accel,
                    &hit,
                    &mut rng,
                );
                spawned += 5;
            }
        }
    }
    assert!(spawned > 300_000, "only {spawned} spawned rays");
}

/// Hit points near the origin on primitives whose coordinates are ~10⁴: the error of the
/// reconstructed point is far larger than its own ulp, so only the error bounds (γ₇·Σ|bᵢpᵢ| for
/// triangles, the |center| term for spheres) keep spawned rays off the surface.
#[test]
fn spawned_rays_leave_large_primitives_near_the_origin() {
    let mut rng = Pcg64::seed_from_u64(9);
    let mut shapes = Vec::new();
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for i in 0..100u32 {
        // A huge triangle through a random point of the unit box.
        let through = vec(&mut rng, -1.0, 1.0);
        let (a, b) = (dir(&mut rng), dir(&mut rng));
        positions.extend([
            through + 1e4 * a,
            through + 1e4 * b,
            through - 1e4 * (a + b),
        ]);
        indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    shapes.push(shape(Geometry::Mesh(
        TriangleMesh::new(positions, None, None, indices).unwrap(),
    )));
    for _ in 0..40 {
        // A sphere of radius ~10⁴ whose surface crosses the unit box.
        let center = 1e4 * dir(&mut rng);
        let radius = (center - vec(&mut rng, -1.0, 1.0)).length();
        shapes.push(shape(Geometry::Sphere(Sphere::new(center, radius))));
    }
    let accel = Accel::new(shapes);
    let mut spawned = 0;
    for _ in 0..20_000 {
        let o = vec(&mut rng, -1.0, 1.0);
        let target = vec(&mut rng, -1.0, 1.0);
        if let Some(hit) = accel.intersect(&Ray::new(o, target - o)) {
            check_spawns("large primitives", &accel, &hit, &mut rng);
            spawned += 5;
        }
    }
    assert!(spawned > 50_000, "only {spawned} spawned rays");
}

#[test]
fn segments_between_facing_surfaces_are_never_occluded() {
    for (v, &(scale, offset)) in VARIANTS.iter().enumerate() {
        let tf = |p: Vec3| p * scale + offset;
        // Two facing, slightly tilted quads and a sphere between them that no segment crosses.
        let quad = |z: f32, tilt: f32| {
            let p = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .map(|(x, y)| tf(Vec3::new(x, y, z + tilt * x)))
                .to_vec();
            shape(Geometry::Mesh(
                TriangleMesh::new(p, None, None, vec![[0, 1, 2], [0, 2, 3]]).unwrap(),
            ))
        };
        let shapes = vec![
            quad(-1.0, 0.1),
            quad(1.0, -0.2),
            shape(Geometry::Sphere(Sphere::new(
                tf(Vec3::new(3.0, 0.0, 0.0)),
                scale,
            ))),
        ];
        let accel = Accel::new(shapes);
        let mut rng = Pcg64::seed_from_u64(20 + v as u64);
        let light = tf(Vec3::new(0.1, 0.2, 0.3));
        for k in 0..50_000 {
            let u = |rng: &mut Pcg64| Vec2::new(rng.random::<f32>(), rng.random::<f32>());
            let a = accel.shapes()[0].sample_area(u(&mut rng));
            let b = accel.shapes()[1].sample_area(u(&mut rng));
            let r = spawn_ray_to(a.p, a.p_error, a.n, b.p, b.p_error, b.n);
            assert!(
                !accel.occluded(&r),
                "variant {v} sample {k}: {a:?} -> {b:?}"
            );
            let r = spawn_ray_to_point(a.p, a.p_error, a.n, light);
            assert!(
                !accel.occluded(&r),
                "variant {v} sample {k}: {a:?} -> light"
            );
            let s = accel.shapes()[2].sample_area(u(&mut rng));
            let r = spawn_ray_to(a.p, a.p_error, a.n, s.p, s.p_error, s.n);
            // Points on the sphere's far side are hidden by the sphere itself.
            // (Grazing points, within the error bounds of either end, may be either side.)
            let margin = 1e-3 * (a.p - s.p).length() + 4.0 * (a.p_error + s.p_error).length();
            if s.n.dot(a.p - s.p) > margin {
                assert!(
                    !accel.occluded(&r),
                    "variant {v} sample {k}: {a:?} to sphere point {s:?}: {r:?} hits {:?}",
                    accel.intersect(&r)
                );
            }
        }
    }
}
