//! The camera's end of a path: the ray a pixel sample starts, and the connection of a light-side
//! vertex to a point sampled on the lens (light tracing; the t = 1 strategies of bidirectional
//! path tracing, Veach 1997 §10.2).

use super::vertex::{Kind, PathVertex};
use crate::render::Counters;
use glam::{Vec2, Vec3};
use lightlab_core::{Ray, Rgb};
use lightlab_geometry::spawn_ray_to_point;
use lightlab_scene::Scene;

/// The camera vertex and ray through raster position `film` with lens sample `u_lens`, at
/// instant `time`.
#[inline]
pub(crate) fn camera_ray(scene: &Scene, film: Vec2, u_lens: Vec2, time: f32) -> (PathVertex, Ray) {
    let ray = scene.camera.generate_ray(film, u_lens).at_time(time);
    (PathVertex::new(Kind::Camera, ray.o, time, Rgb::WHITE), ray)
}

/// A light-side vertex seen through the lens.
pub(crate) struct LensConnection {
    /// Where it lands on the film.
    pub raster: Vec2,
    /// The sampled lens point as a camera vertex, β = We / p_ω.
    pub camera: PathVertex,
    /// value · |cos θ_v| · We / p_ω: the unweighted contribution to the pixel at `raster`.
    pub contribution: Rgb,
}

/// Connects `v` to a point sampled on the lens with `u_lens`. `value(camera, wi)` is what leaves
/// `v` toward that point, in unit direction `wi`, per unit of its cosine (β·f for a scattering
/// vertex, Le/p for an emitter's origin). `None` if the lens cannot see `v`, nothing leaves toward
/// it, or the segment is blocked.
#[inline]
pub(crate) fn connect_to_lens(
    scene: &Scene,
    v: &PathVertex,
    u_lens: Vec2,
    counters: &mut Counters,
    value: impl FnOnce(&PathVertex, Vec3) -> Rgb,
) -> Option<LensConnection> {
    let cs = scene.camera.sample_wi(v.p, u_lens)?;
    if !(cs.pdf_w > 0.0) {
        return None;
    }
    let camera = PathVertex::new(
        Kind::Camera,
        cs.p_lens,
        v.time,
        Rgb::splat(cs.we / cs.pdf_w),
    );
    let contribution = value(&camera, cs.wi) * camera.beta * v.ns.dot(cs.wi).abs();
    if contribution.is_black() {
        return None;
    }
    counters.rays += 1;
    // The lens point is on no surface: the shadow ray leaves v's surface (if any) for it.
    let ray = if v.on_surface() {
        spawn_ray_to_point(v.p, v.p_error, v.ng, cs.p_lens)
    } else {
        Ray::segment(v.p, cs.p_lens - v.p, 1.0 - 1e-4)
    };
    if scene.occluded(&ray.at_time(v.time)) {
        return None;
    }
    Some(LensConnection {
        raster: cs.raster,
        camera,
        contribution,
    })
}
