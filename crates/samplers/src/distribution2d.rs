//! Piecewise-constant 2D density on the unit square, sampled by a marginal in v and a
//! conditional in u (pbrt-v4 §A.5, `PiecewiseConstant2D`; the 1D building block is pbrt-v4
//! §A.4.2's `PiecewiseConstant1D`). Used for image-based (environment) lights and tabulated
//! densities.
//!
//! A table of `nu × nv` non-negative values f(i, j) (row-major: `values[j * nu + i]`, row j along
//! v) defines the density p(u, v) = f(⌊u·nu⌋, ⌊v·nv⌋) / I with I = Σ f / (nu·nv), the mean value,
//! so that ∫∫ p du dv = 1. Sampling inverts the marginal CDF of v (row integrals), then the
//! conditional CDF of u within the chosen row: p(u, v) = p(v) · p(u | v) (pbrt-v4 §2.4.2).
//!
//! Floating point: `(cell + offset) / n` can round up onto the next cell's edge; samples are moved
//! back into the cell whose CDF interval `u` fell in, so that [`Distribution2D::pdf`] of a sample
//! is always the density it was drawn with, even next to a zero cell.

use glam::Vec2;

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The cell of `x` ∈ [0, 1] on a grid of `n` cells; x = 1 belongs to the last cell.
#[inline]
fn cell_of(x: f32, n: usize) -> usize {
    ((x * n as f32) as usize).min(n - 1)
}

/// `(cell + offset) / n`, nudged by ulps until [`cell_of`] gives `cell` back, and kept below 1.
#[inline]
fn point_in_cell(cell: usize, offset: f32, n: usize) -> f32 {
    let mut x = ((cell as f32 + offset) / n as f32).min(ONE_MINUS_EPSILON);
    while cell_of(x, n) > cell {
        x = x.next_down();
    }
    while cell_of(x, n) < cell {
        x = x.next_up();
    }
    x
}

/// Piecewise-constant density on [0, 1] (pbrt-v4 `PiecewiseConstant1D`).
#[derive(Clone, Debug)]
struct PiecewiseConstant1D {
    func: Vec<f32>,
    /// cdf[i] = Σ_{j<i} func[j] / Σ func, cdf[n] = 1; uniform steps when every value is zero.
    cdf: Vec<f32>,
    /// ∫₀¹ f = Σ func / n.
    integral: f64,
}

impl PiecewiseConstant1D {
    /// `func` must be non-negative and finite (checked by the caller).
    fn new(func: &[f32]) -> PiecewiseConstant1D {
        let n = func.len();
        let sum: f64 = func.iter().map(|&f| f as f64).sum();
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for (i, &f) in func.iter().enumerate() {
            acc += f as f64;
            cdf.push(if sum > 0.0 {
                (acc / sum) as f32
            } else {
                (i + 1) as f32 / n as f32
            });
        }
        cdf[n] = 1.0;
        PiecewiseConstant1D {
            func: func.to_vec(),
            cdf,
            integral: sum / n as f64,
        }
    }

    fn len(&self) -> usize {
        self.func.len()
    }

    /// (x, cell): the cell whose CDF interval holds `u` (never a zero-valued one when any value is
    /// positive), and x in that cell at the same relative position.
    #[inline]
    fn sample(&self, u: f32) -> (f32, usize) {
        let n = self.len();
        let mut o = self
            .cdf
            .partition_point(|&c| c <= u)
            .saturating_sub(1)
            .min(n - 1);
        if self.integral > 0.0 {
            // Only reachable through rounding at the ends of the CDF.
            while self.func[o] == 0.0 && o > 0 {
                o -= 1;
            }
            while self.func[o] == 0.0 {
                o += 1;
            }
        }
        let width = self.cdf[o + 1] - self.cdf[o];
        let du = if width > 0.0 {
            ((u - self.cdf[o]) / width).clamp(0.0, ONE_MINUS_EPSILON)
        } else {
            0.0
        };
        (point_in_cell(o, du, n), o)
    }

    /// The u that [`PiecewiseConstant1D::sample`] maps to `x` ∈ [0, 1].
    #[inline]
    fn invert(&self, x: f32) -> f32 {
        let n = self.len();
        let o = cell_of(x, n);
        let delta = (x * n as f32 - o as f32).clamp(0.0, 1.0);
        let (c0, c1) = (self.cdf[o], self.cdf[o + 1]);
        (c0 + delta * (c1 - c0)).clamp(0.0, ONE_MINUS_EPSILON)
    }
}

/// A piecewise-constant density on the unit square, sampled by inversion of its marginal CDF in v
/// and the conditional CDF in u of the chosen row (pbrt-v4 §A.5, `PiecewiseConstant2D`).
///
/// `nu × nv` non-negative values f(i, j), row-major with rows along v, define
/// p(u, v) = f(⌊u·nu⌋, ⌊v·nv⌋) / I with I the mean value. [`sample`](Distribution2D::sample)
/// returns points whose cell always has the density it reports (rounding never carries a sample
/// into a neighbouring, possibly empty, cell), and [`invert`](Distribution2D::invert) maps a point
/// back to the uniforms that produce it.
///
/// ```
/// use lightlab_samplers::Distribution2D;
/// use glam::Vec2;
///
/// // Two cells along u, one row: the right half is three times as likely.
/// let d = Distribution2D::new(&[1.0, 3.0], 2, 1).unwrap();
/// let (p, pdf) = d.sample(Vec2::new(0.5, 0.5));
/// assert!(p.x >= 0.5 && pdf == 1.5);
/// assert_eq!(d.pdf(Vec2::new(0.25, 0.9)), 0.5);
/// ```
#[derive(Clone, Debug)]
pub struct Distribution2D {
    /// One conditional density in u per row (v cell).
    conditionals: Vec<PiecewiseConstant1D>,
    /// Density of v; its values are proportional to the rows' integrals.
    marginal: PiecewiseConstant1D,
    /// Mean of all values.
    integral: f64,
}

impl Distribution2D {
    /// Builds the distribution from `nu × nv` values, row-major with rows along v
    /// (`values[j * nu + i]` is the cell [i/nu, (i+1)/nu) × [j/nv, (j+1)/nv)). Returns `None`
    /// when a size is zero, `values.len() != nu * nv`, a value is negative or not finite, or every
    /// value is zero.
    pub fn new(values: &[f32], nu: usize, nv: usize) -> Option<Distribution2D> {
        if nu == 0
            || nv == 0
            || nu.checked_mul(nv) != Some(values.len())
            || values.iter().any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return None;
        }
        let conditionals: Vec<PiecewiseConstant1D> = values
            .chunks_exact(nu)
            .map(PiecewiseConstant1D::new)
            .collect();
        // The marginal's values are the row integrals relative to the largest, so that rows of
        // tiny values do not underflow f32 (a row below 10⁻³⁸ of the largest still does, and is
        // then never sampled).
        let max = conditionals
            .iter()
            .map(|c| c.integral)
            .fold(0.0f64, f64::max);
        if !(max > 0.0) {
            return None;
        }
        let marginal_func: Vec<f32> = conditionals
            .iter()
            .map(|c| (c.integral / max) as f32)
            .collect();
        let marginal = PiecewiseConstant1D::new(&marginal_func);
        let integral =
            conditionals.iter().map(|c| c.integral).sum::<f64>() / conditionals.len() as f64;
        Some(Distribution2D {
            conditionals,
            marginal,
            integral,
        })
    }

    /// (nu, nv): cells along u and v.
    pub fn resolution(&self) -> (usize, usize) {
        (self.conditionals[0].len(), self.conditionals.len())
    }

    /// The mean of the values, ∫∫ f du dv over the unit square.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Samples a point of [0, 1)² from `u` ∈ [0, 1)²: `u.y` picks v from the marginal, `u.x`
    /// picks u within that row. Returns the point and its density, which is exactly
    /// [`Distribution2D::pdf`] of the point.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (y, row) = self.marginal.sample(u.y);
        let (x, _) = self.conditionals[row].sample(u.x);
        let p = Vec2::new(x, y);
        (p, self.pdf(p))
    }

    /// Density per unit area at `p`: value of `p`'s cell over the mean value; 0 outside [0, 1]².
    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        if !((0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y)) {
            return 0.0;
        }
        let (nu, nv) = self.resolution();
        let row = &self.conditionals[cell_of(p.y, nv)];
        (row.func[cell_of(p.x, nu)] as f64 / self.integral) as f32
    }

    /// The `u` that [`Distribution2D::sample`] maps to `p`, or `None` where the density is zero
    /// (no `u` reaches such points) or `p` is outside [0, 1]².
    #[inline]
    pub fn invert(&self, p: Vec2) -> Option<Vec2> {
        if !(self.pdf(p) > 0.0) {
            return None;
        }
        let row = cell_of(p.y, self.conditionals.len());
        Some(Vec2::new(
            self.conditionals[row].invert(p.x),
            self.marginal.invert(p.y),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_tables() {
        assert!(Distribution2D::new(&[], 0, 0).is_none());
        assert!(Distribution2D::new(&[1.0, 2.0], 3, 1).is_none());
        assert!(Distribution2D::new(&[0.0; 6], 3, 2).is_none());
        assert!(Distribution2D::new(&[1.0, -1.0], 2, 1).is_none());
        assert!(Distribution2D::new(&[1.0, f32::NAN], 1, 2).is_none());
    }

    #[test]
    fn point_in_cell_never_leaves_its_cell() {
        for n in [1usize, 3, 7, 10, 1000, 4097] {
            for cell in [0, n / 2, n - 1] {
                for offset in [0.0, 0.5, ONE_MINUS_EPSILON] {
                    let x = point_in_cell(cell, offset, n);
                    assert_eq!(cell_of(x, n), cell, "n {n}, cell {cell}, offset {offset}");
                    assert!((0.0..1.0).contains(&x));
                }
            }
        }
    }

    #[test]
    fn uniform_table_is_the_identity() {
        let d = Distribution2D::new(&[2.0; 12], 4, 3).unwrap();
        for u in [Vec2::ZERO, Vec2::new(0.3, 0.7), Vec2::new(0.9, 0.1)] {
            let (p, pdf) = d.sample(u);
            assert!((p - u).length() < 1e-6, "{u} -> {p}");
            assert_eq!(pdf, 1.0);
            assert!((d.invert(p).unwrap() - u).length() < 1e-6);
        }
        assert_eq!(d.integral(), 2.0);
    }

    #[test]
    fn zero_cells_are_never_sampled() {
        // A zero column, a zero row, and positive cells between them.
        let values = [
            0.0, 1.0, 2.0, //
            0.0, 0.0, 0.0, //
            0.0, 4.0, 0.5,
        ];
        let d = Distribution2D::new(&values, 3, 3).unwrap();
        let n = 200;
        for i in 0..=n {
            for j in 0..=n {
                let u = Vec2::new(i as f32 / n as f32, j as f32 / n as f32)
                    .min(Vec2::splat(ONE_MINUS_EPSILON));
                let (p, pdf) = d.sample(u);
                assert!(pdf > 0.0, "u {u} -> {p} with pdf 0");
                assert!(p.cmpge(Vec2::ZERO).all() && p.cmplt(Vec2::ONE).all());
            }
        }
        // I = 7.5 / 9, so the (2, 0) cell has density 4 / I = 4.8.
        assert!((d.pdf(Vec2::new(0.5, 0.9)) - 4.8).abs() < 1e-5);
        assert_eq!(d.pdf(Vec2::new(0.1, 0.1)), 0.0);
        assert_eq!(d.pdf(Vec2::new(1.5, 0.1)), 0.0);
        assert!(d.invert(Vec2::new(0.5, 0.5)).is_none());
    }
}
