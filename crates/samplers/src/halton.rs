//! The Halton sequence (Halton 1964, "Algorithm 247: Radical-inverse quasi-random point sequence",
//! CACM 7(12)) randomised by Owen scrambling (Owen 1995, "Randomly Permuted (t,m,s)-Nets and
//! (t,s)-Sequences"; pbrt-v4 §8.6.3 `OwenScrambledRadicalInverse`, with pbrt-v4 §8.6 for the
//! sampler).
//!
//! **Method.** Dimension d of sample i is the radical inverse of i in the d-th prime base b_d
//! ([`PRIMES`]: 2, 3, 5, …), its digits scrambled by nested random permutations keyed by
//! (seed, pixel, d) ([`owen_scrambled_radical_inverse`]). Scrambling keeps the sequence's
//! stratification — the first 2^a · 3^c points of dimensions 0 and 1 (bases 2 and 3) put one point
//! in every box of 2^−a × 3^−c — and makes every point uniformly distributed, so the estimator is
//! unbiased.
//!
//! **Pixels.** Unlike pbrt-v4, which maps the image plane into the first two dimensions of one
//! sequence, every pixel here runs its own independently scrambled copy of the sequence with the
//! sample index as the sequence index: simpler, the same quality per pixel, no correlation between
//! pixels, and any image size or sample count. The cost is one hash and one affine digit
//! permutation per digit (16 digits in base 3, 2 in base 8161; base 2 takes Burley's one-step
//! hash scramble), each digit's hash keyed by the digits before it, so the digits are computed one
//! after another. Path tracing the Cornell box takes about 2.1× the time it takes with
//! [`Independent`](crate::Independent), against 1.1–1.3× with [`Sobol`](crate::Sobol),
//! [`Stratified`](crate::Stratified) and [`LatinHypercube`](crate::LatinHypercube)
//! (BENCHMARKS.md, "Samplers' cost").
//!
//! **Dimension layout.** `next_1d` consumes one dimension (one prime base) and `next_2d` two,
//! matching the path tracer's layout (0–1 pixel position in bases 2 and 3, 2–3 lens in bases 5 and
//! 7, then 1D, 2D, 1D, 2D, 1D per bounce). Dimensions from [`NUM_PRIMES`] = 1024 on (about 145
//! bounces) are independent uniform values hashed from (seed, pixel, sample index, dimension).
//!
//! **Sample indices.** The first 2²⁴ samples of a pixel are indices 0 … 2²⁴ − 1 of its sequence
//! (in base 2 an f32 resolves no more: i and i + 2²⁴ would give the same value); the bits above
//! are hashed into the scramble key, so every further block of 2²⁴ is an independently scrambled
//! sequence.
//!
//! **Determinism.** Every value is a function of (seed, pixel, sample index, dimension) alone.

use crate::lowdiscrepancy::{
    NUM_PRIMES, PRIMES, bits_to_unit, owen_scramble_base2, owen_scrambled_radical_inverse, sobol_0,
};
use crate::{Sampler, hash_step, hash_u64s};
use glam::Vec2;

const SCRAMBLE_TAG: u64 = 0x6861_6c74_6f6e_2121;
const FALLBACK_TAG: u64 = 0x6661_6c6c_6261_636b;

/// Owen-scrambled Halton sequence, one scramble per pixel; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct Halton {
    spp: u32,
    /// hash(seed, pixel, tag, sample index ≫ 24): extended by the dimension to give that
    /// dimension's scramble.
    scramble_key: u64,
    /// hash(seed, pixel, tag, sample index): values beyond the dimension limit.
    fallback_key: u64,
    index: u64,
    dim: u32,
}

impl Halton {
    /// A sampler for `spp` samples per pixel (0 is taken as 1). The sequence is progressive, so
    /// `spp` only documents the budget; strata are complete at spp = 2^a · 3^c in dimensions 0–1.
    pub fn new(spp: u32) -> Self {
        Halton {
            spp: spp.max(1),
            scramble_key: 0,
            fallback_key: 0,
            index: 0,
            dim: 0,
        }
    }

    pub fn spp(&self) -> u32 {
        self.spp
    }

    #[inline]
    fn value(&self, d: u32) -> f32 {
        match PRIMES.get(d as usize) {
            // Base 2: the radical inverse is the bit reversal, and Burley's hash scramble a nested
            // uniform scramble in one step instead of 24 digits (as for Sobol's dimension 0).
            Some(2) => bits_to_unit(owen_scramble_base2(
                sobol_0(self.index as u32),
                hash_step(self.scramble_key, d as u64) as u32,
            )),
            Some(&base) => owen_scrambled_radical_inverse(
                self.index,
                base,
                hash_step(self.scramble_key, d as u64),
            ),
            None => bits_to_unit((hash_step(self.fallback_key, d as u64) >> 32) as u32),
        }
    }
}

impl Sampler for Halton {
    #[inline]
    fn start_pixel_sample(&mut self, seed: u64, pixel: u64, sample_index: u64) {
        self.scramble_key = hash_u64s(&[seed, pixel, SCRAMBLE_TAG, sample_index >> 24]);
        self.fallback_key = hash_u64s(&[seed, pixel, FALLBACK_TAG, sample_index]);
        self.index = sample_index & ((1 << 24) - 1);
        self.dim = 0;
    }

    #[inline]
    fn next_1d(&mut self) -> f32 {
        let x = self.value(self.dim);
        self.dim += 1;
        x
    }

    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

const _: () = assert!(NUM_PRIMES >= 1000);
