//! Outlier provenance: large and non-finite contributions logged with where they came from, and
//! the deterministic replay of any pixel sample from (seed, pixel, sample index).

use super::connect::{Contribution, joined_class};
use super::{Bdpt, WorkItem};
use crate::film::Film;
use crate::provenance::Outlier;
use crate::render::Counters;
use crate::walk::PathVertex;
use lightlab_core::Rgb;
use lightlab_samplers::{Independent, Sampler, SamplerVisitor};
use lightlab_scene::Scene;

/// Pixel samples before which no contribution is called an outlier (the running mean is too
/// uncertain before).
pub(super) const OUTLIER_MIN_SAMPLES: u64 = 8;

impl Outlier {
    pub(super) fn new(
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
pub(super) struct SplatSource {
    /// The pixel it lands in.
    pub target: u32,
    /// Its value.
    pub value: Rgb,
    /// The pixel sample that made it: pixel and sample index.
    pub pixel: (u32, u32),
    pub sample: u64,
    /// Its strategy.
    pub s: u16,
    pub t: u16,
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
