//! Outlier provenance: large and non-finite contributions logged with where they came from, and
//! the deterministic replay of any pixel sample from (seed, pixel, sample index).

use super::connect::{Contribution, joined_class};
use super::{Bdpt, WorkItem};
use crate::film::Film;
use crate::provenance::{Logged, Outlier};
use crate::render::Counters;
use crate::walk::PathVertex;
use lightlab_samplers::{Independent, Sampler, SamplerVisitor};
use lightlab_scene::Scene;

impl Outlier {
    pub(super) fn new(
        pixel: (u32, u32),
        sample: u64,
        c: &Contribution,
        pixel_mean: [f64; 3],
        light: &[PathVertex],
        camera: &[PathVertex],
    ) -> Outlier {
        let logged = Logged {
            s: c.s,
            t: c.t,
            merge: false,
            class: joined_class(light, camera, c.s, c.t),
            unweighted: c.unweighted,
            weight: c.weight,
            raster: c.raster,
        };
        Outlier::logged(
            pixel,
            sample,
            &logged,
            pixel_mean,
            light.iter().chain(camera.iter().rev()),
        )
    }
}

impl Bdpt {
    /// The splats larger (largest channel) than `factor` times the final mean of the pixel they
    /// land in, replayed for their provenance.
    pub(super) fn splat_outliers(
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
                if !src.is_outlier(film, factor) {
                    continue;
                }
                let mean = film.mean(src.target as usize);
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
