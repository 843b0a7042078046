//! Walker's alias method for sampling a discrete distribution in constant time, built with Vose's
//! numerically stable algorithm.
//!
//! References: A. J. Walker, "An Efficient Method for Generating Discrete Random Variables with
//! General Distributions", ACM TOMS 3(3), 1977; M. D. Vose, "A Linear Algorithm for Generating
//! Random Numbers with a Given Distribution", IEEE TSE 17(9), 1991; pbrt-v4 §A.1 (`AliasTable`),
//! whose layout and uniform remapping this follows.
//!
//! The table has one bin per item, each chosen with probability 1/n. Bin i keeps its own item with
//! probability `q[i]` and otherwise yields its alias. Vose's construction scales the probabilities
//! by n, pairs an item below 1 ("under-full") with one above 1, gives the under-full item's spare
//! room to the over-full one, and puts the over-full item's remainder back on the matching list,
//! so every item's probability is exactly n⁻¹·(its own q + the 1 − q of the bins that alias it).
//! Compared with [`Distribution1D`](crate::Distribution1D)'s binary search over the CDF, sampling
//! is O(1), but neighbouring uniforms do not map to neighbouring items, so stratification of `u`
//! does not carry over to the item choice.

/// One bin: keep `item`'s own index with probability `q`, else take `alias`.
#[derive(Clone, Copy, Debug)]
struct Bin {
    q: f32,
    alias: u32,
}

/// A discrete distribution over `n` items with probabilities proportional to non-negative
/// weights, sampled in O(1) by Walker's alias method (Walker 1977) with the table built by Vose's
/// algorithm (Vose 1991), as pbrt-v4's `AliasTable` (§A.1). Unlike
/// [`Distribution1D`](crate::Distribution1D), neighbouring uniforms do not map to neighbouring
/// items, so stratification of `u` does not carry over to the choice.
///
/// ```
/// use lightlab_samplers::AliasTable;
///
/// let table = AliasTable::new(&[1.0, 0.0, 3.0]).unwrap();
/// let (i, pmf, remapped) = table.sample(0.9);
/// assert!(i != 1 && pmf == table.pmf(i) && (0.0..1.0).contains(&remapped));
/// assert_eq!(table.pmf(2), 0.75);
/// ```
#[derive(Clone, Debug)]
pub struct AliasTable {
    bins: Vec<Bin>,
    pmf: Vec<f32>,
    total: f64,
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl AliasTable {
    /// Builds the table from weights (Vose 1991). Returns `None` when there are no items, more
    /// than 2³² of them, any weight is negative or not finite, or every weight is zero.
    pub fn new(weights: &[f32]) -> Option<AliasTable> {
        let n = weights.len();
        if n == 0 || n > u32::MAX as usize || weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
        {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if !(total > 0.0) {
            return None;
        }
        let pmf: Vec<f32> = weights.iter().map(|&w| (w as f64 / total) as f32).collect();
        // Probabilities scaled by n, in f64 so the pairing loses nothing measurable.
        let scaled: Vec<f64> = weights
            .iter()
            .map(|&w| w as f64 / total * n as f64)
            .collect();
        // Work lists of (item, scaled probability not yet placed in a bin).
        let (mut under, mut over): (Vec<_>, Vec<_>) = scaled
            .iter()
            .enumerate()
            .map(|(i, &p)| (i, p))
            .partition(|&(_, p)| p < 1.0);
        let mut bins = vec![
            Bin {
                q: 1.0,
                alias: u32::MAX
            };
            n
        ];
        while let (Some(&(small, p_small)), Some(&(large, p_large))) = (under.last(), over.last()) {
            under.pop();
            over.pop();
            bins[small] = Bin {
                q: p_small as f32,
                alias: large as u32,
            };
            // The large item gave 1 − p_small of its mass to bin `small`.
            let excess = p_large + p_small - 1.0;
            if excess < 1.0 {
                under.push((large, excess));
            } else {
                over.push((large, excess));
            }
        }
        // Leftovers have a scaled probability of 1 up to rounding: they keep their own bin. A
        // zero-weight leftover (not possible beyond rounding, but cheap to exclude) sends its whole
        // bin to the most probable item instead.
        let heaviest = (0..n)
            .max_by(|&a, &b| scaled[a].total_cmp(&scaled[b]))
            .unwrap();
        for (i, _) in under.into_iter().chain(over) {
            bins[i] = if pmf[i] > 0.0 {
                Bin {
                    q: 1.0,
                    alias: i as u32,
                }
            } else {
                Bin {
                    q: 0.0,
                    alias: heaviest as u32,
                }
            };
        }
        Some(AliasTable { bins, pmf, total })
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Sum of the weights the table was built from.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Samples an item from `u` ∈ [0, 1): returns (index, probability, `u` remapped to [0, 1)).
    /// The remapped value is uniform and independent of the chosen item, so it can be reused for a
    /// continuous choice (pbrt-v4 `AliasTable::Sample`), though with fewer bits than `u` had:
    /// about 24 − log₂ n of them, less again for items whose `q` is small.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.bins.len();
        let scaled = u * n as f32;
        let offset = (scaled as usize).min(n - 1);
        let up = (scaled - offset as f32).clamp(0.0, ONE_MINUS_EPSILON);
        let bin = self.bins[offset];
        if up < bin.q {
            let remapped = (up / bin.q).min(ONE_MINUS_EPSILON);
            (offset, self.pmf[offset], remapped)
        } else {
            let alias = bin.alias as usize;
            let remapped = ((up - bin.q) / (1.0 - bin.q)).clamp(0.0, ONE_MINUS_EPSILON);
            (alias, self.pmf[alias], remapped)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_degenerate_weights() {
        assert!(AliasTable::new(&[]).is_none());
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[1.0, -1.0]).is_none());
        assert!(AliasTable::new(&[1.0, f32::NAN]).is_none());
        assert!(AliasTable::new(&[1.0, f32::INFINITY]).is_none());
    }

    /// Summing each item's share of every bin gives back its probability: the table is exact up
    /// to f32 rounding of q.
    #[test]
    fn bins_reproduce_the_probabilities() {
        let weights = [
            0.0, 1.0, 3.0, 1e-3, 0.0, 7.5, 2.0, 0.25, 12.0, 1e-5, 4.0, 0.0,
        ];
        let table = AliasTable::new(&weights).unwrap();
        let n = weights.len();
        let mut mass = vec![0.0f64; n];
        for (i, bin) in table.bins.iter().enumerate() {
            mass[i] += bin.q as f64 / n as f64;
            if bin.q < 1.0 {
                mass[bin.alias as usize] += (1.0 - bin.q as f64) / n as f64;
            }
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        for i in 0..n {
            let want = weights[i] as f64 / total;
            assert!(
                (mass[i] - want).abs() < 1e-7,
                "item {i}: {} vs {want}",
                mass[i]
            );
            assert_eq!(table.pmf(i), want as f32);
        }
    }

    #[test]
    fn sample_stays_in_range_and_skips_zeros() {
        let table = AliasTable::new(&[0.0, 2.0, 0.0, 1.0, 0.0]).unwrap();
        for k in 0..=10_000 {
            let u = (k as f32 / 10_000.0).min(ONE_MINUS_EPSILON);
            let (i, pmf, r) = table.sample(u);
            assert!(i == 1 || i == 3, "u {u}: item {i}");
            assert_eq!(pmf, table.pmf(i));
            assert!((0.0..1.0).contains(&r), "u {u}: remapped {r}");
        }
        // A single item takes everything, and the remapped uniform is u itself.
        let one = AliasTable::new(&[5.0]).unwrap();
        assert_eq!(one.sample(0.25), (0, 1.0, 0.25));
        assert_eq!(one.sample(ONE_MINUS_EPSILON).0, 0);
    }
}
