//! `pareto`: run time against error over a sweep of reduction bases.
//!
//! Each point of the sweep brings its `compare` errors, the compute time of its reduced run
//! (the transient's `compute_s`) and, optionally, of its basis; the reference run brings its
//! own. The table has one row per point: the sweep coordinates, `run_s`, `build_s`,
//! `total_s = run_s + build_s`, `speed_up = reference_s / run_s` (the transient against the
//! full transient, as the seed paper counts it), `speed_up_total` (counting the basis), every
//! error column, and for each plotted error whether the point is on the Pareto front of
//! `total_s` against `|error|` (`1 − MAC` for a MAC; no other point is both faster and more
//! accurate).
//!
//! The figure plots, per error, `|error|` against `total_s` (log–log), the front joined, the
//! reference's run time as a vertical line; the points of a sweep over several axes are
//! grouped in series by every coordinate but the last (a colour each, joined, named in the
//! legend) and labelled by the last (a sweep over bases and time steps: one series per basis,
//! its points labelled by their step); and, when
//! the errors carry the runs' `residual_indicator` (compare's `candidate_summary`), each error
//! against the indicator: whether the estimate a reduced run makes of itself, without the
//! reference, orders the bases as their true errors do.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::artifact::{Artifact, ArtifactType};
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::{
    Coords, HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError, Value,
};
use crate::table::{ColumnData, Table};

pub struct Pareto;

crate::stage_params! {
    /// The parameters of `pareto`.
    pub struct ParetoParams {
        /// error columns plotted against run time
        errors: Vec<String> = ["freq_error", "level_error_db", "time_advance", "rms", "mac_min"]
            .map(String::from)
            .to_vec(),
    }
}

impl HasParams for Pareto {
    type Params = ParetoParams;
}

impl Stage for Pareto {
    fn kind(&self) -> &'static str {
        "pareto"
    }
    fn version(&self) -> u32 {
        // 3: a series by every coordinate but the last (CHANGELOG.md, "pareto")
        3
    }
    fn doc(&self) -> &'static str {
        "Run time against error over a sweep of bases: one table with speed-ups and errors, the Pareto fronts, and their figure"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::many(
                "errors",
                ArtifactType::Table,
                "the compare errors of every point",
            ),
            PortSpec::many(
                "run_times",
                ArtifactType::Table,
                "the reduced transient's compute_s of every point",
            ),
            PortSpec::many(
                "build_times",
                ArtifactType::Table,
                "the basis's compute_s of every point",
            )
            .optional(),
            PortSpec::one(
                "reference_time",
                ArtifactType::Table,
                "the reference transient's compute_s",
            ),
        ]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("table", "points"), ("figure", "fronts")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "points",
                ArtifactType::Table,
                "one row per point: coordinates, run_s, build_s, total_s, speed_up, speed_up_total, errors, front_<error>",
            ),
            PortSpec::one(
                "fronts",
                ArtifactType::Figure,
                "each error against the total run time, Pareto fronts joined",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let names = params.read::<Self>()?.errors;
        let reference_s = seconds(inputs.table("reference_time")?, "reference_time")?;
        let errors = inputs.many("errors")?;
        let run_times = inputs.many("run_times")?;
        let build_times = if inputs.0.contains_key("build_times") {
            Some(inputs.many("build_times")?)
        } else {
            None
        };
        let time_of = |points: &[(Coords, std::sync::Arc<Artifact>)],
                       coords: &Coords,
                       port: &str|
         -> Result<f64, StageError> {
            let (_, artifact) = points
                .iter()
                .find(|(other, _)| other == coords)
                .ok_or_else(|| StageError::new(format!("{port}: no point at {}", label(coords))))?;
            let table = artifact
                .as_table()
                .ok_or_else(|| StageError::new(format!("{port}: not a table")))?;
            seconds(table, port)
        };
        let mut rows: Vec<(Coords, Table)> = Vec::with_capacity(errors.len());
        for (coords, artifact) in errors {
            let table = artifact
                .as_table()
                .ok_or_else(|| StageError::new("errors: not a table"))?;
            if table.n_rows() != 1 {
                return Err(StageError::new(format!(
                    "errors at {}: {} rows, a compare table has one",
                    label(coords),
                    table.n_rows()
                )));
            }
            let run_s = time_of(run_times, coords, "run_times")?;
            let build_s = match build_times {
                Some(points) => time_of(points, coords, "build_times")?,
                None => 0.0,
            };
            let mut row = Table::new()
                .with("run_s", vec![run_s])
                .with("build_s", vec![build_s])
                .with("total_s", vec![run_s + build_s])
                .with("speed_up", vec![reference_s / run_s])
                .with("speed_up_total", vec![reference_s / (run_s + build_s)]);
            for column in table.columns() {
                row = row.with(column.name.clone(), column.data.clone());
            }
            rows.push((coords.clone(), row));
        }
        let points: Vec<(Coords, &Table)> = rows
            .iter()
            .map(|(coords, table)| (coords.clone(), table))
            .collect();
        let mut table = Table::gather(&points)?;
        let total = f64s(&table, "total_s")?;
        let mut panels = Vec::with_capacity(names.len());
        for name in &names {
            let values = distances(&table, name)?;
            let front = pareto_front(&total, &values);
            panels.push(Panel {
                name: shown_name(name),
                x: total.clone(),
                x_name: "run time (s)",
                errors: values,
                front: front.clone(),
            });
            table = table.with(format!("front_{name}"), front);
        }
        if let Ok(indicator) = f64s(&table, INDICATOR) {
            for name in names.iter().filter(|name| name.as_str() != INDICATOR) {
                let errors = distances(&table, name)?;
                panels.push(Panel {
                    name: shown_name(name),
                    x: indicator.clone(),
                    x_name: INDICATOR,
                    front: vec![false; errors.len()],
                    errors,
                });
            }
        }
        let mut series: Vec<String> = Vec::new();
        let mut series_of = Vec::with_capacity(rows.len());
        let mut labels = Vec::with_capacity(rows.len());
        for (coords, _) in &rows {
            let (name, point) = series_and_point(coords);
            let index = series
                .iter()
                .position(|other| *other == name)
                .unwrap_or_else(|| {
                    series.push(name);
                    series.len() - 1
                });
            series_of.push(index);
            labels.push(point);
        }
        let figure = plot::render(
            &ParetoFigure {
                labels: &labels,
                series: &series,
                series_of: &series_of,
                panels: &panels,
                reference_s,
            },
            (1000, 330 * panels.len().div_ceil(2).max(1) as u32),
        )?;
        Ok(Outputs::from([
            ("points".to_string(), Artifact::Table(table)),
            ("fronts".to_string(), Artifact::Figure(figure)),
        ]))
    }
}

/// The `compute_s` of a one-row table.
fn seconds(table: &Table, port: &str) -> Result<f64, StageError> {
    match table.column("compute_s") {
        Some(ColumnData::F64(values)) if values.len() == 1 => Ok(values[0]),
        _ => Err(StageError::new(format!(
            "{port}: expected a stage's compute_s output (one row, column compute_s)"
        ))),
    }
}

fn f64s(table: &Table, name: &str) -> Result<Vec<f64>, StageError> {
    match table.column(name) {
        Some(ColumnData::F64(values)) => Ok(values.clone()),
        Some(ColumnData::I64(values)) => Ok(values.iter().map(|v| *v as f64).collect()),
        _ => Err(StageError::new(format!(
            "errors: no numeric column `{name}`"
        ))),
    }
}

/// How far each point is from exact: `|error|`, or `1 − MAC` for a MAC (1 when exact).
fn distances(table: &Table, name: &str) -> Result<Vec<f64>, StageError> {
    let values = f64s(table, name)?;
    Ok(if name.starts_with("mac") {
        values.iter().map(|mac| 1.0 - mac).collect()
    } else {
        values.iter().map(|error| error.abs()).collect()
    })
}

/// The quantity [`distances`] gives, as a caption names it.
fn shown_name(name: &str) -> String {
    if name.starts_with("mac") {
        format!("1 − {name}")
    } else {
        format!("|{name}|")
    }
}

/// A point's label: its coordinates' values.
fn label(coords: &Coords) -> String {
    coords
        .iter()
        .map(|(_, value)| shown_value(value))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A coordinate's value, numbers far from 1 in exponent form (a time step reads `5e-6`, not
/// `0.000005`).
fn shown_value(value: &Value) -> String {
    match value {
        Value::Float(x) if *x != 0.0 && !(1e-3..1e6).contains(&x.abs()) => format!("{x:e}"),
        _ => value.to_string(),
    }
}

/// A point's series, named by every coordinate but the last (`name=value`), and its label,
/// the last coordinate's value. A sweep over one axis is one unnamed series.
fn series_and_point(coords: &Coords) -> (String, String) {
    match coords.split_last() {
        Some((last, others)) if !others.is_empty() => (
            others
                .iter()
                .map(|(name, value)| format!("{name}={}", shown_value(value)))
                .collect::<Vec<_>>()
                .join(", "),
            shown_value(&last.1),
        ),
        _ => (String::new(), label(coords)),
    }
}

/// An error axis's tick label, only at mantissas 1, 2 and 5: a log axis over one decade would
/// otherwise label every unit and the labels overlap.
fn error_tick_label(value: f64) -> String {
    let mantissa = value / 10f64.powf(value.log10().floor());
    let shown = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .any(|m| (mantissa - m).abs() < 1e-6 * m);
    if shown {
        format!("{value:.0e}")
    } else {
        String::new()
    }
}

/// Points no other point beats in both time and error (NaN errors are never on the front).
fn pareto_front(time: &[f64], error: &[f64]) -> Vec<bool> {
    (0..time.len())
        .map(|i| {
            !error[i].is_nan()
                && !(0..time.len()).any(|j| {
                    j != i
                        && time[j] <= time[i]
                        && error[j] <= error[i]
                        && (time[j] < time[i] || error[j] < error[i])
                })
        })
        .collect()
}

/// The a-posteriori estimate a transient's summary gives of a reduced run's error.
const INDICATOR: &str = "residual_indicator";

/// One error against the run time (with its front) or against the indicator.
struct Panel {
    name: String,
    x: Vec<f64>,
    x_name: &'static str,
    errors: Vec<f64>,
    front: Vec<bool>,
}

struct ParetoFigure<'a> {
    labels: &'a [String],
    /// The series' names, and each point's series.
    series: &'a [String],
    series_of: &'a [usize],
    panels: &'a [Panel],
    reference_s: f64,
}

impl Drawing for ParetoFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let rows = self.panels.len().div_ceil(2).max(1);
        let areas = root.split_evenly((rows, 2));
        for (k, (panel, area)) in self.panels.iter().zip(&areas).enumerate() {
            self.draw_panel(panel, area, k == 0)?;
        }
        Ok(())
    }
}

/// `[lo, hi]` widened by a factor for a log axis, for positive finite values.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if hi > 0.0 {
        (lo / 2.0, hi * 2.0)
    } else {
        (1e-6, 1.0)
    }
}

impl ParetoFigure<'_> {
    fn draw_panel<DB: DrawingBackend>(
        &self,
        panel: &Panel,
        area: &DrawingArea<DB, Shift>,
        with_legend: bool,
    ) -> DrawResult {
        let against_time = panel.x_name != INDICATOR;
        let reference = against_time.then_some(self.reference_s);
        let (t_lo, t_hi) = log_range(panel.x.iter().copied().chain(reference));
        let (e_lo, e_hi) = log_range(panel.errors.iter().copied());
        let caption = if against_time {
            format!("{} against run time", panel.name)
        } else {
            format!("{} against the indicator", panel.name)
        };
        let mut chart = ChartBuilder::on(area)
            .caption(caption, (plot::FONT, 16))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d((t_lo..t_hi).log_scale(), (e_lo..e_hi).log_scale())
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc(panel.x_name)
            .x_label_formatter(&|t| plot::tick_label(*t))
            .y_label_formatter(&|e| error_tick_label(*e))
            .label_style((plot::FONT, 12))
            .axis_desc_style((plot::FONT, 13))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        let shown = |i: usize| {
            panel.errors[i].is_finite()
                && panel.errors[i] > 0.0
                && panel.x[i].is_finite()
                && panel.x[i] > 0.0
        };
        let mut front: Vec<(f64, f64)> = (0..panel.x.len())
            .filter(|&i| panel.front[i] && shown(i))
            .map(|i| (panel.x[i], panel.errors[i]))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(front, BLACK.mix(0.6).stroke_width(3)))
            .map_err(drawing_error)?;
        if let Some(reference_s) = reference {
            chart
                .draw_series(LineSeries::new(
                    [(reference_s, e_lo), (reference_s, e_hi)],
                    BLACK.mix(0.5).stroke_width(1),
                ))
                .map_err(drawing_error)?;
        }
        for (k, name) in self.series.iter().enumerate() {
            let color = plot::series_color(k);
            let members: Vec<usize> = (0..panel.x.len())
                .filter(|&i| self.series_of[i] == k && shown(i))
                .collect();
            let mut line: Vec<(f64, f64)> = members
                .iter()
                .map(|&i| (panel.x[i], panel.errors[i]))
                .collect();
            line.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(line, color.mix(0.5).stroke_width(1)))
                .map_err(drawing_error)?;
            let points = chart
                .draw_series(members.iter().map(|&i| {
                    EmptyElement::at((panel.x[i], panel.errors[i]))
                        + Circle::new((0, 0), 4, color.filled())
                        + Text::new(
                            self.labels[i].clone(),
                            (6, -12),
                            (plot::FONT, 11).into_font(),
                        )
                }))
                .map_err(drawing_error)?;
            if !name.is_empty() {
                points
                    .label(name.as_str())
                    .legend(move |(x, y)| Circle::new((x, y), 4, color.filled()));
            }
        }
        if with_legend && self.series.len() > 1 {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerLeft)
                .label_font((plot::FONT, 11))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK.mix(0.3))
                .draw()
                .map_err(drawing_error)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::sync::Arc;

    use super::*;
    use crate::stage::Input;

    fn point(kind: &str, n: i64) -> Coords {
        vec![
            ("kind".to_string(), Value::Str(kind.to_string())),
            ("n_modes".to_string(), Value::Int(n)),
        ]
    }

    fn one_row(name: &str, value: f64) -> Arc<Artifact> {
        Arc::new(Artifact::Table(Table::new().with(name, vec![value])))
    }

    #[test]
    fn speed_ups_and_fronts_follow_from_the_times_and_errors() {
        // (kind, n, run time, error): fc 50 is fast and good, real 50 slower and worse.
        let cases = [
            ("fc", 50, 2.0, 0.01),
            ("fc", 100, 4.0, 0.001),
            ("real", 50, 3.0, 0.1),
        ];
        let errors = cases
            .iter()
            .map(|&(kind, n, _, error)| {
                let table = Table::new()
                    .with("freq_error", vec![error])
                    .with("rms", vec![-error])
                    .with("mac_min", vec![1.0 - 10.0 * error])
                    .with(INDICATOR, vec![0.3 * error]);
                (point(kind, n), Arc::new(Artifact::Table(table)))
            })
            .collect();
        let run_times = cases
            .iter()
            .map(|&(kind, n, time, _)| (point(kind, n), one_row("compute_s", time)))
            .collect();
        let inputs = Inputs(BTreeMap::from([
            ("errors".to_string(), Input::Many(errors)),
            ("run_times".to_string(), Input::Many(run_times)),
            (
                "reference_time".to_string(),
                Input::One(one_row("compute_s", 40.0)),
            ),
        ]));
        let params = Params(BTreeMap::from([(
            "errors".to_string(),
            Value::Str("freq_error, rms, mac_min".into()),
        )]));
        let outputs = Pareto.run(&params, &inputs).unwrap();
        let table = outputs["points"].as_table().unwrap();
        assert_eq!(f64s(table, "speed_up").unwrap(), [20.0, 10.0, 40.0 / 3.0]);
        let front = match table.column("front_rms") {
            Some(ColumnData::Bool(front)) => front.clone(),
            _ => panic!("no front column"),
        };
        assert_eq!(front, [true, true, false], "|rms| is compared");
        let front = match table.column("front_mac_min") {
            Some(ColumnData::Bool(front)) => front.clone(),
            _ => panic!("no front column"),
        };
        assert_eq!(front, [true, true, false], "1 − MAC is compared");
        assert!(matches!(table.column("kind"), Some(ColumnData::Str(_))));
        let Artifact::Figure(figure) = &outputs["fronts"] else {
            panic!("no figure");
        };
        assert!(figure.svg.contains("|rms| against run time"));
        assert!(figure.svg.contains("|rms| against the indicator"));
        assert!(figure.svg.contains("1 − mac_min against run time"));
        // A point without a run time is named.
        let mut missing = inputs.clone();
        missing.0.insert(
            "run_times".to_string(),
            Input::Many(vec![(point("fc", 50), one_row("compute_s", 1.0))]),
        );
        let message = Pareto.run(&params, &missing).unwrap_err().to_string();
        assert!(message.contains("fc 100"), "{message}");
    }

    /// A time step reads as one, and an error axis over a decade labels 1, 2 and 5 only.
    #[test]
    fn labels_and_ticks_read_at_a_glance() {
        let mut coords = point("fc", 400);
        coords.push(("tau".to_string(), Value::Float(5e-6)));
        coords.push(("mu".to_string(), Value::Float(0.38)));
        assert_eq!(label(&coords), "fc 400 5e-6 0.38");
        // Series by every coordinate but the last, which labels the point.
        assert_eq!(
            series_and_point(&coords),
            (
                "kind=fc, n_modes=400, tau=5e-6".to_string(),
                "0.38".to_string()
            )
        );
        assert_eq!(
            series_and_point(&point("fc", 400)[1..].to_vec()),
            (String::new(), "400".to_string())
        );
        assert_eq!(error_tick_label(2e-3), "2e-3");
        assert_eq!(error_tick_label(0.01), "1e-2");
        assert_eq!(error_tick_label(7e-3), "");
    }
}
