//! SVG line plots of experiment results: error against samples (spp), error against time, and
//! efficiency plots, one curve per integrator or setting, with error bars from repeated runs.
//!
//! Rendering uses `plotters` with only its SVG backend (no `ttf`/`ab_glyph` feature): text is
//! written as SVG `<text font-family="sans-serif">` and laid out by plotters' built-in size
//! estimate, so no font files or system C libraries (fontconfig, freetype) are needed.
//! [`render_svg`] returns the document as a string; the caller writes it (atomically, see
//! [`crate::atomic`]).
//!
//! Data handling:
//! - A point is dropped if x or y is not finite or beyond ±[`LIMIT`] (1e100), or on a log axis is
//!   below 1/[`LIMIT`] (so also if it is not positive). An error bar whose half-width is not
//!   finite or not positive is not drawn; on a log axis a bar whose lower end is not positive (below
//!   1/[`LIMIT`]) runs to the bottom of the plot.
//! - Points are joined in the order given (sort them by x first for the usual curves); a dropped
//!   point is bridged by the line between its neighbours.
//! - Axis ranges cover all kept points and error-bar ends, padded by 5 % of the span (linear) or by
//!   a factor (log: 5 % of the span in decades, at least 0.05 decades).
//! - Log axes choose their own ticks ([`log_ticks`]): powers of ten over wide ranges, 1-2-5 steps
//!   over a few decades, every digit within about a decade, and evenly spaced round values when even
//!   that gives fewer than three — so any range gets at least three readable labels, never crowded
//!   into one another.
//! - A series with no plottable point keeps its legend entry, marked "(no data)". If no series has
//!   a plottable point, the result is still `Ok`: an SVG with the title, empty axes (range 0–1, or
//!   1–10 on a log axis) and a centred note "no data". `Err` is returned only if plotters fails.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One curve: points (x, y, y_err) with y_err the half-width of an error bar (0 for none).
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64, f64)>,
}

/// A line plot with any number of series; `log_x`/`log_y` select logarithmic axes.
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
}

/// Size of the SVG in pixels.
pub const SIZE: (u32, u32) = (800, 560);

/// Series colours, cycled (matplotlib's "tab10" order, first eight).
const PALETTE: [RGBColor; 8] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0x7f, 0x7f, 0x7f),
];

/// A kept point: x, y and the error bar's (low, high) ends, if it has one.
#[derive(Clone, Copy, Debug)]
struct Pt {
    x: f64,
    y: f64,
    bar: Option<(f64, f64)>,
}

/// Renders the plot as SVG text (no file I/O) — the caller writes it atomically.
pub fn render_svg(plot: &LinePlot) -> Result<String, String> {
    let data: Vec<Vec<Pt>> = plot
        .series
        .iter()
        .map(|s| plottable(&s.points, plot.log_x, plot.log_y))
        .collect();
    let x_range = axis_range(data.iter().flatten().map(|p| p.x), plot.log_x);
    let y_range = axis_range(
        data.iter().flatten().flat_map(|p| {
            let (lo, hi) = p.bar.unwrap_or((p.y, p.y));
            [p.y, lo, hi]
        }),
        plot.log_y,
    );

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (xr, yr) = (x_range.0..x_range.1, y_range.0..y_range.1);
        let xl = || LogAxis::new(x_range, X_SPACING);
        let yl = || LogAxis::new(y_range, Y_SPACING);
        match (plot.log_x, plot.log_y) {
            (false, false) => draw(&root, plot, &data, xr, yr)?,
            (true, false) => draw(&root, plot, &data, xl(), yr)?,
            (false, true) => draw(&root, plot, &data, xr, yl())?,
            (true, true) => draw(&root, plot, &data, xl(), yl())?,
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Draws everything on `root` with the given axis specs (linear ranges or `.log_scale()`).
fn draw<X, Y>(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    plot: &LinePlot,
    data: &[Vec<Pt>],
    x_spec: X,
    y_spec: Y,
) -> Result<(), String>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(&plot.title, ("sans-serif", 24))
        .margin(15)
        .margin_right(35) // room for the last x tick label
        .x_label_area_size(50)
        .y_label_area_size(75)
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(err)?;
    let y_min = chart.y_range().start;

    chart
        .configure_mesh()
        .x_desc(&plot.x_label)
        .y_desc(&plot.y_label)
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(BLACK.mix(0.05))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .draw()
        .map_err(err)?;

    let mut any_label = false;
    for (i, (series, pts)) in plot.series.iter().zip(data).enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let line = colour.stroke_width(2);
        let anno = chart
            .draw_series(LineSeries::new(pts.iter().map(|p| (p.x, p.y)), line))
            .map_err(err)?;
        if !series.label.is_empty() {
            any_label = true;
            let label = if pts.is_empty() {
                format!("{} (no data)", series.label)
            } else {
                series.label.clone()
            };
            anno.label(label).legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (20, 0)], line)
                    + Circle::new((10, 0), 3, colour.filled())
            });
        }
        chart
            .draw_series(
                pts.iter()
                    .map(|p| Circle::new((p.x, p.y), 3, colour.filled())),
            )
            .map_err(err)?;
        chart
            .draw_series(pts.iter().filter_map(|p| {
                let (lo, hi) = p.bar?;
                // On a log axis a non-positive lower end was kept as NaN: run to the bottom.
                let lo = if lo.is_nan() { y_min } else { lo };
                Some(ErrorBar::new_vertical(
                    p.x,
                    lo,
                    p.y,
                    hi,
                    colour.stroke_width(1),
                    6,
                ))
            }))
            .map_err(err)?;
    }

    if any_label {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .draw()
            .map_err(err)?;
    }

    if data.iter().all(|pts| pts.is_empty()) {
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let centre = ((xs.start + xs.end) / 2, (ys.start + ys.end) / 2);
        let style = ("sans-serif", 22)
            .into_font()
            .color(&BLACK.mix(0.6))
            .pos(Pos::new(HPos::Center, VPos::Center));
        root.draw(&Text::new("no data", centre, style))
            .map_err(err)?;
    }
    Ok(())
}

/// Largest magnitude drawn (log axes: also the smallest positive value is `1 / LIMIT`). plotters'
/// tick search loops forever when an axis span overflows (linear: `hi - lo`; log: `hi / lo`), so
/// values beyond it are dropped and error-bar ends clamped; the padded range then stays finite.
pub const LIMIT: f64 = 1e100;

/// The points of one series that can be drawn on the given axes (see the module doc).
fn plottable(points: &[(f64, f64, f64)], log_x: bool, log_y: bool) -> Vec<Pt> {
    let ok =
        |v: f64, log: bool| v.abs() <= LIMIT && if log { v >= 1.0 / LIMIT } else { !v.is_nan() };
    points
        .iter()
        .filter(|&&(x, y, _)| ok(x, log_x) && ok(y, log_y))
        .map(|&(x, y, e)| {
            let bar = (e.is_finite() && e > 0.0).then(|| {
                let (lo, hi) = (y - e, (y + e).min(LIMIT));
                // NaN marks "below the axis" on a log axis; resolved once the range is known.
                let lo = if log_y && !(lo >= 1.0 / LIMIT) {
                    f64::NAN
                } else {
                    lo.max(-LIMIT)
                };
                (lo, hi)
            });
            Pt { x, y, bar }
        })
        .collect()
}

/// The padded axis range covering `values` (NaNs are ignored); a default range if there are none.
/// Values are within `LIMIT` (and positive on a log axis), so the result is finite.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| !v.is_nan())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !(lo <= hi) {
        return if log { (1.0, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (l, h) = (lo.log10(), hi.log10());
        // 5 % of the span, at least 0.05 decades (a single value still gets a range).
        let pad = (0.05 * (h - l)).max(0.05);
        (10f64.powf(l - pad), 10f64.powf(h + pad))
    } else {
        // 5 % of the span, but at least a millionth of the magnitude (ticks stay distinct at the
        // labels' 9 significant digits) and 1 when everything is 0.
        let pad = (0.05 * (hi - lo)).max(1e-6 * lo.abs().max(hi.abs()));
        let pad = if pad > 0.0 { pad } else { 1.0 };
        (lo - pad, hi + pad)
    }
}

/// Tick labels: rounded to 9 significant digits (hides float noise such as 1000.0000000002),
/// plain between 1e-3 and 1e5, else scientific (`1e-5`, `2.5e6`) so log-axis labels stay short.
fn tick_label(v: &f64) -> String {
    let v: f64 = format!("{v:.8e}").parse().unwrap_or(*v);
    let a = v.abs();
    if a == 0.0 || (1e-3..1e5).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Smallest spacing of labelled ticks, as a fraction of the axis (x labels sit side by side and
/// need more room than y labels stacked above each other).
const X_SPACING: f64 = 0.09;
const Y_SPACING: f64 = 0.05;

/// A logarithmic axis over `lo..hi` with the ticks of [`log_ticks`].
#[derive(Clone, Debug)]
struct LogAxis {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl LogAxis {
    fn new((lo, hi): (f64, f64), spacing: f64) -> LogAxis {
        let ticks = log_ticks(lo, hi, spacing);
        // Grid lines at every digit between labelled powers of ten.
        let minor = if ticks
            .iter()
            .all(|t| (t.log10() - t.log10().round()).abs() < 1e-9)
        {
            digits(lo, hi)
        } else {
            Vec::new()
        };
        LogAxis {
            lo,
            hi,
            ticks,
            minor,
        }
    }
}

impl Ranged for LogAxis {
    type FormatOption = plotters::coord::ranged1d::NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let (l, h) = (self.lo.log10(), self.hi.log10());
        let t = (v.max(f64::MIN_POSITIVE).log10() - l) / (h - l);
        limit.0 + (t * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<H: plotters::coord::ranged1d::KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for LogAxis {
    fn format(v: &f64) -> String {
        tick_label(v)
    }
}

/// Every digit d·10^k (d = 1…9) within `lo..=hi`.
fn digits(lo: f64, hi: f64) -> Vec<f64> {
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (a..=b)
        .flat_map(|e| (1..=9).map(move |d| d as f64 * 10f64.powi(e)))
        .filter(|v| (lo..=hi).contains(v))
        .collect()
}

/// Labelled ticks of a log axis over `lo..=hi` (0 < lo < hi): the richest of every digit, 1-2-5
/// steps and powers of ten (every k-th over many decades) whose neighbours are at least `spacing`
/// of the axis apart, if it gives at least three ticks; otherwise (a range narrower than a digit's
/// step) evenly spaced round values, a 1-2-5 step apart.
fn log_ticks(lo: f64, hi: f64, spacing: f64) -> Vec<f64> {
    let span = (hi / lo).log10();
    let apart = |ticks: &[f64]| {
        ticks
            .windows(2)
            .all(|w| (w[1] / w[0]).log10() >= spacing * span)
    };
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let within = |set: &[f64], every: i32| -> Vec<f64> {
        (a..=b)
            .filter(|e| e.rem_euclid(every) == 0)
            .flat_map(|e| set.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|v| *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12))
            .collect()
    };
    // From the richest choice to the sparsest: the first that is not crowded.
    let digits = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];
    let candidates = [(&digits[..], 1), (&[1.0, 2.0, 5.0][..], 1)]
        .into_iter()
        .chain([1, 2, 5, 10, 20, 50].map(|every| (&[1.0][..], every)));
    let best = candidates
        .map(|(set, every)| within(set, every))
        .find(|t| apart(t) && (t.len() >= 3 || t.len() < 2));
    match best {
        Some(t) if t.len() >= 3 => t,
        _ => {
            // Evenly spaced round values: a 1-2-5 step giving 3–6 ticks.
            let raw = (hi - lo) / 4.0;
            let p = 10f64.powf(raw.log10().floor());
            let step = [1.0, 2.0, 5.0, 10.0]
                .iter()
                .map(|m| m * p)
                .find(|s| (hi - lo) / s <= 6.0)
                .unwrap_or(10.0 * p);
            let first = (lo / step).ceil() as i64;
            let last = (hi / step).floor() as i64;
            (first..=last).map(|k| k as f64 * step).collect()
        }
    }
}

fn err<E: std::fmt::Display>(e: E) -> String {
    format!("plot rendering failed: {e}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot(log: bool, series: Vec<Series>) -> LinePlot {
        LinePlot {
            title: "RMSE vs spp".into(),
            x_label: "samples per pixel".into(),
            y_label: "RMSE".into(),
            log_x: log,
            log_y: log,
            series,
        }
    }

    fn series(label: &str, points: Vec<(f64, f64, f64)>) -> Series {
        Series {
            label: label.into(),
            points,
        }
    }

    #[test]
    fn log_log_two_series_has_title_and_labels() {
        let pt: Vec<_> = (0..8)
            .map(|k| {
                let spp = 4f64.powi(k);
                (spp, 0.5 / spp.sqrt(), 0.05 / spp.sqrt())
            })
            .collect();
        let bdpt: Vec<_> = pt.iter().map(|&(x, y, e)| (x, 0.6 * y, 0.0 * e)).collect();
        let svg = render_svg(&plot(
            true,
            vec![series("path tracer", pt), series("BDPT", bdpt)],
        ))
        .unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(200)]);
        assert!(svg.trim_end().ends_with("</svg>"));
        for text in [
            "RMSE vs spp",
            "path tracer",
            "BDPT",
            "samples per pixel",
            "RMSE",
        ] {
            assert!(svg.contains(text), "missing {text:?}");
        }
        assert!(svg.contains("<text"));
        assert!(svg.contains("<circle"));
        assert!(!svg.contains("no data"));
        // Log tick labels are short powers of ten, not "10000.0".
        assert!(
            svg.contains(">\n1000\n<") || svg.contains(">1000<"),
            "no tick 1000"
        );
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn non_finite_and_non_positive_points_do_not_panic() {
        let bad = vec![
            (f64::NAN, 1.0, 0.1),
            (1.0, f64::INFINITY, 0.1),
            (f64::NEG_INFINITY, 1.0, 0.0),
            (0.0, 1.0, 0.1),
            (-3.0, 2.0, 0.1),
            (2.0, 0.0, 0.1),
            (3.0, -1.0, 0.1),
            (4.0, 0.5, f64::NAN),
            (5.0, 0.25, 1.0), // error bar below zero on a log axis
            (6.0, 0.2, f64::INFINITY),
            (7.0, 0.1, -0.05),
            (5e-324, 1e300, 1e308),
        ];
        for log in [false, true] {
            let svg = render_svg(&plot(
                log,
                vec![
                    series("bad", bad.clone()),
                    series("nan only", vec![(f64::NAN, f64::NAN, f64::NAN)]),
                ],
            ))
            .unwrap();
            assert!(svg.starts_with("<svg"));
            assert!(svg.contains("nan only (no data)"));
            assert!(!svg.contains("NaN"), "NaN in SVG (log = {log})");
        }
        let mut mixed = plot(
            false,
            vec![series(
                "extreme",
                vec![(-f64::MAX, -1e300, 0.0), (f64::MAX, 1e300, 0.0)],
            )],
        );
        assert!(render_svg(&mixed).unwrap().starts_with("<svg"));
        mixed.log_x = true;
        mixed.log_y = true;
        assert!(render_svg(&mixed).unwrap().contains("extreme (no data)"));
        // The widest ranges kept, and a span of one ulp.
        for (log, pts) in [
            (false, vec![(-LIMIT, -LIMIT, 1e308), (LIMIT, LIMIT, 1e308)]),
            (
                true,
                vec![(1.0 / LIMIT, 1.0 / LIMIT, 1.0), (LIMIT, LIMIT, 1e308)],
            ),
            (
                false,
                vec![
                    (1.0, 1.0, 0.0),
                    (1.0 + f64::EPSILON, 1.0 + f64::EPSILON, 0.0),
                ],
            ),
            (
                true,
                vec![
                    (1.0, 1.0, 0.0),
                    (1.0 + f64::EPSILON, 1.0 + f64::EPSILON, 0.0),
                ],
            ),
        ] {
            let svg = render_svg(&plot(log, vec![series("wide", pts)])).unwrap();
            assert!(svg.contains("wide") && !svg.contains("(no data)") && !svg.contains("NaN"));
        }
    }

    #[test]
    fn empty_plot_renders_axes_and_note() {
        for log in [false, true] {
            for s in [vec![], vec![series("empty", vec![]), series("", vec![])]] {
                let svg = render_svg(&plot(log, s)).unwrap();
                assert!(svg.starts_with("<svg"));
                assert!(svg.contains("no data"));
                assert!(svg.contains("RMSE vs spp"));
            }
        }
    }

    #[test]
    fn single_point_and_many_series_render() {
        let many: Vec<_> = (0..11)
            .map(|i| series(&format!("s{i}"), vec![(1.0, 1.0 + i as f64, 0.1)]))
            .collect();
        for log in [false, true] {
            let svg = render_svg(&plot(
                log,
                many.iter()
                    .map(|s| series(&s.label, s.points.clone()))
                    .collect(),
            ))
            .unwrap();
            assert!(svg.contains("s10"));
            let one = render_svg(&plot(
                log,
                vec![series(
                    "one",
                    vec![(0.0_f64.max(if log { 1.0 } else { 0.0 }), 0.7, 0.0)],
                )],
            ))
            .unwrap();
            assert!(one.contains("one") && !one.contains("no data"));
        }
    }

    #[test]
    fn axis_range_pads_and_covers() {
        let (a, b) = axis_range([1.0, 1e4].into_iter(), true);
        assert!(a < 1.0 && a > 0.5 && b > 1e4 && b < 2e4, "{a} {b}");
        // A narrow log range is padded by 5 % of its span (at least 0.05 decades).
        let (a, b) = axis_range([0.5, 0.8].into_iter(), true);
        assert!(a < 0.5 && a > 0.44 && b > 0.8 && b < 0.9, "{a} {b}");
        let (a, b) = axis_range([2.0, 2.0].into_iter(), false);
        assert!(a < 2.0 && b > 2.0);
        assert_eq!(axis_range(std::iter::empty(), false), (0.0, 1.0));
        assert_eq!(tick_label(&1000.0000000002), "1000");
        assert_eq!(tick_label(&1e-5), "1e-5");
        assert_eq!(tick_label(&0.30000000000000004), "0.3");
    }

    /// Every log axis gets at least three labels, within its range, far enough apart not to run
    /// into each other — the ranges plots met before, where labels went missing or collided: time
    /// 0.25–2 s (only "1" and "2"), MSE 0.003–0.05 (nothing below 0.01), spp 1–256 ("90100").
    #[test]
    fn log_ticks_are_readable_at_any_range() {
        for (lo, hi, spacing) in [
            (0.25, 2.0, X_SPACING),
            (0.003, 0.05, Y_SPACING),
            (0.9, 280.0, X_SPACING),
            (1e-9, 1e3, Y_SPACING),
            (1e-30, 1e30, X_SPACING),
            (0.5, 0.8, X_SPACING),
            (1.001, 1.002, Y_SPACING),
            (3.0e-3, 3.3e-3, X_SPACING),
            (7.0, 70.0, X_SPACING),
        ] {
            let t = log_ticks(lo, hi, spacing);
            assert!(t.len() >= 3, "{lo}..{hi}: {t:?}");
            assert!(
                t.iter().all(|v| *v >= lo * 0.999 && *v <= hi * 1.001),
                "{lo}..{hi}: {t:?}"
            );
            let span = (hi / lo).log10();
            for w in t.windows(2) {
                assert!(w[1] > w[0], "{lo}..{hi}: {t:?}");
                // Evenly spaced fallback ticks are ≥ a sixth of the range apart.
                let log_apart = (w[1] / w[0]).log10() / span;
                assert!(
                    log_apart >= spacing * 0.999 || (w[1] - w[0]) >= (hi - lo) / 6.5,
                    "{lo}..{hi}: {t:?}"
                );
            }
            let labels: Vec<String> = t.iter().map(tick_label).collect();
            let mut unique = labels.clone();
            unique.dedup();
            assert_eq!(unique.len(), labels.len(), "{lo}..{hi}: {labels:?}");
        }
        assert_eq!(
            log_ticks(0.9, 280.0, X_SPACING),
            vec![1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0]
        );
        let svg = render_svg(&plot(
            true,
            vec![series("t", vec![(0.25, 0.003, 0.0), (2.0, 0.05, 0.0)])],
        ))
        .unwrap();
        for label in ["0.5", "1", "2", "0.005", "0.01", "0.02", "0.05"] {
            assert!(
                svg.contains(&format!(">{label}<")) || svg.contains(&format!(">\n{label}\n<")),
                "no tick {label}"
            );
        }
    }
}
