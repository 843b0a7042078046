//! Jensen's two-pass photon mapping (Jensen 1996; Jensen 2001, ch. 9).
//!
//! Pass 1 traces `photons` photon paths into the global map and `caustic_photons` more, keeping
//! only their caustic photons, into the caustic map. Pass 2 traces camera paths to their visible
//! point x (`camera`) and splits the light arriving there by the vertices between the light and
//! x, a partition of all paths through x. With T the lobes the camera walk passes — specular
//! ones, and glossy ones with `trace_glossy` (Jensen's caustic paths `L S+ D`, whose S includes
//! glossy reflection; Jensen 2001, §9.1):
//!
//! | part        | paths          | estimated by                                          |
//! |-------------|----------------|-------------------------------------------------------|
//! | `direct`    | `L x`          | next-event estimation                                 |
//! | `caustics`  | `L T+ x`       | caustic map at x                                      |
//! | `indirect`  | `L … y T* x`   | global map at x (photons not `L x`, not `L T+ x`), or |
//! |             | (y not in T)   | final gather: BSDF rays from x through T surfaces to  |
//! |             |                | the first other y, global map (all photons) at y      |
//!
//! plus emission seen through the camera's chain of T vertices (with next-event estimation at its
//! glossy ones). The estimate is biased: density
//! estimation blurs over the gather radius, and with a fixed photon count that blur never goes
//! away, however many camera samples are taken — the method is consistent only as the photon
//! count grows and the radius (or k/N) shrinks with it (Jensen 2001, §7.2; progressive photon
//! mapping, `Ppm`/`Sppm`, makes that schedule explicit).
//!
//! Variance. The film's variance of a pixel is the camera samples' s²/n (their spread for one
//! pair of photon maps) plus the photon maps' own variance, which every camera sample shares:
//! each map's paths form `GROUPS` independent groups, the pixel sums each group's share of its
//! photon estimates, and a two-way crossed design (camera samples × groups) gives the variance of
//! the pixel mean (`passes::shared_variance`). That is exact for a fixed-radius gather. With the
//! k nearest photons each group's share also depends on the other groups, through the radius
//! they set together, so the design's assumption fails; for a constant photon density the two
//! still agree (the group spread then equals the k-nearest estimate's variance, λ²/(k − 2)), and
//! on the tested scenes the variance came out 1–4 % low.
//!
//! A time budget builds the maps once (their time counts) and adds camera samples until the time
//! is spent.
//!
//! Motion blur (shapes moving while the shutter is open): maps of one instant cannot serve camera
//! samples of another, so each pass builds its own maps at its instant and takes one camera
//! sample per pixel there (`render_instants`).

use super::camera::{self, CameraWalk, VisiblePoint};
use super::config::{Indirect, PhotonMapConfig};
use super::map::{PhotonMap, Search};
use super::trace::{GROUPS, Keep, PhotonTracing, stored_per_path, trace_photons, tracing_bytes};
use crate::passes::{PassSpec, Schedule, run_passes, run_progressive_passes};
use crate::paths::{PathClass, Router};
use crate::render::{Counters, PixelVariance, Technique, named};
use crate::shutter::pass_time;
use crate::sink::Sink;
use crate::walk::{
    Arrival, DEEP, Directions, Lobes, PathVertex, RoulettePolicy, Visitor, Walk, continue_walk,
};
use crate::{Budget, Film, Integrator, RenderOutput, RenderStats};
use lightlab_core::{Progress, Rgb, TransportMode};
use lightlab_materials::LobeClass;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;
use std::sync::RwLock;

/// Seed offset of the caustic map's photon stream (independent of the global map's).
const CAUSTIC_STREAM: u64 = 0x1405_7b7e_f767_814f;
/// Key of the per-instant photon seeds of a motion-blurred render.
const INSTANT_STREAM: u64 = 0x696e_7374_616e_7473;

/// The seed of pass `i`'s photon maps in a motion-blurred render: hashed, so that no pass's photon
/// streams coincide with the camera streams (seed, pixel, pass). (It was `seed ^ (i + 1)·φ`, which
/// for pass 0 cancelled the photon stream's own offset φ: photon path p drew pixel p's numbers.)
fn instant_seed(seed: u64, i: u32) -> u64 {
    lightlab_samplers::hash_u64s(&[seed, INSTANT_STREAM, i as u64])
}

/// Jensen's two-pass photon mapping, built from checked [`PhotonMapConfig`] settings.
pub struct PhotonMapper {
    config: PhotonMapConfig,
    router: Router,
}

impl PhotonMapper {
    /// A photon mapper with `config` (checked).
    pub fn new(config: PhotonMapConfig) -> Result<Self, crate::config::ConfigError> {
        let router = config.checked_router()?;
        Ok(PhotonMapper { config, router })
    }

    fn walk(&self) -> CameraWalk {
        let c = &self.config;
        CameraWalk {
            max_bounces: c.max_bounces.unwrap_or(u32::MAX),
            min_bounces: c.min_bounces,
            roulette: c.roulette(),
            trace_glossy: c.trace_glossy,
            direct: c.direct,
        }
    }

    /// Adds the photon-map estimates at the visible point `vp`, times its throughput, to `l`.
    fn at_visible_point(
        &self,
        scene: &Scene,
        maps: &Maps,
        vp: &VisiblePoint,
        sampler: &mut Independent,
        l: &mut Sink,
        counters: &mut Counters,
    ) {
        let c = &self.config;
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let (lo, hi) = vp.photon_bounces(c.min_bounces, max);
        let glossy = c.trace_glossy;
        if let Some(map) = &maps.caustic {
            map.estimate(&vp.gather, maps.caustic_search, c.kernel, |ph, g, v| {
                if (lo..=hi).contains(&ph.bounces()) {
                    deposit(l, g, &vp.class_with(&ph.class), vp.beta * v, counters);
                }
            });
        }
        match (c.indirect, &maps.global) {
            (Indirect::Direct, Some(map)) => {
                let lo = lo.max(2);
                map.estimate(&vp.gather, maps.search, c.kernel, |ph, g, v| {
                    if !ph.is_caustic(glossy) && (lo..=hi).contains(&ph.bounces()) {
                        deposit(l, g, &vp.class_with(&ph.class), vp.beta * v, counters);
                    }
                });
            }
            (Indirect::FinalGather { rays }, Some(map)) => {
                self.final_gather(scene, map, maps.search, vp, rays, sampler, l, counters);
            }
            _ => {}
        }
    }

    /// Jensen's final gather: the mean over `rays` BSDF-sampled directions of the global-map
    /// radiance where each lands, after passing through specular (and, with `trace_glossy`,
    /// glossy) surfaces. Emitters hit are skipped: that light is `direct` or `caustics`.
    fn final_gather(
        &self,
        scene: &Scene,
        map: &PhotonMap,
        search: Search,
        vp: &VisiblePoint,
        rays: u32,
        sampler: &mut Independent,
        l: &mut Sink,
        counters: &mut Counters,
    ) {
        let c = &self.config;
        let max = c.max_bounces.unwrap_or(u32::MAX);
        // Chains from x to y are short and end at y: no roulette until a walk is `DEEP` (glossy
        // surfaces facing each other with no diffuse one in sight), where it must end. The walk
        // counts no emission (that light is `direct` or `caustics`), so it ends at depth `max`.
        let walk = Walk {
            mode: TransportMode::Radiance,
            max_depth: max,
            roulette: RoulettePolicy {
                start: Some(DEEP),
                threshold: 1.0,
            },
            directions: Directions::Bsdf,
        };
        let mut from = vp.vertex;
        from.beta = vp.beta / rays as f32;
        let mut gather = Gather {
            pm: self,
            map,
            search,
            l,
            origin_depth: vp.vertex.depth,
            delta_only: false,
        };
        for _ in 0..rays {
            continue_walk(scene, &walk, &from, sampler, &mut gather, counters);
        }
    }
}

/// The final gather's visitor: the global map's estimate at the first vertex y that is neither
/// delta nor, with `trace_glossy`, glossy. A density estimate on a near-specular glossy surface
/// cannot resolve its BSDF (gathering there lost the caustics seen through glass of roughness
/// 10⁻⁴), and the light that reaches x through glossy surfaces alone, `L G+ x`, is the caustic
/// map's.
struct Gather<'a, 'r> {
    pm: &'a PhotonMapper,
    map: &'a PhotonMap,
    search: Search,
    l: &'a mut Sink<'r>,
    /// Depth of the visible point the rays leave: it stands for its non-delta lobes only.
    origin_depth: u32,
    /// The ray chose a delta lobe at the vertex last visited (see `VisiblePoint::at_or_delta`).
    delta_only: bool,
}

impl Visitor for Gather<'_, '_> {
    #[inline]
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        arrival: &Arrival,
        sampler: &mut S,
        counters: &mut Counters,
    ) -> bool {
        let c = &self.pm.config;
        if v.delta {
            return true;
        }
        if c.trace_glossy
            && let Some(sb) = &v.sb
            && sb.bsdf.lobe_class() == LobeClass::Glossy
        {
            return true;
        }
        let Some(y) = VisiblePoint::at_or_delta(v, arrival, sampler) else {
            self.delta_only = true;
            return true;
        };
        let (lo, hi) = y.photon_bounces(c.min_bounces, c.max_bounces.unwrap_or(u32::MAX));
        let l = &mut *self.l;
        self.map
            .estimate(&y.gather, self.search, c.kernel, |ph, g, w| {
                if (lo..=hi).contains(&ph.bounces()) {
                    deposit(l, g, &y.class_with(&ph.class), y.beta * w, counters);
                }
            });
        false
    }

    #[inline]
    fn lobes(&mut self, v: &PathVertex) -> Lobes {
        if v.depth == self.origin_depth {
            Lobes::NonDelta
        } else if std::mem::take(&mut self.delta_only) {
            Lobes::Delta
        } else {
            Lobes::All
        }
    }
}

/// Adds a photon's contribution (of photon group `group`) unless it is not finite (counted).
#[inline]
fn deposit(l: &mut Sink, group: usize, class: &PathClass, c: Rgb, counters: &mut Counters) {
    if c.is_finite() {
        l.add_photon(group, class, c);
    } else {
        counters.count_non_finite(Technique::Photon);
    }
}

impl PhotonMapper {
    /// Which photons the caustic map keeps: `L T+ X`, T the lobes camera paths pass.
    fn caustic_keep(&self) -> Keep {
        Keep::Caustic {
            through_glossy: self.config.trace_glossy,
        }
    }

    /// How the global (`Keep::All`) or caustic (`Keep::Caustic`) map's photons are traced.
    fn tracing(&self, keep: Keep) -> PhotonTracing {
        PhotonTracing {
            max_bounces: self.config.max_bounces.unwrap_or(u32::MAX),
            roulette: self.config.roulette(),
            keep,
        }
    }

    /// The global and caustic maps (those asked for) of photons traced at instant `time` from the
    /// streams of `seed`.
    fn maps(&self, scene: &Scene, seed: u64, time: f32, counters: &mut Counters) -> Maps {
        let c = &self.config;
        let global = (c.indirect != Indirect::Off).then(|| {
            PhotonMap::new(trace_photons(
                scene,
                seed,
                (0, c.photons),
                time,
                self.tracing(Keep::All),
                counters,
            ))
        });
        let caustic = c.caustics.then(|| {
            PhotonMap::new(trace_photons(
                scene,
                seed ^ CAUSTIC_STREAM,
                (0, c.caustic_photons),
                time,
                self.tracing(self.caustic_keep()),
                counters,
            ))
        });
        Maps {
            global,
            caustic,
            search: c.gather.search(scene.radius),
            caustic_search: c.caustic_gather.search(scene.radius),
        }
    }

    /// Motion blur: camera samples of different instants cannot share maps, so every pass builds
    /// its own at its instant (the passes' stratified times, `shutter`) from photon streams of its
    /// own, and its camera samples (one per pixel) see that instant — photon mapping repeated per
    /// instant, an accumulation buffer (Haeberli & Akeley 1990). Passes are then independent
    /// samples of everything the pixel estimate depends on, and the spread over them is its
    /// variance (conservative where the instants' stratification helps); the price is a pair of
    /// maps per pass.
    fn render_instants(
        &self,
        scene: &Scene,
        seed: u64,
        schedule: &mut Schedule,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let current: RwLock<Option<(f32, Maps)>> = RwLock::new(None);
        let (mut photons, mut stored) = (0u64, 0u64);
        let mut begin = |i: u32, counters: &mut Counters| {
            let time = pass_time(&scene.camera, seed, i as u64);
            let pass_seed = instant_seed(seed, i);
            let maps = self.maps(scene, pass_seed, time, counters);
            photons += self.config.photons * maps.global.is_some() as u64
                + self.config.caustic_photons * maps.caustic.is_some() as u64;
            stored += maps.global.as_ref().map_or(0, |m| m.len() as u64)
                + maps.caustic.as_ref().map_or(0, |m| m.len() as u64);
            *current.write().expect("no pass panicked") = Some((time, maps));
        };
        let walk = self.walk();
        let spec = self.pass_spec(scene);
        let out = run_progressive_passes(
            &spec,
            &self.router,
            schedule,
            on_pass,
            &mut begin,
            |x, y, index, sink, counters, _: &mut ()| {
                let pass = current.read().expect("no pass panicked");
                let Some((time, maps)) = pass.as_ref() else {
                    return;
                };
                let (vp, mut sampler) = camera::trace_pixel(
                    scene,
                    &walk,
                    (seed, *time),
                    (x, y, width),
                    index,
                    index,
                    sink,
                    counters,
                );
                if let Some(vp) = &vp {
                    self.at_visible_point(scene, maps, vp, &mut sampler, sink, counters);
                }
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let mut stats = RenderStats::new(
            "PhotonMap",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * out.spp as u64,
            &out.counters,
            &[Technique::Camera, Technique::Photon],
            crate::shutter::instants_variance(),
        );
        stats.pixel_limit = crate::render::PixelLimit::FixedRadiusBlur;
        stats.photons = photons;
        stats.photons_stored = stored;
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(self.router.layer_names(), films),
            stats,
        }
    }
}

/// The two maps and how each is searched.
struct Maps {
    global: Option<PhotonMap>,
    caustic: Option<PhotonMap>,
    search: Search,
    caustic_search: Search,
}

impl PhotonMapper {
    /// The images the driver keeps: the full image and the router's layers, with the photon
    /// groups' sums when one set of maps serves the whole render (no motion blur).
    fn pass_spec(&self, scene: &Scene) -> PassSpec {
        PassSpec {
            groups: if scene.motion_blur() { 0 } else { GROUPS },
            ..PassSpec::layers(scene, &self.router)
        }
    }
}

impl Integrator for PhotonMapper {
    /// The images, and the maps: the global one built while the caustic one is traced, their
    /// photon counts estimated from a pilot.
    fn memory_bytes(&self, scene: &Scene) -> u64 {
        let c = &self.config;
        let time = scene.camera.shutter.0;
        let stored = |on: bool, paths: u64, keep| {
            if on {
                paths as f64 * stored_per_path(scene, time, self.tracing(keep))
            } else {
                0.0
            }
        };
        let global = stored(c.indirect != Indirect::Off, c.photons, Keep::All);
        let caustic = stored(c.caustics, c.caustic_photons, self.caustic_keep());
        let maps = tracing_bytes(global).max(PhotonMap::bytes_for(global) + tracing_bytes(caustic));
        self.pass_spec(scene).bytes().saturating_add(maps as u64)
    }

    fn check_scene(&self, scene: &Scene) -> Result<(), String> {
        let c = &self.config;
        super::config::check_radius("gather radius", c.gather.radius(), scene)?;
        super::config::check_radius("caustic_gather radius", c.caustic_gather.radius(), scene)
    }

    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let c = &self.config;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        if scene.motion_blur() {
            return self.render_instants(scene, seed, &mut schedule, on_pass);
        }
        let mut counters = Counters::default();
        let maps = self.maps(scene, seed, scene.camera.shutter.0, &mut counters);
        let walk = self.walk();
        let router = &self.router;
        let spec = self.pass_spec(scene);
        let out = run_passes(
            &spec,
            router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, _: &mut ()| {
                let (vp, mut sampler) = camera::trace_pixel(
                    scene,
                    &walk,
                    (seed, scene.camera.shutter.0),
                    (x, y, width),
                    index,
                    index,
                    sink,
                    counters,
                );
                if let Some(vp) = &vp {
                    self.at_visible_point(scene, &maps, vp, &mut sampler, sink, counters);
                }
            },
        );
        counters.merge(&out.counters);
        let mut films = out.films;
        let film = films.remove(0);
        let mut stats = RenderStats::new(
            "PhotonMap",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            width as u64 * height as u64 * out.spp as u64,
            &counters,
            &[Technique::Camera, Technique::Photon],
            PixelVariance::CameraAndPhotonGroups {
                groups: GROUPS as u32,
            },
        );
        stats.pixel_limit = crate::render::PixelLimit::FixedRadiusBlur;
        stats.photons = c.photons * maps.global.is_some() as u64
            + c.caustic_photons * maps.caustic.is_some() as u64;
        stats.photons_stored = maps.global.as_ref().map_or(0, |m| m.len() as u64)
            + maps.caustic.as_ref().map_or(0, |m| m.len() as u64);
        RenderOutput {
            film,
            outliers: Vec::new(),
            layers: named(router.layer_names(), films),
            stats,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::instant_seed;
    use crate::photon::trace::photon_sampler;
    use lightlab_samplers::{Independent, Sampler};

    #[test]
    fn photon_streams_of_every_instant_differ_from_the_camera_streams() {
        for seed in [0, 1, 7, u64::MAX] {
            for pass in 0..32u32 {
                for p in 0..32u64 {
                    let mut photon = photon_sampler(instant_seed(seed, pass), p);
                    let mut camera = Independent::new();
                    camera.start_pixel_sample(seed, p, pass as u64);
                    let (a, b) = (photon.next_2d(), camera.next_2d());
                    assert_ne!(a, b, "seed {seed}, pass {pass}, path/pixel {p}");
                }
            }
        }
    }
}
