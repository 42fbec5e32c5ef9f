//! The transient's figures: the time histories (kinetic energy on a log scale, the
//! contact-zone normal velocity, the contact states) and the energy audit.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::scheme::{HistoryRow, Settings};
use crate::artifact::Figure;
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::StageError;

/// A labelled curve: a quantity of the history against time.
pub(super) type Curve<'a> = (&'a str, &'a dyn Fn(&HistoryRow) -> f64);

/// Most points drawn per curve (the rows are thinned evenly beyond).
const MAX_POINTS: usize = 4000;

pub(super) fn thinned(history: &[HistoryRow]) -> impl Iterator<Item = &HistoryRow> {
    let stride = history.len().div_ceil(MAX_POINTS).max(1);
    history.iter().step_by(stride)
}

/// Engineering labels, in exponent form below 0.01 (energies and velocities are small).
pub(super) fn axis_label(value: f64) -> String {
    if value != 0.0 && value.abs() < 1e-2 {
        format!("{value:.1e}")
    } else {
        plot::tick_label(value)
    }
}

pub(super) fn span(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (low, high) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), v| {
        (low.min(v), high.max(v))
    });
    if !low.is_finite() || !high.is_finite() {
        return -1.0..1.0;
    }
    let margin = 0.05
        * (high - low)
            .max(1e-300)
            .max(high.abs().max(low.abs()) * 1e-9);
    (low - margin)..(high + margin)
}

pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> DrawResult {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.3))
        .label_font((plot::FONT, 13))
        .draw()
        .map_err(drawing_error)
}

/// One panel: curves of `(label, values)` against time.
pub(super) fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    history: &[HistoryRow],
    title: &str,
    y_desc: &str,
    curves: &[Curve],
    log_scale: bool,
) -> DrawResult {
    let t_end = history.last().map_or(1.0, |row| row.t).max(1e-300);
    let values = || curves.iter().flat_map(|(_, f)| thinned(history).map(f));
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(title, (plot::FONT, 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(80);
    if log_scale {
        let top = values().fold(0.0, f64::max).max(1e-300) * 2.0;
        let floor = values()
            .filter(|value| *value > 0.0)
            .fold(top, f64::min)
            .max(top * 1e-16)
            / 2.0;
        let mut chart = builder
            .build_cartesian_2d(0.0..t_end, (floor..top).log_scale())
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(y_desc)
            .x_label_formatter(&|t| plot::tick_label(*t))
            .y_label_formatter(&|value| format!("{value:.0e}"))
            .label_style((plot::FONT, 13))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        for (idx, (label, f)) in curves.iter().enumerate() {
            let color = plot::series_color(idx);
            chart
                .draw_series(LineSeries::new(
                    thinned(history).map(|row| (row.t, f(row).max(floor))),
                    color.stroke_width(1),
                ))
                .map_err(drawing_error)?
                .label(*label)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
        }
        draw_legend(&mut chart)
    } else {
        let mut chart = builder
            .build_cartesian_2d(0.0..t_end, span(values()))
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(y_desc)
            .x_label_formatter(&|t| plot::tick_label(*t))
            .y_label_formatter(&|value| axis_label(*value))
            .label_style((plot::FONT, 13))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        for (idx, (label, f)) in curves.iter().enumerate() {
            let color = plot::series_color(idx);
            chart
                .draw_series(LineSeries::new(
                    thinned(history).map(|row| (row.t, f(row))),
                    color.stroke_width(1),
                ))
                .map_err(drawing_error)?
                .label(*label)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
        }
        draw_legend(&mut chart)
    }
}

struct HistoryPlot<'a> {
    history: &'a [HistoryRow],
    tau: f64,
}

impl Drawing for HistoryPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let panels = root.split_evenly((3, 1));
        panel(
            &panels[0],
            self.history,
            &format!("Transient (tau = {:.3e} s)", self.tau),
            "kinetic energy (J)",
            &[("kinetic", &|row: &HistoryRow| row.kinetic)],
            true,
        )?;
        panel(
            &panels[1],
            self.history,
            "Contact-zone averages of the relative velocity",
            "m/s",
            &[
                ("v_n", &|row: &HistoryRow| row.v_n),
                ("v_t", &|row: &HistoryRow| row.v_t),
            ],
            false,
        )?;
        contact_states_panel(&panels[2], self.history, "pairs", "slide")
    }
}

/// The panel of the shares of the contacts (`what`) open, sticking and sliding (`slide`
/// names the last) against time.
pub(super) fn contact_states_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    history: &[HistoryRow],
    what: &str,
    slide: &str,
) -> DrawResult {
    panel(
        area,
        history,
        "Contact states",
        &format!("fraction of {what}"),
        &[
            ("open", &|row: &HistoryRow| row.open),
            ("stick", &|row: &HistoryRow| row.stick),
            (slide, &|row: &HistoryRow| row.slide),
        ],
        false,
    )
}

struct EnergyPlot<'a> {
    history: &'a [HistoryRow],
}

impl Drawing for EnergyPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let panels = root.split_evenly((2, 1));
        panel(
            &panels[0],
            self.history,
            "Energy audit (from the sliding equilibrium)",
            "J",
            &[
                ("kinetic + strain", &|row: &HistoryRow| {
                    row.energy.kinetic + row.energy.strain
                }),
                ("drive + friction", &|row: &HistoryRow| {
                    row.energy.drive + row.energy.friction
                }),
                ("loads", &|row: &HistoryRow| row.energy.loads),
                ("normal (impacts)", &|row: &HistoryRow| row.energy.normal),
                ("-viscous", &|row: &HistoryRow| -row.energy.viscous),
                ("-scheme", &|row: &HistoryRow| -row.energy.scheme),
            ],
            false,
        )?;
        panel(
            &panels[1],
            self.history,
            "Balance error",
            "J",
            &[("balance error", &|row: &HistoryRow| {
                row.energy.balance_error
            })],
            false,
        )
    }
}

pub fn history(history: &[HistoryRow], settings: &Settings) -> Result<Figure, StageError> {
    plot::render(
        &HistoryPlot {
            history,
            tau: settings.tau,
        },
        (1000, 900),
    )
}

pub fn energy(history: &[HistoryRow]) -> Result<Figure, StageError> {
    plot::render(&EnergyPlot { history }, (1000, 760))
}
