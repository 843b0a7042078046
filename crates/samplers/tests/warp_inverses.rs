//! Inverse warps undo their warps (`x_to_square(square_to_x(u)) = u`) on random points and on the
//! edges of the unit square, for the cone apertures the chi-square tests use. The unit test in
//! `warp.rs` covers a 32 × 32 interior grid with one cone.

use glam::{Vec2, Vec3};
use lightlab_samplers::warp::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

/// 10⁴ random points plus the corners and edge midpoints of [0, 1)².
fn points() -> Vec<Vec2> {
    let below_one = 1.0 - f32::EPSILON / 2.0;
    let edges = [0.0, 0.5, below_one];
    let mut rng = Pcg32::seed_from_u64(13);
    edges
        .into_iter()
        .flat_map(|x| edges.map(|y| Vec2::new(x, y)))
        .chain((0..10_000).map(|_| Vec2::new(rng.random(), rng.random())))
        .collect()
}

/// Distance in u with u.y periodic (it is an azimuth, so 0 and 1 are the same point).
fn periodic_distance(a: Vec2, b: Vec2) -> Vec2 {
    let dy = (a.y - b.y).abs();
    Vec2::new((a.x - b.x).abs(), dy.min(1.0 - dy))
}

/// Asserts the round trip of a direction warp whose u.x is 1 − cos θ scaled and u.y the azimuth;
/// at the pole (u.x = 0) the azimuth is undefined and only u.x is compared.
fn assert_direction_round_trip(
    name: &str,
    warp: impl Fn(Vec2) -> Vec3,
    inverse: impl Fn(Vec3) -> Vec2,
    tolerance: f32,
) {
    for u in points() {
        let back = inverse(warp(u));
        let mut d = periodic_distance(u, back);
        if u.x == 0.0 {
            d.y = 0.0;
        }
        assert!(
            d.max_element() <= tolerance,
            "{name}: {u} -> {} -> {back} (error {d})",
            warp(u)
        );
    }
}

#[test]
fn sphere_and_hemisphere_inverses_round_trip() {
    assert_direction_round_trip(
        "uniform sphere",
        square_to_uniform_sphere,
        uniform_sphere_to_square,
        1e-5,
    );
    assert_direction_round_trip(
        "uniform hemisphere",
        square_to_uniform_hemisphere,
        uniform_hemisphere_to_square,
        1e-5,
    );
    for cos_theta_max in [0.9, 0.0, -0.5] {
        assert_direction_round_trip(
            &format!("uniform cone {cos_theta_max}"),
            |u| square_to_uniform_cone(u, cos_theta_max),
            |v| uniform_cone_to_square(v, cos_theta_max),
            1e-5,
        );
    }
}

#[test]
fn disk_and_cosine_inverses_round_trip() {
    for u in points() {
        let check = |name: &str, back: Vec2| {
            let d = (back - u).abs();
            assert!(d.max_element() <= 1e-5, "{name}: {u} -> {back} (error {d})");
        };
        check(
            "concentric disk",
            concentric_disk_to_square(square_to_concentric_disk(u)),
        );
        check(
            "cosine hemisphere",
            cosine_hemisphere_to_square(square_to_cosine_hemisphere(u)),
        );
    }
}

#[test]
fn triangle_inverse_round_trips() {
    for u in points() {
        let back = uniform_triangle_to_square(square_to_uniform_triangle(u));
        let mut d = (back - u).abs();
        // At u.x = 0 every u.y maps to the vertex b = (1, 0): u.y is lost.
        if u.x == 0.0 {
            d.y = 0.0;
        }
        assert!(
            d.max_element() <= 1e-5,
            "triangle: {u} -> {back} (error {d})"
        );
    }
}

/// Narrow cones (a distant light): `square_to_uniform_cone` keeps 1 − cos θ precise, so its
/// inverse must too.
#[test]
fn narrow_cone_inverse_round_trips() {
    for cos_theta_max in [0.999, 1.0 - 1e-6] {
        assert_direction_round_trip(
            &format!("uniform cone {cos_theta_max}"),
            |u| square_to_uniform_cone(u, cos_theta_max),
            |v| uniform_cone_to_square(v, cos_theta_max),
            1e-5,
        );
    }
}
