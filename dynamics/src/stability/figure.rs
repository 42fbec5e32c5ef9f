//! The stability diagram (divergence rate against frequency) and the coalescence figure of a
//! μ sweep (frequency and divergence rate against μ, one line per tracked mode).

use std::f64::consts::PI;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{EigenPair, divergence_rate, is_unstable};
use crate::artifact::Figure;
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::StageError;

const UNSTABLE: RGBColor = RGBColor(214, 39, 40);
const STABLE: RGBColor = RGBColor(120, 120, 120);

/// `(low, high)` of `values` with a margin, never empty.
fn span(values: impl Iterator<Item = f64>, include_zero: bool) -> std::ops::Range<f64> {
    let (mut low, mut high) = values
        .filter(|value| value.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), value| {
            (low.min(value), high.max(value))
        });
    if include_zero {
        low = low.min(0.0);
        high = high.max(0.0);
    }
    if !low.is_finite() {
        return -1.0..1.0;
    }
    let margin = 0.06 * (high - low).max(1e-9 * high.abs().max(1.0));
    (low - margin)..(high + margin)
}

struct Diagram<'a> {
    /// (frequency Hz, divergence rate %, unstable)
    points: Vec<(f64, f64, bool)>,
    title: &'a str,
}

impl Drawing for Diagram<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let x_range = span(self.points.iter().map(|point| point.0), true);
        let y_range = span(self.points.iter().map(|point| point.1), true);
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, (plot::FONT, 22))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(75)
            .build_cartesian_2d(x_range.clone(), y_range)
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("divergence rate 2 Re/Im (%)")
            .x_label_formatter(&|value| plot::tick_label(*value))
            .label_style((plot::FONT, 15))
            .axis_desc_style((plot::FONT, 16))
            .draw()
            .map_err(drawing_error)?;
        chart
            .draw_series(LineSeries::new(
                [(x_range.start, 0.0), (x_range.end, 0.0)],
                BLACK.stroke_width(1),
            ))
            .map_err(drawing_error)?;
        chart
            .draw_series(
                self.points
                    .iter()
                    .filter(|point| !point.2)
                    .map(|&(x, y, _)| Circle::new((x, y), 4, STABLE.stroke_width(1))),
            )
            .map_err(drawing_error)?
            .label("stable")
            .legend(|(x, y)| Circle::new((x, y), 4, STABLE.stroke_width(1)));
        chart
            .draw_series(
                self.points
                    .iter()
                    .filter(|point| point.2)
                    .map(|&(x, y, _)| Circle::new((x, y), 6, UNSTABLE.filled())),
            )
            .map_err(drawing_error)?
            .label("unstable")
            .legend(|(x, y)| Circle::new((x, y), 6, UNSTABLE.filled()));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((plot::FONT, 15))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(drawing_error)?;
        Ok(())
    }
}

/// Divergence rate (%) against frequency, unstable modes in red.
pub fn stability_diagram(pairs: &[EigenPair], mu: f64) -> Result<Figure, StageError> {
    let points: Vec<(f64, f64, bool)> = pairs
        .iter()
        .map(|pair| {
            (
                pair.lambda.im / (2.0 * PI),
                100.0 * divergence_rate(pair.lambda),
                is_unstable(pair.lambda),
            )
        })
        .collect();
    let unstable = points.iter().filter(|point| point.2).count();
    let title = format!(
        "Stability diagram, mu = {mu}: {} modes, {unstable} unstable",
        points.len()
    );
    plot::render(
        &Diagram {
            points,
            title: &title,
        },
        plot::DEFAULT_SIZE,
    )
}

/// One tracked mode across the sweep: (μ, frequency Hz, divergence rate %, unstable).
pub type Branch = Vec<(f64, f64, f64, bool)>;

struct Coalescence<'a> {
    branches: &'a [Branch],
    axis: &'a str,
}

impl Drawing for Coalescence<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let panels = root.split_evenly((2, 1));
        let all = || self.branches.iter().flatten();
        let x_range = span(all().map(|point| point.0), false);
        for (panel_idx, panel) in panels.iter().enumerate() {
            let value = |point: &(f64, f64, f64, bool)| {
                if panel_idx == 0 { point.1 } else { point.2 }
            };
            let y_range = span(all().map(value), panel_idx == 1);
            let mut chart = ChartBuilder::on(panel)
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(75)
                .build_cartesian_2d(x_range.clone(), y_range)
                .map_err(drawing_error)?;
            chart
                .configure_mesh()
                .x_desc(self.axis)
                .y_desc(if panel_idx == 0 {
                    "frequency (Hz)"
                } else {
                    "divergence rate (%)"
                })
                .y_label_formatter(&|value| plot::tick_label(*value))
                .label_style((plot::FONT, 14))
                .axis_desc_style((plot::FONT, 15))
                .draw()
                .map_err(drawing_error)?;
            for (branch_idx, branch) in self.branches.iter().enumerate() {
                let ever_unstable = branch.iter().any(|point| point.3);
                let color = if ever_unstable {
                    plot::series_color(branch_idx)
                } else {
                    RGBColor(170, 170, 170)
                };
                chart
                    .draw_series(LineSeries::new(
                        branch.iter().map(|point| (point.0, value(point))),
                        color.stroke_width(if ever_unstable { 2 } else { 1 }),
                    ))
                    .map_err(drawing_error)?;
                chart
                    .draw_series(
                        branch.iter().filter(|point| point.3).map(|point| {
                            Circle::new((point.0, value(point)), 4, UNSTABLE.filled())
                        }),
                    )
                    .map_err(drawing_error)?;
            }
        }
        Ok(())
    }
}

/// Frequency and divergence rate against the sweep axis, one line per tracked mode (modes
/// that become unstable in colour, red dots where unstable).
pub fn coalescence_figure(branches: &[Branch], axis: &str) -> Result<Figure, StageError> {
    plot::render(&Coalescence { branches, axis }, (1000, 900))
}
