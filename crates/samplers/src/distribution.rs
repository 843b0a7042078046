//! Piecewise-constant 1D distribution (pbrt-v4 §A.4.2), used for power-proportional light selection
//! and area-proportional triangle selection.

/// A discrete distribution over `n` items with probabilities proportional to non-negative weights,
/// sampled by inverting its CDF.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// cdf[i] = Σ_{j<i} w_j / Σ w, with cdf[n] = 1.
    cdf: Lines,
    pmf: Lines,
    total: f64,
}

/// Floats on 64-byte cache lines of their own. A scene's distributions are read by every thread on
/// every light sample, and a small heap allocation shares its cache line with its neighbours, which
/// threads may write: each read then misses (measured: 7 % of two-thread path tracing time on the
/// Cornell box, none on one thread).
#[derive(Clone, Debug)]
struct Lines {
    lines: Vec<Line>,
    len: usize,
}

#[derive(Clone, Copy, Debug)]
#[repr(align(64))]
struct Line([f32; 16]);

impl Lines {
    fn new(values: impl ExactSizeIterator<Item = f32>) -> Lines {
        let len = values.len();
        let mut lines = vec![Line([0.0; 16]); len.div_ceil(16)];
        for (i, v) in values.enumerate() {
            lines[i / 16].0[i % 16] = v;
        }
        Lines { lines, len }
    }

    #[inline]
    fn get(&self, i: usize) -> f32 {
        assert!(i < self.len);
        self.lines[i / 16].0[i % 16]
    }

    /// The first index i with !pred(values[i]), all earlier ones satisfying it (`slice::partition_point`).
    /// Branch-free: the halving steps depend on the length only and each picks its half by a
    /// conditional move, so a random `u` costs no mispredicted branch (it cost 15 % of light
    /// sampling's time on the Cornell box).
    #[inline]
    fn partition_point(&self, pred: impl Fn(f32) -> bool) -> usize {
        if self.len == 0 {
            return 0;
        }
        let (mut base, mut size) = (0, self.len);
        while size > 1 {
            let half = size / 2;
            let mid = base + half;
            base = if pred(self.get(mid)) { mid } else { base };
            size -= half;
        }
        base + usize::from(pred(self.get(base)))
    }
}

impl Distribution1D {
    /// Builds from weights. Returns `None` when there are no items or every weight is zero; negative
    /// or non-finite weights are the caller's error and also give `None`.
    pub fn new(weights: &[f32]) -> Option<Self> {
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if total <= 0.0 {
            return None;
        }
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &w in weights {
            acc += w as f64;
            cdf.push((acc / total) as f32);
        }
        *cdf.last_mut().unwrap() = 1.0;
        let pmf = Lines::new(weights.iter().map(|&w| (w as f64 / total) as f32));
        Some(Distribution1D {
            cdf: Lines::new(cdf.into_iter()),
            pmf,
            total,
        })
    }

    pub fn len(&self) -> usize {
        self.pmf.len
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.len == 0
    }

    /// Sum of the weights it was built from.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i)
    }

    /// Samples an item; returns (index, probability, u remapped to [0,1) within the item's interval,
    /// so the same number can be reused for a continuous choice).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let (i, p) = self.sample_index(u);
        let remapped = ((u - self.cdf.get(i)) / p).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        (i, p, remapped)
    }

    /// [`Distribution1D::sample`] without the remapped u, for callers that draw nothing more from
    /// it (light selection): (index, probability).
    #[inline]
    pub fn sample_index(&self, u: f32) -> (usize, f32) {
        // Last index with cdf[i] <= u, skipping zero-probability items; the one item of a
        // single-item distribution (a scene's only light) without the search.
        let n = self.pmf.len;
        let i = if n == 1 {
            0
        } else {
            let mut i = self
                .cdf
                .partition_point(|c| c <= u)
                .saturating_sub(1)
                .min(n - 1);
            while self.pmf.get(i) == 0.0 && i > 0 {
                i -= 1;
            }
            while self.pmf.get(i) == 0.0 {
                i += 1;
            }
            i
        };
        (i, self.pmf.get(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_degenerate_weights() {
        assert!(Distribution1D::new(&[]).is_none());
        assert!(Distribution1D::new(&[0.0, 0.0]).is_none());
        assert!(Distribution1D::new(&[1.0, -1.0]).is_none());
        assert!(Distribution1D::new(&[1.0, f32::NAN]).is_none());
    }

    /// One item: always it, with probability 1 and u unchanged (below 1).
    #[test]
    fn a_single_item_is_always_chosen() {
        let d = Distribution1D::new(&[3.5]).unwrap();
        for u in [0.0, 1e-30, 0.25, 0.5, 0.999_999_9, 1.0 - f32::EPSILON / 2.0] {
            let expected = u.min(1.0 - f32::EPSILON / 2.0);
            assert_eq!(d.sample(u), (0, 1.0, expected), "u = {u}");
        }
    }

    #[test]
    fn sampling_matches_pmf_and_skips_zeros() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 0.0]).unwrap();
        assert_eq!(d.pmf(2), 0.75);
        let n = 100_000;
        let mut counts = [0usize; 4];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            // Counted through sample_index, the entry point light selection uses; sample adds
            // only the remapped u.
            let (i, p) = d.sample_index(u);
            assert_eq!(p, d.pmf(i));
            let (_, _, r) = d.sample(u);
            assert!((0.0..1.0).contains(&r));
            counts[i] += 1;
        }
        assert_eq!(counts[1] + counts[3], 0);
        assert!((counts[0] as f32 / n as f32 - 0.25).abs() < 1e-3);
        assert_eq!(d.sample(0.0).0, 0);
        assert_eq!(d.sample(0.99999994).0, 2);
    }

    /// Across several cache lines (and zero weights on line boundaries) sampling inverts the CDF
    /// exactly as a search over a plain slice does: the index whose interval holds u, skipping
    /// zero-probability items.
    #[test]
    fn sampling_across_cache_lines_inverts_the_cdf() {
        let weights: Vec<f32> = (0..41)
            .map(|i| {
                if i % 16 == 15 || i % 16 == 0 {
                    0.0
                } else {
                    1.0 + (i % 7) as f32
                }
            })
            .collect();
        let d = Distribution1D::new(&weights).unwrap();
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let cdf: Vec<f32> = (0..=41)
            .map(|i| (weights[..i].iter().map(|&w| w as f64).sum::<f64>() / total) as f32)
            .collect();
        for k in 0..100_000 {
            let u = k as f32 / 100_000.0;
            let (i, p, _) = d.sample(u);
            assert!(weights[i] > 0.0, "u = {u}: zero-weight item {i}");
            assert!(
                cdf[i] <= u && (u < cdf[i + 1] || i == 40 || cdf[i + 1] == 1.0),
                "u = {u}: {i}"
            );
            assert_eq!(p, (weights[i] as f64 / total) as f32);
        }
        assert_eq!(d.sample(0.0).0, 1);
        assert_eq!(d.sample(0.99999994).0, 40);
    }

    /// The branch-free search returns what `slice::partition_point` does, for every length up
    /// to a few cache lines and thresholds below, on and between the values (ties included).
    #[test]
    fn partition_point_equals_the_slices() {
        for len in 0..70usize {
            let values: Vec<f32> = (0..len).map(|i| (i / 3) as f32).collect();
            let lines = Lines::new(values.iter().copied());
            for k in -2..=(2 * len as i32 / 3 + 2) {
                let x = k as f32 * 0.5;
                for pred in [|v: f32, x: f32| v <= x, |v: f32, x: f32| v < x] {
                    assert_eq!(
                        lines.partition_point(|v| pred(v, x)),
                        values.partition_point(|&v| pred(v, x)),
                        "len {len}, x {x}"
                    );
                }
            }
        }
    }
}
