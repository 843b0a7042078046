//! Bidirectional path tracing (Veach & Guibas 1994; Lafortune & Willems 1993; Veach 1997 ch. 10)
//! with every (s, t) strategy combined by multiple importance sampling (Veach 1997 ch. 9).
//!
//! Each pixel sample traces a camera subpath z₀…z_{t−1} and a light subpath y₀…y_{s−1} and forms
//! every full path y₀…y_{s−1} z_{t−1}…z₀ with s + t − 2 scattering vertices within the bounce
//! limits: s = 0 (the camera path hits an emitter), s = 1 (a point sampled on a light, next-event
//! estimation), t = 1 (a light vertex connected to a point on the lens and splatted into the pixel it
//! lands on, as in light tracing — for s = 1 the light's own point, an emitter seen directly) and
//! s, t ≥ 2 (a deterministic connection of the two subpaths). An emitter seen directly (s + t = 2)
//! thus has two strategies, the camera ray hitting it (s = 0) and its point splatted through the lens
//! (s = 1): the second is what renders an emitter smaller than a pixel's footprint.
//!
//! MIS: the balance heuristic, computed by Veach's walk over ratios of the area-measure densities
//! with which neighbouring strategies would have produced the same path (Veach 1997 §10.2;
//! pbrt-v4 §16.3.4): each vertex stores `pdf_fwd` (density of its generation along its own subpath)
//! and `pdf_rev` (density of its generation from the other side), and the weight of (s, t) is
//! 1 / Σᵢ (pᵢ / p_s). Strategies that cannot produce a path (a delta vertex at a connection) are left
//! out of the sum. At a specular vertex the two directions' densities are the lobe's selection
//! probability times η²|cos θ| (`delta_densities`: the Dirac delta written in the throughput
//! measure, which refraction preserves, cancels from the ratios), unlike pbrt's
//! zero-then-remap-to-one, which loses the cos/d² conversions beside specular chains and the
//! solid-angle compression of a refraction.
//!
//! Research views: `strategy_layers` writes every strategy as a layer, weighted and unweighted;
//! `outliers` logs large contributions with their provenance, and [`Bdpt::replay`] recomputes any
//! pixel sample from (seed, pixel, sample index). Russian roulette decides how long subpaths are, not the densities in the weights,
//! so the weights of all strategies of a path still sum to one.
//!
//! Sample dimensions per pixel sample: pixel (2), lens (2), then the camera subpath (per vertex:
//! lobe 1, direction 2, roulette 1), then the light subpath (light 1, position 2, direction 2, per
//! vertex lobe 1, direction 2, roulette 1) and the connection samples (per camera vertex: light 1,
//! light point 2, lens 2). Light subpath values come from a second stream keyed by the pixel sample,
//! so the camera dimensions keep the layout stratified samplers expect.

use crate::config::{ConfigError, Validate, check_common, default_rr, invalid};
use crate::film::Film;
use crate::passes::{PassSpec, Schedule, run_passes};
use crate::paths::{Layers, PathClass, Router};
use crate::render::{Counters, PixelVariance, Technique};
use crate::walk::{
    Arrival, Directions, Kind, PathVertex, Visitor, Walk, connect_to_lens, from_camera, from_light,
    geometry_term, unoccluded,
};
use crate::{Budget, Integrator, RenderOutput, RenderStats};
use glam::Vec2;
use lightlab_core::{Progress, Ray, Rgb, TransportMode};
use lightlab_materials::BsdfSample;
use lightlab_samplers::{Independent, Sampler, SamplerConfig, SamplerVisitor};
use lightlab_scene::Scene;
use serde::{Deserialize, Serialize};

/// Settings of bidirectional path tracing: `Bdpt(max_bounces: 8, mis: Balance)`; every field
/// optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields, rename = "Bdpt")]
pub struct BdptConfig {
    /// Largest number of scattering vertices of a full path; `None` for no limit. Default `None`.
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    pub min_bounces: u32,
    /// Russian roulette on both subpaths from this many vertices on; `None` turns it off.
    /// Default `Some(3)`.
    pub russian_roulette: Option<u32>,
    /// Sampler of the camera subpaths (the light subpaths use independent samples). Default
    /// `Independent`.
    pub sampler: SamplerConfig,
    /// Strategy weights: `Balance`, `Power`, `Uniform` or `Only(s: S, t: T)`. Default `Balance`.
    pub mis: Mis,
    /// Also write every strategy (s, t) as layers `s{s}t{t}` (MIS-weighted; they sum to the image)
    /// and `s{s}t{t}.unweighted` (the strategy's own estimate of its paths). Needs `max_bounces`.
    /// Default false.
    pub strategy_layers: bool,
    /// Log every contribution larger (in its largest channel) than this multiple of its pixel's
    /// mean, with its provenance (pixel, sample index, strategy, path class, densities, MIS
    /// weight), for replay with `lightlab replay`. Non-finite contributions are always logged.
    /// Default `None` (only non-finite ones).
    pub outliers: Option<f32>,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    pub layers: Layers,
}

impl Default for BdptConfig {
    fn default() -> Self {
        BdptConfig {
            max_bounces: None,
            min_bounces: 0,
            russian_roulette: default_rr(),
            sampler: SamplerConfig::Independent,
            mis: Mis::Balance,
            strategy_layers: false,
            outliers: None,
            paths: None,
            layers: Layers::Off,
        }
    }
}

impl Validate for BdptConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_common(
            self.max_bounces,
            self.min_bounces,
            self.russian_roulette,
            self.paths.as_deref(),
            &self.layers,
        )?;
        if let Mis::Only { s, t } = self.mis
            && t == 0
        {
            return invalid(format!(
                "Only(s: {s}, t: 0) is not a strategy: paths must reach the camera, so t ≥ 1"
            ));
        }
        if let Some(f) = self.outliers
            && !(f > 1.0 && f.is_finite())
        {
            return invalid(format!(
                "outliers is a multiple of the pixel's mean and must be finite and > 1, got {f}"
            ));
        }
        if self.strategy_layers && self.max_bounces.is_none() {
            return invalid(
                "strategy_layers needs max_bounces (it bounds the number of strategies)",
            );
        }
        Ok(())
    }
}

/// How bidirectional path tracing weights its strategies (Veach 1997, ch. 9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mis {
    /// wᵢ = pᵢ / Σⱼ pⱼ (Veach's balance heuristic).
    #[default]
    Balance,
    /// wᵢ = pᵢ² / Σⱼ pⱼ² (the power heuristic with β = 2).
    Power,
    /// wᵢ = 1 / (number of strategies that can produce the path): unweighted averaging.
    Uniform,
    /// No MIS: only strategy (s, t), with weight 1 — the paths of s + t − 2 bounces that this one
    /// strategy samples, for looking at one technique alone.
    Only { s: u32, t: u32 },
}

impl Mis {
    /// Whether strategy (s, t) is left out entirely.
    pub fn excludes(&self, s: usize, t: usize) -> bool {
        matches!(*self, Mis::Only { s: os, t: ot } if (os as usize, ot as usize) != (s, t))
    }
}

pub struct Bdpt {
    config: BdptConfig,
    router: Router,
    /// With `strategy_layers`: every strategy (s, t), in layer order.
    strategies: Vec<(usize, usize)>,
}

impl Bdpt {
    /// BDPT with `config` (checked).
    pub fn new(config: BdptConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let router = Router::new(config.paths.as_deref(), &config.layers, config.max_bounces)
            .map_err(ConfigError::Invalid)?;
        let strategies = match (config.strategy_layers, config.max_bounces) {
            (true, Some(max)) => (2..=max as usize + 2)
                .flat_map(|n| (0..n).map(move |s| (s, n - s)))
                .filter(|&st| st.1 >= 1)
                .collect(),
            _ => Vec::new(),
        };
        Ok(Bdpt {
            config,
            router,
            strategies,
        })
    }

    /// Slot of the weighted layer of strategy (s, t) (the unweighted one follows it), counted from
    /// the first strategy layer.
    fn strategy_slot(&self, s: usize, t: usize) -> Option<usize> {
        self.strategies
            .iter()
            .position(|&x| x == (s, t))
            .map(|i| 2 * i)
    }

    /// The walk settings of a subpath of at most `max_depth` scattering vertices.
    fn walk(&self, mode: TransportMode, max_depth: u32) -> Walk {
        Walk {
            mode,
            max_depth,
            russian_roulette: self.config.russian_roulette,
            directions: Directions::Bsdf,
        }
    }

    /// The camera subpath through raster position `film`: the camera vertex and up to
    /// `max_depth` surface vertices (and a vertex at infinity if it escapes to an environment).
    fn camera_subpath<S: Sampler>(
        &self,
        scene: &Scene,
        film: Vec2,
        sampler: &mut S,
        max_depth: u32,
        path: &mut Vec<PathVertex>,
        counters: &mut Counters,
    ) {
        let walk = self.walk(TransportMode::Radiance, max_depth);
        let mut subpath = Subpath {
            scene,
            camera: true,
            path,
        };
        from_camera(scene, &walk, film, sampler, &mut subpath, counters);
    }

    /// The light subpath (pbrt-v4 `GenerateLightSubpath`): its origin on a light and up to
    /// `max_depth` surface vertices.
    fn light_subpath<S: Sampler>(
        &self,
        scene: &Scene,
        sampler: &mut S,
        max_depth: u32,
        path: &mut Vec<PathVertex>,
        counters: &mut Counters,
    ) {
        let walk = self.walk(TransportMode::Importance, max_depth);
        let mut subpath = Subpath {
            scene,
            camera: false,
            path,
        };
        from_light(scene, &walk, sampler, &mut subpath, counters);
    }

    /// The MIS weight of strategy (s, t) (pbrt-v4 `MISWeight`, balance heuristic). `sampled` replaces
    /// the endpoint that strategy sampled anew (the light point for s = 1, the lens point for t = 1).
    fn mis_weight(
        scene: &Scene,
        light: &[PathVertex],
        camera: &[PathVertex],
        sampled: Option<PathVertex>,
        s: usize,
        t: usize,
        heuristic: Mis,
    ) -> f32 {
        if matches!(heuristic, Mis::Only { .. }) {
            return 1.0;
        }
        let mut lv: Vec<PathVertex> = light[..s].to_vec();
        let mut cv: Vec<PathVertex> = camera[..t].to_vec();
        // t = 1 samples the lens point (for s = t = 1 too, whose light vertex is the subpath's
        // origin); s = 1 with t ≥ 2 samples a point on a light.
        if t == 1 {
            cv[0] = sampled.expect("t = 1 samples the camera vertex");
        } else if s == 1 {
            lv[0] = sampled.expect("s = 1 samples the light vertex");
        }
        // The connection vertices are never delta for the connection itself.
        if t > 0 {
            cv[t - 1].delta = false;
        }
        if s > 0 {
            lv[s - 1].delta = false;
        }
        // Densities of the connection vertices and their predecessors from the other side.
        if t > 0 {
            let pt = cv[t - 1];
            cv[t - 1].pdf_rev = if s > 0 {
                let qs_minus = if s > 1 { Some(lv[s - 2]) } else { None };
                lv[s - 1].pdf(scene, qs_minus.as_ref(), &pt)
            } else {
                pt.pdf_light_origin(scene)
            };
        }
        if t > 1 {
            let (pt, pt_minus) = (cv[t - 1], cv[t - 2]);
            cv[t - 2].pdf_rev = if s > 0 {
                pt.pdf(scene, Some(&lv[s - 1]), &pt_minus)
            } else {
                pt.pdf_light(scene, &pt_minus)
            };
        }
        if s > 0 {
            let qs = lv[s - 1];
            let pt_minus = if t > 1 { Some(cv[t - 2]) } else { None };
            lv[s - 1].pdf_rev = cv[t - 1].pdf(scene, pt_minus.as_ref(), &qs);
        }
        if s > 1 {
            let (qs, qs_minus) = (lv[s - 1], lv[s - 2]);
            lv[s - 2].pdf_rev = qs.pdf(scene, Some(&cv[t - 1]), &qs_minus);
        }
        let remap = |p: f32| if p != 0.0 { p } else { 1.0 };
        // Each other strategy i enters with rᵢ = pᵢ / p_s: the balance heuristic sums rᵢ, the power
        // heuristic (β = 2) rᵢ², uniform weights count the strategies (Veach 1997, §9.2).
        let term = |r: f32| match heuristic {
            Mis::Balance => r,
            Mis::Power => r * r,
            Mis::Uniform => 1.0,
            Mis::Only { .. } => 0.0,
        };
        let mut sum = 0.0f32;
        let mut ri = 1.0f32;
        for i in (1..t).rev() {
            ri *= remap(cv[i].pdf_rev) / remap(cv[i].pdf_fwd);
            if !cv[i].delta && !cv[i - 1].delta {
                sum += term(ri);
            }
        }
        ri = 1.0;
        for i in (0..s).rev() {
            ri *= remap(lv[i].pdf_rev) / remap(lv[i].pdf_fwd);
            let delta_before = if i > 0 {
                lv[i - 1].delta
            } else {
                lv[0]
                    .light()
                    .is_some_and(|l| scene.lights[l as usize].is_delta())
            };
            if !lv[i].delta && !delta_before {
                sum += term(ri);
            }
        }
        1.0 / (1.0 + sum)
    }

    /// Unweighted contribution of strategy (s, t), its MIS weight, and where it goes: the pixel
    /// (`None`) or, for t = 1, a splat position.
    #[allow(clippy::too_many_arguments)]
    fn connect(
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
            if !qs.connectible(scene) || qs.infinite {
                return None;
            }
            // s = t = 1: the point on the light seen directly through the lens (light tracing's
            // emission connection); a point or spot light has no area to be seen.
            if s == 1 && (!qs.on_surface() || !(qs.pdf_fwd > 0.0)) {
                return None;
            }
            let c = connect_to_lens(scene, qs, u_lens, counters, |v| {
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
            if !pt.connectible(scene) {
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
            if !qs.connectible(scene) || !pt.connectible(scene) || qs.infinite {
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
        let w = Self::mis_weight(scene, light, camera, sampled, s, t, self.config.mis);
        Some((l, w, raster))
    }
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
        self.path[n - 2].pdf_rev = v.convert_density(pdf_rev_w, &self.path[n - 2]);
    }

    /// A camera subpath that escapes ends on the environment, if there is one.
    #[inline]
    fn escaped(&mut self, ray: &Ray, beta: Rgb, arrival: &Arrival, _: &mut Counters) {
        if !self.camera {
            return;
        }
        if let Some(env) = self.scene.environment_light() {
            let mut v = PathVertex::new(Kind::Light { light: env }, ray.o + ray.d, beta);
            v.class = arrival.class;
            v.depth = arrival.class.len();
            v.infinite = true;
            v.ng = ray.d.normalize();
            v.pdf_fwd = arrival.pdf_w;
            self.path.push(v);
        }
    }
}

/// Seed offset of the light subpaths' random-number stream.
const LIGHT_STREAM: u64 = 0x6c69_6768_7470_6174;

/// Pixel samples before which no contribution is called an outlier (the running mean is too
/// uncertain before).
const OUTLIER_MIN_SAMPLES: u64 = 8;

/// A logged contribution: where it came from (pixel, sample index: with the seed, enough to
/// replay it), which strategy and path, its value and MIS weight, and the area-measure densities
/// of the full path's vertices y₀ … y_{s−1} z_{t−1} … z₀ along the light and camera subpaths.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Outlier {
    pub pixel: [u32; 2],
    pub sample: u64,
    pub s: u32,
    pub t: u32,
    pub class: String,
    /// Weighted contribution (what the image receives).
    pub value: [f32; 3],
    pub unweighted: [f32; 3],
    pub mis_weight: f32,
    /// Raster position of a t = 1 splat.
    pub raster: Option<[f32; 2]>,
    /// The pixel's running mean before this sample.
    pub pixel_mean: [f64; 3],
    pub pdf_fwd: Vec<f32>,
    pub pdf_rev: Vec<f32>,
}

impl Outlier {
    fn new(
        pixel: (u32, u32),
        sample: u64,
        c: &Contribution,
        pixel_mean: [f64; 3],
        light: &[PathVertex],
        camera: &[PathVertex],
    ) -> Outlier {
        let path = light.iter().chain(camera.iter().rev());
        let v = c.unweighted * c.weight;
        Outlier {
            pixel: [pixel.0, pixel.1],
            sample,
            s: c.s as u32,
            t: c.t as u32,
            class: joined_class(light, camera, c.s, c.t).to_heckbert(),
            value: [v.r, v.g, v.b],
            unweighted: [c.unweighted.r, c.unweighted.g, c.unweighted.b],
            mis_weight: c.weight,
            raster: c.raster.map(|r| [r.x, r.y]),
            pixel_mean,
            pdf_fwd: path.clone().map(|v| v.pdf_fwd).collect(),
            pdf_rev: path.map(|v| v.pdf_rev).collect(),
        }
    }
}

/// A splat, and the pixel sample and strategy it came from, to replay it if it turns out an
/// outlier.
#[derive(Clone, Copy, Debug)]
struct SplatSource {
    /// The pixel it lands in, and its value.
    target: u32,
    value: Rgb,
    pixel: (u32, u32),
    sample: u64,
    s: u16,
    t: u16,
}

/// The class of the path strategy (s, t) joins, light first (for s = 0 the last camera vertex is
/// the emitter, not a scattering vertex).
fn joined_class(light: &[PathVertex], camera: &[PathVertex], s: usize, t: usize) -> PathClass {
    match s {
        0 if t >= 2 => camera[t - 2].class.reversed(),
        0 => PathClass::EMPTY,
        _ => light[s - 1].class.then(camera[t - 1].class.reversed()),
    }
}

/// One strategy's contribution to one pixel sample.
#[derive(Clone, Copy, Debug)]
pub struct Contribution {
    pub s: usize,
    pub t: usize,
    /// Its layer (see `Router::route`).
    pub layer: usize,
    /// The strategy's own estimate, before the MIS weight.
    pub unweighted: Rgb,
    pub weight: f32,
    /// Where a t = 1 contribution lands; `None` for the sample's own pixel.
    pub raster: Option<Vec2>,
}

impl Bdpt {
    /// Traces pixel sample `index` of `pixel` and calls `visit(contribution, light subpath, camera
    /// subpath)` for every strategy that contributes, in the order the renderer adds them. Rendering
    /// and [`Bdpt::replay`] both go through here, so a replay reproduces a render's sample exactly.
    #[allow(clippy::too_many_arguments)]
    fn pixel_sample<S: Sampler>(
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
        sampler.start_pixel_sample(seed, pixel, index);
        light_sampler.start_pixel_sample(seed ^ LIGHT_STREAM, pixel, index);
        let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
        camera.clear();
        light.clear();
        // A full path of at most max_bounces scattering vertices: the camera side may reach an
        // emitter after max_bounces of them (s = 0), the light side scatter max_bounces times
        // before its last vertex is seen through the lens (t = 1).
        self.camera_subpath(
            scene,
            film,
            sampler,
            max_bounces.saturating_add(1),
            camera,
            counters,
        );
        self.light_subpath(scene, light_sampler, max_bounces, light, counters);
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

    /// The splats larger (largest channel) than `factor` times the final mean of the pixel they
    /// land in, replayed for their provenance.
    fn splat_outliers(
        &self,
        scene: &Scene,
        seed: u64,
        spp: u32,
        items: &[WorkItem],
        film: &Film,
        factor: f32,
    ) -> Vec<Outlier> {
        let mut out = Vec::new();
        for r in items {
            for src in &r.splat_sources {
                let value = src.value;
                let mean = film.mean(src.target as usize);
                let scale = mean[0].max(mean[1]).max(mean[2]);
                if (value.max_component() as f64) <= factor as f64 * scale.max(f64::MIN_POSITIVE) {
                    continue;
                }
                let replayed = self.replay(scene, seed, spp, src.pixel, src.sample);
                if let Some(mut o) = replayed.into_iter().find(|o| {
                    (o.s, o.t) == (src.s as u32, src.t as u32)
                        && o.value == [value.r, value.g, value.b]
                }) {
                    o.pixel_mean = mean;
                    out.push(o);
                }
            }
        }
        out
    }

    /// Every contribution of pixel sample `index` of `pixel` (x, y), recomputed from (seed, pixel,
    /// sample index) alone: the deterministic replay of a logged outlier.
    /// `spp` is the render's samples per pixel (stratified samplers depend on it).
    pub fn replay(
        &self,
        scene: &Scene,
        seed: u64,
        spp: u32,
        pixel: (u32, u32),
        index: u64,
    ) -> Vec<Outlier> {
        struct Replay<'a> {
            bdpt: &'a Bdpt,
            scene: &'a Scene,
            seed: u64,
            pixel: (u32, u32),
            index: u64,
        }
        impl SamplerVisitor for Replay<'_> {
            type Output = Vec<Outlier>;
            fn visit<S: Sampler + Clone + Send + Sync + 'static>(
                self,
                mut sampler: S,
            ) -> Vec<Outlier> {
                let mut out = Vec::new();
                let (mut camera, mut light) = (Vec::new(), Vec::new());
                self.bdpt.pixel_sample(
                    self.scene,
                    self.seed,
                    self.pixel,
                    self.index,
                    &mut sampler,
                    &mut Independent::new(),
                    (&mut camera, &mut light),
                    &mut Counters::default(),
                    |c, light, camera| {
                        out.push(Outlier::new(
                            self.pixel, self.index, c, [0.0; 3], light, camera,
                        ))
                    },
                );
                out
            }
        }
        self.config.sampler.dispatch(
            spp,
            Replay {
                bdpt: self,
                scene,
                seed,
                pixel,
                index,
            },
        )
    }
}

impl Integrator for Bdpt {
    fn render_passes(
        &self,
        scene: &Scene,
        budget: &Budget,
        seed: u64,
        progress: &dyn Progress,
        on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    ) -> RenderOutput {
        let spp = match *budget {
            Budget::Samples(n) => n,
            Budget::Seconds(_) => 1,
        };
        self.config.sampler.dispatch(
            spp,
            RenderWith {
                bdpt: self,
                scene,
                budget,
                seed,
                progress,
                on_pass,
            },
        )
    }

    fn needs_sample_count(&self) -> bool {
        self.config.sampler.needs_sample_count()
    }

    fn best_sample_count(&self, n: u32) -> u32 {
        self.config.sampler.best_count_up_to(n)
    }
}

struct RenderWith<'a, 'b> {
    bdpt: &'a Bdpt,
    scene: &'a Scene,
    budget: &'a Budget,
    seed: u64,
    progress: &'a dyn Progress,
    on_pass: &'b mut dyn FnMut(u32, &Film) -> bool,
}

/// What one work item keeps besides its contributions: the subpath buffers it reuses, and the
/// outliers and splat provenance it logged.
#[derive(Default)]
struct WorkItem {
    camera: Vec<PathVertex>,
    light: Vec<PathVertex>,
    outliers: Vec<Outlier>,
    /// Where each splat of the full image came from (only with `outliers`).
    splat_sources: Vec<SplatSource>,
}

impl SamplerVisitor for RenderWith<'_, '_> {
    type Output = RenderOutput;

    fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, prototype: S) -> RenderOutput {
        let RenderWith {
            bdpt,
            scene,
            budget,
            seed,
            progress,
            on_pass,
        } = self;
        let cfg = &bdpt.config;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let router = &bdpt.router;
        // Per pixel: the full image, the class or bounce layers, then two per strategy.
        let first_strategy = 1 + router.layer_count();
        let spec = PassSpec {
            width,
            height,
            slots: first_strategy + 2 * bdpt.strategies.len(),
            splats: true,
            groups: 0,
            independent: cfg.sampler.independent(),
        };
        let mut schedule = Schedule::new(*budget, progress, width as u64 * height as u64);
        let out = run_passes(
            &spec,
            router,
            &mut schedule,
            on_pass,
            |x, y, index, sink, counters, item: &mut WorkItem| {
                let mut sampler = prototype.clone();
                let mut light_sampler = Independent::new();
                // Non-finite counts of this sample (the sample holds `counters`).
                let mut non_finite = Counters::default();
                let (running_mean, running_count) = sink.running_mean();
                let scale = running_mean[0].max(running_mean[1]).max(running_mean[2]);
                let WorkItem {
                    camera,
                    light,
                    outliers,
                    splat_sources,
                } = item;
                bdpt.pixel_sample(
                    scene,
                    seed,
                    (x, y),
                    index,
                    &mut sampler,
                    &mut light_sampler,
                    (camera, light),
                    counters,
                    |c, light, camera| {
                        let value = c.unweighted * c.weight;
                        let finite = value.is_finite();
                        if !finite {
                            non_finite.count_non_finite(if c.raster.is_some() {
                                Technique::CameraConnection
                            } else {
                                Technique::Connection
                            });
                        }
                        // Camera-side contributions are compared with their pixel's mean over
                        // the passes before this one; splats (t = 1), which land in other
                        // pixels, with their pixel's final mean after the render (see
                        // `splat_outliers`).
                        let outlier = match cfg.outliers {
                            Some(factor) if c.raster.is_none() => {
                                running_count >= OUTLIER_MIN_SAMPLES
                                    && value.max_component() as f64
                                        > factor as f64 * scale.max(f64::MIN_POSITIVE)
                            }
                            _ => false,
                        };
                        if !finite || outlier {
                            outliers.push(Outlier::new(
                                (x, y),
                                index,
                                c,
                                running_mean,
                                light,
                                camera,
                            ));
                        }
                        if !finite {
                            return;
                        }
                        let strategy = bdpt
                            .strategy_slot(c.s, c.t)
                            .filter(|_| c.unweighted.is_finite());
                        match c.raster {
                            Some(r) => {
                                let pixel = sink.pixel_at(r);
                                sink.splat_routed(pixel, c.layer, value);
                                if let Some(k) = strategy {
                                    sink.splat_slot(pixel, first_strategy + k, value);
                                    sink.splat_slot(pixel, first_strategy + k + 1, c.unweighted);
                                }
                                if cfg.outliers.is_some() {
                                    splat_sources.push(SplatSource {
                                        target: pixel,
                                        value,
                                        pixel: (x, y),
                                        sample: index,
                                        s: c.s as u16,
                                        t: c.t as u16,
                                    });
                                }
                            }
                            None => {
                                sink.add_routed(c.layer, value);
                                if let Some(k) = strategy {
                                    sink.add_slot(first_strategy + k, value);
                                    sink.add_slot(first_strategy + k + 1, c.unweighted);
                                }
                            }
                        }
                    },
                );
                counters.merge(&non_finite);
            },
        );
        let mut films = out.films;
        let film = films.remove(0);
        let pixels = width as u64 * height as u64;
        let mut stats = RenderStats::new(
            "Bdpt",
            &film,
            out.spp,
            seed,
            schedule.elapsed(),
            pixels * out.spp as u64,
            &out.counters,
            &[Technique::Connection, Technique::CameraConnection],
            if spec.independent {
                PixelVariance::Independent
            } else {
                PixelVariance::NotAnEstimate(format!(
                    "the {} sampler's camera subpaths are correlated (s²/n overestimates the \
                     variance of the mean)",
                    cfg.sampler.name()
                ))
            },
        );
        let mut outliers: Vec<Outlier> = out
            .extras
            .iter()
            .flat_map(|r| r.outliers.iter().cloned())
            .collect();
        if let Some(factor) = cfg.outliers {
            outliers.extend(bdpt.splat_outliers(scene, seed, out.spp, &out.extras, &film, factor));
        }
        let mut per_strategy: std::collections::BTreeMap<(u32, u32), u64> = Default::default();
        for o in &outliers {
            *per_strategy.entry((o.s, o.t)).or_default() += 1;
        }
        stats.outliers = per_strategy
            .into_iter()
            .map(|((s, t), n)| (format!("s{s}t{t}"), n))
            .collect();
        let names = router.layer_names().into_iter().chain(
            bdpt.strategies
                .iter()
                .flat_map(|(s, t)| [format!("s{s}t{t}"), format!("s{s}t{t}.unweighted")]),
        );
        RenderOutput {
            film,
            layers: names.zip(films).collect(),
            outliers,
            stats,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightlab_geometry::NO_LIGHT;

    fn scene(name: &str) -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes")
            .join(name);
        lightlab_scene::load_scene(&path).unwrap()
    }

    /// The vertices of a full path x₀ (on a light) … x_{n−1} (the camera) split as s light and
    /// t = n − s camera vertices, with every density recomputed from the geometry, as both subpath
    /// generators would have stored them.
    fn split(scene: &Scene, z: &[PathVertex], s: usize) -> (Vec<PathVertex>, Vec<PathVertex>) {
        let n = z.len();
        let t = n - s;
        let mut camera: Vec<PathVertex> = z[..t].to_vec();
        let mut light: Vec<PathVertex> = z[t..].iter().rev().copied().collect();
        if let Some(y0) = light.first_mut() {
            y0.kind = Kind::Light { light: y0.emitter };
            y0.sb = None;
            y0.delta = false;
        }
        for i in 1..camera.len() {
            let prev = if i >= 2 { Some(camera[i - 2]) } else { None };
            camera[i].pdf_fwd = camera[i - 1].pdf(scene, prev.as_ref(), &camera[i]);
        }
        if !light.is_empty() {
            light[0].pdf_fwd = light[0].pdf_light_origin(scene);
        }
        for i in 1..light.len() {
            let prev = if i >= 2 { Some(light[i - 2]) } else { None };
            light[i].pdf_fwd = light[i - 1].pdf(scene, prev.as_ref(), &light[i]);
        }
        // Reverse densities of the interior vertices (the last two of each side are set by
        // `mis_weight` itself).
        for i in 0..camera.len().saturating_sub(2) {
            let next2 = camera[i + 2];
            camera[i].pdf_rev = camera[i + 1].pdf(scene, Some(&next2), &camera[i]);
        }
        for i in 0..light.len().saturating_sub(2) {
            let next2 = light[i + 2];
            light[i].pdf_rev = light[i + 1].pdf(scene, Some(&next2), &light[i]);
        }
        (light, camera)
    }

    /// Veach's condition for unbiased MIS: the weights of all strategies that can produce a path sum
    /// to one, for the balance and power heuristics and uniform weights. Checked on camera paths that end on the light, in the Cornell box (all diffuse) and
    /// the caustic scene (delta vertices, whose connections are impossible strategies).
    #[test]
    fn weights_of_all_strategies_sum_to_one() {
        for name in ["cornell-box.ron", "caustic-sphere.ron"] {
            let scene = scene(name);
            let bdpt = Bdpt::new(BdptConfig {
                max_bounces: Some(6),
                russian_roulette: None,
                ..BdptConfig::default()
            })
            .unwrap();
            let mut counters = Counters::default();
            let mut checked = 0;
            for pixel in 0..200_000u64 {
                let mut sampler = Independent::new();
                sampler.start_pixel_sample(7, pixel, 0);
                let film = Vec2::new(
                    (pixel % 256) as f32 + 0.5,
                    ((pixel / 256) % 256) as f32 + 0.5,
                );
                let mut z = Vec::new();
                bdpt.camera_subpath(&scene, film, &mut sampler, 8, &mut z, &mut counters);
                let Some(last) = z.last() else { continue };
                if z.len() < 3
                    || last.emitter == NO_LIGHT
                    || last.le(&scene, &z[z.len() - 2]).is_black()
                {
                    continue;
                }
                let n = z.len();
                for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                    let mut sum = 0.0f64;
                    for s in 0..n {
                        let t = n - s;
                        let (light, camera) = split(&scene, &z, s);
                        let connection_delta = s > 0 && (light[s - 1].delta || camera[t - 1].delta);
                        if connection_delta {
                            continue;
                        }
                        let sampled = if t == 1 {
                            Some(camera[0])
                        } else if s == 1 {
                            Some(light[0])
                        } else {
                            None
                        };
                        sum += Bdpt::mis_weight(&scene, &light, &camera, sampled, s, t, heuristic)
                            as f64;
                    }
                    assert!(
                        (sum - 1.0).abs() < 1e-3,
                        "{name}, {heuristic:?}: a path of {n} vertices has weights summing to {sum}"
                    );
                }
                checked += 1;
                if checked == 300 {
                    break;
                }
            }
            assert!(
                checked >= 50,
                "{name}: only {checked} paths reached the light"
            );
        }
    }

    /// A sampler that replays `values` in order (then ½): drives a production walk along a path
    /// chosen in advance.
    struct Script {
        values: Vec<f32>,
        next: usize,
    }

    impl Sampler for Script {
        fn start_pixel_sample(&mut self, _: u64, _: u64, _: u64) {}
        fn next_1d(&mut self) -> f32 {
            self.next += 1;
            self.values.get(self.next - 1).copied().unwrap_or(0.5)
        }
        fn next_2d(&mut self) -> Vec2 {
            Vec2::new(self.next_1d(), self.next_1d())
        }
    }

    fn bdpt(max_bounces: u32) -> Bdpt {
        Bdpt::new(BdptConfig {
            max_bounces: Some(max_bounces),
            russian_roulette: None,
            ..BdptConfig::default()
        })
        .unwrap()
    }

    /// The camera subpath that `camera_subpath` traces back through the vertices of the light
    /// subpath `light` (x₀ on the light … x_{n−1}) when its samples are chosen to: the camera ray
    /// through x_{n−1}'s raster position, at every diffuse vertex the inverse of the cosine warp
    /// toward the next vertex, at every delta vertex the lobe the light path took. `None` unless
    /// the walk retraces every vertex.
    fn camera_through(bdpt: &Bdpt, scene: &Scene, light: &[PathVertex]) -> Option<Vec<PathVertex>> {
        use lightlab_samplers::warp::cosine_hemisphere_to_square;
        let n = light.len();
        let raster = scene
            .camera
            .sample_wi(light[n - 1].p, Vec2::splat(0.5))?
            .raster;
        let mut values = vec![0.5, 0.5];
        for j in (1..n).rev() {
            let (here, next) = (&light[j], &light[j - 1]);
            let sb = here.sb?;
            let wi = (next.p - here.p).normalize();
            let (u_lobe, u_dir) = if here.delta {
                let prev = if j + 1 < n {
                    light[j + 1].p
                } else {
                    scene.camera.eye
                };
                let through = (prev - here.p).dot(here.ng) * (next.p - here.p).dot(here.ng) < 0.0;
                (if through { 1.0 - 1e-6 } else { 0.0 }, Vec2::splat(0.5))
            } else {
                let mut local = sb.frame.to_local(wi);
                local.z = local.z.abs();
                (0.5, cosine_hemisphere_to_square(local))
            };
            values.extend([u_lobe, u_dir.x, u_dir.y, 0.5]);
        }
        let mut sampler = Script { values, next: 0 };
        let mut camera = Vec::new();
        let film = raster;
        bdpt.camera_subpath(
            scene,
            film,
            &mut sampler,
            n as u32 + 1,
            &mut camera,
            &mut Counters::default(),
        );
        let retraced = camera.len() == n + 1
            && (1..=n).all(|j| camera[j].p.distance(light[n - j].p) < 1e-3)
            && camera[n].emitter != NO_LIGHT;
        retraced.then_some(camera)
    }

    /// Σ over the strategies that can make the path `light` + camera of their MIS weights, from
    /// the densities the two production walks stored.
    fn weight_sum(
        scene: &Scene,
        light: &[PathVertex],
        camera: &[PathVertex],
        heuristic: Mis,
    ) -> f64 {
        let m = light.len();
        (0..=m)
            .filter(|&s| s == 0 || !(light[s - 1].delta || camera[m - s].delta))
            .map(|s| {
                let t = m + 1 - s;
                let sampled = match (s, t) {
                    (_, 1) => Some(camera[0]),
                    (1, _) => Some(light[0]),
                    _ => None,
                };
                Bdpt::mis_weight(scene, light, camera, sampled, s, t, heuristic) as f64
            })
            .sum()
    }

    /// Light subpaths of `scene` traced by production code (seeds 0, 1, …) whose last vertex the
    /// camera sees and which `keep` accepts, each with the camera subpath retracing it.
    fn production_paths(
        scene: &Scene,
        bdpt: &Bdpt,
        vertices: u32,
        keep: impl Fn(&[PathVertex]) -> bool,
        want: usize,
    ) -> Vec<(Vec<PathVertex>, Vec<PathVertex>)> {
        let mut out = Vec::new();
        for seed in 0..400_000u64 {
            let mut sampler = Independent::new();
            sampler.start_pixel_sample(seed, 0, 0);
            let mut light = Vec::new();
            bdpt.light_subpath(
                scene,
                &mut sampler,
                vertices,
                &mut light,
                &mut Counters::default(),
            );
            let Some(last) = light.last() else { continue };
            if last.delta || !keep(&light) {
                continue;
            }
            let visible = scene
                .camera
                .sample_wi(last.p, Vec2::splat(0.5))
                .is_some_and(|cs| {
                    unoccluded(
                        scene,
                        last,
                        &PathVertex::new(Kind::Camera, cs.p_lens, Rgb::WHITE),
                    )
                });
            if !visible {
                continue;
            }
            if let Some(camera) = camera_through(bdpt, scene, &light) {
                out.push((light, camera));
                if out.len() == want {
                    break;
                }
            }
        }
        out
    }

    /// One refractive interface: a light under a diffuse ceiling above a flat glass surface
    /// (η = 1.5 below it), a diffuse floor in the glass and the camera in the glass too — the
    /// path `L D S D E` crosses the interface once.
    fn flat_interface(material: &str) -> Scene {
        let text = format!(
            "Scene(camera: Camera(eye: (0, -0.4, 1.6), target: (0, -1, 0), fov: 50, resolution: (32, 32)),
               materials: {{ \"white\": Diffuse(albedo: (0.8, 0.8, 0.8)), \"black\": Diffuse(albedo: (0, 0, 0)),
                             \"interface\": {material} }},
               shapes: [
                 Shape(geometry: Quad(corner: (-10, 0, -10), edge1: (0, 0, 20), edge2: (20, 0, 0)), material: \"interface\"),
                 Shape(geometry: Quad(corner: (-3, -1, -3), edge1: (0, 0, 6), edge2: (6, 0, 0)), material: \"white\"),
                 Shape(geometry: Quad(corner: (-3, 1, -3), edge1: (6, 0, 0), edge2: (0, 0, 6)), material: \"white\"),
                 Shape(geometry: Quad(corner: (-0.3, 0.5, -0.3), edge1: (0, 0, 0.6), edge2: (0.6, 0, 0)), material: \"black\",
                       emission: (radiance: (5, 5, 5))),
               ])"
        );
        lightlab_scene::parse_scene(&text, std::path::Path::new("flat-interface.ron")).unwrap()
    }

    /// The weights of all strategies sum to one with the densities the walks themselves store —
    /// through a mirror, one flat refractive interface, the glass sphere (two interfaces), and for
    /// an emitter seen directly —
    /// for the balance and power heuristics and uniform weights. (It fails when the two walks
    /// disagree on a delta vertex's ratio of densities.)
    #[test]
    fn production_weights_sum_to_one_through_specular_vertices() {
        let with_delta = |p: &[PathVertex]| p.iter().any(|v| v.delta);
        let mirror_floor = {
            let text = std::fs::read_to_string(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../../scenes/caustic-sphere.ron"),
            )
            .unwrap()
            .replace(
                "\"glass\": Dielectric(ior: 1.5)",
                "\"glass\": Mirror(reflectance: (0.9, 0.9, 0.9))",
            );
            lightlab_scene::parse_scene(&text, std::path::Path::new("mirror-sphere.ron")).unwrap()
        };
        let directly = |p: &[PathVertex]| p.len() == 1;
        for (name, scene, keep, vertices) in [
            (
                "mirror sphere",
                mirror_floor,
                &with_delta as &dyn Fn(&[PathVertex]) -> bool,
                6,
            ),
            (
                "flat interface",
                flat_interface("Dielectric(ior: 1.5)"),
                &with_delta,
                6,
            ),
            (
                "glass sphere",
                super::tests::scene("caustic-sphere.ron"),
                &with_delta,
                6,
            ),
            // An emitter seen directly: s = 0 (the camera ray hits it) and s = t = 1.
            (
                "emitter seen directly",
                super::tests::scene("cornell-box.ron"),
                &directly,
                1,
            ),
        ] {
            let bdpt = bdpt(6);
            let paths = production_paths(&scene, &bdpt, vertices, keep, 40);
            assert!(paths.len() >= 20, "{name}: only {} paths", paths.len());
            for (light, camera) in &paths {
                for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                    let sum = weight_sum(&scene, light, camera, heuristic);
                    assert!(
                        (sum - 1.0).abs() < 2e-3,
                        "{name}, {heuristic:?}: a path of {} light vertices has weights summing to {sum}",
                        light.len()
                    );
                }
            }
        }
    }

    /// On `L D S D E` through one flat interface the balance weights are the true ones: the ratio
    /// of the light-tracing strategy (s = 4) to next-event estimation (s = 1) equals the ratio of
    /// their path densities computed independently, with the solid-angle Jacobians through the
    /// refraction taken by finite differences in f64 (Snell's law, the landing point's area per
    /// steradian). Keeping the lobe probability alone at the delta vertex was off by the
    /// compression (η_i/η_t)² cos θ_i / cos θ_t — a factor 0.3–0.5 here.
    #[test]
    fn weights_through_one_refraction_match_finite_difference_densities() {
        use glam::DVec3;
        let scene = flat_interface("Dielectric(ior: 1.5)");
        let eta = 1.5f64;
        let bdpt = bdpt(3);
        let shape = |p: &[PathVertex]| {
            p.len() == 4 && !p[1].delta && p[2].delta && p[1].p.y > 0.9 && p[3].p.y < -0.9
        };
        let paths = production_paths(&scene, &bdpt, 4, shape, 10);
        assert!(paths.len() >= 5, "only {} L D S D paths", paths.len());
        // Refracts d at the plane y = 0 and returns where it lands on the plane y = `to`.
        let land = |origin: DVec3, d: DVec3, to: f64| -> DVec3 {
            let at = origin + d * (-origin.y / d.y);
            let (eta_i, eta_t) = if d.y < 0.0 { (1.0, eta) } else { (eta, 1.0) };
            let n = DVec3::new(0.0, -d.y.signum(), 0.0);
            let cos_i = -d.dot(n);
            let r = eta_i / eta_t;
            let t = d * r + n * (r * cos_i - (1.0 - r * r * (1.0 - cos_i * cos_i)).sqrt());
            at + t * ((to - at.y) / t.y)
        };
        // Steradians per unit area of the landing point on the plane y = `to`, for directions
        // around d from `origin`.
        let jacobian = |origin: DVec3, d: DVec3, to: f64| -> f64 {
            let (t1, t2) = {
                let a = if d.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
                let t1 = d.cross(a).normalize();
                (t1, d.cross(t1))
            };
            let h = 1e-6;
            let at = |a: f64, b: f64| land(origin, (d + t1 * a + t2 * b).normalize(), to);
            let da = (at(h, 0.0) - at(-h, 0.0)) / (2.0 * h);
            let db = (at(0.0, h) - at(0.0, -h)) / (2.0 * h);
            1.0 / da.cross(db).length()
        };
        for (light, camera) in &paths {
            let x: Vec<DVec3> = light.iter().map(|v| v.p.as_dvec3()).collect();
            let eye = scene.camera.eye.as_dvec3();
            let cos_up = |a: DVec3, b: DVec3| (b - a).normalize().y.abs();
            // s = 4: the light emits x₀ → x₁ (cosine), x₁ scatters toward x₂ (cosine), which
            // refracts to x₃; the camera vertex is the pinhole for every strategy.
            let d01 = x[1] - x[0];
            let p_41 = cos_up(x[0], x[1]) / std::f64::consts::PI * cos_up(x[0], x[1])
                / d01.length_squared()
                * cos_up(x[1], x[2])
                / std::f64::consts::PI
                * jacobian(x[1], (x[2] - x[1]).normalize(), -1.0);
            // s = 1: the camera samples x₃ (its directional density times cos/d²), x₃ scatters
            // toward x₂ (cosine), which refracts to x₁; the light point x₀ is sampled alike.
            let d3 = x[3] - eye;
            let p_cam = scene
                .camera
                .pdf_we_dir(scene.camera.eye, d3.normalize().as_vec3())
                as f64
                * cos_up(eye, x[3])
                / d3.length_squared();
            let p_14 = p_cam * cos_up(x[3], x[2]) / std::f64::consts::PI
                * jacobian(x[3], (x[2] - x[3]).normalize(), 1.0);
            let w = |s: usize| {
                let t = 5 - s;
                let sampled = match (s, t) {
                    (_, 1) => Some(camera[0]),
                    (1, _) => Some(light[0]),
                    _ => None,
                };
                Bdpt::mis_weight(&scene, light, camera, sampled, s, t, Mis::Balance) as f64
            };
            let (production, exact) = (w(4) / w(1), p_41 / p_14);
            assert!(
                (production / exact - 1.0).abs() < 2e-3,
                "w(4,1)/w(1,4) = {production:.5}, the densities' ratio {exact:.5}"
            );
        }
    }
}
