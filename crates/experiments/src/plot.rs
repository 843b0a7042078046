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
//!   a factor (log: 5 % of the span in decades, and always at least one decade shown so that a tick
//!   label appears).
//! - A series with no plottable point keeps its legend entry, marked "(no data)". If no series has
//!   a plottable point, the result is still `Ok`: an SVG with the title, empty axes (range 0–1, or
//!   1–10 on a log axis) and a centred note "no data". `Err` is returned only if plotters fails.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
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
        match (plot.log_x, plot.log_y) {
            (false, false) => draw(&root, plot, &data, xr, yr)?,
            (true, false) => draw(&root, plot, &data, xr.log_scale(), yr)?,
            (false, true) => draw(&root, plot, &data, xr, yr.log_scale())?,
            (true, true) => draw(&root, plot, &data, xr.log_scale(), yr.log_scale())?,
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
        let span = h - l;
        // 5 % of the span, and at least one decade in all so a power of ten (a tick) is inside.
        let pad = (0.05 * span).max(0.5 * (1.0 - span));
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
        // A narrow log range still spans a decade.
        let (a, b) = axis_range([0.5, 0.8].into_iter(), true);
        assert!((b / a - 10.0).abs() < 1e-9, "{a} {b}");
        let (a, b) = axis_range([2.0, 2.0].into_iter(), false);
        assert!(a < 2.0 && b > 2.0);
        assert_eq!(axis_range(std::iter::empty(), false), (0.0, 1.0));
        assert_eq!(tick_label(&1000.0000000002), "1000");
        assert_eq!(tick_label(&1e-5), "1e-5");
        assert_eq!(tick_label(&0.30000000000000004), "0.3");
    }
}
