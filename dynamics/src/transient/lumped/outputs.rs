//! What `transient.matrices` gives: the DOFs' and the contacts' histories, the energy audit,
//! the summary and their figures.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::super::contact::PairState;
use super::super::figure::{self, Curve, axis_label, draw_legend, panel, span};
use super::super::scheme::{HistoryRow, Run, Settings};
use super::super::{energy_figure_port, energy_port, energy_table, run_quantities};
use super::{LumpedParams, LumpedRun};
use crate::artifact::{Artifact, ArtifactType};
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::{Outputs, PortSpec, StageError};
use crate::table::Table;

/// Reads a quantity of a history row.
type Reader<'a> = Box<dyn Fn(&HistoryRow) -> f64 + 'a>;

/// Most points of the phase portrait's last fifth.
const LAST_POINTS: usize = 20_000;

/// Most DOFs drawn in the history figure (the table holds them all).
const MOST_CURVES: usize = 8;

pub(super) fn ports() -> Vec<PortSpec> {
    vec![
        PortSpec::one(
            "history",
            ArtifactType::Table,
            "t; q_D and v_D, displacement and velocity of each recorded DOF D",
        ),
        PortSpec::one(
            "contacts",
            ArtifactType::Table,
            "one row per contact and time: t, contact, gap, slip_t, slip_b, impulse_n, impulse_t, impulse_b (over the step), state (open, stick, slip)",
        ),
        energy_port(),
        PortSpec::one(
            "summary",
            ArtifactType::Table,
            "steps, contact solver figures, peak penetration, energy balance, shares of contact-steps open, sticking and slipping, the start mode",
        ),
        PortSpec::one(
            "history_figure",
            ArtifactType::Figure,
            "displacements, velocities and contact states against time",
        ),
        PortSpec::one(
            "phase_figure",
            ArtifactType::Figure,
            "phase portrait of phase_dof: velocity against displacement",
        ),
        energy_figure_port(),
    ]
}

/// Reads DOF `dof`'s displacement and velocity from history rows.
struct Dofs<'a> {
    lumped: &'a LumpedRun<'a>,
    /// The scheme's recorded unknowns (free DOF indices), ascending.
    recorded: Vec<usize>,
}

impl Dofs<'_> {
    fn at(&self, row: &HistoryRow, dof: usize) -> (f64, f64) {
        let lumped = self.lumped;
        match lumped.free.binary_search(&dof) {
            Ok(k) => {
                let slot = self
                    .recorded
                    .binary_search(&k)
                    .expect("every DOF read is recorded");
                let (u, v) = row.dofs[slot];
                (lumped.q_ref[k] + u, v)
            }
            Err(_) => {
                let d = lumped
                    .model
                    .driven
                    .iter()
                    .position(|(driven, _)| *driven == dof)
                    .expect("a DOF not free is driven");
                let velocity = lumped.model.driven[d].1;
                (lumped.q_driven[d] + velocity * row.t, velocity)
            }
        }
    }
}

fn state_name(state: PairState) -> &'static str {
    match state {
        PairState::Open => "open",
        PairState::Stick => "stick",
        PairState::Slide => "slip",
    }
}

pub(super) fn outputs(
    lumped: &LumpedRun,
    params: &LumpedParams,
    settings: &Settings,
    run: &Run,
) -> Result<Outputs, StageError> {
    let dofs = Dofs {
        lumped,
        recorded: settings.record_dofs.clone(),
    };
    let history = &run.history;
    let times: Vec<f64> = history.iter().map(|row| row.t).collect();
    let mut history_table = Table::new().with("t", times.clone());
    for &dof in &lumped.record_dofs {
        let values: Vec<(f64, f64)> = history.iter().map(|row| dofs.at(row, dof)).collect();
        history_table = history_table
            .with(
                format!("q_{dof}"),
                values.iter().map(|x| x.0).collect::<Vec<f64>>(),
            )
            .with(
                format!("v_{dof}"),
                values.iter().map(|x| x.1).collect::<Vec<f64>>(),
            );
    }
    let contacts = contacts_table(lumped, settings, history);
    let summary = summary(lumped, settings, run);
    let history_figure = plot::render(
        &HistoryPlot {
            history,
            dofs: &dofs,
            tau: settings.tau,
        },
        (1000, 900),
    )?;
    let phase_figure = plot::render(
        &PhasePlot {
            history,
            dofs: &dofs,
            dof: params.phase_dof,
        },
        (800, 700),
    )?;
    Ok(Outputs::from([
        ("history".to_string(), Artifact::Table(history_table)),
        ("contacts".to_string(), Artifact::Table(contacts)),
        ("energy".to_string(), Artifact::Table(energy_table(history))),
        ("summary".to_string(), Artifact::Table(summary)),
        (
            "history_figure".to_string(),
            Artifact::Figure(history_figure),
        ),
        ("phase_figure".to_string(), Artifact::Figure(phase_figure)),
        (
            "energy_figure".to_string(),
            Artifact::Figure(figure::energy(history)?),
        ),
    ]))
}

/// One row per contact and history row, contact after contact within a time.
fn contacts_table(lumped: &LumpedRun, settings: &Settings, history: &[HistoryRow]) -> Table {
    let n_contacts = lumped.contact_state.gap.len();
    let speeds = &lumped.contact_state.sliding_speed;
    let records = || {
        history.iter().flat_map(|row| {
            row.contacts
                .iter()
                .enumerate()
                .map(move |(c, record)| (row.t, c, record))
        })
    };
    let column = |f: &dyn Fn(usize, &super::super::scheme::PairRecord) -> f64| {
        records()
            .map(|(_, c, record)| f(c, record))
            .collect::<Vec<f64>>()
    };
    let tau = settings.tau;
    let table = Table::new()
        .with("t", records().map(|(t, _, _)| t).collect::<Vec<f64>>())
        .with(
            "contact",
            records().map(|(_, c, _)| c as i64).collect::<Vec<i64>>(),
        )
        .with("gap", column(&|_, record| record.gap))
        .with("slip_t", column(&|c, record| record.w[1] - speeds[c]))
        .with("slip_b", column(&|_, record| record.w[2]))
        .with("impulse_n", column(&|_, record| tau * record.r[0]))
        .with("impulse_t", column(&|_, record| tau * record.r[1]))
        .with("impulse_b", column(&|_, record| tau * record.r[2]))
        .with(
            "state",
            records()
                .map(|(_, _, record)| state_name(record.state).to_string())
                .collect::<Vec<String>>(),
        );
    debug_assert!(history.iter().all(|row| row.contacts.len() == n_contacts));
    table
}

fn summary(lumped: &LumpedRun, settings: &Settings, run: &Run) -> Table {
    let mut quantities = run_quantities(settings, run);
    let total: u64 = run.pair_steps.iter().flatten().sum();
    let share = |state: PairState| {
        let steps: u64 = run
            .pair_steps
            .iter()
            .map(|steps| steps[state as usize])
            .sum();
        if total > 0 {
            steps as f64 / total as f64
        } else {
            0.0
        }
    };
    let (growth, frequency, residual) =
        lumped
            .start_mode
            .map_or((f64::NAN, f64::NAN, f64::NAN), |(lambda, residual)| {
                (
                    lambda.re,
                    lambda.im / (2.0 * std::f64::consts::PI),
                    residual,
                )
            });
    quantities.extend([
        ("share_open", share(PairState::Open)),
        ("share_stick", share(PairState::Stick)),
        ("share_slip", share(PairState::Slide)),
        ("start_growth_rate", growth),
        ("start_frequency_hz", frequency),
        ("equilibrium_residual", residual),
    ]);
    Table::quantities(&quantities)
}

struct HistoryPlot<'a> {
    history: &'a [HistoryRow],
    dofs: &'a Dofs<'a>,
    tau: f64,
}

impl Drawing for HistoryPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let panels = root.split_evenly((3, 1));
        let shown: Vec<usize> = self
            .dofs
            .lumped
            .record_dofs
            .iter()
            .copied()
            .take(MOST_CURVES)
            .collect();
        let labels: Vec<[String; 2]> = shown
            .iter()
            .map(|dof| [format!("q_{dof}"), format!("v_{dof}")])
            .collect();
        let readers: Vec<[Reader; 2]> = shown
            .iter()
            .map(|&dof| -> [Reader; 2] {
                [
                    Box::new(move |row: &HistoryRow| self.dofs.at(row, dof).0),
                    Box::new(move |row: &HistoryRow| self.dofs.at(row, dof).1),
                ]
            })
            .collect();
        for (panel_index, (title, unit)) in [
            (format!("Displacements (tau = {:.3e} s)", self.tau), "m"),
            ("Velocities".to_string(), "m/s"),
        ]
        .into_iter()
        .enumerate()
        {
            let curves: Vec<Curve> = labels
                .iter()
                .zip(&readers)
                .map(|(label, reader)| {
                    (
                        label[panel_index].as_str(),
                        &*reader[panel_index] as &dyn Fn(&HistoryRow) -> f64,
                    )
                })
                .collect();
            panel(
                &panels[panel_index],
                self.history,
                &title,
                unit,
                &curves,
                false,
            )?;
        }
        figure::contact_states_panel(&panels[2], self.history, "contacts", "slip")
    }
}

struct PhasePlot<'a> {
    history: &'a [HistoryRow],
    dofs: &'a Dofs<'a>,
    dof: usize,
}

impl Drawing for PhasePlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        // The whole run thinned, in grey; its last fifth (a limit cycle, once there is one)
        // at up to LAST_POINTS points, in colour.
        let whole: Vec<(f64, f64)> = figure::thinned(self.history)
            .map(|row| self.dofs.at(row, self.dof))
            .collect();
        let last = &self.history[self.history.len() * 4 / 5..];
        let stride = last.len().div_ceil(LAST_POINTS).max(1);
        let final_fifth: Vec<(f64, f64)> = last
            .iter()
            .step_by(stride)
            .map(|row| self.dofs.at(row, self.dof))
            .collect();
        let (x_range, y_range) = (
            span(whole.iter().map(|p| p.0)),
            span(whole.iter().map(|p| p.1)),
        );
        // Ticks a hair from zero by round-off read as zero.
        let label = |range: &std::ops::Range<f64>| {
            let scale = 1e-9 * (range.end - range.start);
            move |value: &f64| axis_label(if value.abs() < scale { 0.0 } else { *value })
        };
        let (x_label, y_label) = (label(&x_range), label(&y_range));
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("Phase portrait of DOF {}", self.dof),
                (plot::FONT, 18),
            )
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x_range, y_range)
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc(format!("q_{} (m)", self.dof))
            .y_desc(format!("v_{} (m/s)", self.dof))
            .x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .label_style((plot::FONT, 13))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        let grey = RGBColor(170, 170, 170);
        chart
            .draw_series(LineSeries::new(whole, grey.stroke_width(1)))
            .map_err(drawing_error)?
            .label("the run")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], grey));
        let color = plot::series_color(0);
        chart
            .draw_series(LineSeries::new(final_fifth, color.stroke_width(1)))
            .map_err(drawing_error)?
            .label("its last fifth")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color));
        draw_legend(&mut chart)
    }
}
