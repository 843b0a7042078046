//! The film: per-pixel running mean and sum of squared deviations in f64, updated with Welford's
//! algorithm (Welford 1962; Chan, Golub & LeVeque 1983 for the merge), so that millions of samples
//! neither drift nor lose the variance to cancellation, and every image comes with its own variance
//! image.
//!
//! A pixel's samples are whatever the integrator makes independent and identically distributed:
//! a camera path for path tracing, the whole sample pass (every contribution any path of pass k
//! made to the pixel, splats included) for light tracing and BDPT. Parts shared by all of a pixel's
//! samples — a photon map — add their own variance (`shared_var`), estimated separately.

/// The running statistics of one pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    /// Mean of the samples so far, per channel (Welford's running mean).
    pub mean: [f64; 3],
    /// Σ (xᵢ − mean)², per channel (kept 0 where the samples form replicates: see `shared_var`).
    pub m2: [f64; 3],
    /// Samples so far.
    pub count: u64,
    /// Variance of the mean estimated apart from the samples' own s²/n: the share of what all
    /// samples share (Jensen's photon maps, estimated across independent photon groups), added to
    /// s²/n; or, where the samples form independent replicates of a sampler, all of it (the spread
    /// of the replicate means; `m2` is then 0).
    pub shared_var: [f64; 3],
}

impl PixelSums {
    /// Adds one sample (one estimate of the pixel's value).
    #[inline]
    pub fn add(&mut self, v: [f64; 3]) {
        self.count += 1;
        let inv_n = 1.0 / self.count as f64;
        for c in 0..3 {
            let delta = v[c] - self.mean[c];
            self.mean[c] += delta * inv_n;
            self.m2[c] += delta * (v[c] - self.mean[c]);
        }
    }

    /// Combines the statistics of two disjoint sets of samples (Chan et al. 1983, eq. 2.1).
    pub fn merge(&mut self, other: &PixelSums) {
        if other.count == 0 {
            return;
        }
        let (na, nb) = (self.count as f64, other.count as f64);
        let n = na + nb;
        for c in 0..3 {
            let delta = other.mean[c] - self.mean[c];
            self.mean[c] += delta * nb / n;
            self.m2[c] += other.m2[c] + delta * delta * na * nb / n;
        }
        self.count += other.count;
    }

    /// Sample mean (0 with no samples).
    #[inline]
    pub fn mean(&self) -> [f64; 3] {
        self.mean
    }

    /// Estimated variance of the mean: s²/n with s² the unbiased sample variance (0 with fewer than
    /// two samples), plus the shared part. Its square root is the standard error used by z-tests.
    #[inline]
    pub fn variance_of_mean(&self) -> [f64; 3] {
        if self.count < 2 {
            return self.shared_var;
        }
        let n = self.count as f64;
        let mut v = self.shared_var;
        for c in 0..3 {
            v[c] += self.m2[c] / ((n - 1.0) * n);
        }
        v
    }
}

/// Accumulated samples of an image, row-major, pixel (x, y) at index y·width + x.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Each pixel's statistics, row-major.
    pub pixels: Vec<PixelSums>,
    /// Standard error of the image-wide average ([`Film::average`]) from the spread of the
    /// averages of independent sample passes (and photon groups), which holds however correlated
    /// the pixels are (a light path splats into many); `None` where the passes are not independent
    /// (stratified and low-discrepancy samplers, progressive photon mapping) or fewer than two.
    pub image_se: Option<[f64; 3]>,
}

impl Film {
    /// An empty film of `width` × `height` pixels.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelSums::default(); width as usize * height as usize],
            image_se: None,
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.pixels.len()
    }

    /// Mean of pixel `i` (row-major index).
    #[inline]
    pub fn mean(&self, i: usize) -> [f64; 3] {
        self.pixels[i].mean()
    }

    /// Variance of pixel `i`'s mean (see [`PixelSums::variance_of_mean`]).
    #[inline]
    pub fn variance_of_mean(&self, i: usize) -> [f64; 3] {
        self.pixels[i].variance_of_mean()
    }

    /// Image-wide average of the pixel means.
    pub fn average(&self) -> [f64; 3] {
        let n = self.pixel_count() as f64;
        let mut mean = [0.0; 3];
        for p in &self.pixels {
            let m = p.mean();
            for c in 0..3 {
                mean[c] += m[c] / n;
            }
        }
        mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_variance_of_mean() {
        let mut f = Film::new(2, 1);
        for v in [1.0, 2.0, 3.0, 6.0] {
            f.pixels[1].add([v, 2.0 * v, 0.0]);
        }
        assert_eq!(f.mean(1), [3.0, 6.0, 0.0]);
        // s² = ((−2)² + (−1)² + 0² + 3²)/3 = 14/3; variance of the mean = s²/4.
        let v = f.variance_of_mean(1);
        assert!((v[0] - 14.0 / 12.0).abs() < 1e-12 && (v[1] - 4.0 * 14.0 / 12.0).abs() < 1e-12);
        assert_eq!(f.mean(0), [0.0; 3]);
        assert_eq!(f.variance_of_mean(0), [0.0; 3]);
    }

    #[test]
    fn large_sums_do_not_drift() {
        let mut f = Film::new(1, 1);
        for _ in 0..4_000_000 {
            f.pixels[0].add([0.1, 1e-3, 1e3]);
        }
        let m = f.mean(0);
        assert!(
            (m[0] - 0.1).abs() < 1e-12 && (m[1] - 1e-3).abs() < 1e-15 && (m[2] - 1e3).abs() < 1e-9,
            "{m:?}"
        );
        assert!(
            f.variance_of_mean(0)[2] < 1e-12,
            "{:?}",
            f.variance_of_mean(0)
        );
    }

    #[test]
    fn variance_survives_a_large_offset() {
        // Samples 1e6 + {0, 1, 2, 3}: a sum-of-squares formula loses all digits of s² = 5/3 in f64
        // after a million repetitions; Welford keeps them.
        let mut f = PixelSums::default();
        for i in 0..1_000_000u64 {
            f.add([1e6 + (i % 4) as f64; 3]);
        }
        let s2 = f.variance_of_mean()[0] * f.count as f64;
        assert!((s2 - 1.25 * 1e6 / (1e6 - 1.0)).abs() < 1e-6, "{s2}");
    }

    #[test]
    fn merge_equals_sequential_adds() {
        let xs: Vec<f64> = (0..1000)
            .map(|i| ((i * 7919) % 1009) as f64 * 0.37)
            .collect();
        let (mut a, mut b, mut all) = (
            PixelSums::default(),
            PixelSums::default(),
            PixelSums::default(),
        );
        for (i, &x) in xs.iter().enumerate() {
            all.add([x; 3]);
            if i < 300 {
                a.add([x; 3])
            } else {
                b.add([x; 3])
            }
        }
        a.merge(&b);
        assert_eq!(a.count, all.count);
        assert!(
            (a.mean[0] - all.mean[0]).abs() < 1e-9 && (a.m2[0] / all.m2[0] - 1.0).abs() < 1e-12
        );
    }
}
