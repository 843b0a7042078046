//! Jittered (stratified) sampling: one uniform point in each cell of a regular grid, the cells
//! visited in a pseudo-random order (Cook 1986, "Stochastic Sampling in Computer Graphics", ACM TOG
//! 5(1); Mitchell 1996 for its convergence, MSE O(N^(−1−2/d)) for smooth integrands in d
//! dimensions; pbrt-v4 §8.5 `StratifiedSampler`).
//!
//! **Strata.** With `spp` samples per pixel, a 1D dimension is split into `spp` strata and a 2D
//! dimension pair into an nx × ny grid with nx · ny = spp, the most square factorisation
//! (ny = the largest divisor of spp not above √spp, nx = spp / ny ≥ ny). When that grid leaves y
//! unstratified (ny = 1: a prime spp) or is elongated (nx > 4 ny, e.g. 22 = 11 × 2), the pair
//! falls back to N-rooks sampling (Shirley 1991, "Discrepancy as a Quality Measure for
//! Sample Distributions"): spp strata along x and spp along y, matched by two independent
//! permutations, so both projections stay stratified though 2D cells are not.
//!
//! **Decorrelation.** Sample i of a pixel takes stratum π_d(i) in dimension d, where π_d is a
//! permutation of {0, …, spp−1} chosen by a hash of (seed, pixel, pass, d) and evaluated without a
//! table ([`permutation_element`], Kensler 2013); the jitter inside the stratum hashes
//! (seed, pixel, sample index, d). Independent permutations per dimension keep dimensions from
//! pairing stratum k with stratum k, which would correlate them (pbrt-v4 §8.5 does the same with
//! its own hashing). In 1D this is the same as [`LatinHypercube`](crate::LatinHypercube).
//!
//! **Dimension layout.** `next_1d` consumes one dimension number, `next_2d` two (the pair d, d + 1
//! gets one grid, keyed by d), matching the path tracer's layout (0–1 pixel position, 2–3 lens,
//! then 1D, 2D, 1D, 2D, 1D per bounce); there is no dimension limit.
//!
//! **Sample indices beyond spp.** Index i belongs to pass ⌊i / spp⌋ and is sample i mod spp of a
//! fresh, independently permuted and jittered set of spp, so progressive rendering past the
//! budget stays unbiased (and stratified per pass).
//!
//! **Determinism.** Every value is a function of (seed, pixel, sample index, dimension) alone.

use crate::lowdiscrepancy::{permutation_element, stratum_value};
use crate::{Sampler, hash_step, hash_u64s};
use glam::Vec2;

/// Keys that separate the hash used for permutations from the one used for jitter.
pub(crate) const PERMUTATION_TAG: u64 = 0x7065_726d_7574_6521;
pub(crate) const JITTER_TAG: u64 = 0x6a69_7474_6572_2121;

/// Per-sample hash state shared by [`Stratified`] and [`LatinHypercube`](crate::LatinHypercube):
/// the index within the pass, the key of the pass's permutations and the key of this sample's
/// jitter.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct StrataKeys {
    pub index: u32,
    pub permutation: u64,
    pub jitter: u64,
}

impl StrataKeys {
    #[inline]
    pub fn new(spp: u32, seed: u64, pixel: u64, sample_index: u64) -> Self {
        let pixel_key = hash_u64s(&[seed, pixel]);
        let pass = sample_index / spp as u64;
        StrataKeys {
            index: (sample_index % spp as u64) as u32,
            permutation: hash_step(hash_step(pixel_key, PERMUTATION_TAG), pass),
            jitter: hash_step(hash_step(pixel_key, JITTER_TAG), sample_index),
        }
    }

    /// Permutation key of dimension d (32 bits for Kensler's permute) and 64 jitter bits.
    #[inline]
    pub fn dimension(&self, d: u32) -> (u64, u64) {
        (
            hash_step(self.permutation, d as u64),
            hash_step(self.jitter, d as u64),
        )
    }
}

/// Jittered sampling with `spp` strata per 1D dimension and an nx × ny grid per 2D pair (N-rooks
/// when spp has no factorisation with 2 ≤ ny and nx ≤ 4 ny); see the [module docs](self).
#[derive(Clone, Debug)]
pub struct Stratified {
    spp: u32,
    nx: u32,
    ny: u32,
    rooks: bool,
    keys: StrataKeys,
    dim: u32,
}

impl Stratified {
    /// A sampler for `spp` samples per pixel (0 is taken as 1).
    pub fn new(spp: u32) -> Self {
        let spp = spp.max(1);
        let mut ny = spp.isqrt();
        while !spp.is_multiple_of(ny) {
            ny -= 1;
        }
        let nx = spp / ny;
        let rooks = spp > 1 && (ny == 1 || nx > 4 * ny);
        let (nx, ny) = if rooks { (spp, spp) } else { (nx, ny) };
        Stratified {
            spp,
            nx,
            ny,
            rooks,
            keys: StrataKeys::default(),
            dim: 0,
        }
    }

    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Strata of a 2D pair along x and y: (nx, ny) with nx · ny = spp for a grid, (spp, spp) for
    /// the N-rooks fallback.
    pub fn grid(&self) -> (u32, u32) {
        (self.nx, self.ny)
    }

    /// Whether 2D pairs use N-rooks instead of a grid (spp > 1 has no factorisation with
    /// 2 ≤ ny ≤ nx ≤ 4 ny).
    pub fn is_n_rooks(&self) -> bool {
        self.rooks
    }
}

impl Sampler for Stratified {
    #[inline]
    fn start_pixel_sample(&mut self, seed: u64, pixel: u64, sample_index: u64) {
        self.keys = StrataKeys::new(self.spp, seed, pixel, sample_index);
        self.dim = 0;
    }

    #[inline]
    fn next_1d(&mut self) -> f32 {
        let (p, j) = self.keys.dimension(self.dim);
        self.dim += 1;
        let stratum = permutation_element(self.keys.index, self.spp, p as u32);
        stratum_value(stratum, self.spp, (j >> 40) as u32)
    }

    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let (p, j) = self.keys.dimension(self.dim);
        self.dim += 2;
        let i = self.keys.index;
        let (sx, sy) = if self.rooks {
            (
                permutation_element(i, self.spp, p as u32),
                permutation_element(i, self.spp, (p >> 32) as u32),
            )
        } else {
            let s = permutation_element(i, self.spp, p as u32);
            if self.nx.is_power_of_two() {
                (s & (self.nx - 1), s >> self.nx.trailing_zeros())
            } else {
                (s % self.nx, s / self.nx)
            }
        };
        Vec2::new(
            stratum_value(sx, self.nx, (j >> 40) as u32),
            stratum_value(sy, self.ny, ((j >> 8) & 0xff_ffff) as u32),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_the_most_square_factorisation() {
        let grid = |spp| {
            let s = Stratified::new(spp);
            (s.grid(), s.is_n_rooks())
        };
        assert_eq!(grid(1), ((1, 1), false));
        assert_eq!(grid(2), ((2, 2), true));
        assert_eq!(grid(3), ((3, 3), true));
        assert_eq!(grid(4), ((2, 2), false));
        assert_eq!(grid(5), ((5, 5), true));
        assert_eq!(grid(8), ((4, 2), false));
        assert_eq!(grid(12), ((4, 3), false));
        assert_eq!(grid(16), ((4, 4), false));
        assert_eq!(grid(22), ((22, 22), true));
        assert_eq!(grid(256), ((16, 16), false));
        assert_eq!(grid(0), ((1, 1), false));
    }
}
