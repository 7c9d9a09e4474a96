//! The learning curve: one row per finished training trial, written as CSV and
//! drawn as a PNG with the embedded font ([`crate::font`]).

use std::path::{Path, PathBuf};

use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::PolicyError;

/// A named, coloured line of the plot.
type Line = (&'static str, RGBColor, Vec<(f32, f32)>);

/// One point of the learning curve, written when a training trial ends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveRow {
    /// Actions executed so far.
    pub action: usize,
    /// Trials finished so far.
    pub trial: usize,
    /// Whether this trial succeeded.
    pub success: bool,
    /// Trial success rate over the last `window` trials.
    pub success_rate: f32,
    /// Action efficiency (ideal / actual actions, 0 for a failed trial) over the
    /// last `window` trials.
    pub action_efficiency: f32,
    /// This trial's action efficiency (ideal / actual, 0 when it failed).
    #[serde(default)]
    pub trial_efficiency: f32,
    /// Mean training loss over the actions of this trial (NaN before training;
    /// JSON writes NaN as null, read back as NaN).
    #[serde(deserialize_with = "nan_if_null")]
    pub loss: f32,
    pub epsilon: f32,
    pub oracle_probability: f32,
}

fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    Ok(Option::<f32>::deserialize(d)?.unwrap_or(f32::NAN))
}

impl CurveRow {
    pub fn action_efficiency_trial(&self) -> f32 {
        self.trial_efficiency
    }
}

/// Writes the rows as CSV (one header line, then a row per trial).
pub fn write_csv(path: &Path, rows: &[CurveRow]) -> Result<(), PolicyError> {
    let csv_err = |e: csv::Error| PolicyError::io(path, std::io::Error::other(e));
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    w.write_record([
        "action",
        "trial",
        "success",
        "success_rate",
        "action_efficiency",
        "loss",
        "epsilon",
        "oracle_probability",
    ])
    .map_err(csv_err)?;
    for r in rows {
        w.write_record([
            r.action.to_string(),
            r.trial.to_string(),
            u8::from(r.success).to_string(),
            format!("{:.4}", r.success_rate),
            format!("{:.4}", r.action_efficiency),
            format!("{:.5}", r.loss),
            format!("{:.3}", r.epsilon),
            format!("{:.3}", r.oracle_probability),
        ])
        .map_err(csv_err)?;
    }
    w.flush().map_err(|e| PolicyError::io(path, e))
}

/// Draws success rate, action efficiency and loss against actions. Writes
/// `<stem>.png`, or `<stem>.svg` without text should the embedded font fail
/// to load. Returns the file written.
pub fn plot(stem: &Path, title: &str, rows: &[CurveRow]) -> Result<PathBuf, PolicyError> {
    let with_text = crate::font::register().is_ok();
    let path = stem.with_extension(if with_text { "png" } else { "svg" });
    let err = |e: String| PolicyError::Checkpoint {
        path: path.clone(),
        reason: format!("cannot draw the learning curve: {e}"),
    };
    let max_x = rows.last().map_or(1, |r| r.action.max(1)) as f32;
    let max_loss = rows
        .iter()
        .map(|r| r.loss)
        .filter(|l| l.is_finite())
        .fold(0.0f32, f32::max);
    let max_y = 1.0f32.max(max_loss * 1.05);
    let series = |f: &dyn Fn(&CurveRow) -> f32| -> Vec<(f32, f32)> {
        rows.iter()
            .filter(|r| f(r).is_finite())
            .map(|r| (r.action as f32, f(r)))
            .collect()
    };
    let lines = |_: ()| -> [Line; 3] {
        [
            ("trial success (window)", BLUE, series(&|r| r.success_rate)),
            (
                "action efficiency (window)",
                GREEN,
                series(&|r| r.action_efficiency),
            ),
            ("loss", RED, series(&|r| r.loss)),
        ]
    };
    let chart = Chart {
        title,
        with_text,
        max_x,
        max_y,
    };
    let drawn = if with_text {
        draw(
            BitMapBackend::new(&path, (900, 540)).into_drawing_area(),
            &chart,
            lines(()),
        )
    } else {
        draw(
            SVGBackend::new(&path, (900, 540)).into_drawing_area(),
            &chart,
            lines(()),
        )
    };
    drawn.map_err(err)?;
    Ok(path)
}

/// What a curve's chart shows besides its lines.
struct Chart<'a> {
    title: &'a str,
    with_text: bool,
    max_x: f32,
    max_y: f32,
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
    lines: [Line; 3],
) -> Result<(), String> {
    let Chart {
        title,
        with_text,
        max_x,
        max_y,
    } = *chart;
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut builder = ChartBuilder::on(&root);
    builder.margin(15);
    if with_text {
        builder
            .caption(title, ("sans-serif", 22))
            .x_label_area_size(40)
            .y_label_area_size(50);
    }
    let mut chart = builder
        .build_cartesian_2d(0f32..max_x, 0f32..max_y)
        .map_err(|e| e.to_string())?;
    if with_text {
        chart
            .configure_mesh()
            .x_desc("actions")
            .y_desc("rate / loss")
            .draw()
            .map_err(|e| e.to_string())?;
    }
    for (name, color, pts) in lines {
        let s = chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(|e| e.to_string())?;
        if with_text {
            s.label(name).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        }
    }
    if with_text {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}
