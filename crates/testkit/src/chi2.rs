//! Pearson's chi-square goodness-of-fit test of a sampling routine against its claimed density,
//! on the model of Mitsuba 3's `src/python/python/chi2.py` (`ChiSquareTest`) and pbrt-v3's
//! `src/tests/bsdfs.cpp` (`Chi2Test`).
//!
//! The null hypothesis is "the samples are distributed with density `pdf`". The test
//!
//! 1. draws `samples` sets of uniforms from a `Pcg32` seeded with `seed`, maps them through the
//!    sampling routine and histograms the accepted samples over a `rows × cols` grid in the
//!    domain's 2D parameterisation ([`Domain`]); a rejected sample (`None`) is counted but not
//!    histogrammed, so its probability must be missing from the pdf's integral (as in Mitsuba);
//! 2. integrates the pdf over every cell numerically (midpoint rule on a 6 × 6 sub-grid; near the
//!    edge of the pdf's support, adaptive refinement down to 1/2048 of a cell side) and multiplies
//!    by the number of samples drawn, which gives the expected count of each cell;
//! 3. rejects at once when a sample is invalid (not finite, not unit length, outside the domain),
//!    when a sample lands in a cell whose expected count is zero, or when the pdf is negative or
//!    not finite somewhere;
//! 4. otherwise sorts the cells by expected count and pools those expected below 5 into one cell
//!    (the usual validity rule for Pearson's approximation, as pbrt-v3 and Mitsuba do), computes
//!    X² = Σ (O − E)² / E over the remaining cells and its p-value P(χ²_k ≥ X²) with k = cells − 1
//!    degrees of freedom (no parameter is fitted from the data), from statrs's `ChiSquared`;
//! 5. accepts when p > α.
//!
//! **False failures.** Under the null hypothesis p is uniform on [0, 1], so a correct routine fails
//! with probability α. The default α is Šidák's correction of a suite-wide 1 % over 300 tests,
//! α = 1 − 0.99^(1/300) = 3.35 × 10⁻⁵ per test ([`crate::stats::default_alpha`]): a project
//! running at most 300 such tests sees a spurious failure in at most 1 % of runs with fresh seeds.
//! With the fixed seeds a passing test keeps passing until the code under test changes; a change
//! that makes a correct routine consume different random numbers re-draws its one-in-10⁴ chance.
//!
//! **Parameterisations** are equal-area, so every cell of a domain covers the same measure and a
//! table is readable as an image of the density: see [`Domain`]. Numerical integration is
//! trustworthy for densities that are smooth inside their support; a discontinuity other than the
//! support's edge should lie on cell edges (choose the resolution so). The support's edge is found
//! by probing cell midpoints and corners and, next to the edge, the corners of 1/8-size quads; a
//! support that enters a cell only through a gap narrower than 1/8 of its side and less than 1/64
//! deep escapes the probes. When samples land in such a cell (up to 16 cells), it is integrated
//! again with probes 1/256 of a side apart and refined down to 1/4096; a support that escapes
//! those too (or a pdf that really is zero there) is reported as samples landing in a cell of
//! expected count zero.
//!
//! A sharply peaked pdf (a glossy lobe) needs cells, and an integration sub-grid
//! ([`Chi2Test::integration`]), fine enough to resolve the peak, or the integration error alone
//! fails the test.
//!
//! **Blind spots.** Pearson's statistic sees local shape errors, not a small error in the pdf's
//! total: scaling a correct pdf by 1.01 adds only ≈ 0.01² · N = 100 to X² at N = 10⁶, within the
//! noise of 3280 degrees of freedom. The report prints the pdf's integral beside the acceptance
//! rate; compare them (`pdf_mass` against `accepted / samples`) when a normalisation is in doubt.
//!
//! **On failure** the observed and expected tables are written to `target/chi2/<name>.txt`
//! (observed block, then expected block, one line per row; `numpy.loadtxt(path).reshape(2, rows,
//! cols)` reads both) and the panic message of [`Chi2Result::assert_ok`] names the file.

use crate::stats::default_alpha;
use glam::{Vec2, Vec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::TAU;
use std::fmt;
use std::path::{Path, PathBuf};

/// Cells expected to receive fewer samples than this are pooled (pbrt-v3, Mitsuba: 5).
const MIN_EXPECTED: f64 = 5.0;
/// A sample may lie this fraction of the domain's extent outside it before it is invalid; it is
/// then clamped into the edge cell (Mitsuba's `chi2.py` uses the same 10⁻⁴).
const DOMAIN_SLACK: f64 = 1e-4;
/// Near the edge of the pdf's support a cell is split into 2 × 2 quads this many times regardless…
const FORCED_LEVELS: u32 = 3;
/// …and quads whose 4 × 4 midpoints and corners straddle the edge are split further, down to this
/// depth: 4 × 4 points in quads of 2⁻⁹ of a cell resolve the edge to 1/2048 of a cell side, so a
/// cell's expected count is off by at most ~1/4096 of a full cell's along the edge.
const MAX_LEVELS: u32 = 9;
/// Corner probes sit this fraction of a rectangle's side inside it.
const CORNER_INSET: f64 = 1e-4;
/// A cell with samples whose probes all saw a zero pdf is integrated again, split into
/// 2⁶ × 2⁶ quads of 4 × 4 midpoints (probes 1/256 of a side apart) and then adaptively down to
/// 2⁻¹² of a side…
const SECOND_LOOK_LEVELS: u32 = 6;
/// …for at most this many cells (a sampler that scatters samples everywhere fails anyway).
const SECOND_LOOK_CELLS: usize = 16;

/// The sample space of a chi-square test and its 2D parameterisation
/// (a, b) ∈ [0, a_max] × [0, b_max]. Rows of the table run along a, columns along b. Every
/// parameterisation is equal-area (the measure of a cell is proportional to its parameter area),
/// so all cells of a domain are alike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Domain {
    /// Unit directions ([`Vec3`]), solid-angle measure: a = 1 − cos θ ∈ [0, 2], b = φ ∈ [0, 2π);
    /// dω = da dφ. Row 0 is at the +z pole.
    Sphere,
    /// Unit directions with z ≥ 0 ([`Vec3`]): a = 1 − cos θ ∈ [0, 1], b = φ ∈ [0, 2π).
    Hemisphere,
    /// Unit directions in the cap cos θ ≥ `cos_theta_max` around +z ([`Vec3`]):
    /// a = 1 − cos θ ∈ [0, 1 − cos θmax], b = φ. For narrow cones (a distant light): the Sphere
    /// domain would put the whole cone in one cell. 1 − cos θ is computed as (x² + y²)/(1 + z), so
    /// it keeps its relative precision however small the cap (z itself is quantised to a few
    /// values in f32).
    Cap { cos_theta_max: f32 },
    /// Points of the unit square ([`Vec2`]), area measure: a = y, b = x.
    Square,
    /// Points of the unit disk ([`Vec2`]), area measure: a = r² ∈ [0, 1], b = φ ∈ [0, 2π);
    /// dA = ½ da dφ.
    Disk,
}

impl Domain {
    /// (a_max, b_max): the parameter extents.
    fn extent(self) -> (f64, f64) {
        match self {
            Domain::Sphere => (2.0, TAU),
            Domain::Hemisphere => (1.0, TAU),
            Domain::Cap { cos_theta_max } => (1.0 - cos_theta_max as f64, TAU),
            Domain::Square => (1.0, 1.0),
            Domain::Disk => (1.0, TAU),
        }
    }

    /// The domain's measure per unit of parameter area.
    fn jacobian(self) -> f64 {
        match self {
            Domain::Disk => 0.5,
            _ => 1.0,
        }
    }

    /// Default (rows, cols). An odd row count keeps natural boundaries such as cos θ = 0 in the
    /// Sphere domain off cell edges, where rounding could put a sample just across the support's
    /// edge into a cell of expected count zero (Mitsuba's reason for its default of 101).
    fn default_resolution(self) -> (usize, usize) {
        match self {
            Domain::Square => (41, 40),
            _ => (41, 80),
        }
    }

    fn is_directional(self) -> bool {
        matches!(
            self,
            Domain::Sphere | Domain::Hemisphere | Domain::Cap { .. }
        )
    }

    /// Human-readable extent of a parameter rectangle.
    fn describe(self, a0: f64, a1: f64, b0: f64, b1: f64) -> String {
        // θ = 2 asin(√(a/2)) is exact for a = 1 − cos θ and keeps tiny angles precise.
        let theta = |a: f64| (2.0 * (a / 2.0).sqrt().asin()).to_degrees();
        match self {
            Domain::Square => format!("x ∈ [{b0:.4}, {b1:.4}], y ∈ [{a0:.4}, {a1:.4}]"),
            Domain::Disk => format!(
                "r ∈ [{:.4}, {:.4}], φ ∈ [{:.2}°, {:.2}°]",
                a0.sqrt(),
                a1.sqrt(),
                b0.to_degrees(),
                b1.to_degrees()
            ),
            _ => format!(
                "θ ∈ [{:.6}°, {:.6}°], φ ∈ [{:.2}°, {:.2}°]",
                theta(a0),
                theta(a1),
                b0.to_degrees(),
                b1.to_degrees()
            ),
        }
    }

    fn layout(self) -> &'static str {
        match self {
            Domain::Square => "rows: y ascending, columns: x ascending",
            Domain::Disk => "rows: r² ascending, columns: φ ascending",
            _ => "rows: θ from the +z pole (1 − cos θ ascending), columns: φ ascending",
        }
    }
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for glam::Vec2 {}
    impl Sealed for glam::Vec3 {}
}

/// A sample type a [`Domain`] accepts: [`Vec3`] directions for the spherical domains, [`Vec2`]
/// points for the planar ones. Sealed; the methods are the harness's mapping to and from (a, b).
pub trait DomainPoint: sealed::Sealed + Copy + fmt::Debug {
    /// Whether `domain` takes samples of this type.
    fn fits(domain: Domain) -> bool;
    /// Parameter coordinates (a, b) of the sample, or why it is not a valid sample.
    fn to_param(self, domain: Domain) -> Result<(f64, f64), String>;
    /// The point at parameter coordinates (a, b).
    fn from_param(domain: Domain, a: f64, b: f64) -> Self;
}

/// Azimuth in [0, 2π].
fn azimuth(x: f64, y: f64) -> f64 {
    let phi = y.atan2(x);
    if phi < 0.0 { phi + TAU } else { phi }
}

impl DomainPoint for Vec3 {
    fn fits(domain: Domain) -> bool {
        domain.is_directional()
    }

    fn to_param(self, _domain: Domain) -> Result<(f64, f64), String> {
        if !self.is_finite() {
            return Err("not finite".into());
        }
        // glam's tolerance: |‖v‖² − 1| ≤ 2·10⁻⁴.
        if !self.is_normalized() {
            return Err(format!("not unit length (‖v‖ = {})", self.length()));
        }
        let (x, y, z) = (self.x as f64, self.y as f64, self.z as f64);
        // 1 − cos θ = sin²θ / (1 + cos θ): no cancellation near the pole.
        let a = if z > 0.0 {
            (x * x + y * y) / (1.0 + z)
        } else {
            1.0 - z
        };
        Ok((a, azimuth(x, y)))
    }

    fn from_param(_domain: Domain, a: f64, b: f64) -> Self {
        let sin_theta = (a * (2.0 - a)).max(0.0).sqrt();
        Vec3::new(
            (sin_theta * b.cos()) as f32,
            (sin_theta * b.sin()) as f32,
            (1.0 - a) as f32,
        )
    }
}

impl DomainPoint for Vec2 {
    fn fits(domain: Domain) -> bool {
        matches!(domain, Domain::Square | Domain::Disk)
    }

    fn to_param(self, domain: Domain) -> Result<(f64, f64), String> {
        if !self.is_finite() {
            return Err("not finite".into());
        }
        let (x, y) = (self.x as f64, self.y as f64);
        Ok(match domain {
            Domain::Disk => (x * x + y * y, azimuth(x, y)),
            _ => (y, x),
        })
    }

    fn from_param(domain: Domain, a: f64, b: f64) -> Self {
        match domain {
            Domain::Disk => {
                let r = a.sqrt();
                Vec2::new((r * b.cos()) as f32, (r * b.sin()) as f32)
            }
            _ => Vec2::new(b as f32, a as f32),
        }
    }
}

/// A rectangle [a0, a1] × [b0, b1] in parameter space.
#[derive(Clone, Copy)]
struct Rect {
    a0: f64,
    a1: f64,
    b0: f64,
    b1: f64,
}

impl Rect {
    /// The 2 × 2 quads of the rectangle.
    fn quads(self) -> [Rect; 4] {
        let am = 0.5 * (self.a0 + self.a1);
        let bm = 0.5 * (self.b0 + self.b1);
        [
            Rect {
                a1: am,
                b1: bm,
                ..self
            },
            Rect {
                a1: am,
                b0: bm,
                ..self
            },
            Rect {
                a0: am,
                b1: bm,
                ..self
            },
            Rect {
                a0: am,
                b0: bm,
                ..self
            },
        ]
    }
}

/// The histogram grid over a domain's parameter rectangle.
struct Grid {
    domain: Domain,
    rows: usize,
    cols: usize,
    a_max: f64,
    b_max: f64,
}

impl Grid {
    fn new(domain: Domain, rows: usize, cols: usize) -> Grid {
        let (a_max, b_max) = domain.extent();
        Grid {
            domain,
            rows,
            cols,
            a_max,
            b_max,
        }
    }

    /// The cell containing (a, b), or why the point is outside the domain.
    fn locate(&self, a: f64, b: f64) -> Result<usize, String> {
        let index = |x: f64, max: f64, n: usize| {
            let t = x / max;
            (-DOMAIN_SLACK..=1.0 + DOMAIN_SLACK)
                .contains(&t)
                .then(|| ((t * n as f64) as usize).min(n - 1))
        };
        match (
            index(a, self.a_max, self.rows),
            index(b, self.b_max, self.cols),
        ) {
            (Some(i), Some(j)) => Ok(i * self.cols + j),
            _ => Err(format!("outside the {:?} domain", self.domain)),
        }
    }

    fn rect(&self, cell: usize) -> Rect {
        let (i, j) = (cell / self.cols, cell % self.cols);
        let da = self.a_max / self.rows as f64;
        let db = self.b_max / self.cols as f64;
        Rect {
            a0: i as f64 * da,
            a1: (i + 1) as f64 * da,
            b0: j as f64 * db,
            b1: (j + 1) as f64 * db,
        }
    }

    fn describe(&self, cell: usize) -> String {
        let r = self.rect(cell);
        format!(
            "cell (row {}, col {}): {}",
            cell / self.cols,
            cell % self.cols,
            self.domain.describe(r.a0, r.a1, r.b0, r.b1)
        )
    }
}

/// Integrates a pdf over parameter rectangles by the midpoint rule, remembering the first value
/// that is not a density (negative or not finite).
struct PdfIntegrator<'a, P, F> {
    domain: Domain,
    pdf: &'a F,
    bad_value: Option<String>,
    _point: std::marker::PhantomData<P>,
}

/// A midpoint-rule estimate and whether the pdf was zero and positive at some of its points.
struct Estimate {
    integral: f64,
    any_zero: bool,
    any_positive: bool,
}

impl<P: DomainPoint, F: Fn(P) -> f32> PdfIntegrator<'_, P, F> {
    /// ∫ pdf over `rect` (in parameter measure) by the midpoint rule on an m × m grid. The
    /// rectangle's corners are also probed (not integrated) so that a support clipping a corner
    /// between the midpoints still marks the rectangle as straddling the support's edge.
    fn midpoint(&mut self, rect: Rect, m: usize) -> Estimate {
        let (da, db) = (
            (rect.a1 - rect.a0) / m as f64,
            (rect.b1 - rect.b0) / m as f64,
        );
        let mut sum = 0.0;
        let (mut any_zero, mut any_positive) = (false, false);
        for i in 0..m {
            let a = rect.a0 + (i as f64 + 0.5) * da;
            for j in 0..m {
                let b = rect.b0 + (j as f64 + 0.5) * db;
                let p = P::from_param(self.domain, a, b);
                let value = (self.pdf)(p);
                if !(value.is_finite() && value >= 0.0) {
                    self.bad_value
                        .get_or_insert_with(|| format!("the pdf is {value} at {p:?}"));
                    continue;
                }
                any_zero |= value == 0.0;
                any_positive |= value > 0.0;
                sum += value as f64;
            }
        }
        // Probes just inside the corners: on the domain's outer edge a pdf may be zero (the
        // horizon) or undefined (the pole) without any support edge there.
        let (ea, eb) = (
            CORNER_INSET * (rect.a1 - rect.a0),
            CORNER_INSET * (rect.b1 - rect.b0),
        );
        for (a, b) in [
            (rect.a0 + ea, rect.b0 + eb),
            (rect.a0 + ea, rect.b1 - eb),
            (rect.a1 - ea, rect.b0 + eb),
            (rect.a1 - ea, rect.b1 - eb),
        ] {
            let value = (self.pdf)(P::from_param(self.domain, a, b));
            any_zero |= value == 0.0;
            any_positive |= value > 0.0 && value.is_finite();
        }
        Estimate {
            integral: sum * da * db,
            any_zero,
            any_positive,
        }
    }

    /// Adaptive midpoint rule for a rectangle near the support's edge: split into quads `forced`
    /// times, then keep splitting the quads that straddle the edge (their 4 × 4 midpoints and
    /// corners include zero and positive values), at most `levels` times in all.
    fn refine(&mut self, rect: Rect, forced: u32, levels: u32) -> f64 {
        let estimate = self.midpoint(rect, 4);
        if levels > 0 && (forced > 0 || (estimate.any_zero && estimate.any_positive)) {
            rect.quads()
                .into_iter()
                .map(|q| self.refine(q, forced.saturating_sub(1), levels - 1))
                .sum()
        } else {
            estimate.integral
        }
    }

    /// ∫ pdf over every cell of `grid`, in the domain's measure. Cells whose 3 × 3 neighbourhood
    /// has both zero and positive probe values are integrated adaptively, so the support's edge
    /// is resolved even where it clips a cell between two midpoints.
    fn tabulate(&mut self, grid: &Grid, m: usize) -> Vec<f64> {
        let cells = grid.rows * grid.cols;
        let coarse: Vec<Estimate> = (0..cells).map(|c| self.midpoint(grid.rect(c), m)).collect();
        let jacobian = grid.domain.jacobian();
        (0..cells)
            .map(|c| {
                let (i, j) = (c / grid.cols, c % grid.cols);
                let neighbours = (i.saturating_sub(1)..(i + 2).min(grid.rows)).flat_map(|ni| {
                    (j.saturating_sub(1)..(j + 2).min(grid.cols)).map(move |nj| ni * grid.cols + nj)
                });
                let (mut any_zero, mut any_positive) = (false, false);
                for n in neighbours {
                    any_zero |= coarse[n].any_zero;
                    any_positive |= coarse[n].any_positive;
                }
                let integral = if any_zero && any_positive {
                    self.refine(grid.rect(c), FORCED_LEVELS, MAX_LEVELS)
                } else {
                    coarse[c].integral
                };
                integral * jacobian
            })
            .collect()
    }
}

/// A chi-square goodness-of-fit test of a sampling routine: configure with the builder methods,
/// then [`run`](Chi2Test::run) or [`run_lobe`](Chi2Test::run_lobe). See the [module docs](self).
#[derive(Clone, Debug)]
pub struct Chi2Test {
    domain: Domain,
    rows: usize,
    cols: usize,
    samples: u64,
    seed: u64,
    alpha: f64,
    integration: usize,
}

impl Chi2Test {
    /// A test over `domain` with defaults: 41 × 80 cells (41 × 40 for [`Domain::Square`]),
    /// 10⁶ samples, seed 0, α = [`default_alpha`], a 6 × 6 integration sub-grid per cell.
    pub fn new(domain: Domain) -> Chi2Test {
        if let Domain::Cap { cos_theta_max } = domain {
            assert!(
                (-1.0..1.0).contains(&cos_theta_max),
                "Domain::Cap needs cos_theta_max in [-1, 1), got {cos_theta_max}"
            );
        }
        let (rows, cols) = domain.default_resolution();
        Chi2Test {
            domain,
            rows,
            cols,
            samples: 1_000_000,
            seed: 0,
            alpha: default_alpha(),
            integration: 6,
        }
    }

    /// Table size: `rows` along the domain's a coordinate (θ, r² or y), `cols` along b (φ or x).
    pub fn resolution(mut self, rows: usize, cols: usize) -> Chi2Test {
        assert!(rows >= 1 && cols >= 1, "resolution must be at least 1 × 1");
        self.rows = rows;
        self.cols = cols;
        self
    }

    /// Number of sample draws (accepted or rejected).
    pub fn samples(mut self, samples: u64) -> Chi2Test {
        assert!(samples >= 1, "a chi-square test needs samples");
        self.samples = samples;
        self
    }

    /// Seed of the `Pcg32` stream the uniforms come from.
    pub fn seed(mut self, seed: u64) -> Chi2Test {
        self.seed = seed;
        self
    }

    /// Per-test significance level α: the test fails when p ≤ α. Use [`crate::sidak`] to split a
    /// suite-wide level over several tests.
    pub fn significance(mut self, alpha: f64) -> Chi2Test {
        assert!(
            alpha > 0.0 && alpha < 1.0,
            "significance must be in (0, 1), got {alpha}"
        );
        self.alpha = alpha;
        self
    }

    /// Midpoint-rule sub-grid per cell (`m × m` pdf evaluations); raise it for sharply peaked pdfs.
    pub fn integration(mut self, m: usize) -> Chi2Test {
        assert!(m >= 1, "integration sub-grid must be at least 1 × 1");
        self.integration = m;
        self
    }

    /// Tests `sample`, a map from two uniforms to the domain (`None` = rejected), against `pdf`
    /// (in the domain's measure: solid angle or area).
    pub fn run<P: DomainPoint>(
        &self,
        name: &str,
        mut sample: impl FnMut(Vec2) -> Option<P>,
        pdf: impl Fn(P) -> f32,
    ) -> Chi2Result {
        self.run_with(
            name,
            |rng| sample(Vec2::new(rng.random(), rng.random())),
            pdf,
        )
    }

    /// As [`run`](Chi2Test::run) for routines taking three uniforms, such as BSDF sampling
    /// (`u_lobe` picks a lobe, `u` samples it). A rejected sample (`None`) is lost mass: the pdf
    /// must integrate to the acceptance probability.
    pub fn run_lobe<P: DomainPoint>(
        &self,
        name: &str,
        mut sample: impl FnMut(f32, Vec2) -> Option<P>,
        pdf: impl Fn(P) -> f32,
    ) -> Chi2Result {
        self.run_with(
            name,
            |rng| {
                let u_lobe = rng.random();
                sample(u_lobe, Vec2::new(rng.random(), rng.random()))
            },
            pdf,
        )
    }

    fn run_with<P: DomainPoint>(
        &self,
        name: &str,
        mut draw: impl FnMut(&mut Pcg32) -> Option<P>,
        pdf: impl Fn(P) -> f32,
    ) -> Chi2Result {
        assert!(
            P::fits(self.domain),
            "chi2 test `{name}`: {:?} does not take samples of type {}",
            self.domain,
            std::any::type_name::<P>()
        );
        let grid = Grid::new(self.domain, self.rows, self.cols);
        let mut problems = Vec::new();

        let mut observed = vec![0u64; self.rows * self.cols];
        let mut rng = Pcg32::seed_from_u64(self.seed);
        let (mut accepted, mut invalid) = (0u64, 0u64);
        let mut first_invalid = None;
        for _ in 0..self.samples {
            let Some(p) = draw(&mut rng) else { continue };
            accepted += 1;
            match p.to_param(self.domain).and_then(|(a, b)| grid.locate(a, b)) {
                Ok(cell) => observed[cell] += 1,
                Err(why) => {
                    invalid += 1;
                    first_invalid.get_or_insert_with(|| format!("{p:?}: {why}"));
                }
            }
        }
        if let Some(first) = first_invalid {
            problems.push(format!("{invalid} invalid samples; the first: {first}"));
        }

        let mut integrator = PdfIntegrator {
            domain: self.domain,
            pdf: &pdf,
            bad_value: None,
            _point: std::marker::PhantomData,
        };
        let mut expected = integrator.tabulate(&grid, self.integration);
        // A second look at cells where samples landed but the probes found no support: it may
        // enter the cell through a gap between them (a polygon's vertex just across a cell edge).
        // The samples only choose where to integrate harder; the expected count is still ∫ pdf.
        let jacobian = self.domain.jacobian();
        for cell in (0..expected.len())
            .filter(|&c| expected[c] == 0.0 && observed[c] > 0)
            .take(SECOND_LOOK_CELLS)
            .collect::<Vec<_>>()
        {
            expected[cell] =
                integrator.refine(grid.rect(cell), SECOND_LOOK_LEVELS, MAX_LEVELS + 3) * jacobian;
        }
        problems.extend(integrator.bad_value);
        let pdf_mass: f64 = expected.iter().sum();
        for e in &mut expected {
            *e *= self.samples as f64;
        }

        conclude(
            Tables {
                name: name.to_string(),
                setup: format!(
                    "{:?}, {} × {} cells, seed {}",
                    self.domain, self.rows, self.cols, self.seed
                ),
                layout: self.domain.layout(),
                rows: self.rows,
                cols: self.cols,
                observed,
                expected,
                samples: self.samples,
                accepted,
                pdf_mass,
            },
            |cell| grid.describe(cell),
            problems,
            self.alpha,
        )
    }
}

/// Chi-square test of a discrete distribution: `counts[i]` samples fell on item i, whose claimed
/// probability is `probabilities[i]` (summing to 1, or to the acceptance rate when draws can be
/// rejected). Same pooling, immediate failures and table dump as [`Chi2Test`]; `alpha` as in
/// [`Chi2Test::significance`].
pub fn chi2_discrete(name: &str, counts: &[u64], probabilities: &[f64], alpha: f64) -> Chi2Result {
    assert_eq!(
        counts.len(),
        probabilities.len(),
        "chi2 test `{name}`: one probability per count"
    );
    let mut problems = Vec::new();
    if let Some((i, p)) = probabilities
        .iter()
        .enumerate()
        .find(|(_, p)| !(p.is_finite() && **p >= 0.0))
    {
        problems.push(format!("probability of item {i} is {p}"));
    }
    let samples: u64 = counts.iter().sum();
    conclude(
        Tables {
            name: name.to_string(),
            setup: format!("discrete, {} items", counts.len()),
            layout: "one row, a column per item",
            rows: 1,
            cols: counts.len(),
            observed: counts.to_vec(),
            expected: probabilities.iter().map(|p| p * samples as f64).collect(),
            samples,
            accepted: samples,
            pdf_mass: probabilities.iter().sum(),
        },
        |i| format!("item {i}"),
        problems,
        alpha,
    )
}

/// Histogram and expected counts of one test.
struct Tables {
    name: String,
    setup: String,
    layout: &'static str,
    rows: usize,
    cols: usize,
    observed: Vec<u64>,
    expected: Vec<f64>,
    samples: u64,
    accepted: u64,
    /// ∫ pdf over the domain (Σ probabilities for a discrete test).
    pdf_mass: f64,
}

/// Pearson's statistic after pooling.
#[derive(Debug, PartialEq)]
struct Pearson {
    statistic: f64,
    /// Cells after pooling, minus one.
    dof: usize,
    /// Cells merged into the pooled cell.
    pooled_cells: usize,
}

/// X² = Σ (O − E)²/E over the cells with E > 0, sorted by E; cells with E < 5 are pooled into one
/// cell, which keeps absorbing the next cells until its own E reaches 5 (pbrt-v3's `Chi2Test`;
/// Mitsuba's `chi2` does the same). Cells with E = 0 are skipped: samples there are rejected
/// before this is called.
fn pearson_pooled(observed: &[u64], expected: &[f64]) -> Pearson {
    let mut order: Vec<usize> = (0..expected.len()).filter(|&i| expected[i] > 0.0).collect();
    order.sort_by(|&i, &j| expected[i].total_cmp(&expected[j]));
    let (mut statistic, mut terms) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e, mut pooled_cells) = (0.0, 0.0, 0usize);
    for i in order {
        let (o, e) = (observed[i] as f64, expected[i]);
        if e < MIN_EXPECTED || (pooled_cells > 0 && pooled_e < MIN_EXPECTED) {
            pooled_o += o;
            pooled_e += e;
            pooled_cells += 1;
        } else {
            statistic += (o - e) * (o - e) / e;
            terms += 1;
        }
    }
    if pooled_cells > 0 {
        statistic += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        terms += 1;
    }
    Pearson {
        statistic,
        dof: terms.saturating_sub(1),
        pooled_cells,
    }
}

/// Applies the immediate-failure rules and Pearson's test, and dumps the tables on failure.
fn conclude(
    tables: Tables,
    describe: impl Fn(usize) -> String,
    mut problems: Vec<String>,
    alpha: f64,
) -> Chi2Result {
    let stray: Vec<usize> = (0..tables.observed.len())
        .filter(|&c| tables.expected[c] == 0.0 && tables.observed[c] > 0)
        .collect();
    if let Some(&first) = stray.first() {
        problems.push(format!(
            "{} samples in {} cells where the pdf integrates to zero; the first: {} samples in {}",
            stray.iter().map(|&c| tables.observed[c]).sum::<u64>(),
            stray.len(),
            tables.observed[first],
            describe(first)
        ));
    }
    // Mitsuba's sanity bound: numerical integration may overshoot 1 a little, not by 10 %.
    if tables.pdf_mass > 1.1 {
        problems.push(format!(
            "the pdf integrates to {:.6} > 1 over the domain",
            tables.pdf_mass
        ));
    }
    let pearson = pearson_pooled(&tables.observed, &tables.expected);
    if pearson.dof == 0 {
        problems.push("fewer than 2 cells after pooling: raise the sample count".into());
    }
    let p_value = if pearson.dof == 0 {
        f64::NAN
    } else {
        ChiSquared::new(pearson.dof as f64)
            .expect("dof ≥ 1")
            .sf(pearson.statistic)
    };
    // `p > α` is false for NaN, so a non-finite statistic fails.
    let passed = problems.is_empty() && p_value > alpha;
    let (table, table_error) = if passed {
        (None, None)
    } else {
        match write_tables(&tables) {
            Ok(path) => (Some(path), None),
            Err(e) => (None, Some(e.to_string())),
        }
    };
    if let Some(e) = table_error {
        problems.push(format!("could not write the tables: {e}"));
    }
    Chi2Result {
        name: tables.name,
        setup: tables.setup,
        p_value,
        alpha,
        statistic: pearson.statistic,
        dof: pearson.dof,
        pooled_cells: pearson.pooled_cells,
        samples: tables.samples,
        accepted: tables.accepted,
        pdf_mass: tables.pdf_mass,
        rows: tables.rows,
        cols: tables.cols,
        observed: tables.observed,
        expected: tables.expected,
        problems,
        table,
    }
}

/// Writes `target/chi2/<name>.txt`: the observed block, then the expected block.
fn write_tables(tables: &Tables) -> std::io::Result<PathBuf> {
    use std::fmt::Write as _;
    let dir = target_dir().join("chi2");
    std::fs::create_dir_all(&dir)?;
    let file: String = tables
        .name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let path = dir.join(format!("{file}.txt"));
    let mut text = String::new();
    let mut block = |title: &str, value: &dyn Fn(usize) -> String| {
        let _ = writeln!(
            text,
            "# chi2 `{}` {title}: {} rows × {} columns ({})",
            tables.name, tables.rows, tables.cols, tables.layout
        );
        for i in 0..tables.rows {
            let row: Vec<String> = (0..tables.cols)
                .map(|j| value(i * tables.cols + j))
                .collect();
            let _ = writeln!(text, "{}", row.join(" "));
        }
    };
    block("observed counts", &|c| tables.observed[c].to_string());
    block("expected counts", &|c| format!("{:.6}", tables.expected[c]));
    std::fs::write(&path, text)?;
    Ok(path)
}

/// `$CARGO_TARGET_DIR` (relative paths taken from the workspace root), else `target/` in the
/// workspace root: the nearest ancestor of the running package's `CARGO_MANIFEST_DIR` whose
/// `Cargo.toml` has a `[workspace]` table.
fn target_dir() -> PathBuf {
    let manifest = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    let root = manifest
        .ancestors()
        .find(|dir| {
            std::fs::read_to_string(dir.join("Cargo.toml"))
                .is_ok_and(|toml| toml.lines().any(|l| l.trim() == "[workspace]"))
        })
        .unwrap_or(&manifest)
        .to_path_buf();
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) if Path::new(&dir).is_absolute() => PathBuf::from(dir),
        Some(dir) => root.join(dir),
        None => root.join("target"),
    }
}

/// The outcome of a chi-square test. [`assert_ok`](Chi2Result::assert_ok) panics with
/// [`Display`](fmt::Display)'s report unless it passed.
#[derive(Clone, Debug)]
pub struct Chi2Result {
    pub name: String,
    /// Domain, resolution and seed, for the report.
    pub setup: String,
    /// P(χ²_dof ≥ statistic); NaN when fewer than 2 cells remain after pooling.
    pub p_value: f64,
    pub alpha: f64,
    /// Pearson's X² after pooling.
    pub statistic: f64,
    pub dof: usize,
    /// Cells merged into the pooled cell (0 when none was expected below 5).
    pub pooled_cells: usize,
    /// Draws made, including rejected ones.
    pub samples: u64,
    /// Draws that returned a sample (valid or not).
    pub accepted: u64,
    /// ∫ pdf over the domain: the expected acceptance rate.
    pub pdf_mass: f64,
    pub rows: usize,
    pub cols: usize,
    /// Row-major observed counts.
    pub observed: Vec<u64>,
    /// Row-major expected counts.
    pub expected: Vec<f64>,
    /// Reasons for rejection independent of the p-value.
    pub problems: Vec<String>,
    /// Where the tables were written (only on failure).
    pub table: Option<PathBuf>,
}

impl Chi2Result {
    /// No immediate failure and p > α (false for a NaN p-value).
    pub fn passed(&self) -> bool {
        self.problems.is_empty() && self.p_value > self.alpha
    }

    /// Panics with the report unless the test passed.
    #[track_caller]
    pub fn assert_ok(&self) {
        if !self.passed() {
            panic!("{self}");
        }
    }
}

impl fmt::Display for Chi2Result {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verdict = if self.passed() { "passed" } else { "FAILED" };
        writeln!(f, "chi2 test `{}` {verdict} ({})", self.name, self.setup)?;
        writeln!(
            f,
            "  {} draws, {} samples returned ({:.6} of draws), pdf integrates to {:.6}",
            self.samples,
            self.accepted,
            self.accepted as f64 / self.samples as f64,
            self.pdf_mass
        )?;
        let pooled = if self.pooled_cells > 0 {
            format!(
                ", {} cells expected below {MIN_EXPECTED} pooled into one",
                self.pooled_cells
            )
        } else {
            String::new()
        };
        writeln!(
            f,
            "  X² = {:.2}, {} degrees of freedom{pooled}: p = {:.4e}, α = {:.4e}",
            self.statistic, self.dof, self.p_value, self.alpha
        )?;
        for problem in &self.problems {
            writeln!(f, "  rejected: {problem}")?;
        }
        if let Some(path) = &self.table {
            writeln!(
                f,
                "  observed and expected tables: {} (numpy.loadtxt(path).reshape(2, {}, {}))",
                path.display(),
                self.rows,
                self.cols
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightlab_samplers::warp::*;

    #[test]
    fn correct_warps_pass() {
        Chi2Test::new(Domain::Hemisphere)
            .run(
                "testkit_cosine_hemisphere",
                |u| Some(square_to_cosine_hemisphere(u)),
                square_to_cosine_hemisphere_pdf,
            )
            .assert_ok();
        Chi2Test::new(Domain::Disk)
            .seed(3)
            .run(
                "testkit_concentric_disk",
                |u| Some(square_to_concentric_disk(u)),
                square_to_concentric_disk_pdf,
            )
            .assert_ok();
    }

    #[test]
    fn uniform_cos_theta_fails_against_cosine_pdf() {
        let result = Chi2Test::new(Domain::Hemisphere).run(
            "testkit_wrong_hemisphere",
            |u| Some(square_to_uniform_hemisphere(u)),
            square_to_cosine_hemisphere_pdf,
        );
        assert!(!result.passed() && result.problems.is_empty(), "{result}");
        assert!(result.p_value < 1e-100, "{result}");
        // The tables were written for plotting: two blocks of `rows` lines of `cols` numbers.
        let path = result.table.as_ref().expect("tables written on failure");
        let text = std::fs::read_to_string(path).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(rows.len(), 2 * result.rows);
        assert!(
            rows.iter()
                .all(|r| r.split_whitespace().count() == result.cols)
        );
        let panic = std::panic::catch_unwind(|| result.assert_ok()).unwrap_err();
        let message = panic.downcast_ref::<String>().unwrap();
        assert!(
            message.contains("testkit_wrong_hemisphere.txt"),
            "{message}"
        );
    }

    #[test]
    fn ten_percent_density_error_fails() {
        // Uniform disk samples against (0.9 + 0.2 r²)/π, which also integrates to 1.
        let result = Chi2Test::new(Domain::Disk).run(
            "testkit_tilted_disk",
            |u| Some(square_to_concentric_disk(u)),
            |p: Vec2| (0.9 + 0.2 * p.length_squared()) / std::f32::consts::PI,
        );
        assert!(!result.passed(), "{result}");
    }

    #[test]
    fn samples_where_the_pdf_is_zero_fail_naming_the_cell() {
        // Full-sphere samples against the upper-hemisphere density.
        let result = Chi2Test::new(Domain::Sphere).run(
            "testkit_sphere_vs_hemisphere",
            |u| Some(square_to_uniform_sphere(u)),
            square_to_uniform_hemisphere_pdf,
        );
        assert!(!result.passed());
        let problem = &result.problems[0];
        assert!(
            problem.contains("pdf integrates to zero") && problem.contains("θ ∈ ["),
            "{problem}"
        );
    }

    #[test]
    fn invalid_samples_fail() {
        let long = Chi2Test::new(Domain::Sphere).samples(1000).run(
            "testkit_not_unit",
            |u| Some(1.01 * square_to_uniform_sphere(u)),
            square_to_uniform_sphere_pdf,
        );
        assert!(
            long.problems[0].contains("1000 invalid samples")
                && long.problems[0].contains("unit length")
        );
        let outside = Chi2Test::new(Domain::Square).samples(1000).run(
            "testkit_outside_square",
            |u| Some(u * 1.5),
            |_| 1.0,
        );
        assert!(
            outside.problems[0].contains("outside the Square domain"),
            "{outside}"
        );
        let nan =
            Chi2Test::new(Domain::Square)
                .samples(1000)
                .run("testkit_nan_pdf", Some, |p: Vec2| {
                    if p.x < 0.5 { f32::NAN } else { 1.0 }
                });
        assert!(
            nan.problems.iter().any(|p| p.contains("the pdf is NaN")),
            "{nan}"
        );
    }

    #[test]
    fn rejected_samples_are_missing_pdf_mass() {
        // 30 % of draws are rejected; the pdf must integrate to 0.7.
        let sample = |u_lobe: f32, u: Vec2| (u_lobe >= 0.3).then(|| square_to_cosine_hemisphere(u));
        let test = Chi2Test::new(Domain::Hemisphere).seed(5);
        let right = test.run_lobe("testkit_lossy", sample, |v| {
            0.7 * square_to_cosine_hemisphere_pdf(v)
        });
        right.assert_ok();
        assert!((right.pdf_mass - 0.7).abs() < 1e-4 && right.accepted < right.samples);
        let wrong = test.run_lobe(
            "testkit_lossy_wrong",
            sample,
            square_to_cosine_hemisphere_pdf,
        );
        assert!(!wrong.passed(), "{wrong}");
    }

    #[test]
    fn pooling_merges_cells_expected_below_five() {
        // Sorted by expected: 0.5, 1, 1.5, 3 are pooled (6 ≥ 5 after the fourth), 0 is skipped.
        let observed = [0, 2, 1, 1, 4, 90, 110];
        let expected = [0.0, 0.5, 1.0, 1.5, 3.0, 100.0, 100.0];
        let pearson = pearson_pooled(&observed, &expected);
        let want = (8.0f64 - 6.0).powi(2) / 6.0 + 1.0 + 1.0;
        assert!((pearson.statistic - want).abs() < 1e-12, "{pearson:?}");
        assert_eq!((pearson.dof, pearson.pooled_cells), (2, 4));
        // Pooling keeps absorbing until the pooled cell reaches 5: 4 + 4 > 5 absorbs a cell ≥ 5.
        let pearson = pearson_pooled(&[3, 5, 7], &[4.0, 6.0, 7.0]);
        assert_eq!((pearson.dof, pearson.pooled_cells), (1, 2));
    }

    #[test]
    fn sparse_tables_pass_with_pooling() {
        // Density 4xy on the square by inversion (x = √u₁, y = √u₂): 20 000 samples over 1640
        // cells leave many cells near the origin expected below 5.
        let result = Chi2Test::new(Domain::Square).samples(20_000).run(
            "testkit_sparse",
            |u| Some(Vec2::new(u.x.sqrt(), u.y.sqrt())),
            |p: Vec2| 4.0 * p.x * p.y,
        );
        result.assert_ok();
        assert!(result.pooled_cells > 100, "{result}");
        assert!(result.dof < result.rows * result.cols - 100, "{result}");
    }

    #[test]
    fn support_edge_inside_cells_is_integrated_accurately() {
        // A disk of radius 0.3 inside the unit square: its edge crosses cells at every angle.
        let center = Vec2::splat(0.5);
        let result = Chi2Test::new(Domain::Square).run(
            "testkit_disk_in_square",
            |u| Some(center + 0.3 * square_to_concentric_disk(u)),
            |p: Vec2| {
                if (p - center).length_squared() <= 0.09 {
                    1.0 / (std::f32::consts::PI * 0.09)
                } else {
                    0.0
                }
            },
        );
        result.assert_ok();
    }

    /// The unit triangle's density, 2 on x + y ≤ 1.
    fn triangle_pdf(p: Vec2) -> f32 {
        if p.x + p.y <= 1.0 { 2.0 } else { 0.0 }
    }

    #[test]
    fn support_clipping_a_cell_corner_gets_its_mass() {
        // On the 41 × 40 grid the diagonal x + y = 1 misses the corner (39/40, 1/41) of cell
        // (row 1, col 39) by g = 1/1640, clipping a triangle of area g²/2 between the probes.
        let result = Chi2Test::new(Domain::Square).run(
            "testkit_clipped_corner",
            |u| Some(square_to_uniform_triangle(u)),
            triangle_pdf,
        );
        let g = 1.0 / 1640.0;
        let want = 1e6 * 2.0 * g * g / 2.0;
        let got = result.expected[40 + 39];
        assert!(
            (got - want).abs() < 0.02 * want,
            "expected {got}, want {want}"
        );
    }

    #[test]
    fn support_entering_a_cell_between_probes_is_found() {
        // A disk of radius 0.025 at (0.55, 0.52) dips 0.005 below y = 0.5 into row 4 of a 10 × 10
        // grid, between that cell's midpoints (the nearest 1/120 below its edge) and corners.
        let (center, radius) = (Vec2::new(0.55, 0.52), 0.025);
        let result = Chi2Test::new(Domain::Square)
            .resolution(10, 10)
            .samples(100_000)
            .run(
                "testkit_dipping_disk",
                |u| Some(center + radius * square_to_concentric_disk(u)),
                |p: Vec2| {
                    if (p - center).length_squared() <= radius * radius {
                        1.0 / (std::f32::consts::PI * radius * radius)
                    } else {
                        0.0
                    }
                },
            );
        result.assert_ok();
        assert!(result.observed[4 * 10 + 5] > 4000, "{:?}", result.observed);
    }

    #[test]
    fn support_poking_between_the_probes_gets_a_second_look() {
        // A triangle whose tip pokes 0.0038 (1/26 of a row) into row 4 of a 10 × 10 grid as a
        // wedge at most 0.001 wide: no probe of the first pass (1/32 of a cell apart) falls in it.
        let [a, b, c] = [
            Vec2::new(0.5531, 0.4962),
            Vec2::new(0.52, 0.8),
            Vec2::new(0.60, 0.8),
        ];
        let area = 0.5 * (b - a).perp_dot(c - a).abs();
        let inside = move |p: Vec2| {
            let d = [
                (b - a).perp_dot(p - a),
                (c - b).perp_dot(p - b),
                (a - c).perp_dot(p - c),
            ];
            d.iter().all(|&x| x <= 0.0) || d.iter().all(|&x| x >= 0.0)
        };
        let result = Chi2Test::new(Domain::Square)
            .resolution(10, 10)
            .samples(200_000)
            .seed(7)
            .run(
                "testkit_poking_tip",
                |u| {
                    let t = square_to_uniform_triangle(u);
                    Some(a + t.x * (b - a) + t.y * (c - a))
                },
                |p: Vec2| if inside(p) { 1.0 / area } else { 0.0 },
            );
        result.assert_ok();
        let poke = 4 * 10 + 5;
        assert!(result.observed[poke] > 0, "{:?}", result.observed);
        let want = 200_000.0 * 0.5 * 0.0038 * 0.0038 * (0.08 / 0.3038) / area as f64;
        assert!(
            (result.expected[poke] / want - 1.0).abs() < 0.05,
            "{} vs {want}",
            result.expected[poke]
        );
    }

    #[test]
    fn tiny_cap_keeps_precision() {
        let cos_theta_max = 1.0 - 1e-6;
        Chi2Test::new(Domain::Cap { cos_theta_max })
            .run(
                "testkit_tiny_cap",
                |u| Some(square_to_uniform_cone(u, cos_theta_max)),
                |v| square_to_uniform_cone_pdf(v, cos_theta_max),
            )
            .assert_ok();
    }

    #[test]
    fn discrete_test_accepts_and_rejects() {
        let probabilities = [0.5, 0.25, 0.125, 0.125, 0.0];
        chi2_discrete(
            "testkit_discrete",
            &[5030, 2480, 1260, 1230, 0],
            &probabilities,
            1e-4,
        )
        .assert_ok();
        let wrong = chi2_discrete(
            "testkit_discrete_wrong",
            &[5400, 2300, 1150, 1150, 0],
            &probabilities,
            1e-4,
        );
        assert!(!wrong.passed() && wrong.problems.is_empty(), "{wrong}");
        let stray = chi2_discrete(
            "testkit_discrete_stray",
            &[5000, 2500, 1250, 1249, 1],
            &probabilities,
            1e-4,
        );
        assert!(stray.problems[0].contains("item 4"), "{stray}");
    }

    #[test]
    #[should_panic(expected = "does not take samples of type")]
    fn wrong_sample_type_panics() {
        Chi2Test::new(Domain::Sphere).run("testkit_type", Some, |_: Vec2| 1.0);
    }
}
