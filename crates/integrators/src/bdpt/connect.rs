//! The strategies of one pixel sample: every (s, t) connection of its camera and light subpaths,
//! with its unweighted contribution, MIS weight and where it lands.

use super::{Bdpt, LIGHT_STREAM};
use crate::paths::PathClass;
use crate::render::Counters;
use crate::walk::{Kind, PathVertex, connect_to_lens, geometry_term, unoccluded};
use glam::Vec2;
use lightlab_core::{Rgb, TransportMode};
use lightlab_samplers::{Independent, Sampler, replicate_sample};
use lightlab_scene::Scene;

/// The class of the path strategy (s, t) joins, light first (for s = 0 the last camera vertex is
/// the emitter, not a scattering vertex). A connection vertex is named by its own class (the
/// connection evaluates its BSDF's non-delta part); the vertices before it as the walk left them
/// (plastic's coating an `S`), which only the class arriving at the next vertex records.
pub(crate) fn joined_class(
    light: &[PathVertex],
    camera: &[PathVertex],
    s: usize,
    t: usize,
) -> PathClass {
    match s {
        0 if t >= 2 => camera[t - 1].arrival_class().reversed(),
        0 => PathClass::EMPTY,
        _ => light[s - 1].class.then(camera[t - 1].class.reversed()),
    }
}

/// One strategy's contribution to one pixel sample.
#[derive(Clone, Copy, Debug)]
pub struct Contribution {
    /// Light subpath vertices of the strategy.
    pub s: usize,
    /// Camera subpath vertices of the strategy.
    pub t: usize,
    /// Its layer (see `Router::route`).
    pub layer: usize,
    /// The strategy's own estimate, before the MIS weight.
    pub unweighted: Rgb,
    /// Its MIS weight.
    pub weight: f32,
    /// Where a t = 1 contribution lands; `None` for the sample's own pixel.
    pub raster: Option<Vec2>,
}

impl Bdpt {
    /// Traces pixel sample `index` of `pixel` and calls `visit(contribution, light subpath, camera
    /// subpath)` for every strategy that contributes, in the order the renderer adds them. Rendering
    /// and [`Bdpt::replay`] both go through here, so a replay reproduces a render's sample exactly.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn pixel_sample<S: Sampler>(
        &self,
        scene: &Scene,
        seed: u64,
        (x, y): (u32, u32),
        index: u64,
        sampler: &mut S,
        light_sampler: &mut Independent,
        (camera, light): (&mut Vec<PathVertex>, &mut Vec<PathVertex>),
        counters: &mut Counters,
        mut visit: impl FnMut(&Contribution, &[PathVertex], &[PathVertex]),
    ) {
        let cfg = &self.config;
        let max_bounces = cfg.max_bounces.unwrap_or(u32::MAX - 2);
        let pixel = y as u64 * scene.camera.width as u64 + x as u64;
        let (seed, index) = replicate_sample(seed, index, cfg.replicates);
        sampler.start_pixel_sample(seed, pixel, index);
        light_sampler.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, index);
        let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
        // One instant for both subpaths: their connections join points of one scene.
        let time = scene.camera.sample_time(sampler);
        camera.clear();
        light.clear();
        // A full path of at most max_bounces scattering vertices: the camera side may reach an
        // emitter after max_bounces of them (s = 0), the light side scatter max_bounces times
        // before its last vertex is seen through the lens (t = 1).
        self.camera_subpath(
            scene,
            film,
            time,
            sampler,
            max_bounces.saturating_add(1),
            camera,
            counters,
        );
        self.light_subpath(scene, time, light_sampler, max_bounces, light, counters);
        for t in 1..=camera.len() {
            let (u_light, u_point, u_lens) = (
                light_sampler.next_1d(),
                light_sampler.next_2d(),
                light_sampler.next_2d(),
            );
            for s in 0..=light.len() {
                let depth = (s + t) as i64 - 2;
                if depth < cfg.min_bounces as i64
                    || depth > max_bounces as i64
                    || cfg.mis.excludes(s, t)
                {
                    continue;
                }
                // Only a router that filters or splits needs the joined path's class (outliers
                // rebuild it).
                let class = if self.router.is_trivial() {
                    PathClass::EMPTY
                } else {
                    joined_class(light, camera, s, t)
                };
                let Some(layer) = self.router.route(&class) else {
                    continue;
                };
                let Some((unweighted, weight, raster)) = self.connect(
                    scene, light, camera, s, t, u_light, u_point, u_lens, counters,
                ) else {
                    continue;
                };
                let c = Contribution {
                    s,
                    t,
                    layer,
                    unweighted,
                    weight,
                    raster,
                };
                visit(&c, &light[..s.min(light.len())], &camera[..t]);
            }
        }
    }

    /// Unweighted contribution of strategy (s, t), its MIS weight, and where it goes: the pixel
    /// (`None`) or, for t = 1, a splat position.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn connect(
        &self,
        scene: &Scene,
        light: &[PathVertex],
        camera: &[PathVertex],
        s: usize,
        t: usize,
        u_light: f32,
        u_point: Vec2,
        u_lens: Vec2,
        counters: &mut Counters,
    ) -> Option<(Rgb, f32, Option<Vec2>)> {
        let c = connection(
            scene, light, camera, s, t, u_light, u_point, u_lens, counters,
        )?;
        let w = Self::mis_weight(scene, light, camera, c.sampled, s, t, self.config.mis);
        Some((c.unweighted, w, c.raster))
    }
}

/// What connecting subpaths by strategy (s, t) found, before any MIS weight.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Connected {
    /// The strategy's unweighted estimate.
    pub unweighted: Rgb,
    /// Where a t = 1 contribution lands; `None` for the sample's own pixel.
    pub raster: Option<Vec2>,
    /// The endpoint the strategy sampled anew: the light point for s = 1 with t ≥ 2, the lens
    /// point for t = 1.
    pub sampled: Option<PathVertex>,
}

/// Strategy (s, t) of subpaths `light` and `camera` (Veach 1997 §10.2): s = 0 the camera subpath
/// ends on an emitter, s = 1 a light point sampled from the camera vertex (`u_light`, `u_point`),
/// t = 1 the light vertex connected to a lens point (`u_lens`), otherwise the two end vertices
/// joined by a shadow ray. `None` when the strategy cannot carry light.
#[allow(clippy::too_many_arguments)]
pub(crate) fn connection(
    scene: &Scene,
    light: &[PathVertex],
    camera: &[PathVertex],
    s: usize,
    t: usize,
    u_light: f32,
    u_point: Vec2,
    u_lens: Vec2,
    counters: &mut Counters,
) -> Option<Connected> {
    // An escaped camera path can only be completed by s = 0.
    if t > 1 && s != 0 && camera[t - 1].infinite {
        return None;
    }
    let mut sampled = None;
    let mut raster = None;
    let l = if s == 0 {
        let pt = &camera[t - 1];
        pt.light()?;
        pt.beta * pt.le(scene, &camera[t - 2])
    } else if t == 1 {
        let qs = &light[s - 1];
        if !qs.connectible() || qs.infinite {
            return None;
        }
        // s = t = 1: the point on the light seen directly through the lens (light tracing's
        // emission connection); a point or spot light has no area to be seen.
        if s == 1 && (!qs.on_surface() || !(qs.pdf_fwd > 0.0)) {
            return None;
        }
        let c = connect_to_lens(scene, qs, u_lens, counters, |v, _| {
            if s == 1 {
                qs.le(scene, v) / qs.pdf_fwd
            } else {
                qs.beta * qs.f(&light[s - 2], v, TransportMode::Importance)
            }
        })?;
        raster = Some(c.raster);
        sampled = Some(c.camera);
        c.contribution
    } else if s == 1 {
        let pt = &camera[t - 1];
        if !pt.connectible() {
            return None;
        }
        let (light_index, pmf) = scene.sample_light(u_light)?;
        let lt = &scene.lights[light_index as usize];
        let ls = lt.sample_li(scene.shapes(), pt.p, u_point)?;
        if !(ls.pdf_w > 0.0) || ls.li.is_black() {
            return None;
        }
        let mut v = PathVertex::new(
            Kind::Light { light: light_index },
            ls.p,
            pt.time,
            ls.li / (ls.pdf_w * pmf),
        );
        v.p_error = ls.p_error;
        if ls.infinite {
            v.infinite = true;
            v.ng = -ls.wi;
        } else if !ls.delta {
            v.ng = ls.n;
            v.ns = ls.n;
        }
        v.pdf_fwd = v.pdf_light_origin(scene);
        let f = pt.f(&camera[t - 2], &v, TransportMode::Radiance);
        let l = pt.beta * f * v.beta * pt.ns.dot(ls.wi).abs();
        sampled = Some(v);
        if l.is_black() {
            return None;
        }
        counters.rays += 1;
        if !unoccluded(scene, pt, &v) {
            return None;
        }
        l
    } else {
        let (qs, pt) = (&light[s - 1], &camera[t - 1]);
        if !qs.connectible() || !pt.connectible() || qs.infinite {
            return None;
        }
        // s ≥ 2: qs is a surface vertex.
        let fq = qs.f(&light[s - 2], pt, TransportMode::Importance);
        let l = qs.beta * fq * pt.f(&camera[t - 2], qs, TransportMode::Radiance) * pt.beta;
        if l.is_black() {
            return None;
        }
        let l = l * geometry_term(qs, pt);
        if l.is_black() {
            return None;
        }
        counters.rays += 1;
        if !unoccluded(scene, qs, pt) {
            return None;
        }
        l
    };
    Some(Connected {
        unweighted: l,
        raster,
        sampled,
    })
}
