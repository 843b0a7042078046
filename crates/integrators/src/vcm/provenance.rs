//! VCM's outlier provenance and replay: a pixel sample is reproduced from (seed, pixel, pass)
//! alone by retracing that pass's light subpaths (every camera path of a pass merges with all of
//! them) and the pixel's camera subpath.

use super::{Pass, Vcm};
use crate::film::Film;
use crate::provenance::{Outlier, SplatSource};
use crate::render::Counters;
use lightlab_samplers::{Sampler, SamplerVisitor};
use lightlab_scene::Scene;
use std::collections::BTreeMap;

/// Logged outliers counted per technique: `s{S}t{T}` for connections, `m{S},{T}` for merges.
pub(super) fn count_by_technique(outliers: &[Outlier]) -> Vec<(String, u64)> {
    let mut per: BTreeMap<(bool, u32, u32), u64> = BTreeMap::new();
    for o in outliers {
        *per.entry((o.merge, o.s, o.t)).or_default() += 1;
    }
    per.into_iter()
        .map(|((merge, s, t), n)| {
            let name = if merge {
                format!("m{s},{t}")
            } else {
                format!("s{s}t{t}")
            };
            (name, n)
        })
        .collect()
}

impl Vcm {
    /// The splats larger (largest channel) than `factor` times the final mean of the pixel they
    /// land in, replayed for their provenance.
    pub(super) fn splat_outliers<'a>(
        &self,
        scene: &Scene,
        seed: u64,
        passes: u32,
        sources: impl Iterator<Item = &'a SplatSource>,
        film: &Film,
        factor: f32,
    ) -> Vec<Outlier> {
        let large: Vec<&SplatSource> = sources.filter(|s| s.is_outlier(film, factor)).collect();
        let requests: Vec<_> = large.iter().map(|s| (s.pixel, s.sample)).collect();
        let replayed = self.replay_all(scene, seed, passes, &requests);
        large
            .iter()
            .zip(replayed)
            .filter_map(|(src, contributions)| {
                let value = [src.value.r, src.value.g, src.value.b];
                let mut o = contributions.into_iter().find(|o| {
                    !o.merge && (o.s, o.t) == (src.s as u32, src.t as u32) && o.value == value
                })?;
                o.pixel_mean = film.mean(src.target as usize);
                Some(o)
            })
            .collect()
    }

    /// Every contribution of pass `index` to pixel `pixel` (x, y), recomputed from (seed, pixel,
    /// pass) alone: the deterministic replay of a logged outlier. `spp` is the render's passes
    /// (stratified samplers depend on it).
    pub fn replay(
        &self,
        scene: &Scene,
        seed: u64,
        spp: u32,
        pixel: (u32, u32),
        index: u64,
    ) -> Vec<Outlier> {
        self.replay_all(scene, seed, spp, &[(pixel, index)])
            .pop()
            .unwrap_or_default()
    }

    /// [`Vcm::replay`] of each (pixel, pass) of `requests`, tracing each pass's light side once.
    fn replay_all(
        &self,
        scene: &Scene,
        seed: u64,
        spp: u32,
        requests: &[((u32, u32), u64)],
    ) -> Vec<Vec<Outlier>> {
        struct Replay<'a> {
            vcm: &'a Vcm,
            scene: &'a Scene,
            seed: u64,
            requests: &'a [((u32, u32), u64)],
        }
        impl SamplerVisitor for Replay<'_> {
            type Output = Vec<Vec<Outlier>>;
            fn visit<S: Sampler + Clone + Send + Sync + 'static>(
                self,
                sampler: S,
            ) -> Vec<Vec<Outlier>> {
                let mut out = vec![Vec::new(); self.requests.len()];
                let mut order: Vec<usize> = (0..self.requests.len()).collect();
                order.sort_by_key(|&i| self.requests[i].1);
                let mut pass: Option<(u64, Pass)> = None;
                let (mut camera, mut quantities) = (Vec::new(), Vec::new());
                let mut counters = Counters::default();
                for i in order {
                    let (pixel, index) = self.requests[i];
                    if pass.as_ref().is_none_or(|(p, _)| *p != index) {
                        let light =
                            self.vcm
                                .pass(self.scene, self.seed, index as u32, &mut counters);
                        pass = Some((index, light));
                    }
                    let (_, light) = pass.as_ref().expect("traced above");
                    self.vcm.pixel_sample(
                        self.scene,
                        self.seed,
                        pixel,
                        index,
                        sampler.clone(),
                        light,
                        (&mut camera, &mut quantities),
                        &mut counters,
                        |_, _, c, light, camera| {
                            out[i].push(Outlier::logged(
                                pixel,
                                index,
                                c,
                                [0.0; 3],
                                light.iter().chain(camera.iter().rev()),
                            ))
                        },
                    );
                }
                out
            }
        }
        self.config.sampler.dispatch(
            spp,
            Replay {
                vcm: self,
                scene,
                seed,
                requests,
            },
        )
    }
}
