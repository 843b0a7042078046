//! Independent replicates of a randomised sampler: randomised quasi-Monte Carlo with a variance
//! estimate (Owen 1997, "Monte Carlo variance of scrambled net quadrature", SIAM J. Numer. Anal.
//! 34(5); L'Ecuyer & Lemieux 2002, "Recent advances in randomized quasi-Monte Carlo methods", §2).
//!
//! A pixel's N samples are split into R replicates of N/R, each an independent randomisation of
//! the sampler (its own seed: a fresh scramble, permutation or jitter), so the R replicate means
//! are independent and identically distributed whatever the sampler, and s²/R over them is an
//! unbiased estimate of the variance of their mean, with R − 1 degrees of freedom. Within a
//! replicate the samples keep the sampler's stratification. Sample index i belongs to replicate
//! i mod R as its sample i div R, so the first kR indices hold k samples of every replicate: a
//! render stopped after any multiple of R samples has equal replicates.

use crate::hash_u64s;

/// Seed word of the replicates' seeds.
const REPLICATE_TAG: u64 = 0x52e1_c7a4_0b93_d65f;

/// Where sample `index` of a render with `seed` comes from when its samples are split into
/// `replicates` independent replicates: (the seed of its replicate, its index within it).
/// One replicate (or none, 0) is the sampler itself: `(seed, index)`.
#[inline]
pub fn replicate_sample(seed: u64, index: u64, replicates: u32) -> (u64, u64) {
    if replicates <= 1 {
        return (seed, index);
    }
    let r = replicates as u64;
    (hash_u64s(&[seed, REPLICATE_TAG, index % r]), index / r)
}

#[cfg(test)]
mod tests {
    use super::replicate_sample;
    use std::collections::HashSet;

    /// One replicate is the sampler itself; with R, the first kR indices give every replicate its
    /// samples 0 … k − 1, each (seed, index) once, under R distinct seeds.
    #[test]
    fn indices_are_dealt_to_replicates_in_turn() {
        assert_eq!(replicate_sample(5, 77, 1), (5, 77));
        assert_eq!(replicate_sample(5, 77, 0), (5, 77));
        let (r, k) = (8u64, 16u64);
        let pairs: Vec<(u64, u64)> = (0..r * k)
            .map(|i| replicate_sample(5, i, r as u32))
            .collect();
        let seeds: HashSet<u64> = pairs.iter().map(|p| p.0).collect();
        assert_eq!(seeds.len(), r as usize);
        assert!(!seeds.contains(&5));
        for seed in seeds {
            let mut within: Vec<u64> = pairs.iter().filter(|p| p.0 == seed).map(|p| p.1).collect();
            within.sort();
            assert_eq!(within, (0..k).collect::<Vec<_>>());
        }
        // Another seed, other replicates.
        assert_ne!(replicate_sample(6, 0, 8).0, replicate_sample(5, 0, 8).0);
    }
}
