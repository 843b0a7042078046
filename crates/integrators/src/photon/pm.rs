//! Jensen's two-pass photon mapping (Jensen 1996; Jensen 2001, ch. 9).
//!
//! Pass 1 traces `photons` photon paths into the global map and `caustic_photons` more, keeping
//! only their caustic photons (`L S+ X`), into the caustic map. Pass 2 traces camera paths to
//! their visible point x (`camera`) and splits the light arriving there by the vertex before x,
//! a partition of all paths through x:
//!
//! | part        | paths          | estimated by                                          |
//! |-------------|----------------|-------------------------------------------------------|
//! | `direct`    | `L x`          | next-event estimation                                 |
//! | `caustics`  | `L S+ x`       | caustic map at x                                      |
//! | `indirect`  | `L … y S* x`   | global map at x (photons not `L x`, not `L S+ x`), or |
//! |             | (y not `S`)    | final gather: BSDF rays from x through specular       |
//! |             |                | surfaces to y, global map (all photons) at y          |
//!
//! plus emission seen through the camera's specular chain. The estimate is consistent, not
//! unbiased: density estimation blurs over the gather radius. The per-pixel variance in the film
//! is over camera samples for one photon map, so it leaves out the photon map's own noise (which
//! is correlated across pixels); measure that across seeds, as experiments do.

use super::camera::{self, VisiblePoint, Walk};
use super::config::{Indirect, PhotonMapConfig};
use super::map::{GatherPoint, PhotonMap, Search};
use super::trace::{Keep, PhotonTracing, trace_photons};
use crate::film::PixelSums;
use crate::render::{Counters, render_tiles};
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{INV_PI, Progress, Rgb, TransportMode};
use lightlab_geometry::spawn_ray;
use lightlab_materials::SurfaceBsdf;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;

/// Seed offset of the next-event-estimation stream (independent of the camera path's stream).
const LIGHT_STREAM: u64 = 0x5851_f42d_4c95_7f2d;
/// Seed offset of the caustic map's photon stream (independent of the global map's).
const CAUSTIC_STREAM: u64 = 0x1405_7b7e_f767_814f;

pub struct PhotonMapper {
    config: PhotonMapConfig,
}

impl PhotonMapper {
    pub fn new(config: PhotonMapConfig) -> Self {
        PhotonMapper { config }
    }

    fn walk(&self) -> Walk {
        let c = &self.config;
        Walk {
            max_bounces: c.max_bounces.unwrap_or(u32::MAX),
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            trace_glossy: c.trace_glossy,
            direct: c.direct,
        }
    }

    /// The photon-map estimates at the visible point `vp`, times its throughput.
    fn at_visible_point(
        &self,
        scene: &Scene,
        maps: &Maps,
        vp: &VisiblePoint,
        sampler: &mut Independent,
        counters: &mut Counters,
    ) -> Rgb {
        let c = &self.config;
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let (lo, hi) = vp.photon_bounces(c.min_bounces, max);
        let mut l = Rgb::BLACK;
        if let Some(map) = &maps.caustic {
            let k = |b: u16| (lo..=hi).contains(&(b as u32));
            l += radiance(map, &vp.gather, maps.caustic_search, c.kernel, |p| {
                k(p.bounces)
            });
        }
        match (c.indirect, &maps.global) {
            (Indirect::Direct, Some(map)) => {
                let (lo, hi) = (lo.max(2), hi);
                l += radiance(map, &vp.gather, maps.search, c.kernel, |p| {
                    !p.is_caustic() && (lo..=hi).contains(&(p.bounces as u32))
                });
            }
            (Indirect::FinalGather { rays }, Some(map)) => {
                l += self.final_gather(scene, map, maps.search, vp, rays, sampler, counters);
            }
            _ => {}
        }
        vp.beta * l
    }

    /// Jensen's final gather: the mean over `rays` BSDF-sampled directions of the global-map
    /// radiance where each lands, after passing through specular surfaces. Emitters hit are
    /// skipped: that light is `direct` (or `caustics`).
    fn final_gather(
        &self,
        scene: &Scene,
        map: &PhotonMap,
        search: Search,
        vp: &VisiblePoint,
        rays: u32,
        sampler: &mut Independent,
        counters: &mut Counters,
    ) -> Rgb {
        let c = &self.config;
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let mut sum = Rgb::BLACK;
        for _ in 0..rays {
            let (u_lobe, u_dir) = (sampler.next_1d(), sampler.next_2d());
            let Some(s) =
                vp.gather
                    .bsdf
                    .sample(vp.gather.wo, u_lobe, u_dir, TransportMode::Radiance)
            else {
                continue;
            };
            let mut beta = s.weight;
            let mut ray = spawn_ray(vp.hit.p, vp.hit.p_error, vp.hit.ng, s.wi);
            let mut depth = vp.depth;
            loop {
                counters.rays += 1;
                let Some(hit) = scene.intersect(&ray) else {
                    break;
                };
                depth += 1;
                if depth > max {
                    break;
                }
                let bsdf = scene.materials[hit.material as usize];
                let sb = SurfaceBsdf::new(hit.ns, hit.dpdu, hit.ng, bsdf);
                let wo = -ray.d.normalize();
                if !bsdf.is_delta() {
                    let y = VisiblePoint {
                        gather: GatherPoint {
                            p: hit.p,
                            wo,
                            bsdf: sb,
                        },
                        hit,
                        beta,
                        depth,
                    };
                    let (lo, hi) = y.photon_bounces(c.min_bounces, max);
                    sum += beta
                        * radiance(map, &y.gather, search, c.kernel, |p| {
                            (lo..=hi).contains(&(p.bounces as u32))
                        });
                    break;
                }
                let Some(s) = sb.sample(
                    wo,
                    sampler.next_1d(),
                    sampler.next_2d(),
                    TransportMode::Radiance,
                ) else {
                    break;
                };
                beta *= s.weight;
                ray = spawn_ray(hit.p, hit.p_error, hit.ng, s.wi);
            }
        }
        sum / rays as f32
    }
}

/// Radiance estimate from `map` at `g` over the photons `accept` keeps.
fn radiance(
    map: &PhotonMap,
    g: &GatherPoint,
    search: Search,
    kernel: super::map::Kernel,
    accept: impl Fn(&super::trace::Photon) -> bool,
) -> Rgb {
    let (sum, radius_sq) = map.estimate(g, search, kernel, accept);
    if radius_sq > 0.0 {
        sum * (INV_PI / radius_sq)
    } else {
        Rgb::BLACK
    }
}

/// The two maps and how each is searched.
struct Maps {
    global: Option<PhotonMap>,
    caustic: Option<PhotonMap>,
    search: Search,
    caustic_search: Search,
}

impl Integrator for PhotonMapper {
    fn render(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
    ) -> RenderOutput {
        let c = &self.config;
        let start = std::time::Instant::now();
        let max = c.max_bounces.unwrap_or(u32::MAX);
        let mut counters = Counters::default();
        let tracing = |keep| PhotonTracing {
            max_bounces: max,
            russian_roulette: c.russian_roulette,
            keep,
        };
        let global = (c.indirect != Indirect::Off).then(|| {
            PhotonMap::new(trace_photons(
                scene,
                seed,
                0,
                c.photons,
                tracing(Keep::All),
                &mut counters,
            ))
        });
        let caustic = c.caustics.then(|| {
            PhotonMap::new(trace_photons(
                scene,
                seed ^ CAUSTIC_STREAM,
                0,
                c.caustic_photons,
                tracing(Keep::Caustic),
                &mut counters,
            ))
        });
        let maps = Maps {
            global,
            caustic,
            search: c.gather.search(scene.radius),
            caustic_search: c.caustic_gather.search(scene.radius),
        };
        let photon_seconds = start.elapsed().as_secs_f64();
        let walk = self.walk();
        let width = scene.camera.width;
        let (film, camera_counters, wall) = render_tiles(
            width,
            scene.camera.height,
            progress,
            |x, y, sums: &mut PixelSums, counters| {
                let pixel = y as u64 * width as u64 + x as u64;
                for s in 0..budget.spp as u64 {
                    let mut sampler = Independent::new();
                    sampler.start_pixel_sample(seed, pixel, s);
                    let mut lights = Independent::new();
                    lights.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, s);
                    let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                    let r = camera::walk(scene, &walk, film, &mut sampler, &mut lights, counters);
                    let mut l = r.l;
                    if let Some(vp) = &r.visible {
                        let p = self.at_visible_point(scene, &maps, vp, &mut sampler, counters);
                        if p.is_finite() {
                            l += p;
                        } else {
                            counters.non_finite[super::trace::PHOTON_FLUX] += 1;
                        }
                    }
                    sums.add([l.r as f64, l.g as f64, l.b as f64]);
                }
            },
        );
        counters.merge(&camera_counters);
        let mut stats = RenderStats::new(
            "PhotonMap",
            (width, scene.camera.height),
            budget,
            seed,
            wall + photon_seconds,
            width as u64 * scene.camera.height as u64 * budget.spp as u64,
            &counters,
            &["camera", "photon"],
        );
        stats.photons = c.photons * maps.global.is_some() as u64
            + c.caustic_photons * maps.caustic.is_some() as u64;
        stats.photons_stored = maps.global.as_ref().map_or(0, |m| m.len() as u64)
            + maps.caustic.as_ref().map_or(0, |m| m.len() as u64);
        RenderOutput { film, stats }
    }
}
