//! The figure in the style of the paper's Figure 4: trial success against
//! compute and sample efficiency, log x axis.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::*;
use crate::metrics::Summary;

/// One marker of the plot.
struct Point {
    label: String,
    success: f64,
    compute: f64,
    sample: f64,
    paper: bool,
}

fn plot_points(summaries: &[Summary]) -> Vec<Point> {
    let mut points: Vec<Point> = with_means(summaries)
        .into_iter()
        .filter(|s| s.task.is_none())
        .map(|s| Point {
            label: display_method(&s.method),
            success: s.success_rate,
            compute: s.compute_efficiency,
            // Methods without demonstrations: training actions are their samples
            // (0, and so off the log axis, for oracle and random).
            sample: s.sample_efficiency.unwrap_or(if s.train_steps > 0 {
                s.success_rate / s.train_steps as f64
            } else {
                0.0
            }),
            paper: false,
        })
        .collect();
    // Per method the paper's mean, on its 50-trial protocol.
    for p in paper_results().into_iter().filter(|p| p.task.is_none()) {
        points.push(Point {
            label: format!("{} (paper)", p.method),
            success: p.success,
            compute: p.compute_efficiency(),
            sample: p.sample_efficiency(),
            paper: true,
        });
    }
    points
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, points: &[Point]) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((1, 2));
    type Axis = (&'static str, fn(&Point) -> f64);
    let axes: [Axis; 2] = [
        (
            "compute efficiency = success rate / (train steps + 1)",
            |p| p.compute,
        ),
        (
            "sample efficiency = success rate / annotated actions",
            |p| p.sample,
        ),
    ];
    for (panel, (xdesc, xof)) in panels.iter().zip(axes) {
        let xs: Vec<f64> = points
            .iter()
            .map(xof)
            .filter(|x| *x > 0.0 && x.is_finite())
            .collect();
        let lo = xs.iter().copied().fold(f64::INFINITY, f64::min).min(1e-3);
        let hi = xs.iter().copied().fold(0.0, f64::max).max(1.0);
        // Room on the right for the labels.
        let (lo, hi) = (lo / 3.0, hi * 30.0);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                "trial success vs. efficiency (mean over tasks)",
                ("sans-serif", 18),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d((lo..hi).log_scale(), 0.0..100.0)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(xdesc)
            .y_desc("trial success (%)")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
            .light_line_style(WHITE)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(err)?;
        let mut colour = 0;
        for p in points {
            let x = xof(p);
            if !(x > 0.0 && x.is_finite()) {
                continue;
            }
            let y = 100.0 * p.success;
            let c = if p.paper {
                RGBColor(150, 150, 150)
            } else {
                colour += 1;
                PALETTE[(colour - 1) % PALETTE.len()]
            };
            if p.paper {
                chart
                    .draw_series([TriangleMarker::new((x, y), 7, c.filled())])
                    .map_err(err)?;
            } else {
                chart
                    .draw_series([Circle::new((x, y), 7, c.filled())])
                    .map_err(err)?;
            }
            chart
                .draw_series([Text::new(
                    p.label.clone(),
                    (x * 1.15, y + 1.5),
                    ("sans-serif", 13).into_font().color(&c),
                )])
                .map_err(err)?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Draws the Figure-4-style plot: trial success (mean over tasks) against compute
/// efficiency and against sample efficiency, log x axes, one marker per method
/// (the paper's in grey triangles, seespot's in colour). Writes a PNG at `path`
/// with the embedded font ([`seespot_policy::font`]); should it fail to load,
/// an SVG beside it (`path` with extension `svg`). Returns the path written.
pub fn plot_figure4(summaries: &[Summary], path: &Path) -> Result<PathBuf, ReportError> {
    let points = plot_points(summaries);
    write_plot(
        path,
        (1400, 560),
        |root| draw(root, &points),
        |root| draw(root, &points),
    )
}

/// Draws a figure into a PNG at `path` with the embedded font
/// ([`seespot_policy::font`]), or, should the font fail to load, into an SVG
/// beside it (`path` with extension `svg`): `png` and `svg` draw the same
/// figure on either backend. Returns the path written.
fn write_plot(
    path: &Path,
    size: (u32, u32),
    png: impl FnOnce(DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
    svg: impl FnOnce(DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>,
) -> Result<PathBuf, ReportError> {
    let (out, result) = if seespot_policy::font::register().is_ok() {
        let out = path.to_path_buf();
        let r = png(BitMapBackend::new(&out, size).into_drawing_area());
        (out, r)
    } else {
        let out = path.with_extension("svg");
        let r = svg(SVGBackend::new(&out, size).into_drawing_area());
        (out, r)
    };
    result.map_err(|message| ReportError::Plot {
        path: out.display().to_string(),
        message,
    })?;
    Ok(out)
}

/// One embedding set's curve of the correspondence benchmark: the share of
/// SSR CCD's chosen actions within each tolerance of a right action
/// ([`crate::correspondence::TOLERANCES_MM`]), with Wilson intervals.
pub struct ToleranceCurve {
    pub label: String,
    pub shares: Vec<crate::correspondence::Share>,
}

fn draw_tolerance<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    curves: &[ToleranceCurve],
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let top = crate::correspondence::TOLERANCES_MM
        .last()
        .copied()
        .unwrap_or(50.0) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..top, 0.0..100.0)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("tolerance d (mm on the table, rotation aside)")
        .y_desc("SSR CCD's actions within d of a right action (%)")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y:.0}"))
        .light_line_style(WHITE)
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    for (i, c) in curves.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let at = |k: usize| crate::correspondence::TOLERANCES_MM[k] as f64;
        // The Wilson band, then the curve.
        let band: Vec<(f64, f64)> = (0..c.shares.len())
            .map(|k| (at(k), 100.0 * c.shares[k].high))
            .chain(
                (0..c.shares.len())
                    .rev()
                    .map(|k| (at(k), 100.0 * c.shares[k].low)),
            )
            .collect();
        chart
            .draw_series([Polygon::new(band, colour.mix(0.15).filled())])
            .map_err(err)?;
        let n = c.shares.first().map_or(0, |s| s.of);
        chart
            .draw_series(LineSeries::new(
                (0..c.shares.len()).map(|k| (at(k), 100.0 * c.shares[k].value)),
                colour.stroke_width(2),
            ))
            .map_err(err)?
            .label(format!("{} ({n} probe states)", c.label))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Draws the correspondence benchmark's accuracy at a tolerance: one curve
/// per set, with its Wilson 95% band. A PNG with the embedded font, or an
/// SVG beside `path` should the font fail to load; returns the path written.
pub fn plot_tolerance(
    title: &str,
    curves: &[ToleranceCurve],
    path: &Path,
) -> Result<PathBuf, ReportError> {
    write_plot(
        path,
        (900, 560),
        |root| draw_tolerance(root, title, curves),
        |root| draw_tolerance(root, title, curves),
    )
}
