//! Owen-scrambled Sobol' sampling with per-pixel padding (Burley 2020, "Practical Hash-based Owen
//! Scrambling", JCGT 9(4), §4 "shuffled scrambled Sobol'"; Sobol' 1967; Owen 1995; the same idea
//! underlies Cycles' and pbrt-v4's padded/Z-Sobol samplers).
//!
//! **Method.** Only the first two Sobol' dimensions are used: together they form a (0, 2)-sequence
//! in base 2, every aligned block of 2ᵐ indices a (0, m, 2)-net (one point in every elementary
//! interval of area 2⁻ᵐ). Each 2D pair of a sample, keyed by (seed, pixel, first dimension number
//! d), gets three independent 32-bit seeds from a hash:
//!
//! 1. the sample index is shuffled by a nested uniform scramble ([`owen_scramble_base2`] applied to
//!    the index, Burley 2020 §4), which maps the first 2ᵏ indices onto one aligned block of 2ᵏ for
//!    every k, so every prefix of a pixel's samples stays a (0, k, 2)-net, while different pairs
//!    visit the points in unrelated orders ("padding": no correlation between pairs);
//! 2. the two coordinates [`sobol_0`] and [`sobol_1`] of the shuffled index are Owen-scrambled
//!    with independent seeds, which keeps the net property and makes each point uniform.
//!
//! A 1D dimension is the scrambled dimension 0 of its own shuffled index: every prefix of 2ᵏ
//! samples has one value in each of 2ᵏ strata. Scrambled (0, m, 2)-nets give MSE
//! O(N⁻³ (log N)) for smooth integrands (Owen 1997).
//!
//! **Dimension layout.** `next_1d` consumes one dimension number and `next_2d` two, matching the
//! path tracer's layout (0–1 pixel position, 2–3 lens, then 1D, 2D, 1D, 2D, 1D per bounce); there is
//! no dimension limit. Best with spp a power of two (each pass of 2ᵏ is then a full net).
//!
//! **Sample indices** below 2³² index the sequence directly; the bits above are hashed into the
//! per-pixel key, so index i + 2³² starts an independently scrambled sequence.
//!
//! **Determinism.** Every value is a function of (seed, pixel, sample index, dimension) alone.

use crate::lowdiscrepancy::{bits_to_unit, owen_scramble_base2, sobol_0, sobol_1};
use crate::{Sampler, hash_step, hash_u64s, splitmix64};
use glam::Vec2;

/// Shuffled, Owen-scrambled Sobol' (0, 2)-sequence per pixel and dimension pair; see the
/// [module docs](self).
#[derive(Clone, Debug)]
pub struct Sobol {
    spp: u32,
    /// hash(seed, pixel, sample index ≫ 32), extended by the dimension number.
    key: u64,
    index: u32,
    dim: u32,
}

impl Sobol {
    /// A sampler for `spp` samples per pixel (0 is taken as 1). The sequence is progressive, so
    /// `spp` only documents the budget; powers of two give complete nets.
    pub fn new(spp: u32) -> Self {
        Sobol {
            spp: spp.max(1),
            key: 0,
            index: 0,
            dim: 0,
        }
    }

    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// The hash of dimension `d`'s pair and the shuffled sample index it selects.
    #[inline]
    fn shuffled(&self, d: u32) -> (u64, u32) {
        let h = hash_step(self.key, d as u64);
        (h, owen_scramble_base2(self.index, h as u32))
    }
}

impl Sampler for Sobol {
    #[inline]
    fn start_pixel_sample(&mut self, seed: u64, pixel: u64, sample_index: u64) {
        self.key = hash_u64s(&[seed, pixel, sample_index >> 32]);
        self.index = sample_index as u32;
        self.dim = 0;
    }

    #[inline]
    fn next_1d(&mut self) -> f32 {
        let (h, i) = self.shuffled(self.dim);
        self.dim += 1;
        bits_to_unit(owen_scramble_base2(sobol_0(i), (h >> 32) as u32))
    }

    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let (h, i) = self.shuffled(self.dim);
        self.dim += 2;
        Vec2::new(
            bits_to_unit(owen_scramble_base2(sobol_0(i), (h >> 32) as u32)),
            bits_to_unit(owen_scramble_base2(sobol_1(i), splitmix64(h) as u32)),
        )
    }
}
