//! Building blocks of the stratified and low-discrepancy samplers, all table-free and hash-driven so
//! that a value depends only on its inputs:
//!
//! - [`permutation_element`]: element i of a pseudo-random permutation of {0, …, n−1} chosen by a
//!   32-bit key, without building the permutation (Kensler 2013, "Correlated Multi-Jittered
//!   Sampling", Pixar TM 13-01, `permute`; pbrt-v4 `PermutationElement`).
//! - [`owen_scramble_base2`]: hash-based nested uniform (Owen) scrambling of a 32-bit binary
//!   fraction (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4), §3), with the
//!   improved Laine–Karras-style hash of Vegdahl 2021 ("Building a Better LK Hash", psychopath.io),
//!   as pbrt-v4's `FastOwenScrambler` and Cycles use.
//! - [`sobol_0`], [`sobol_1`]: the first two dimensions of the Sobol' sequence (Sobol' 1967), a
//!   (0, 2)-sequence in base 2; together they are all a padded 2D sampler needs (Burley 2020, §4).
//! - [`owen_scrambled_radical_inverse`]: Owen-scrambled radical inverse in any prime base
//!   (Owen 1995; pbrt-v4 §8.6.3 `OwenScrambledRadicalInverse`) with affine digit permutations,
//!   for the Halton sequence (Halton 1964), with [`PRIMES`] as the bases.

use crate::seeding::splitmix64;

/// Element `i` of a pseudo-random permutation of {0, …, n−1} selected by `key`: a bijective hash on
/// the smallest power-of-two domain ≥ n, cycle-walked until it lands below n (Kensler 2013, §4;
/// at most two walks on average). `i < n`, `1 ≤ n ≤ 2²⁷` (Kensler's stated range).
#[inline]
pub fn permutation_element(mut i: u32, n: u32, key: u32) -> u32 {
    debug_assert!(i < n, "permutation_element: {i} ≥ {n}");
    let p = key;
    // Mask of the smallest power-of-two domain holding n − 1.
    let w = if n <= 1 {
        0
    } else {
        u32::MAX >> (n - 1).leading_zeros()
    };
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            // (i + p) mod n; for n = 2ᵏ the low k bits of the wrapped sum are the same number.
            return if n.is_power_of_two() {
                i.wrapping_add(p) & (n - 1)
            } else {
                ((i as u64 + p as u64) % n as u64) as u32
            };
        }
    }
}

/// Nested uniform (Owen) scrambling of the binary fraction `x · 2⁻³²`: each bit is flipped or not
/// depending on the bits above it and `seed` (Burley 2020, Listing 2 `nested_uniform_scramble`, with
/// Vegdahl's hash). In reversed order every step of the hash only lets lower bits influence higher
/// ones (multiplication by an even constant, addition, multiplication by an odd one), which is
/// exactly Owen's tree structure read from the most significant bit.
///
/// Applied to an index instead of a value it is Burley's index shuffle: indices that agree above
/// bit k keep agreeing above bit k, so the first 2ᵏ indices map to one aligned block of 2ᵏ.
#[inline]
pub fn owen_scramble_base2(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits();
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v.reverse_bits()
}

/// Sobol' dimension 0 as a 32-bit fraction: the base-2 radical inverse (van der Corput), whose
/// generator matrix is the identity.
#[inline]
pub fn sobol_0(i: u32) -> u32 {
    i.reverse_bits()
}

/// Sobol' dimension 1 as a 32-bit fraction (primitive polynomial x + 1): direction numbers
/// v₀ = 2³¹, v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1), i.e. the upper-triangular Pascal matrix mod 2.
/// With [`sobol_0`] it forms a (0, 2)-sequence: every aligned block of 2ᵐ indices is a (0, m, 2)-net.
///
/// Computed without a loop over the bits of `i`: by Lucas' theorem C(k, r) is odd exactly when the
/// bits of r are a subset of those of k, so bit 31 − r of the result is the parity of the set bits k
/// of `i` with k ⊇ r. That is the superset-sum (zeta) transform mod 2 over the 5-bit bit positions,
/// five shift-and-xor steps on the packed bits, then read from the top bit down. (The loop
/// x ⊕= v_k over the set bits of i, whose trip count varies with i, cost a sixth of a
/// Sobol'-sampled path's time, mostly in mispredicted loop exits: BENCHMARKS.md.)
#[inline]
pub fn sobol_1(i: u32) -> u32 {
    let mut f = i;
    // Step b: every position r without bit b takes the xor of position r + 2ᵇ.
    f ^= (f >> 1) & 0x5555_5555;
    f ^= (f >> 2) & 0x3333_3333;
    f ^= (f >> 4) & 0x0f0f_0f0f;
    f ^= (f >> 8) & 0x00ff_00ff;
    f ^= f >> 16;
    f.reverse_bits()
}

/// Number of prime bases the Halton sampler uses ([`PRIMES`]).
pub const NUM_PRIMES: usize = 1024;

/// The first [`NUM_PRIMES`] primes (2, 3, 5, …, 8161), computed at compile time.
pub const PRIMES: [u32; NUM_PRIMES] = first_primes();

const fn first_primes<const N: usize>() -> [u32; N] {
    let mut primes = [0u32; N];
    let (mut count, mut candidate) = (0, 2u32);
    while count < N {
        let mut k = 0;
        let mut is_prime = true;
        while k < count && primes[k] * primes[k] <= candidate {
            if candidate.is_multiple_of(primes[k]) {
                is_prime = false;
                break;
            }
            k += 1;
        }
        if is_prime {
            primes[count] = candidate;
            count += 1;
        }
        candidate += 1;
    }
    primes
}

/// Owen-scrambled radical inverse of `a` in the prime `base` (Owen 1995; pbrt-v4 §8.6.3
/// `OwenScrambledRadicalInverse`): digit k of `a` (least significant first) becomes digit k after
/// the radix point, permuted by a permutation chosen by `key` and by the node of the digit tree —
/// the depth and the digits already written — so the scramble is nested. pbrt keys the node by the
/// written digits alone, which gives all-zero prefixes of different depths the same permutation
/// (index 0 then maps to exactly 0 with probability 1/b); here the key is `scale + reversed`,
/// unique because `reversed < scale`.
///
/// **Permutations.** Each node applies an affine map d ↦ (m·d + c) mod b with m ∈ [1, b) and
/// c ∈ [0, b) uniform (from one hash by multiply-shift range reduction, bias ≤ b · 2⁻³²) instead
/// of a uniformly random permutation (pbrt: [`permutation_element`], with which the Halton sampler
/// took 2.3× as long: 4.4 against 1.9 µs for a 25-dimension path sample, measured). For prime b
/// these maps are sharply 2-transitive: one digit's image is uniform, two distinct digits' images a uniform pair
/// of distinct digits. Under nested scrambling two points share the permutations down to the
/// first digit where they differ and draw independent ones below it, so every pair of points has
/// the same joint distribution as with uniform permutations; the estimator's variance, a sum over
/// pairs (Owen 1997, "Monte Carlo Variance of Scrambled Net Quadrature", SIAM J. Numer. Anal.
/// 34(5)), is therefore that of full Owen scrambling, and stratification holds for any bijection.
///
/// **Precision.** Digits are produced until the resolution is at least 2⁻²⁴, the precision of the
/// result, so the trailing zero digits of `a` are scrambled too (otherwise every point would sit
/// on a coarse grid). The result lies on a grid of spacing ≤ 2⁻²⁴ (truncation, mean bias ≤ 2⁻²⁵).
/// Boundaries j / bᵈ are not f32 numbers for odd bases, so rounding could move a point just above
/// one into the box below; the result is therefore kept inside its box at the deepest depth D with
/// bᴰ ≤ 2²² (boxes at least 4 f32 ulps wide, which contain every shallower box): floor(x · bᵈ) is
/// the point's exact digit prefix for every d ≤ D, so Halton's stratification survives.
pub fn owen_scrambled_radical_inverse(mut a: u64, base: u32, key: u64) -> f32 {
    let b = base as u64;
    let (mut reversed, mut scale) = (0u64, 1u64);
    let (mut box_index, mut box_scale) = (0u64, 1u64);
    while scale < 1 << 24 {
        let digit = a % b;
        a /= b;
        let h = splitmix64(key ^ (scale + reversed));
        let m = 1 + (((h as u32) as u64 * (b - 1)) >> 32);
        let c = ((h >> 32) * b) >> 32;
        reversed = reversed * b + (m * digit + c) % b;
        scale *= b;
        if scale <= 1 << 22 {
            (box_index, box_scale) = (reversed, scale);
        }
    }
    let x = round_down_f32(reversed as f64 / scale as f64);
    // x · bᴰ is exact in f64 (24-bit mantissa times bᴰ ≤ 2²²); see `stratum_value` for next_up.
    if (x as f64) * (box_scale as f64) < box_index as f64 {
        x.next_up()
    } else {
        x
    }
}

/// The top 24 bits of a 32-bit fraction as an f32 in [0, 1) (exact; never 1).
#[inline]
pub fn bits_to_unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The largest f32 not above `v` ≥ 0 (so a value in [0, 1) stays below 1). Branch-free: rounding to
/// nearest goes up for half of all values, and a branch on it, mispredicted half the time, was 40 % of
/// what the `Stratified` sampler added to a path's time (BENCHMARKS.md). For f > v ≥ 0, f is positive
/// and its bits less one are the f32 below.
#[inline]
pub(crate) fn round_down_f32(v: f64) -> f32 {
    debug_assert!(v >= 0.0 && v.is_finite(), "round_down_f32: {v}");
    let f = v as f32;
    f32::from_bits(f.to_bits() - (f as f64 > v) as u32)
}

/// (i + jitter · 2⁻²⁴) / n as an f32 inside stratum i: floor(x · n) = i holds exactly (the product
/// of a 24-bit mantissa and n < 2²⁷ is exact in f64), so stratification survives the rounding.
#[inline]
pub(crate) fn stratum_value(i: u32, n: u32, jitter24: u32) -> f32 {
    let x = i as f64 + jitter24 as f64 * (1.0 / (1u64 << 24) as f64);
    // Dividing by n = 2ᵏ is exact, and so is multiplying by 2⁻ᵏ (built from its exponent): the same
    // double without the division's latency.
    let v = if n.is_power_of_two() {
        x * f64::from_bits((1023 - n.trailing_zeros() as u64) << 52)
    } else {
        x / n as f64
    };
    let f = round_down_f32(v);
    // Round-down can drop below i/n only when i/n is not an f32; the next float up is then the
    // smallest f32 above i/n and still not above v.
    if (f as f64) * (n as f64) < i as f64 {
        f.next_up()
    } else {
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutation_element_is_a_bijection() {
        for n in [1u32, 2, 3, 7, 16, 17, 100, 1000, 4096] {
            for key in [0u32, 1, 0xdead_beef, 0x8000_0000, u32::MAX] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let j = permutation_element(i, n, key);
                    assert!(
                        j < n && !seen[j as usize],
                        "n = {n}, key = {key:#x}, i = {i}"
                    );
                    seen[j as usize] = true;
                }
            }
        }
        // Different keys give different permutations.
        let perm = |key| {
            (0..64)
                .map(|i| permutation_element(i, 64, key))
                .collect::<Vec<_>>()
        };
        assert_ne!(perm(1), perm(2));
    }

    #[test]
    fn owen_scramble_keeps_the_prefix_tree() {
        // x and y share their leading bits down to the first difference; a nested scramble keeps
        // that depth: clz(x ⊕ y) = clz(s(x) ⊕ s(y)). A bijection on 32 bits, too.
        let mut state = 1u64;
        let mut next = || {
            state = splitmix64(state);
            state as u32
        };
        for _ in 0..10_000 {
            let (x, seed) = (next(), next());
            let y = x ^ (next() >> (next() % 32));
            let (sx, sy) = (owen_scramble_base2(x, seed), owen_scramble_base2(y, seed));
            assert_eq!((x ^ y).leading_zeros(), (sx ^ sy).leading_zeros());
            assert_eq!(x == y, sx == sy);
        }
        assert_ne!(owen_scramble_base2(0, 1), owen_scramble_base2(0, 2));
    }

    #[test]
    fn sobol_1_matches_the_known_sequence() {
        // Natural (not Gray-code) order: x_i = ⊕ of v_k over the set bits k of i.
        let y: Vec<f32> = (0..8).map(|i| sobol_1(i) as f32 / 2f32.powi(32)).collect();
        assert_eq!(y, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
        assert_eq!(sobol_0(1), 1 << 31);
        // The direction-number definition itself, on every index below 2¹⁶ and on indices using
        // all 32 bits.
        let by_direction_numbers = |mut i: u32| {
            let (mut v, mut x) = (1u32 << 31, 0u32);
            while i != 0 {
                x ^= v & (i & 1).wrapping_neg();
                i >>= 1;
                v ^= v >> 1;
            }
            x
        };
        let mut state = 3u64;
        let wide = std::iter::repeat_with(|| {
            state = splitmix64(state);
            state as u32
        });
        for i in (0..1u32 << 16).chain(wide.take(100_000)).chain([u32::MAX]) {
            assert_eq!(sobol_1(i), by_direction_numbers(i), "index {i:#x}");
        }
    }

    #[test]
    fn primes_table() {
        assert_eq!(PRIMES[..6], [2, 3, 5, 7, 11, 13]);
        assert_eq!(PRIMES[999], 7919);
        assert_eq!(PRIMES[NUM_PRIMES - 1], 8161);
    }

    #[test]
    fn scrambled_radical_inverse_keeps_points_in_their_boxes() {
        // The first bᵏ points put one value in each box of width b⁻ᵏ, and f32 rounding must not
        // move a value across a boundary j / bᵏ (not an f32 for odd b). Over 1000 keys values
        // within an ulp of a boundary occur: without the correction this fails at base 3, key 32.
        for (base, k) in [(3u32, 6u32), (5, 4), (7, 3)] {
            let n = base.pow(k) as usize;
            for key in 0..1000 {
                let mut seen = vec![false; n];
                for a in 0..n as u64 {
                    let x = owen_scrambled_radical_inverse(a, base, splitmix64(key));
                    let cell = (x as f64 * n as f64) as usize;
                    assert!(x < 1.0 && !seen[cell], "base {base}, key {key}: {a} -> {x}");
                    seen[cell] = true;
                }
            }
        }
    }

    #[test]
    fn stratum_values_of_powers_of_two_are_the_divided_ones() {
        // The shortcut for n = 2ᵏ must give the double that dividing gives, bit for bit.
        let mut state = 9u64;
        let mut next = || {
            state = splitmix64(state);
            state
        };
        for k in 0..27 {
            let n = 1u32 << k;
            for _ in 0..1000 {
                let (i, jitter) = ((next() % n as u64) as u32, (next() >> 40) as u32);
                let x = i as f64 + jitter as f64 / (1u64 << 24) as f64;
                let divided = round_down_f32(x / n as f64);
                let expected = if (divided as f64) * (n as f64) < i as f64 {
                    divided.next_up()
                } else {
                    divided
                };
                assert_eq!(stratum_value(i, n, jitter).to_bits(), expected.to_bits());
            }
        }
    }

    #[test]
    fn round_down_is_the_largest_f32_not_above() {
        let mut state = 11u64;
        let values = std::iter::repeat_with(|| {
            state = splitmix64(state);
            // Uniform in [0, 1), then values near and at f32 numbers and tiny ones.
            (state >> 11) as f64 / (1u64 << 53) as f64
        });
        let near = [0.0, 1e-45, 1.5e-45, 0.1, 0.5, 1.0 - 1e-12, 0.75f32 as f64];
        for v in values.take(100_000).chain(near) {
            let f = round_down_f32(v);
            assert!(f as f64 <= v && f.next_up() as f64 > v, "{v}: {f}");
        }
    }

    #[test]
    fn stratum_values_stay_in_their_stratum() {
        for n in [1u32, 3, 7, 10, 12, 1000, 99_991] {
            for i in [0, n / 3, n - 1] {
                for jitter in [0, 1, 1 << 23, (1 << 24) - 1] {
                    let x = stratum_value(i, n, jitter);
                    assert!(x < 1.0 && (x as f64 * n as f64).floor() as u32 == i);
                }
            }
        }
        assert!(round_down_f32(1.0 - 1e-12) < 1.0);
        assert_eq!(bits_to_unit(u32::MAX), 1.0 - f32::EPSILON / 2.0);
    }
}
