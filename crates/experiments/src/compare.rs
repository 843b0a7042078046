//! `lightlab compare A.exr B.exr`: one image against another, as pbrt-v4's `imgtool diff` does —
//! the mean ratio, MSE and relMSE, and, when both images carry their variance of the mean, a
//! per-pixel z-test — over the whole image or a region, with an error image to look at.
//!
//! The z-test. For each pixel and channel z = (a − b) / √(v_a + v_b). If both images estimate the
//! same values with independent noise and honest variances, and v_a, v_b are exact, the z are
//! standard normal. The variances are estimated from n_a and n_b samples, though, so z follows
//! Student's t with the Welch–Satterthwaite degrees of freedom
//! ν = (v_a + v_b)² / (v_a²/(n_a − 1) + v_b²/(n_b − 1)) (Welch 1947), whose tails at a Šidák
//! level are far heavier than the normal's at 16 samples. Where both sample counts are known each
//! z is mapped to the normal deviate of the same tail probability (z' = Φ⁻¹(T_ν(z))), so that |z'|
//! exceeds the Šidák-corrected critical value of the chosen α somewhere with probability α and
//! Σz'² over the n pixel channels tested is χ²(n) (its p-value is reported). Without the counts the
//! normal approximation is used and the rate holds only for many samples per pixel. Pixels where
//! both variances are zero are left out (an exact match, or nothing sampled there: the variance
//! cannot tell).
//!
//! The χ² takes the z' as independent. The three channels of a pixel come from the same paths and
//! are correlated (for grey and white surfaces nearly perfectly), which makes Σz'² spread wider
//! than χ²(n): its p-value is then too small, up to 30 times at 10⁻³ for a grey image. So are
//! neighbouring pixels of a light-traced image. The per-pixel test with its Šidák bound only
//! becomes conservative under such correlation, and decides agreement.

use crate::metrics::{Image, REL_EPSILON};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

/// Which pixels to compare.
#[derive(Clone, Debug)]
pub enum Region {
    All,
    /// Pixels x0 ≤ x < x1, y0 ≤ y < y1.
    Rect {
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
    },
    /// Pixels where the mask's value (any channel) is non-zero.
    Mask(Vec<bool>),
}

impl Region {
    fn contains(&self, i: usize, width: u32) -> bool {
        match self {
            Region::All => true,
            Region::Rect { x0, y0, x1, y1 } => {
                let (x, y) = ((i % width as usize) as u32, (i / width as usize) as u32);
                (*x0..*x1).contains(&x) && (*y0..*y1).contains(&y)
            }
            Region::Mask(m) => m[i],
        }
    }
}

/// The per-pixel z-test's outcome.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ZTest {
    /// Pixel channels tested (both variances not zero).
    pub tested: usize,
    /// √(mean z²): 1 for agreement.
    pub rms_z: f64,
    pub max_abs_z: f64,
    /// Where the largest |z| is: (x, y, channel).
    pub worst: (u32, u32, usize),
    /// Šidák-corrected critical |z| for `alpha` over the tested channels, and how many exceed it.
    pub alpha: f64,
    pub critical: f64,
    pub exceeding: usize,
    /// P(χ²(n) ≥ Σz'²): small when the images differ by more than their noise (channels taken as
    /// independent; see the module docs).
    pub chi2_p_value: f64,
    /// The smallest Welch–Satterthwaite degrees of freedom of the channels tested, when both
    /// images' samples per pixel are known (the z are then t-corrected); `None`: normal
    /// approximation.
    pub min_degrees_of_freedom: Option<f64>,
    /// Of the channels beyond the critical value, those where an image's value rests on fewer than
    /// [`FEW_EFFECTIVE_SAMPLES`] effective samples (see [`effective_samples`]): there its variance
    /// is itself too noisy to test against, and for a heavy-tailed estimator usually too small.
    pub exceeding_on_few_samples: usize,
}

/// Below this many effective samples a pixel's variance estimate is not trusted to scale a z.
pub const FEW_EFFECTIVE_SAMPLES: f64 = 10.0;

/// mean² / variance of the mean: for a value made of rare contributions of similar size (a small
/// light found by BSDF sampling, a caustic found by path tracing, a sub-pixel feature) about the
/// number of samples that contributed, since a mean p·Y of n samples that are Y with probability p
/// has variance p(1 − p)Y²/n. With a handful of contributions s²/n is most often far below the
/// variance it estimates (its distribution is skewed), and the z-test raises false alarms. A
/// value with no variance is exact unless it is 0 (every sample missed): 0 effective samples.
pub fn effective_samples(mean: f64, variance: f64) -> f64 {
    if variance > 0.0 {
        mean * mean / variance
    } else if mean == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

impl ZTest {
    /// Whether the images agree: no channel beyond the critical value.
    pub fn agrees(&self) -> bool {
        self.exceeding == 0
    }
}

/// What `compare` found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Comparison {
    pub pixels: usize,
    pub mean_a: [f64; 3],
    pub mean_b: [f64; 3],
    /// mean a / mean b per channel; `None` (JSON `null`) where mean b is 0, so the ratio is
    /// undefined (a black channel).
    pub ratio: [Option<f64>; 3],
    /// Mean over pixels and channels of (a − b)², and of (a − b)² / (b² + ε).
    pub mse: f64,
    pub rel_mse: f64,
    /// The z-test, when both images carry their variance.
    pub z: Option<ZTest>,
}

/// The normal deviate with the tail probability that z has under Student's t with ν degrees of
/// freedom; |z'| ≤ |z|. Where that probability underflows, z itself (far beyond any critical
/// value either way).
fn t_to_normal(z: f64, nu: f64) -> f64 {
    use statrs::distribution::StudentsT;
    let Ok(t) = StudentsT::new(0.0, 1.0, nu) else {
        return z;
    };
    let tail = t.sf(z.abs());
    if tail <= 0.0 {
        return z;
    }
    let deviate = -Normal::standard().inverse_cdf(tail);
    deviate.min(z.abs()).copysign(z)
}

/// Welch–Satterthwaite degrees of freedom of v_a + v_b, the variances of two means of n_a and n_b
/// samples; a zero variance is exact and adds nothing.
fn welch_dof(va: f64, vb: f64, na: u64, nb: u64) -> f64 {
    let part = |v: f64, n: u64| {
        if v > 0.0 {
            v * v / (n as f64 - 1.0)
        } else {
            0.0
        }
    };
    (va + vb).powi(2) / (part(va, na) + part(vb, nb))
}

/// Compares `a` with `b` over `region`; `None` when the sizes differ or the region is empty.
/// `samples` are the samples per pixel behind each image's variance, where known: with both the
/// z-test is t-corrected (module docs).
pub fn compare(
    a: &Image,
    b: &Image,
    region: &Region,
    alpha: f64,
    samples: (Option<u64>, Option<u64>),
) -> Option<Comparison> {
    if (a.width, a.height) != (b.width, b.height) {
        return None;
    }
    let inside: Vec<usize> = (0..a.mean.len())
        .filter(|&i| region.contains(i, a.width))
        .collect();
    if inside.is_empty() {
        return None;
    }
    let n = inside.len() as f64;
    let (mut mean_a, mut mean_b) = ([0.0f64; 3], [0.0f64; 3]);
    let (mut mse, mut rel) = (0.0, 0.0);
    for &i in &inside {
        for c in 0..3 {
            let (x, y) = (a.mean[i][c] as f64, b.mean[i][c] as f64);
            mean_a[c] += x / n;
            mean_b[c] += y / n;
            mse += (x - y).powi(2) / (3.0 * n);
            rel += (x - y).powi(2) / (y * y + REL_EPSILON) / (3.0 * n);
        }
    }
    let z = match (&a.variance, &b.variance) {
        (Some(va), Some(vb)) => {
            // A variance from one sample is no estimate: n ≥ 2 for the correction.
            let counts = match samples {
                (Some(na), Some(nb)) if na >= 2 && nb >= 2 => Some((na, nb)),
                _ => None,
            };
            let mut zs = Vec::new();
            let mut min_dof = f64::INFINITY;
            for &i in &inside {
                for c in 0..3 {
                    let (vai, vbi) = (va[i][c] as f64, vb[i][c] as f64);
                    let v = vai + vbi;
                    if v > 0.0 {
                        let z = (a.mean[i][c] - b.mean[i][c]) as f64 / v.sqrt();
                        let z = match counts {
                            Some((na, nb)) => {
                                let nu = welch_dof(vai, vbi, na, nb);
                                min_dof = min_dof.min(nu);
                                t_to_normal(z, nu)
                            }
                            None => z,
                        };
                        let few = effective_samples(a.mean[i][c] as f64, vai)
                            .min(effective_samples(b.mean[i][c] as f64, vbi))
                            < FEW_EFFECTIVE_SAMPLES;
                        zs.push((z, i, c, few));
                    }
                }
            }
            (!zs.is_empty()).then(|| {
                let per_test = -((-alpha).ln_1p() / zs.len() as f64).exp_m1();
                let critical = -Normal::standard().inverse_cdf(per_test / 2.0);
                let sum_sq: f64 = zs.iter().map(|z| z.0 * z.0).sum();
                let &(zmax, wi, wc, _) = zs
                    .iter()
                    .max_by(|p, q| p.0.abs().total_cmp(&q.0.abs()))
                    .expect("non-empty");
                ZTest {
                    tested: zs.len(),
                    rms_z: (sum_sq / zs.len() as f64).sqrt(),
                    max_abs_z: zmax.abs(),
                    worst: (wi as u32 % a.width, wi as u32 / a.width, wc),
                    alpha,
                    critical,
                    exceeding: zs.iter().filter(|z| z.0.abs() > critical).count(),
                    chi2_p_value: ChiSquared::new(zs.len() as f64)
                        .map_or(f64::NAN, |d| d.sf(sum_sq)),
                    min_degrees_of_freedom: counts.map(|_| min_dof),
                    exceeding_on_few_samples: zs
                        .iter()
                        .filter(|z| z.0.abs() > critical && z.3)
                        .count(),
                }
            })
        }
        _ => None,
    };
    Some(Comparison {
        pixels: inside.len(),
        mean_a,
        mean_b,
        ratio: [0, 1, 2].map(|c| (mean_b[c] != 0.0).then(|| mean_a[c] / mean_b[c])),
        mse,
        rel_mse: rel,
        z,
    })
}

/// The error images of `a` against `b`: `difference` (a − b), `relative` ((a − b)/(|b| + 0.01)) and,
/// with both variances, `z`; pixels outside `region` are 0.
pub fn error_layers(a: &Image, b: &Image, region: &Region) -> Vec<crate::image_io::RgbLayer> {
    use crate::image_io::RgbLayer;
    let px = |f: &dyn Fn(usize, usize) -> f32| -> Vec<[f32; 3]> {
        (0..a.mean.len())
            .map(|i| {
                if region.contains(i, a.width) {
                    [f(i, 0), f(i, 1), f(i, 2)]
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    };
    let mut layers = vec![
        RgbLayer {
            name: "difference".into(),
            pixels: px(&|i, c| a.mean[i][c] - b.mean[i][c]),
        },
        RgbLayer {
            name: "relative".into(),
            pixels: px(&|i, c| (a.mean[i][c] - b.mean[i][c]) / (b.mean[i][c].abs() + 0.01)),
        },
    ];
    if let (Some(va), Some(vb)) = (&a.variance, &b.variance) {
        layers.push(RgbLayer {
            name: "z".into(),
            pixels: px(&|i, c| {
                let v = va[i][c] + vb[i][c];
                if v > 0.0 {
                    (a.mean[i][c] - b.mean[i][c]) / v.sqrt()
                } else {
                    0.0
                }
            }),
        });
    }
    layers
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(usize) -> f32, var: Option<f32>) -> Image {
        let n = (w * h) as usize;
        Image {
            width: w,
            height: h,
            mean: (0..n).map(|i| [f(i); 3]).collect(),
            variance: var.map(|v| vec![[v; 3]; n]),
        }
    }

    /// Known differences give known statistics; a region restricts them; noise at the stated
    /// variance passes the z-test and a 10σ offset in one pixel fails it, located.
    #[test]
    fn statistics_of_known_images() {
        let a = image(4, 2, |i| 1.0 + i as f32, None);
        let b = image(4, 2, |i| 1.0 + i as f32 + 0.5, None);
        let c = compare(&a, &b, &Region::All, 1e-3, (None, None)).unwrap();
        assert_eq!(c.pixels, 8);
        assert!((c.mse - 0.25).abs() < 1e-12 && c.z.is_none());
        assert!(
            (c.ratio[0].unwrap() - 4.5 / 5.0).abs() < 1e-12,
            "{:?}",
            c.ratio
        );
        // A black reference channel has no ratio.
        let black = image(4, 2, |_| 0.0, None);
        assert_eq!(
            compare(&a, &black, &Region::All, 1e-3, (None, None))
                .unwrap()
                .ratio,
            [None; 3]
        );
        let r = Region::Rect {
            x0: 1,
            y0: 0,
            x1: 2,
            y1: 2,
        };
        assert_eq!(compare(&a, &b, &r, 1e-3, (None, None)).unwrap().pixels, 2);
        assert!(
            compare(
                &a,
                &image(2, 2, |_| 0.0, None),
                &Region::All,
                1e-3,
                (None, None)
            )
            .is_none()
        );

        // Deterministic pseudo-noise of variance 1/12 (uniform) against exact values.
        let noisy = image(
            64,
            64,
            |i| (i * 7919 % 1000) as f32 / 1000.0 - 0.5,
            Some(1.0 / 12.0),
        );
        let exact = image(64, 64, |_| 0.0, Some(0.0));
        let z = compare(&noisy, &exact, &Region::All, 1e-3, (None, None))
            .unwrap()
            .z
            .unwrap();
        assert!(z.agrees() && (z.rms_z - 1.0).abs() < 0.05, "{z:?}");
        let mut off = noisy.clone();
        off.mean[70] = [3.0; 3];
        let z = compare(&off, &exact, &Region::All, 1e-3, (None, None))
            .unwrap()
            .z
            .unwrap();
        assert!(
            !z.agrees() && (z.worst.0, z.worst.1) == (6, 1) && z.max_abs_z > 10.0,
            "{z:?}"
        );
        let layers = error_layers(&off, &exact, &Region::All);
        let names: Vec<&str> = layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["difference", "relative", "z"]);
    }

    /// Channels beyond the critical value are told apart by how many samples their variance rests
    /// on: one carried by a single contribution (mean² / variance = 1) or by none (0, variance 0)
    /// is counted as resting on few, a well-sampled one (10⁴) is not.
    #[test]
    fn disagreements_on_few_effective_samples_are_counted() {
        assert_eq!(effective_samples(0.01, 1e-4), 1.0);
        assert_eq!(effective_samples(0.0, 0.0), 0.0);
        assert_eq!(effective_samples(2.0, 0.0), f64::INFINITY);
        let mut a = image(8, 8, |_| 1.0, Some(1e-4));
        let mut b = image(8, 8, |_| 1.0, Some(1e-4));
        // Pixel 3: A found one rare sample, B many; pixel 5: both well sampled, far apart.
        (a.mean[3], a.variance.as_mut().unwrap()[3]) = ([0.01; 3], [1e-4; 3]);
        (b.mean[3], b.variance.as_mut().unwrap()[3]) = ([0.5; 3], [1e-6; 3]);
        b.mean[5] = [2.0; 3];
        let z = compare(&a, &b, &Region::All, 1e-3, (None, None))
            .unwrap()
            .z
            .unwrap();
        assert_eq!((z.exceeding, z.exceeding_on_few_samples), (6, 3), "{z:?}");
    }

    /// The family-wise false-alarm rate holds at 16 samples per pixel once the z are t-corrected:
    /// 100 agreeing pairs — a 32×32 image, each channel the mean of 16 standard normal samples with
    /// its sample variance of the mean, against exact zeros — at α = 10⁻³. At most 2 of the 100 may
    /// disagree: the chance of 3 or more is 1.5·10⁻⁴ (binomial, p = α), the false-failure rate. The
    /// normal approximation fails about 39 % of them (Šidák critical |z| = 4.99 against t with 15
    /// degrees of freedom), so the uncorrected count must exceed 15.
    #[test]
    fn t_corrected_z_test_keeps_its_false_alarm_rate_at_16_samples() {
        // splitmix64 and Box–Muller: a fixed stream of standard normals.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut normal = move || {
            let (u, v) = (uniform(), uniform());
            (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        };
        let (n, size) = (16u64, 32u32);
        let exact = image(size, size, |_| 0.0, Some(0.0));
        let (mut corrected, mut normal_approx) = (0, 0);
        for _ in 0..100 {
            let (mut mean, mut variance) = (Vec::new(), Vec::new());
            for _ in 0..size * size {
                let mut m = [0.0f32; 3];
                let mut v = [0.0f32; 3];
                for c in 0..3 {
                    let x: Vec<f64> = (0..n).map(|_| normal()).collect();
                    let mu = x.iter().sum::<f64>() / n as f64;
                    let s2 = x.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / (n - 1) as f64;
                    (m[c], v[c]) = (mu as f32, (s2 / n as f64) as f32);
                }
                mean.push(m);
                variance.push(v);
            }
            let noisy = Image {
                width: size,
                height: size,
                mean,
                variance: Some(variance),
            };
            let with = compare(&noisy, &exact, &Region::All, 1e-3, (Some(n), Some(n))).unwrap();
            let z = with.z.unwrap();
            let dof = z.min_degrees_of_freedom.unwrap();
            assert!((dof - 15.0).abs() < 1e-9, "{dof}");
            corrected += !z.agrees() as u32;
            let without = compare(&noisy, &exact, &Region::All, 1e-3, (None, None)).unwrap();
            normal_approx += !without.z.unwrap().agrees() as u32;
        }
        assert!(
            corrected <= 2,
            "{corrected} of 100 agreeing pairs disagreed"
        );
        assert!(
            normal_approx > 15,
            "the normal approximation failed only {normal_approx} of 100"
        );
    }
}
