//! Latin hypercube sampling (McKay, Beckman and Conover 1979, "A Comparison of Three Methods for
//! Selecting Values of Input Variables in the Analysis of Output from a Computer Code",
//! Technometrics 21(2); "N-rooks" in Shirley 1991; pbrt-v3 §7.3 `LatinHypercube`).
//!
//! **Method.** Every dimension d is cut into `spp` strata; sample i of a pixel lies in stratum
//! π_d(i), uniformly jittered inside it, where π_d is a permutation of {0, …, spp−1} chosen by a
//! hash of (seed, pixel, pass, d) ([`permutation_element`], Kensler 2013). Every 1D projection is
//! stratified however many dimensions there are, but 2D pairs are not (the integrand's additive part
//! converges fast, its interactions at the plain Monte Carlo rate: Stein 1987).
//!
//! **Dimension layout.** `next_1d` consumes one dimension number and `next_2d` two, each coordinate
//! an independent Latin hypercube dimension, matching the path tracer's layout (0–1 pixel
//! position, 2–3 lens, then 1D, 2D, 1D, 2D, 1D per bounce); there is no dimension limit.
//!
//! **Sample indices beyond spp** start a fresh pass of spp samples (index i is sample i mod spp of
//! pass ⌊i / spp⌋), as for [`Stratified`](crate::Stratified).
//!
//! **Determinism.** Every value is a function of (seed, pixel, sample index, dimension) alone.

use crate::Sampler;
use crate::lowdiscrepancy::{permutation_element, stratum_value};
use crate::stratified::StrataKeys;
use glam::Vec2;

/// Latin hypercube sampling with `spp` strata per dimension; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct LatinHypercube {
    spp: u32,
    keys: StrataKeys,
    dim: u32,
}

impl LatinHypercube {
    /// A sampler for `spp` samples per pixel (0 is taken as 1).
    pub fn new(spp: u32) -> Self {
        LatinHypercube {
            spp: spp.max(1),
            keys: StrataKeys::default(),
            dim: 0,
        }
    }

    pub fn spp(&self) -> u32 {
        self.spp
    }
}

impl Sampler for LatinHypercube {
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
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}
