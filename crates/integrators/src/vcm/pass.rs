//! The light side of one VCM pass (Georgiev et al. 2012, Alg. 1): a light subpath per pixel,
//! stored once with each vertex's MIS quantities, serving as connection vertices for the camera
//! path of its pixel and — its non-delta surface vertices, indexed by a hash grid of the pass's
//! radius — as the photons every camera path merges with. The light vertex is the photon.
//!
//! Determinism: light path p of pass i draws from (seed, p, i) alone, and the chunks of paths
//! are kept, and their mergeable vertices indexed, in path order, so a pass is bit-identical on
//! any number of threads. The chunks are not concatenated: copying every vertex once more was
//! the pass's largest serial step.

use super::mis::{Quantities, Techniques};
use crate::bdpt::light_subpath;
use crate::photon::grid::{HashGrid, Located};
use crate::render::Counters;
use crate::walk::{PathVertex, Walk};
use glam::Vec3;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;
use rayon::prelude::*;

/// Offset of the light subpaths' random-number streams from the camera's.
const LIGHT_STREAM: u64 = 0x7663_6d5f_6c69_6768;
/// Light paths per parallel work item.
const CHUNK: usize = 256;

/// A light vertex a camera vertex can merge with: where it is, its chunk and its index there.
#[derive(Clone, Copy, Debug)]
pub(super) struct Merge {
    p: Vec3,
    pub chunk: u32,
    pub index: u32,
}

impl Located for Merge {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// The light subpaths of one pass.
pub(super) struct LightPass {
    /// Paths `c · CHUNK ..` in chunk c.
    pub chunks: Vec<Chunk>,
    /// The mergeable vertices (none without merging).
    pub grid: Option<HashGrid<Merge>>,
}

/// Consecutive light paths, as one parallel work item traced them.
pub(super) struct Chunk {
    /// Every path's vertices, path after path.
    pub vertices: Vec<PathVertex>,
    /// Their MIS quantities.
    pub quantities: Vec<Quantities>,
    /// The chunk's path p is `vertices[starts[p]..starts[p + 1]]`.
    starts: Vec<u32>,
}

impl LightPass {
    /// Traces `paths` light subpaths of pass `pass` at instant `time` as `walk` says, with the
    /// MIS quantities of `techniques`, and indexes their mergeable vertices for gathers of
    /// `radius`.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        scene: &Scene,
        walk: &Walk,
        techniques: &Techniques,
        (seed, pass): (u64, u32),
        time: f32,
        paths: usize,
        radius: f32,
        counters: &mut Counters,
    ) -> LightPass {
        let traced: Vec<(Chunk, Vec<Merge>, Counters)> = (0..paths.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut out = Chunk {
                    vertices: Vec::new(),
                    quantities: Vec::new(),
                    starts: vec![0],
                };
                let mut counters = Counters::default();
                let mut sampler = Independent::new();
                for p in c * CHUNK..((c + 1) * CHUNK).min(paths) {
                    sampler.start_pixel_sample(seed ^ LIGHT_STREAM, p as u64, pass as u64);
                    let start = out.vertices.len();
                    light_subpath(
                        scene,
                        walk,
                        time,
                        &mut sampler,
                        &mut out.vertices,
                        &mut counters,
                    );
                    let path = &out.vertices[start..];
                    let delta_light = path
                        .first()
                        .and_then(|v| v.light())
                        .is_some_and(|l| scene.lights[l as usize].is_delta());
                    techniques.subpath(path, true, delta_light, &mut out.quantities);
                    out.starts.push(out.vertices.len() as u32);
                }
                let mergeable = if techniques.merge {
                    out.vertices
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| techniques.merges_at(v))
                        .map(|(i, v)| Merge {
                            p: v.p,
                            chunk: c as u32,
                            index: i as u32,
                        })
                        .collect()
                } else {
                    Vec::new()
                };
                (out, mergeable, counters)
            })
            .collect();
        let mut chunks = Vec::with_capacity(traced.len());
        let mut mergeable = Vec::new();
        for (chunk, merges, c) in traced {
            counters.merge(&c);
            chunks.push(chunk);
            mergeable.extend(merges);
        }
        LightPass {
            chunks,
            grid: techniques.merge.then(|| HashGrid::new(&mergeable, radius)),
        }
    }

    /// Light path `p`: its vertices and their quantities.
    pub fn path(&self, p: usize) -> (&[PathVertex], &[Quantities]) {
        let c = &self.chunks[p / CHUNK];
        let r = c.starts[p % CHUNK] as usize..c.starts[p % CHUNK + 1] as usize;
        (&c.vertices[r.clone()], &c.quantities[r])
    }

    /// Vertices stored for merging.
    pub fn mergeable(&self) -> usize {
        self.grid.as_ref().map_or(0, |g| g.len())
    }
}
