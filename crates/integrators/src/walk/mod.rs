//! The random walk every integrator builds its paths with (Veach 1997 §10.2; pbrt-v4 §16.3.2
//! `RandomWalk`): from a ray leaving a vertex, intersect, make the [`PathVertex`], let the
//! integrator's [`Visitor`] look at it, and scatter — the one place that builds a surface BSDF,
//! samples it, rejects black and non-finite weights, plays Russian roulette and spawns the next
//! ray. Path tracing and the photon camera walk stream through it without storing; bidirectional
//! path tracing stores its subpaths; photon tracing keeps the light walk's non-delta vertices.
//!
//! Depth: a walk's vertices are numbered on from its origin's `depth` (0 at the camera or a
//! light), and the walk ends after the vertex of depth `max_depth` without scattering from it.
//!
//! Sample dimensions per vertex, the layout stratified samplers rely on: first whatever the
//! visitor draws at the vertex (next-event estimation, a lens sample, …), then the walk's own
//! lobe choice (1), direction (2) and roulette (1) — drawn only if the walk scatters there.

mod camera;
mod emit;
mod roulette;
mod scatter;
mod vertex;

use camera::camera_ray;
pub(crate) use camera::connect_to_lens;
pub(crate) use emit::emit;
pub(crate) use scatter::Directions;

pub(crate) use vertex::{Kind, PathVertex, geometry_term, unoccluded};

use crate::paths::PathClass;
use crate::render::{Counters, Technique};
use glam::{Vec2, Vec3};
use lightlab_core::{Ray, Rgb, TransportMode};
use lightlab_geometry::spawn_ray;
use lightlab_materials::{BsdfSample, LobeClass, SurfaceBsdf};
use lightlab_samplers::Sampler;
use lightlab_scene::Scene;
pub(crate) use roulette::DEEP;
use roulette::Roulette;
pub use roulette::RoulettePolicy;

/// How a walk continues.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Walk {
    /// Radiance from the camera or importance (flux) from a light: the BSDFs' adjoint and the
    /// roulette's η² correction depend on it.
    pub mode: TransportMode,
    /// Depth of the last vertex the walk makes.
    pub max_depth: u32,
    /// When the walk plays Russian roulette, and how hard.
    pub roulette: RoulettePolicy,
    pub directions: Directions,
}

/// How the walk reached a vertex (or left the scene): what an estimator needs of the vertex
/// before it to weight emission found there against light sampling.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Arrival {
    /// The previous vertex.
    pub from: Vec3,
    /// Solid-angle density of the direction taken there (delta lobes as
    /// `vertex::delta_densities` writes them).
    pub pdf_w: f32,
    /// The previous vertex was the walk's origin (camera, light) or sampled a Dirac delta: no
    /// other strategy could have chosen this direction.
    pub delta: bool,
    /// Scattering vertices before the new one, origin first.
    pub class: PathClass,
}

/// The lobes a visitor lets the walk sample at a vertex whose BSDF mixes delta and non-delta
/// lobes (plastic), when the visitor itself estimates the non-delta part there (a photon
/// gather).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Lobes {
    All,
    /// The delta lobes alone: the visitor chose them with their probability P
    /// (`SurfaceBsdf::delta_probability`), so the sample's weight f·|cos|/P is already the
    /// estimator's. The walk draws its lobe choice in [0, P), which selects them.
    Delta,
    /// A delta sample ends the walk (unbiased for the non-delta part: the sample's weight divides
    /// by the non-delta lobes' own probability).
    NonDelta,
}

/// What an integrator does along a walk.
pub(crate) trait Visitor {
    /// Whether the walk gives its vertices their area densities (`pdf_fwd`; the camera ray's
    /// density) — what bidirectional methods weight strategies with. The others skip the work.
    const DENSITIES: bool = false;

    /// The walk starts at `v` (the camera, a light's origin, …), before tracing anything.
    #[inline]
    fn origin<S: Sampler>(&mut self, _v: &PathVertex, _sampler: &mut S, _counters: &mut Counters) {}

    /// The walk made vertex `v`, reached as `arrival` says; `false` ends the walk there. Sample
    /// dimensions the estimator needs at the vertex are drawn here, from `sampler`.
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        arrival: &Arrival,
        sampler: &mut S,
        counters: &mut Counters,
    ) -> bool;

    /// Which lobes the walk may sample at `v`, asked just before it scatters there.
    #[inline]
    fn lobes(&mut self, _v: &PathVertex) -> Lobes {
        Lobes::All
    }

    /// The walk scattered from `v` (the vertex last visited) into `s`, before roulette.
    #[inline]
    fn scattered(&mut self, _v: &PathVertex, _s: &BsdfSample) {}

    /// The ray after the last vertex left the scene with throughput `beta`.
    #[inline]
    fn escaped(&mut self, _ray: &Ray, _beta: Rgb, _arrival: &Arrival, _counters: &mut Counters) {}
}

/// Walks from `ray`, which leaves `from` with throughput `beta` in a direction of density
/// `pdf` (solid angle; for a ray from an emitter at infinity, the area density of its origin on
/// the scene's disk; read only by visitors that take [`Visitor::DENSITIES`]).
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn random_walk<S: Sampler, V: Visitor>(
    scene: &Scene,
    walk: &Walk,
    from: &PathVertex,
    ray: Ray,
    beta: Rgb,
    pdf: f32,
    sampler: &mut S,
    visitor: &mut V,
    counters: &mut Counters,
) {
    visitor.origin(from, sampler, counters);
    if beta.is_black() || from.depth >= walk.max_depth {
        return;
    }
    let arrival = Arrival {
        from: from.p,
        pdf_w: pdf,
        delta: true,
        class: from.class,
    };
    let roulette = Roulette::new(walk.roulette, walk.mode, beta);
    trace(
        scene, walk, *from, ray, beta, arrival, roulette, sampler, visitor, counters,
    );
}

/// Walks from the camera through raster position `film` at instant `time` (lens: 2 dimensions).
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn from_camera<S: Sampler, V: Visitor>(
    scene: &Scene,
    walk: &Walk,
    film: Vec2,
    time: f32,
    sampler: &mut S,
    visitor: &mut V,
    counters: &mut Counters,
) {
    let (camera, ray) = camera_ray(scene, film, sampler.next_2d(), time);
    let pdf = if V::DENSITIES {
        scene.camera.pdf_we_dir(ray.o, ray.d)
    } else {
        0.0
    };
    random_walk(
        scene,
        walk,
        &camera,
        ray,
        camera.beta,
        pdf,
        sampler,
        visitor,
        counters,
    );
}

/// Walks from a point and direction sampled on a light ([`emit`]: 5 dimensions) at instant
/// `time`, carrying flux.
#[inline]
pub(crate) fn from_light<S: Sampler, V: Visitor>(
    scene: &Scene,
    walk: &Walk,
    time: f32,
    sampler: &mut S,
    visitor: &mut V,
    counters: &mut Counters,
) {
    if let Some(e) = emit(scene, sampler, time) {
        random_walk(
            scene, walk, &e.origin, e.ray, e.beta, e.pdf, sampler, visitor, counters,
        );
    }
}

/// Walks on from the surface vertex `v` (already visited), scattering there first: a walk that
/// branches off another (final gathering from a photon-mapping visible point).
#[inline]
pub(crate) fn continue_walk<S: Sampler, V: Visitor>(
    scene: &Scene,
    walk: &Walk,
    v: &PathVertex,
    sampler: &mut S,
    visitor: &mut V,
    counters: &mut Counters,
) {
    if v.beta.is_black() || v.depth >= walk.max_depth {
        return;
    }
    let mut beta = v.beta;
    let mut roulette = Roulette::new(walk.roulette, walk.mode, beta);
    if let Some((ray, arrival)) = scatter(
        walk,
        v,
        &mut beta,
        &mut roulette,
        sampler,
        visitor,
        counters,
    ) {
        trace(
            scene, walk, *v, ray, beta, arrival, roulette, sampler, visitor, counters,
        );
    }
}

/// The walk's loop: intersect, visit, scatter.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn trace<S: Sampler, V: Visitor>(
    scene: &Scene,
    walk: &Walk,
    mut prev: PathVertex,
    mut ray: Ray,
    mut beta: Rgb,
    mut arrival: Arrival,
    mut roulette: Roulette,
    sampler: &mut S,
    visitor: &mut V,
    counters: &mut Counters,
) {
    loop {
        counters.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            visitor.escaped(&ray, beta, &arrival, counters);
            return;
        };
        let material = &scene.materials[hit.material as usize];
        let bsdf = material.bsdf_at(hit.uv, &scene.textures);
        let sb = SurfaceBsdf::of(hit.ns, hit.dpdu, hit.ng, material, bsdf);
        let mut v = PathVertex {
            kind: Kind::Surface,
            p: hit.p,
            p_error: hit.p_error,
            ng: hit.ng,
            ns: sb.frame.n,
            wo: -ray.d.normalize(),
            sb: Some(sb),
            emitter: hit.light,
            shape: hit.shape,
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            // Until the walk samples here: whether every lobe is a delta.
            delta: bsdf.is_delta(),
            infinite: false,
            depth: prev.depth + 1,
            class: arrival.class.push(bsdf.lobe_class()),
            time: ray.time,
        };
        if V::DENSITIES {
            v.pdf_fwd = prev.convert_density(arrival.pdf_w, &v);
        }
        if !visitor.vertex(&v, &arrival, sampler, counters) || v.depth >= walk.max_depth {
            return;
        }
        let Some(next) = scatter(
            walk,
            &v,
            &mut beta,
            &mut roulette,
            sampler,
            visitor,
            counters,
        ) else {
            return;
        };
        (ray, arrival) = next;
        v.delta = arrival.delta;
        prev = v;
    }
}

/// The scatter step at surface vertex `v`: samples a direction (lobe 1, direction 2, roulette 1
/// dimensions), rejects black and non-finite weights, multiplies `beta` by the weight, plays
/// Russian roulette, and returns the next ray and how it leaves `v`; `None` ends the walk.
#[inline(always)]
fn scatter<S: Sampler, V: Visitor>(
    walk: &Walk,
    v: &PathVertex,
    beta: &mut Rgb,
    roulette: &mut Roulette,
    sampler: &mut S,
    visitor: &mut V,
    counters: &mut Counters,
) -> Option<(Ray, Arrival)> {
    let sb = v.sb.as_ref()?;
    let (u_lobe, u_dir, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
    let lobes = visitor.lobes(v);
    let u_lobe = match lobes {
        Lobes::Delta => u_lobe * sb.delta_probability(v.wo),
        _ => u_lobe,
    };
    let s = scatter::sample(sb, v.wo, u_lobe, u_dir, walk.mode, walk.directions)?;
    if s.delta && lobes == Lobes::NonDelta {
        return None;
    }
    if s.weight.is_black() {
        return None;
    }
    if !s.weight.is_finite() {
        counters.count_non_finite(Technique::Scattering);
        return None;
    }
    visitor.scattered(v, &s);
    *beta *= s.weight;
    // A throughput that underflowed to zero (hundreds of bounces without roulette) carries
    // nothing further: the walk ends rather than tracing zeros to its depth limit.
    if beta.is_black() {
        return None;
    }
    if !roulette.survives(v.depth, &s, u_rr, beta) {
        return None;
    }
    let arrival = Arrival {
        from: v.p,
        // After a delta lobe only bidirectional methods read the density.
        pdf_w: if s.delta && V::DENSITIES {
            vertex::delta_densities(&s, v.wo, v.ns).0
        } else {
            s.pdf
        },
        delta: s.delta,
        class: if s.delta && sb.bsdf.mixes_delta() {
            v.class.with_last(LobeClass::Specular)
        } else {
            v.class
        },
    };
    Some((
        spawn_ray(v.p, v.p_error, v.ng, s.wi).at_time(v.time),
        arrival,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightlab_samplers::Independent;

    /// The furnace sphere with its walls of albedo `albedo`: every camera walk hits them, and
    /// every light walk whose first ray the two-sided emission sends inward (the others escape
    /// at once: no vertex, one ray).
    fn furnace(albedo: f32) -> Scene {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/furnace.ron"),
        )
        .unwrap()
        .replace(
            "albedo: (0.8, 0.8, 0.8)",
            &format!("albedo: ({albedo}, {albedo}, {albedo})"),
        );
        lightlab_scene::parse_scene(&text, std::path::Path::new("furnace.ron")).unwrap()
    }

    /// Records the depths a walk visits.
    #[derive(Default)]
    struct Depths(Vec<u32>);

    impl Visitor for Depths {
        fn vertex<S: Sampler>(
            &mut self,
            v: &PathVertex,
            _: &Arrival,
            _: &mut S,
            _: &mut Counters,
        ) -> bool {
            self.0.push(v.depth);
            true
        }
    }

    /// Roulette from the first vertex on with threshold `threshold`.
    fn every_vertex(threshold: f32) -> RoulettePolicy {
        RoulettePolicy {
            start: Some(0),
            threshold,
        }
    }

    fn walk(light: bool, max_depth: u32, roulette: RoulettePolicy) -> Walk {
        Walk {
            mode: if light {
                TransportMode::Importance
            } else {
                TransportMode::Radiance
            },
            max_depth,
            roulette,
            directions: Directions::Bsdf,
        }
    }

    /// The depths `n` walks visit, from the light or the camera, and their counters.
    fn walks(scene: &Scene, walk: Walk, n: u64, light: bool) -> (Vec<Vec<u32>>, Counters) {
        let mut counters = Counters::default();
        let out = (0..n)
            .map(|i| {
                let mut sampler = Independent::new();
                sampler.start_pixel_sample(7, i, 0);
                let mut depths = Depths::default();
                if light {
                    from_light(scene, &walk, 0.0, &mut sampler, &mut depths, &mut counters);
                } else {
                    let film = Vec2::splat(16.0);
                    from_camera(
                        scene,
                        &walk,
                        film,
                        0.0,
                        &mut sampler,
                        &mut depths,
                        &mut counters,
                    );
                }
                depths.0
            })
            .collect();
        (out, counters)
    }

    /// Camera and light walks alike visit depths 1, 2, …, `max_depth` — the bounce limit means
    /// the same on both sides — and trace one ray per vertex, none past the limit.
    #[test]
    fn walks_visit_every_depth_up_to_the_limit_on_both_sides() {
        let scene = furnace(0.8);
        for light in [false, true] {
            for max_depth in [0, 1, 4] {
                let (depths, counters) = walks(
                    &scene,
                    walk(light, max_depth, RoulettePolicy::OFF),
                    200,
                    light,
                );
                let full: Vec<u32> = (1..=max_depth).collect();
                let escaped = depths.iter().filter(|d| d.is_empty()).count() as u64;
                for d in &depths {
                    assert!(
                        *d == full || (light && d.is_empty()),
                        "light side {light}, max depth {max_depth}: {d:?}"
                    );
                }
                let rays = match max_depth {
                    0 => 0,
                    m => (200 - escaped) * m as u64 + escaped,
                };
                assert_eq!(
                    counters.rays, rays,
                    "light side {light}, max depth {max_depth}"
                );
            }
        }
    }

    /// A black surface ends every walk at its first vertex, without tracing the next ray.
    #[test]
    fn a_black_weight_ends_the_walk() {
        let scene = furnace(0.0);
        for light in [false, true] {
            let (depths, counters) = walks(&scene, walk(light, 8, every_vertex(1.0)), 100, light);
            assert!(
                depths.iter().all(|d| d == &[1] || (light && d.is_empty())),
                "light side {light}"
            );
            assert_eq!(counters.rays, 100);
        }
    }

    /// Without roulette and with no depth limit to speak of, a walk in a furnace of albedo 1/2 ends
    /// when its throughput underflows to zero: 2⁻¹⁴⁹ is f32's smallest, so after about 150
    /// vertices on the camera side (β starts at 1) and a few more on the light side (β starts at
    /// the emitted flux). It traced zeros on to the depth limit, and BDPT stored them.
    #[test]
    fn a_throughput_of_zero_ends_the_walk() {
        let scene = furnace(0.5);
        for light in [false, true] {
            let (depths, _) = walks(&scene, walk(light, 1 << 16, RoulettePolicy::OFF), 20, light);
            let longest = depths.iter().map(Vec::len).max().unwrap();
            assert!(
                (140..200).contains(&longest),
                "light side {light}: {longest} vertices"
            );
        }
    }

    /// With roulette at every vertex in a furnace of albedo ρ = 1/2, each scatter leaves β at
    /// ρ times its start and survives with q = ρ (β/q is the start again), on the camera and the
    /// light side alike: the number of vertices is geometric with mean 1/(1 − ρ) = 2 and
    /// variance ρ/(1 − ρ)² = 2. With threshold τ = 1/2 the first scatter (score 1/2 = τ) always
    /// survives and every later one (score 1/4) with q = 1/2, restoring score τ: two vertices plus
    /// a geometric count of mean 1 and variance 2. z-test of the mean at 4.4σ (false-failure rate
    /// 1e-5 per side and case).
    #[test]
    fn roulette_ends_walks_at_the_same_rate_on_both_sides() {
        let scene = furnace(0.5);
        let n = 20_000;
        for (threshold, want) in [(1.0, 2.0), (0.5, 3.0)] {
            for light in [false, true] {
                let walk = walk(light, u32::MAX, every_vertex(threshold));
                let (depths, _) = walks(&scene, walk, n, light);
                let lengths: Vec<f64> = depths
                    .iter()
                    .filter(|d| !d.is_empty())
                    .map(|d| d.len() as f64)
                    .collect();
                let m = lengths.len() as f64;
                assert!(
                    m > 0.4 * n as f64,
                    "light side {light}: {m} walks entered the sphere"
                );
                let mean = lengths.iter().sum::<f64>() / m;
                let z = (mean - want) / (2.0 / m).sqrt();
                assert!(
                    z.abs() < 4.4,
                    "τ = {threshold}, light side {light}: mean {mean} (want {want}), z = {z}"
                );
            }
        }
    }
}
