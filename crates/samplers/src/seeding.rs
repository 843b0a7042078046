//! Hash-based seeding so that random streams depend on what is being sampled, not on who samples it.

use rand::SeedableRng;
use rand_pcg::Pcg32;

/// SplitMix64 finaliser (Steele et al. 2014): a bijective 64-bit mixer with full avalanche.
#[inline]
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hashes a sequence of keys into one 64-bit value (chained SplitMix64).
#[inline]
pub fn hash_u64s(keys: &[u64]) -> u64 {
    keys.iter()
        .fold(0x6A09_E667_F3BC_C909, |h, &k| hash_step(h, k))
}

/// One link of [`hash_u64s`]'s chain: `hash_step(hash_u64s(&[a, b]), c) == hash_u64s(&[a, b, c])`,
/// so a prefix such as (seed, pixel) is hashed once and extended per dimension.
#[inline]
pub fn hash_step(h: u64, key: u64) -> u64 {
    splitmix64(h ^ splitmix64(key))
}

/// The PCG stream of one (seed, pixel, sample) triple. Distinct triples get unrelated states; we do not
/// use PCG stream selection, whose streams may be correlated (rand_pcg documentation).
#[inline]
pub fn pixel_stream(seed: u64, pixel: u64, sample: u64) -> Pcg32 {
    Pcg32::seed_from_u64(hash_u64s(&[seed, pixel, sample]))
}
