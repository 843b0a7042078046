//! Photon tracing (Jensen 1996; Jensen 2001, ch. 5): light paths started on the lights exactly as
//! light tracing starts them, with a photon stored at every non-specular surface vertex.
//!
//! Flux. Photon path j leaves light ℓ with probability pmf(ℓ) (power-proportional selection), at a
//! point of area density p_A and in a direction of solid-angle density p_ω, so it carries
//! Φ_j = Lₑ·|cos θ| / (pmf · p_A · p_ω) / N; E[Σ_j Φ_j] is the emitted power and, for area and point
//! lights of one colour, every term equals it exactly (tested). At each scattering vertex the flux
//! is multiplied by the importance-mode BSDF weight f*·|cos θ|/p (with the shading-normal
//! correction, Veach 1997 eq. 5.19), and Russian roulette divides by its survival probability.
//!
//! Determinism: photon j's random numbers come from (seed, j) alone, and chunks of photons are
//! concatenated in index order, so a photon map is bit-identical on any number of threads.

use crate::paths::PathClass;
use crate::render::Counters;
use crate::roulette::survives;
use glam::Vec3;
use lightlab_core::{Ray, Rgb, TransportMode};
use lightlab_geometry::spawn_ray;
use lightlab_materials::{LobeClass, SurfaceBsdf};
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::{Light, Scene};
use rayon::prelude::*;

/// Photon paths per parallel work item.
const CHUNK: u64 = 4096;
/// Offset of the photons' random-number streams from the camera's (both are keyed by an index).
const PHOTON_STREAM: u64 = 0x9e37_79b9_7f4a_7c15;

/// A photon: flux arriving at a surface point.
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    pub p: Vec3,
    /// Unit direction toward where the photon came from (the ωᵢ of the density estimate).
    pub wi: Vec3,
    /// Geometric normal of the surface it landed on; a gather point only accepts photons whose
    /// surface faces the same way (photons on the far side of a thin wall are rejected).
    pub ng: Vec3,
    /// Flux, W per channel, already divided by the number of photon paths of its map.
    pub power: Rgb,
    /// The scattering vertices of its path from the light, this one included (k ≥ 1 of them):
    /// the photon is the end of a path `L X₁ … X_k`.
    pub class: PathClass,
}

impl Photon {
    /// Number of scattering vertices k.
    #[inline]
    pub fn bounces(&self) -> u32 {
        self.class.len()
    }

    /// Whether the photon is a caustic photon, `L S+ X`.
    #[inline]
    pub fn is_caustic(&self) -> bool {
        let k = self.class.len();
        k >= 2
            && !self.class.is_long()
            && (0..k - 1).all(|i| self.class.get(i) == LobeClass::Specular)
    }
}

/// Which photons a tracing pass keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// Every non-specular vertex.
    All,
    /// Only caustic photons (`L S+ X`); paths end at their first non-specular vertex.
    Caustic,
}

/// How photons are traced.
#[derive(Clone, Copy, Debug)]
pub struct PhotonTracing {
    /// Largest k stored.
    pub max_bounces: u32,
    /// Russian roulette from this many scattering vertices on.
    pub russian_roulette: Option<u32>,
    pub keep: Keep,
}

/// The start of photon path `index`: the emission ray and its flux (before division by the number
/// of paths). `None` when the scene does not emit or the sample has zero density.
pub fn emit(scene: &Scene, sampler: &mut Independent) -> Option<(Ray, Rgb)> {
    let (u_light, u_pos, u_dir) = (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
    let (light_index, pmf) = scene.sample_light(u_light)?;
    let light = &scene.lights[light_index as usize];
    let em = light.sample_le(scene.shapes(), scene.center, scene.radius, u_pos, u_dir)?;
    let at_infinity = matches!(light, Light::Environment { .. });
    let cos = if em.delta_pos || at_infinity {
        1.0
    } else {
        em.n.dot(em.dir).abs()
    };
    let power = em.le * (cos / (pmf * em.pdf_pos * em.pdf_dir));
    let ray = if em.delta_pos || at_infinity {
        Ray::new(em.p, em.dir)
    } else {
        spawn_ray(em.p, em.p_error, em.n, em.dir)
    };
    Some((ray, power))
}

/// A sampler positioned at the start of photon path `index` of the stream `seed`.
pub fn photon_sampler(seed: u64, index: u64) -> Independent {
    let mut sampler = Independent::new();
    sampler.start_pixel_sample(seed ^ PHOTON_STREAM, index, 0);
    sampler
}

/// Traces photon paths `first .. first + count` and returns their photons in path order, each
/// path's flux divided by `count`.
pub fn trace_photons(
    scene: &Scene,
    seed: u64,
    first: u64,
    count: u64,
    how: PhotonTracing,
    counters: &mut Counters,
) -> Vec<Photon> {
    let scale = 1.0 / count as f32;
    let chunks: Vec<(Vec<Photon>, Counters)> = (0..count.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut photons = Vec::new();
            let mut c = Counters::default();
            for j in chunk * CHUNK..((chunk + 1) * CHUNK).min(count) {
                trace_one(scene, seed, first + j, scale, how, &mut photons, &mut c);
            }
            (photons, c)
        })
        .collect();
    let mut photons = Vec::with_capacity(chunks.iter().map(|(p, _)| p.len()).sum());
    for (p, c) in chunks {
        photons.extend_from_slice(&p);
        counters.merge(&c);
    }
    photons
}

/// Technique number of non-finite photon fluxes in [`Counters::non_finite`].
pub const PHOTON_FLUX: usize = 1;

fn trace_one(
    scene: &Scene,
    seed: u64,
    index: u64,
    scale: f32,
    how: PhotonTracing,
    photons: &mut Vec<Photon>,
    counters: &mut Counters,
) {
    let mut sampler = photon_sampler(seed, index);
    let Some((mut ray, power)) = emit(scene, &mut sampler) else {
        return;
    };
    let mut beta = power * scale;
    let mut bounces = 0u32;
    let mut class = PathClass::EMPTY;
    loop {
        counters.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            return;
        };
        bounces += 1;
        if bounces > how.max_bounces {
            return;
        }
        let wo = -ray.d.normalize();
        let bsdf = scene.materials[hit.material as usize];
        let delta = bsdf.is_delta();
        class = class.push(bsdf.lobe_class());
        if !delta {
            let photon = Photon {
                p: hit.p,
                wi: wo,
                ng: hit.ng,
                power: beta,
                class,
            };
            if !beta.is_finite() {
                counters.non_finite[PHOTON_FLUX] += 1;
                return;
            }
            match how.keep {
                Keep::All => photons.push(photon),
                Keep::Caustic => {
                    if photon.is_caustic() {
                        photons.push(photon);
                    }
                    return;
                }
            }
        }
        let sb = SurfaceBsdf::new(hit.ns, hit.dpdu, hit.ng, bsdf);
        let (u_lobe, u_dir, u_rr) = (sampler.next_1d(), sampler.next_2d(), sampler.next_1d());
        let Some(s) = sb.sample(wo, u_lobe, u_dir, TransportMode::Importance) else {
            return;
        };
        beta *= s.weight;
        // Survival in proportion to the flux relative to the path's start keeps photon powers
        // roughly equal (Jensen 2001, §5.2).
        let score = beta.max_component() / (power * scale).max_component();
        if !survives(how.russian_roulette, bounces, score, u_rr, &mut beta) {
            return;
        }
        ray = spawn_ray(hit.p, hit.p_error, hit.ng, s.wi);
    }
}
