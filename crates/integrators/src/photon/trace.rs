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
use crate::render::{Counters, Technique};
use crate::walk::{
    self, Arrival, Directions, Lobes, PathVertex, RoulettePolicy, Visitor, Walk, from_light,
};
use glam::Vec3;
use lightlab_core::{Ray, Rgb, TransportMode};
use lightlab_materials::LobeClass;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;
use rayon::prelude::*;

/// Photon paths per parallel work item.
const CHUNK: u64 = 4096;
/// Offset of the photons' random-number streams from the camera's (both are keyed by an index).
const PHOTON_STREAM: u64 = 0x9e37_79b9_7f4a_7c15;

/// A photon: flux arriving at a surface point. 48 bytes: its two directions are stored
/// octahedrally in 2 × 16 bits each (Cigolle et al. 2014; error below 1e-4 rad).
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    /// Where it landed.
    pub p: Vec3,
    /// Flux, W per channel, already divided by the number of photon paths of its map.
    pub power: Rgb,
    wi: u32,
    ng: u32,
    /// The scattering vertices of its path from the light, this one included (k ≥ 1 of them):
    /// the photon is the end of a path `L X₁ … X_k`.
    pub class: PathClass,
}

impl Photon {
    /// A photon at `p` arriving from direction `wi` (unit, pointing away from the surface) on a
    /// surface of geometric normal `ng`.
    pub fn new(p: Vec3, wi: Vec3, ng: Vec3, power: Rgb, class: PathClass) -> Photon {
        Photon {
            p,
            power,
            wi: octahedral::encode(wi),
            ng: octahedral::encode(ng),
            class,
        }
    }

    /// Unit direction toward where the photon came from (the ωᵢ of the density estimate).
    #[inline]
    pub fn wi(&self) -> Vec3 {
        octahedral::decode(self.wi)
    }

    /// Geometric normal of the surface it landed on; a gather point only accepts photons whose
    /// surface faces the same way (photons on the far side of a thin wall are rejected).
    #[inline]
    pub fn ng(&self) -> Vec3 {
        octahedral::decode(self.ng)
    }

    /// Number of scattering vertices k.
    #[inline]
    pub fn bounces(&self) -> u32 {
        self.class.len()
    }

    /// Whether the photon is a caustic photon: `L S+ X`, or `L (S|G)+ X` `through_glossy` (Jensen's
    /// caustic paths, whose "specular" vertices include glossy ones, for camera paths that pass
    /// glossy surfaces instead of gathering on them).
    #[inline]
    pub fn is_caustic(&self, through_glossy: bool) -> bool {
        let k = self.class.len();
        k >= 2 && caustic_prefix(&self.class, k - 1, through_glossy)
    }
}

/// Whether the first `n` vertices of `class` are specular (or, `through_glossy`, specular or
/// glossy): a caustic path so far.
#[inline]
fn caustic_prefix(class: &PathClass, n: u32, through_glossy: bool) -> bool {
    !class.is_long()
        && (0..n).all(|i| match class.get(i) {
            LobeClass::Specular => true,
            LobeClass::Glossy => through_glossy,
            LobeClass::Diffuse => false,
        })
}

/// Which photons a tracing pass keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// Every non-specular vertex.
    All,
    /// Only caustic photons ([`Photon::is_caustic`]); paths end at their first vertex that is not
    /// specular (or, `through_glossy`, glossy), and no photon is kept on a glossy surface then,
    /// where no caustic estimate is made.
    Caustic {
        /// Glossy vertices continue a caustic path.
        through_glossy: bool,
    },
}

/// How photons are traced.
#[derive(Clone, Copy, Debug)]
pub struct PhotonTracing {
    /// Largest k stored.
    pub max_bounces: u32,
    /// The photon paths' Russian roulette.
    pub roulette: RoulettePolicy,
    /// Which photons are stored.
    pub keep: Keep,
}

/// The start of a photon path at instant `time`: the emission ray and its flux (before division
/// by the number of paths), as the shared walk's `emit` samples it. `None` when the scene does not
/// emit or the sample has zero density.
pub fn emit(scene: &Scene, sampler: &mut Independent, time: f32) -> Option<(Ray, Rgb)> {
    walk::emit(scene, sampler, time).map(|e| (e.ray, e.beta))
}

/// A sampler positioned at the start of photon path `index` of the stream `seed`.
pub fn photon_sampler(seed: u64, index: u64) -> Independent {
    let mut sampler = Independent::new();
    sampler.start_pixel_sample(seed ^ PHOTON_STREAM, index, 0);
    sampler
}

/// Photon paths traced to estimate how many photons a map will hold ([`stored_per_path`]).
const PILOT_PATHS: u64 = 4096;
/// Seed of those paths' stream, which no render's photons use.
const PILOT_SEED: u64 = 0x7069_6c6f_7470_6870;

/// Photons stored per photon path traced at instant `time` as `how` says, estimated from
/// `PILOT_PATHS` paths of a stream of their own (a few milliseconds): a map of n paths holds
/// about n times as many. The memory check's estimate: from k pilot photons its relative standard
/// error is about 1/√k (2 % for a global map, far more for rare caustic photons, which are then
/// too few to matter).
pub fn stored_per_path(scene: &Scene, time: f32, how: PhotonTracing) -> f64 {
    let traced = trace_photons(
        scene,
        PILOT_SEED,
        (0, PILOT_PATHS),
        time,
        how,
        &mut Counters::default(),
    );
    traced.photons.len() as f64 / PILOT_PATHS as f64
}

/// Bytes of `photons` photons being traced: the chunks' photons and their merged copy.
pub fn tracing_bytes(photons: f64) -> f64 {
    photons * 2.0 * size_of::<Photon>() as f64
}

/// Photon groups of a photon map: its paths split into this many contiguous ranges of path index,
/// whose estimates are independent and average to the map's.
pub const GROUPS: usize = 16;

/// The photons of a tracing pass, in path order, and where each photon group starts.
pub struct Traced {
    /// The photons, in path order.
    pub photons: Vec<Photon>,
    /// Index of the first photon of each of the `GROUPS` groups (paths j with
    /// ⌊j·GROUPS/count⌋ = g form group g).
    pub group_starts: Vec<u32>,
}

impl Traced {
    /// Photons not traced here, all in group 0.
    pub fn ungrouped(photons: Vec<Photon>) -> Traced {
        Traced {
            photons,
            group_starts: vec![0],
        }
    }
}

/// Traces photon paths `first .. first + count` at instant `time` and returns their photons in
/// path order, each path's flux divided by `count`.
pub fn trace_photons(
    scene: &Scene,
    seed: u64,
    (first, count): (u64, u64),
    time: f32,
    how: PhotonTracing,
    counters: &mut Counters,
) -> Traced {
    let scale = 1.0 / count as f32;
    let group_of = |j: u64| (j as u128 * GROUPS as u128 / count as u128) as usize;
    // Per chunk: its photons, the (group, local photon index) where each group starts in it, and
    // its counters.
    type Chunk = (Vec<Photon>, Vec<(usize, usize)>, Counters);
    let chunks: Vec<Chunk> = (0..count.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut photons = Vec::new();
            let mut starts = Vec::new();
            let mut c = Counters::default();
            for j in chunk * CHUNK..((chunk + 1) * CHUNK).min(count) {
                if j == 0 || group_of(j) != group_of(j - 1) {
                    starts.push((group_of(j), photons.len()));
                }
                trace_one(
                    scene,
                    (seed, first + j),
                    time,
                    scale,
                    how,
                    &mut photons,
                    &mut c,
                );
            }
            (photons, starts, c)
        })
        .collect();
    let mut photons = Vec::with_capacity(chunks.iter().map(|(p, _, _)| p.len()).sum());
    let mut group_starts = vec![u32::MAX; GROUPS];
    for (p, starts, c) in chunks {
        for (g, local) in starts {
            group_starts[g] = (photons.len() + local) as u32;
        }
        photons.extend_from_slice(&p);
        counters.merge(&c);
    }
    // A group without paths (fewer paths than groups) is empty: it starts where the next does.
    let mut next = photons.len() as u32;
    for start in group_starts.iter_mut().rev() {
        if *start == u32::MAX {
            *start = next;
        }
        next = *start;
    }
    Traced {
        photons,
        group_starts,
    }
}

fn trace_one(
    scene: &Scene,
    (seed, index): (u64, u64),
    time: f32,
    scale: f32,
    how: PhotonTracing,
    photons: &mut Vec<Photon>,
    counters: &mut Counters,
) {
    let mut sampler = photon_sampler(seed, index);
    // Roulette on the flux relative to the path's start keeps photon powers roughly equal
    // (Jensen 2001, §5.2): with threshold τ a surviving photon carries at least τ of its path's
    // starting flux (τ = 1: exactly it, Jensen's rule).
    let walk = Walk {
        mode: TransportMode::Importance,
        max_depth: how.max_bounces,
        roulette: how.roulette,
        directions: Directions::Bsdf,
    };
    let mut deposit = Deposit {
        keep: how.keep,
        scale,
        photons,
        delta_only: false,
    };
    from_light(scene, &walk, time, &mut sampler, &mut deposit, counters);
}

/// The photon-tracing visitor: a photon at every non-delta vertex of the light walk.
struct Deposit<'a> {
    keep: Keep,
    /// 1 / the number of photon paths of the map.
    scale: f32,
    photons: &'a mut Vec<Photon>,
    /// A caustic walk chose the delta lobe at the vertex last visited.
    delta_only: bool,
}

impl Visitor for Deposit<'_> {
    #[inline]
    fn vertex<S: Sampler>(
        &mut self,
        v: &PathVertex,
        _arrival: &Arrival,
        sampler: &mut S,
        counters: &mut Counters,
    ) -> bool {
        if v.delta {
            return true;
        }
        let power = v.beta * self.scale;
        if !power.is_finite() {
            counters.count_non_finite(Technique::Photon);
            return false;
        }
        let photon = Photon::new(v.p, v.wo, v.ng, power, v.class);
        match self.keep {
            Keep::All => {
                self.photons.push(photon);
                true
            }
            Keep::Caustic { through_glossy } => {
                let sb = v.sb.as_ref().expect("photons land on surfaces");
                let caustic_so_far = caustic_prefix(&v.class, v.class.len() - 1, through_glossy);
                if through_glossy && caustic_so_far && sb.bsdf.lobe_class() == LobeClass::Glossy {
                    // A glossy vertex continues the caustic path.
                    return true;
                }
                if caustic_so_far && v.class.len() >= 2 {
                    self.photons.push(photon);
                }
                // A caustic path may go on through a delta lobe mixed into this surface's BSDF
                // (plastic's coating): chosen with its probability P, so that the walk's weight,
                // which divides by P, keeps the estimate unbiased.
                self.delta_only = caustic_so_far
                    && sb.bsdf.mixes_delta()
                    && sampler.next_1d() < sb.delta_probability(v.wo);
                self.delta_only
            }
        }
    }

    #[inline]
    fn lobes(&mut self, _v: &PathVertex) -> Lobes {
        if std::mem::take(&mut self.delta_only) {
            Lobes::Delta
        } else {
            Lobes::All
        }
    }
}

/// Octahedral unit-vector encoding in two 16-bit signed-normalised components (Cigolle et al. 2014,
/// "A Survey of Efficient Representations for Independent Unit Vectors", §3.6).
mod octahedral {
    use glam::{Vec2, Vec3};

    pub fn encode(v: Vec3) -> u32 {
        let p = Vec2::new(v.x, v.y) / (v.x.abs() + v.y.abs() + v.z.abs());
        let p = if v.z < 0.0 {
            (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * Vec2::new(sign(p.x), sign(p.y))
        } else {
            p
        };
        let q = |x: f32| ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
        q(p.x) | (q(p.y) << 16)
    }

    pub fn decode(e: u32) -> Vec3 {
        let f = |b: u32| (b as u16 as i16) as f32 / 32767.0;
        let p = Vec2::new(f(e & 0xffff), f(e >> 16));
        let z = 1.0 - p.x.abs() - p.y.abs();
        let (x, y) = if z < 0.0 {
            ((1.0 - p.y.abs()) * sign(p.x), (1.0 - p.x.abs()) * sign(p.y))
        } else {
            (p.x, p.y)
        };
        Vec3::new(x, y, z).normalize()
    }

    fn sign(x: f32) -> f32 {
        if x >= 0.0 { 1.0 } else { -1.0 }
    }

    #[cfg(test)]
    mod tests {
        use super::*;
        use lightlab_samplers::warp::square_to_uniform_sphere;
        use lightlab_samplers::{Independent, Sampler};

        /// Round trips stay within 1e-4 rad everywhere, the poles and the octahedron's seams
        /// included.
        #[test]
        fn round_trip_error_is_below_1e_4_radians() {
            let mut s = Independent::new();
            s.start_pixel_sample(1, 0, 0);
            let special = [
                Vec3::X,
                -Vec3::X,
                Vec3::Y,
                -Vec3::Y,
                Vec3::Z,
                -Vec3::Z,
                Vec3::new(1.0, -1.0, -1e-7).normalize(),
            ];
            for v in special
                .into_iter()
                .chain((0..100_000).map(|_| square_to_uniform_sphere(s.next_2d())))
            {
                let d = decode(encode(v));
                // The chord, not acos of the dot product (which f32 cannot resolve near 1).
                let angle = 2.0 * ((v.as_dvec3() - d.as_dvec3()).length() / 2.0).asin();
                assert!(angle < 1e-4, "{v} → {d}: {angle} rad");
            }
        }
    }
}
