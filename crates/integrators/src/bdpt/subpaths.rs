//! The camera and light subpaths (Veach 1997 §10.2): walks stored vertex by vertex, each vertex
//! with the area densities of its generation from both sides.

use super::Bdpt;
use crate::render::Counters;
use crate::walk::{Arrival, Kind, PathVertex, Visitor, Walk, from_camera, from_light};
use glam::Vec2;
use lightlab_core::{Ray, Rgb, TransportMode};
use lightlab_materials::BsdfSample;
use lightlab_samplers::Sampler;
use lightlab_scene::Scene;

impl Bdpt {
    /// The camera subpath through raster position `film` at instant `time`: the camera vertex and
    /// up to `max_depth` surface vertices (and a vertex at infinity if it escapes to an
    /// environment).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn camera_subpath<S: Sampler>(
        &self,
        scene: &Scene,
        film: Vec2,
        time: f32,
        sampler: &mut S,
        max_depth: u32,
        path: &mut Vec<PathVertex>,
        counters: &mut Counters,
    ) {
        let walk = self.walk(TransportMode::Radiance, max_depth);
        camera_subpath(scene, &walk, film, time, sampler, path, counters);
    }

    /// The light subpath (pbrt-v4 `GenerateLightSubpath`) at instant `time`: its origin on a light
    /// and up to `max_depth` surface vertices.
    pub(super) fn light_subpath<S: Sampler>(
        &self,
        scene: &Scene,
        time: f32,
        sampler: &mut S,
        max_depth: u32,
        path: &mut Vec<PathVertex>,
        counters: &mut Counters,
    ) {
        let walk = self.walk(TransportMode::Importance, max_depth);
        light_subpath(scene, &walk, time, sampler, path, counters);
    }
}

/// Appends the camera subpath through raster position `film` at instant `time`, walked as `walk`
/// says (radiance), to `path`: the camera vertex, its surface vertices, and a vertex at infinity
/// if it escapes to an environment.
pub(crate) fn camera_subpath<S: Sampler>(
    scene: &Scene,
    walk: &Walk,
    film: Vec2,
    time: f32,
    sampler: &mut S,
    path: &mut Vec<PathVertex>,
    counters: &mut Counters,
) {
    let mut subpath = Subpath {
        scene,
        camera: true,
        path,
    };
    from_camera(scene, walk, film, time, sampler, &mut subpath, counters);
}

/// Appends a light subpath at instant `time`, walked as `walk` says (importance), to `path`: its
/// origin on a light and its surface vertices.
pub(crate) fn light_subpath<S: Sampler>(
    scene: &Scene,
    walk: &Walk,
    time: f32,
    sampler: &mut S,
    path: &mut Vec<PathVertex>,
    counters: &mut Counters,
) {
    let mut subpath = Subpath {
        scene,
        camera: false,
        path,
    };
    from_light(scene, walk, time, sampler, &mut subpath, counters);
}

/// A subpath stored vertex by vertex, with the reverse density of each vertex set once the walk
/// has scattered from the next one.
struct Subpath<'a> {
    scene: &'a Scene,
    /// The camera's subpath (radiance), not a light's.
    camera: bool,
    path: &'a mut Vec<PathVertex>,
}

impl Visitor for Subpath<'_> {
    const DENSITIES: bool = true;

    #[inline]
    fn origin<S: Sampler>(&mut self, v: &PathVertex, _: &mut S, _: &mut Counters) {
        self.path.push(*v);
    }

    #[inline]
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        _: &Arrival,
        _: &mut S,
        _: &mut Counters,
    ) -> bool {
        self.path.push(*v);
        true
    }

    #[inline]
    fn scattered(&mut self, v: &PathVertex, s: &BsdfSample) {
        let (_, pdf_rev_w) = v.step_densities(s);
        let n = self.path.len();
        self.path[n - 1].delta = s.delta;
        self.path[n - 2].pdf_rev = v.convert_density(pdf_rev_w, &self.path[n - 2]);
    }

    /// A camera subpath that escapes ends on the environment, if there is one.
    #[inline]
    fn escaped(&mut self, ray: &Ray, beta: Rgb, arrival: &Arrival, _: &mut Counters) {
        if !self.camera {
            return;
        }
        if let Some(env) = self.scene.environment_light() {
            let mut v = PathVertex::new(Kind::Light { light: env }, ray.o + ray.d, ray.time, beta);
            v.class = arrival.class;
            v.depth = arrival.class.len();
            v.infinite = true;
            // At infinity `ng` is the direction light travels in: back along the ray.
            v.ng = -ray.d.normalize();
            v.pdf_fwd = arrival.pdf_w;
            self.path.push(v);
        }
    }
}
