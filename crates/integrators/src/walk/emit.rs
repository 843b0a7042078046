//! The start of every light path (Veach 1997 §10.2; pbrt-v4 §16.3.2): a light chosen by power,
//! a point and direction sampled on it, and the flux the path carries.

use super::vertex::{Kind, PathVertex};
use lightlab_core::{Ray, Rgb};
use lightlab_geometry::spawn_ray;
use lightlab_samplers::Sampler;
use lightlab_scene::Scene;

/// An emitted light path's origin and first ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Emitted {
    /// y₀: the point on the light (the direction of travel for an emitter at infinity), with
    /// β = Le / (pmf · p_A) and its density (pmf · p_A; pmf / 4π directional at infinity).
    pub origin: PathVertex,
    pub ray: Ray,
    /// Le·|cos θ| / (pmf · p_A · p_ω): the flux of the path (E over paths = the emitted power).
    pub beta: Rgb,
    /// The density of the ray to give the walk: p_ω, or p_A of the disk an emitter at infinity
    /// sends its rays from.
    pub pdf: f32,
}

/// Samples a light path's start at instant `time` with three dimensions of `sampler`: light (1),
/// position (2), direction (2). `None` when the scene does not emit or the sample has zero
/// density. (Emitters do not move, so `time` only travels with the path.)
pub(crate) fn emit<S: Sampler>(scene: &Scene, sampler: &mut S, time: f32) -> Option<Emitted> {
    let (u_light, u_pos, u_dir) = (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
    let (light, pmf) = scene.sample_light(u_light)?;
    let l = &scene.lights[light as usize];
    let em = l.sample_le(scene.shapes(), scene.center, scene.radius, u_pos, u_dir)?;
    let infinite = l.is_infinite();
    let mut origin = PathVertex::new(
        Kind::Light { light },
        em.p,
        time,
        em.le / (pmf * em.pdf_pos),
    );
    origin.p_error = em.p_error;
    if infinite {
        origin.infinite = true;
        origin.ng = em.dir;
        origin.pdf_fwd = pmf * em.pdf_dir;
    } else {
        origin.pdf_fwd = pmf * em.pdf_pos;
        if !em.delta_pos {
            origin.ng = em.n;
            origin.ns = em.n;
        }
    }
    let (cos, ray) = if em.delta_pos || infinite {
        (1.0, Ray::new(em.p, em.dir).at_time(time))
    } else {
        (
            em.n.dot(em.dir).abs(),
            spawn_ray(em.p, em.p_error, em.n, em.dir).at_time(time),
        )
    };
    Some(Emitted {
        origin,
        ray,
        beta: em.le * (cos / (pmf * em.pdf_pos * em.pdf_dir)),
        pdf: if infinite { em.pdf_pos } else { em.pdf_dir },
    })
}
