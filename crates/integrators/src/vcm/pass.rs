//! The light side of one VCM pass (Georgiev et al. 2012, Alg. 1): a light subpath per pixel,
//! stored once with each vertex's MIS quantities, serving as connection vertices for the camera
//! path of its pixel and — its non-delta surface vertices, indexed by a hash grid of the pass's
//! radius — as the photons every camera path merges with. The light vertex is the photon.
//!
//! Determinism: light path p of pass i draws from (seed, p, i) alone, and chunks of paths are
//! concatenated in path order, so a pass is bit-identical on any number of threads.

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

/// A light vertex a camera vertex can merge with: where it is, and its index in the pass.
#[derive(Clone, Copy, Debug)]
pub(super) struct Merge {
    p: Vec3,
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
    /// Every path's vertices, path after path.
    pub vertices: Vec<PathVertex>,
    /// Their MIS quantities.
    pub quantities: Vec<Quantities>,
    /// Path p is `vertices[starts[p]..starts[p + 1]]`.
    starts: Vec<u32>,
    /// The mergeable vertices (none without merging).
    pub grid: Option<HashGrid<Merge>>,
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
        struct Chunk {
            vertices: Vec<PathVertex>,
            quantities: Vec<Quantities>,
            lengths: Vec<u32>,
            counters: Counters,
        }
        let chunks: Vec<Chunk> = (0..paths.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut out = Chunk {
                    vertices: Vec::new(),
                    quantities: Vec::new(),
                    lengths: Vec::new(),
                    counters: Counters::default(),
                };
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
                        &mut out.counters,
                    );
                    let path = &out.vertices[start..];
                    let delta_light = path
                        .first()
                        .and_then(|v| v.light())
                        .is_some_and(|l| scene.lights[l as usize].is_delta());
                    techniques.subpath(path, true, delta_light, &mut out.quantities);
                    out.lengths.push(path.len() as u32);
                }
                out
            })
            .collect();
        let mut pass_out = LightPass {
            vertices: Vec::new(),
            quantities: Vec::new(),
            starts: vec![0],
            grid: None,
        };
        for c in chunks {
            counters.merge(&c.counters);
            let base = pass_out.vertices.len() as u32;
            let mut end = base;
            for len in c.lengths {
                end += len;
                pass_out.starts.push(end);
            }
            pass_out.vertices.extend(c.vertices);
            pass_out.quantities.extend(c.quantities);
        }
        if techniques.merge {
            let mergeable: Vec<Merge> = pass_out
                .vertices
                .iter()
                .enumerate()
                .filter(|(_, v)| techniques.merges_at(v))
                .map(|(i, v)| Merge {
                    p: v.p,
                    index: i as u32,
                })
                .collect();
            pass_out.grid = Some(HashGrid::new(&mergeable, radius));
        }
        pass_out
    }

    /// Light path `p`: its vertices and their quantities.
    pub fn path(&self, p: usize) -> (&[PathVertex], &[Quantities]) {
        let r = self.starts[p] as usize..self.starts[p + 1] as usize;
        (&self.vertices[r.clone()], &self.quantities[r])
    }

    /// Vertices stored for merging.
    pub fn mergeable(&self) -> usize {
        self.grid.as_ref().map_or(0, |g| g.len())
    }
}
