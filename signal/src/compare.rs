//! `compare`: a run (a reduced model's, say) beside a reference run, as errors a person can
//! weigh against the run time.
//!
//! Both runs are `transient` tables: `history` (t, u_n, u_t, v_n, v_t, kinetic, open, stick,
//! slide) and, optionally, `snapshots` with the `mass` on their rows, over the same time span
//! (their time steps may differ; their ends by a sample). Reported, in one row:
//!
//! - **Spectral peaks** of `column` (the kinetic energy by default, the seed's figure 4) over
//!   each run's final window: the reference's `n_peaks` highest peaks, each matched to the
//!   candidate's peak nearest in frequency. A peak's frequency and level are interpolated
//!   between bins (a parabola through the log power of the peak bin and its neighbours, exact
//!   for a Gaussian lobe), so frequency errors well below a bin are measured. `peak_k_hz`,
//!   `peak_k_freq_error` (relative), `peak_k_level_error_db` (candidate over reference), and
//!   the worst of each, `freq_error` and `level_error_db` (absolute).
//! - **Time advance** of the growth envelope: for kinetic-energy levels `K_f 10^{-j}`
//!   (`K_f` the reference's mean over its final window, `j = 1 … 4`, only levels above ten
//!   times its starting energy), the first time each run reaches the level, interpolated
//!   between samples; `time_advance` is the mean of `t_reference − t_candidate` (positive when
//!   the candidate grows earlier), over `advance_levels` levels (NaN when none applies).
//! - **RMS** of the difference of each contact-zone average over the common times, relative
//!   to the reference's RMS: `rms_u_n`, `rms_u_t`, `rms_v_n`, `rms_v_t`, and their worst,
//!   `rms`. The candidate is interpolated linearly onto the reference's times.
//! - **Contact states**: the mean fractions of open, sticking and sliding pairs over each final
//!   window, and their absolute differences `open_error`, `stick_error`, `slide_error`.
//! - **Principal shapes** (with snapshots): the mass-weighted SVD of each run's snapshots
//!   (as `svd_projection`); for each of the reference's first `n_shapes` shapes, the best MAC
//!   with the candidate's, `(ψ_rᵀ M ψ_c)²` (both `M`-normalised): `mac_k`, and `mac_min`.
//!
//! - **Residual indicator** (with the candidate's `summary`): its `residual_indicator`, the
//!   a-posteriori estimate a reduced run makes of its own error without the reference
//!   (`squeal_dynamics::transient::reduced`), beside the true errors it should track.
//!
//! A peak the candidate does not have gives NaN errors for it, and NaN worst errors.

use faer::Mat;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::spectrum::{Detrend, PowerSpectrum, Window, find_peaks, power_spectrum};
use super::svd_projection::{MassMatrix, mass_svd, snapshot_matrix};
use super::uniform_series;
use crate::artifact::{Artifact, ArtifactType};
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

/// The contact-zone averages compared by RMS.
const FIELDS: [&str; 4] = ["u_n", "u_t", "v_n", "v_t"];
/// Kinetic-energy levels of the envelope, as decades below the reference's final level.
const ENVELOPE_DECADES: [i32; 4] = [1, 2, 3, 4];
/// Candidate peaks searched per reference peak.
const CANDIDATE_PEAKS_PER_PEAK: usize = 3;

pub struct Compare;

crate::stage_params! {
    /// The parameters of `compare`.
    pub struct CompareParams {
        /// history column whose spectrum is compared
        column: String = "kinetic".into(),
        /// final window of the spectra and contact states (0: the last fifth of the reference)
        #[unit = "s"]
        #[min = 0.0]
        window_s: f64 = 0.0,
        /// reference peaks compared
        #[min = 1]
        n_peaks: usize = 3,
        /// peaks at most this far below the highest
        #[unit = "dB"]
        threshold_db: f64 = -30.0,
        /// principal shapes compared (with snapshots)
        #[min = 1]
        n_shapes: usize = 3,
    }
}

impl HasParams for Compare {
    type Params = CompareParams;
}

impl Stage for Compare {
    fn kind(&self) -> &'static str {
        "compare"
    }
    fn version(&self) -> u32 {
        // 2: runs over different time spans are refused (CHANGELOG.md, "compare")
        2
    }
    fn doc(&self) -> &'static str {
        "A transient run beside a reference: spectral peak frequencies and levels, time advance of the growth, RMS of the contact averages, contact states, MAC of the principal shapes"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "reference",
                ArtifactType::Table,
                "the reference run's history",
            ),
            PortSpec::one(
                "candidate",
                ArtifactType::Table,
                "the compared run's history",
            ),
            PortSpec::one(
                "reference_snapshots",
                ArtifactType::Table,
                "the reference run's snapshots",
            )
            .optional(),
            PortSpec::one(
                "candidate_snapshots",
                ArtifactType::Table,
                "the compared run's snapshots",
            )
            .optional(),
            PortSpec::one(
                "mass",
                ArtifactType::Table,
                "M on the snapshot rows (the transient's mass)",
            )
            .optional(),
            PortSpec::one(
                "candidate_summary",
                ArtifactType::Table,
                "the compared run's summary: its residual_indicator joins the errors",
            )
            .optional(),
        ]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("figure", "spectra")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "errors",
                ArtifactType::Table,
                "one row: peak frequencies and level errors, time advance, RMS, contact-state and MAC errors",
            ),
            PortSpec::one(
                "spectra",
                ArtifactType::Figure,
                "kinetic energy against time and the spectra of both runs",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: CompareParams = params.read::<Self>()?;
        let reference = Run::read(inputs.table("reference")?, "reference")?;
        let candidate = Run::read(inputs.table("candidate")?, "candidate")?;
        same_time_span(&reference, &candidate)?;
        let duration = reference.t[reference.t.len() - 1] - reference.t[0];
        let window_s = if params.window_s > 0.0 {
            params.window_s
        } else {
            0.2 * duration
        };
        let spectra = [&reference, &candidate]
            .map(|run| run.spectrum(&params.column, window_s))
            .into_iter()
            .collect::<Result<Vec<_>, _>>()?;
        let mut errors = Table::new();
        let n_peaks = params.n_peaks;
        let peaks = compare_peaks(&spectra[0], &spectra[1], n_peaks, params.threshold_db);
        let (mut freq_error, mut level_error) = (0.0_f64, 0.0_f64);
        for (k, peak) in peaks.iter().enumerate() {
            let k = k + 1;
            errors = errors
                .with(format!("peak_{k}_hz"), vec![peak.reference_hz])
                .with(format!("peak_{k}_freq_error"), vec![peak.freq_error])
                .with(
                    format!("peak_{k}_level_error_db"),
                    vec![peak.level_error_db],
                );
            // NaN propagates: a missing peak makes the worst error NaN.
            freq_error = nan_max(freq_error, peak.freq_error.abs());
            level_error = nan_max(level_error, peak.level_error_db.abs());
        }
        if peaks.is_empty() {
            return Err(StageError::new(format!(
                "the reference's `{}` has no spectral peak in its last {window_s} s",
                params.column
            )));
        }
        errors = errors
            .with("freq_error", vec![freq_error])
            .with("level_error_db", vec![level_error]);
        let (advance, levels) = time_advance(&reference, &candidate, window_s);
        errors = errors
            .with("time_advance", vec![advance])
            .with("advance_levels", vec![levels as i64]);
        let mut worst_rms = 0.0_f64;
        for field in FIELDS {
            let rms = relative_rms(&reference, &candidate, field)?;
            worst_rms = nan_max(worst_rms, rms);
            errors = errors.with(format!("rms_{field}"), vec![rms]);
        }
        errors = errors.with("rms", vec![worst_rms]);
        for state in ["open", "stick", "slide"] {
            let means = [&reference, &candidate]
                .map(|run| run.final_mean(state, window_s))
                .into_iter()
                .collect::<Result<Vec<_>, _>>()?;
            errors = errors
                .with(state.to_string(), vec![means[1]])
                .with(format!("{state}_error"), vec![(means[1] - means[0]).abs()]);
        }
        if let Some(macs) = shape_macs(inputs, params.n_shapes)? {
            let worst = macs.iter().copied().fold(1.0, f64::min);
            for (k, mac) in macs.iter().enumerate() {
                errors = errors.with(format!("mac_{}", k + 1), vec![*mac]);
            }
            errors = errors.with("mac_min", vec![worst]);
        }
        if let Some(summary) = inputs.get_optional::<Table>("candidate_summary")? {
            let indicator = summary.quantity("residual_indicator").ok_or_else(|| {
                StageError::new(
                    "candidate_summary: no `residual_indicator` (a transient's summary has it)",
                )
            })?;
            errors = errors.with("residual_indicator", vec![indicator]);
        }
        let figure = plot::render(
            &CompareFigure {
                runs: [&reference, &candidate],
                spectra: [&spectra[0], &spectra[1]],
                column: &params.column,
            },
            plot::DEFAULT_SIZE,
        )?;
        Ok(Outputs::from([
            ("errors".to_string(), Artifact::Table(errors)),
            ("spectra".to_string(), Artifact::Figure(figure)),
        ]))
    }
}

/// Runs over different spans would be compared over different final windows and envelopes:
/// refused. Their ends may differ by a sample (a step count rounded from the duration).
fn same_time_span(reference: &Run, candidate: &Run) -> Result<(), StageError> {
    let span = |run: &Run| (run.t[0], run.t[run.t.len() - 1]);
    let spacing = |run: &Run| run.t[1] - run.t[0];
    let (reference_span, candidate_span) = (span(reference), span(candidate));
    let slack = spacing(reference).max(spacing(candidate));
    if (reference_span.0 - candidate_span.0).abs() > slack
        || (reference_span.1 - candidate_span.1).abs() > slack
    {
        return Err(StageError::new(format!(
            "the reference runs from {:.6e} to {:.6e} s, the candidate from {:.6e} to {:.6e} s: compare runs over the same time span (give both transients the same duration)",
            reference_span.0, reference_span.1, candidate_span.0, candidate_span.1
        )));
    }
    Ok(())
}

/// `max`, NaN if either is.
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// A run's history.
struct Run<'a> {
    table: &'a Table,
    t: &'a [f64],
    kinetic: &'a [f64],
}

impl<'a> Run<'a> {
    fn read(table: &'a Table, which: &str) -> Result<Run<'a>, StageError> {
        let named = |err: StageError| StageError::new(format!("{which}: {err}"));
        let series = uniform_series(table, "kinetic").map_err(named)?;
        if series.len() < 8 {
            return Err(StageError::new(format!(
                "{which}: {} samples, too few to compare",
                series.len()
            )));
        }
        Ok(Run {
            table,
            t: table.f64("t").map_err(named)?,
            kinetic: series.values,
        })
    }

    /// First row of the final `window_s`.
    fn window_start(&self, window_s: f64) -> usize {
        let t_last = self.t[self.t.len() - 1];
        self.t
            .iter()
            .position(|&t| t >= t_last - window_s)
            .unwrap_or(0)
            .min(self.t.len() - 4)
    }

    fn spectrum(&self, column: &str, window_s: f64) -> Result<PowerSpectrum, StageError> {
        let series = uniform_series(self.table, column)?;
        let first = self.window_start(window_s);
        Ok(power_spectrum(
            &series.values[first..],
            series.dt,
            Window::Hann,
            Detrend::Mean,
        ))
    }

    fn final_mean(&self, column: &str, window_s: f64) -> Result<f64, StageError> {
        let values = &self.table.f64(column)?[self.window_start(window_s)..];
        Ok(values.iter().sum::<f64>() / values.len() as f64)
    }

    /// The first time the kinetic energy reaches `level`, between samples.
    fn first_reaching(&self, level: f64) -> Option<f64> {
        let row = self.kinetic.iter().position(|&k| k >= level)?;
        if row == 0 {
            return Some(self.t[0]);
        }
        let (k0, k1) = (self.kinetic[row - 1], self.kinetic[row]);
        let fraction = (level - k0) / (k1 - k0);
        Some(self.t[row - 1] + fraction * (self.t[row] - self.t[row - 1]))
    }
}

/// A reference peak and the candidate's nearest.
struct PeakError {
    reference_hz: f64,
    freq_error: f64,
    level_error_db: f64,
}

/// Frequency and level of the peak at bin `k`, from the parabola through the log power of
/// bins `k − 1`, `k`, `k + 1`.
fn interpolated_peak(spectrum: &PowerSpectrum, k: usize) -> (f64, f64) {
    let power = &spectrum.power;
    let df = spectrum.freqs_hz[1] - spectrum.freqs_hz[0];
    let [a, b, c] = [power[k - 1], power[k], power[k + 1]].map(|p| p.max(f64::MIN_POSITIVE).ln());
    let curvature = a - 2.0 * b + c;
    let offset = if curvature < 0.0 {
        (0.5 * (a - c) / curvature).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let level = (b - 0.25 * (a - c) * offset).exp();
    (spectrum.freqs_hz[k] + offset * df, level)
}

fn compare_peaks(
    reference: &PowerSpectrum,
    candidate: &PowerSpectrum,
    n_peaks: usize,
    threshold_db: f64,
) -> Vec<PeakError> {
    let candidate_peaks: Vec<(f64, f64)> = find_peaks(
        &candidate.power,
        threshold_db,
        CANDIDATE_PEAKS_PER_PEAK * n_peaks,
    )
    .into_iter()
    .map(|k| interpolated_peak(candidate, k))
    .collect();
    find_peaks(&reference.power, threshold_db, n_peaks)
        .into_iter()
        .map(|k| {
            let (f_ref, level_ref) = interpolated_peak(reference, k);
            let nearest = candidate_peaks
                .iter()
                .min_by(|a, b| (a.0 - f_ref).abs().total_cmp(&(b.0 - f_ref).abs()));
            match nearest {
                Some(&(f, level)) => PeakError {
                    reference_hz: f_ref,
                    freq_error: (f - f_ref) / f_ref,
                    level_error_db: 10.0 * (level / level_ref).log10(),
                },
                None => PeakError {
                    reference_hz: f_ref,
                    freq_error: f64::NAN,
                    level_error_db: f64::NAN,
                },
            }
        })
        .collect()
}

/// Mean `t_reference − t_candidate` over the envelope levels both runs reach, and how many.
fn time_advance(reference: &Run, candidate: &Run, window_s: f64) -> (f64, usize) {
    let first = reference.window_start(window_s);
    let final_level =
        reference.kinetic[first..].iter().sum::<f64>() / (reference.kinetic.len() - first) as f64;
    let floor = 10.0 * reference.kinetic[0];
    let advances: Vec<f64> = ENVELOPE_DECADES
        .iter()
        .map(|&decades| final_level * 10f64.powi(-decades))
        .filter(|&level| level > floor)
        .filter_map(|level| {
            Some(reference.first_reaching(level)? - candidate.first_reaching(level)?)
        })
        .collect();
    if advances.is_empty() {
        (f64::NAN, 0)
    } else {
        (
            advances.iter().sum::<f64>() / advances.len() as f64,
            advances.len(),
        )
    }
}

/// `‖c − r‖ / ‖r‖` (RMS over the reference's times inside the candidate's span), `c`
/// interpolated linearly.
fn relative_rms(reference: &Run, candidate: &Run, field: &str) -> Result<f64, StageError> {
    let r = reference.table.f64(field)?;
    let c = candidate.table.f64(field)?;
    let (t_c, dt_c) = (candidate.t, candidate.t[1] - candidate.t[0]);
    let (mut difference, mut norm) = (0.0, 0.0);
    for (&t, &r) in reference.t.iter().zip(r) {
        let position = (t - t_c[0]) / dt_c;
        if position < -1e-9 || position > (t_c.len() - 1) as f64 + 1e-9 {
            continue;
        }
        let nearest = position.round();
        let value = if (position - nearest).abs() < 1e-9 {
            // On a sample (the same time grid): the value itself, not an interpolation.
            c[nearest.max(0.0) as usize]
        } else {
            let row = (position.floor().max(0.0) as usize).min(t_c.len() - 2);
            let fraction = (position - row as f64).clamp(0.0, 1.0);
            c[row] + fraction * (c[row + 1] - c[row])
        };
        difference += (value - r).powi(2);
        norm += r * r;
    }
    Ok(if norm > 0.0 {
        (difference / norm).sqrt()
    } else {
        difference.sqrt()
    })
}

/// For each of the reference's first `n_shapes` principal shapes, the best MAC with the
/// candidate's; `None` without snapshots.
fn shape_macs(inputs: &Inputs, n_shapes: usize) -> Result<Option<Vec<f64>>, StageError> {
    let (Some(reference), Some(candidate)) = (
        inputs.get_optional::<Table>("reference_snapshots")?,
        inputs.get_optional::<Table>("candidate_snapshots")?,
    ) else {
        return Ok(None);
    };
    let mass = inputs.get_optional::<Table>("mass")?.ok_or_else(|| {
        StageError::new("the principal shapes are M-weighted: connect `mass` with the snapshots")
    })?;
    let X_r = snapshot_matrix(reference, 0)?;
    let X_c = snapshot_matrix(candidate, 0)?;
    if X_r.nrows() != X_c.nrows() {
        return Err(StageError::new(format!(
            "the snapshots have {} and {} rows: not the same model",
            X_r.nrows(),
            X_c.nrows()
        )));
    }
    let mass = MassMatrix::from_table(mass, X_r.nrows())?;
    let shapes_r = mass_svd(&X_r, &mass)?.shapes;
    let shapes_c = mass_svd(&X_c, &mass)?.shapes;
    let M_shapes_c = mass.apply_columns(&shapes_c);
    let overlaps: Mat<f64> = shapes_r.transpose() * &M_shapes_c;
    Ok(Some(
        (0..n_shapes.min(shapes_r.ncols()))
            .map(|k| {
                (0..overlaps.ncols())
                    .map(|j| overlaps[(k, j)].powi(2))
                    .fold(0.0, f64::max)
            })
            .collect(),
    ))
}

/// Kinetic energy against time (log scale) and the spectra, both runs.
struct CompareFigure<'a> {
    runs: [&'a Run<'a>; 2],
    spectra: [&'a PowerSpectrum; 2],
    column: &'a str,
}

impl Drawing for CompareFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
        self.draw_energy(&top)?;
        self.draw_spectra(&bottom)
    }
}

const LABELS: [&str; 2] = ["reference", "candidate"];

impl CompareFigure<'_> {
    fn draw_energy<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult {
        let positive = |run: &Run| {
            run.kinetic
                .iter()
                .copied()
                .filter(|k| *k > 0.0)
                .collect::<Vec<f64>>()
        };
        let highest = self
            .runs
            .iter()
            .flat_map(|run| positive(run))
            .fold(0.0, f64::max);
        let lowest = self
            .runs
            .iter()
            .flat_map(|run| positive(run))
            .fold(f64::INFINITY, f64::min);
        let (lowest, highest) = if highest > 0.0 {
            (lowest.max(highest * 1e-12), highest * 2.0)
        } else {
            (1e-12, 1.0)
        };
        let t_last = self
            .runs
            .iter()
            .map(|run| run.t[run.t.len() - 1])
            .fold(0.0, f64::max);
        let t_first = self.runs.iter().map(|run| run.t[0]).fold(t_last, f64::min);
        let mut chart = ChartBuilder::on(area)
            .caption("Kinetic energy", (plot::FONT, 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(t_first..t_last, (lowest..highest).log_scale())
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc("J")
            .x_label_formatter(&|t| plot::tick_label(*t))
            .y_label_formatter(&|k| format!("{k:.0e}"))
            .label_style((plot::FONT, 14))
            .axis_desc_style((plot::FONT, 15))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        for (idx, run) in self.runs.iter().enumerate() {
            let colour = plot::series_color(idx);
            chart
                .draw_series(LineSeries::new(
                    run.t
                        .iter()
                        .zip(run.kinetic)
                        .map(|(&t, &k)| (t, k.max(lowest))),
                    colour.stroke_width(1),
                ))
                .map_err(drawing_error)?
                .label(LABELS[idx])
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font((plot::FONT, 14))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(drawing_error)
    }

    fn draw_spectra<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult {
        let highest = self
            .spectra
            .iter()
            .flat_map(|spectrum| spectrum.power.iter().copied())
            .fold(0.0, f64::max);
        let top = if highest > 0.0 { highest * 3.0 } else { 1.0 };
        let floor = top * 1e-10;
        let f_last = self
            .spectra
            .iter()
            .map(|spectrum| spectrum.freqs_hz[spectrum.freqs_hz.len() - 1])
            .fold(0.0, f64::max);
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!("Power spectrum of {} over the final window", self.column),
                (plot::FONT, 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..f_last, (floor..top).log_scale())
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("power")
            .x_label_formatter(&|f| plot::tick_label(*f))
            .y_label_formatter(&|p| format!("{p:.0e}"))
            .label_style((plot::FONT, 14))
            .axis_desc_style((plot::FONT, 15))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        for (idx, spectrum) in self.spectra.iter().enumerate() {
            chart
                .draw_series(LineSeries::new(
                    spectrum
                        .freqs_hz
                        .iter()
                        .zip(&spectrum.power)
                        .map(|(&f, &p)| (f, p.max(floor))),
                    plot::series_color(idx).stroke_width(1),
                ))
                .map_err(drawing_error)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::f64::consts::PI;
    use std::sync::Arc;

    use super::*;
    use crate::stage::Input;
    use crate::table::ColumnData;

    /// A history: growth `e^{σ t}` (saturating at 1 from 20 ms) of an oscillation at `f_hz`,
    /// everything happening `delay` later.
    fn history(delay: f64, f_hz: f64, amplitude: f64) -> Table {
        let (dt, n, sigma) = (1e-5, 4000, 400.0);
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let envelope = |t: f64| amplitude * (sigma * (t - delay - 0.02)).exp().min(1.0);
        let field = |phase: f64| -> Vec<f64> {
            t.iter()
                .map(|&t| envelope(t) * (2.0 * PI * f_hz * (t - delay) + phase).sin())
                .collect()
        };
        let kinetic: Vec<f64> = t
            .iter()
            .map(|&t| envelope(t).powi(2) * (1.0 + 0.5 * (4.0 * PI * f_hz * (t - delay)).sin()))
            .collect();
        let constant = |value: f64| vec![value; n];
        Table::new()
            .with("t", t.clone())
            .with("u_n", field(0.0))
            .with("u_t", field(1.0))
            .with("v_n", field(2.0))
            .with("v_t", field(3.0))
            .with("kinetic", kinetic)
            .with("open", constant(0.25))
            .with("stick", constant(0.25))
            .with("slide", constant(0.5))
    }

    fn compare(reference: Table, candidate: Table) -> Table {
        let params = Params::defaults(&Compare, &[]);
        let inputs = Inputs(BTreeMap::from([
            (
                "reference".to_string(),
                Input::One(Arc::new(Artifact::Table(reference))),
            ),
            (
                "candidate".to_string(),
                Input::One(Arc::new(Artifact::Table(candidate))),
            ),
        ]));
        let outputs = Compare.run(&params, &inputs).unwrap();
        outputs["errors"].as_table().unwrap().clone()
    }

    fn value(table: &Table, name: &str) -> f64 {
        match table.column(name) {
            Some(ColumnData::F64(values)) => values[0],
            Some(ColumnData::I64(values)) => values[0] as f64,
            _ => panic!("no column {name}"),
        }
    }

    #[test]
    fn two_identical_runs_differ_by_nothing() {
        let errors = compare(history(0.0, 1234.0, 1.0), history(0.0, 1234.0, 1.0));
        for name in [
            "freq_error",
            "level_error_db",
            "time_advance",
            "rms",
            "open_error",
            "stick_error",
            "slide_error",
        ] {
            assert_eq!(value(&errors, name), 0.0, "{name}");
        }
        assert!(value(&errors, "advance_levels") >= 2.0);
        // The kinetic energy's peak: twice the field's frequency, found between bins
        // (a 0.008 s window: 125 Hz bins).
        let peak = value(&errors, "peak_1_hz");
        assert!((peak - 2468.0).abs() < 0.1 * 125.0, "{peak} Hz");
    }

    #[test]
    fn runs_over_different_time_spans_are_refused() {
        let reference = history(0.0, 1234.0, 1.0);
        let mut inputs = Inputs(BTreeMap::from([(
            "reference".to_string(),
            Input::One(Arc::new(Artifact::Table(reference.clone()))),
        )]));
        let t = reference.f64("t").unwrap();
        let keep = t.len() / 2;
        let mut shorter = Table::new();
        for column in reference.columns() {
            let ColumnData::F64(values) = &column.data else {
                panic!("f64 history")
            };
            shorter = shorter.with(column.name.clone(), values[..keep].to_vec());
        }
        inputs.0.insert(
            "candidate".to_string(),
            Input::One(Arc::new(Artifact::Table(shorter))),
        );
        let message = Compare
            .run(&Params::defaults(&Compare, &[]), &inputs)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("the candidate from 0.000000e0 to 1.999000e-2 s")
                && message.contains("same time span"),
            "{message}"
        );
    }

    #[test]
    fn a_copy_shifted_in_time_shows_the_shift() {
        let shift = 1.7e-3;
        let errors = compare(history(0.0, 1234.0, 1.0), history(shift, 1234.0, 1.0));
        let advance = value(&errors, "time_advance");
        // The candidate reaches each level `shift` later: a negative advance.
        assert!(
            (advance + shift).abs() < 1e-3 * shift,
            "advance {advance} s"
        );
        // Its final window sees the same saturated cycle: the same peaks.
        assert!(value(&errors, "freq_error").abs() < 1e-9);
        assert!(value(&errors, "rms") > 0.1);
    }

    #[test]
    fn a_detuned_quieter_run_shows_its_frequency_and_level_errors() {
        let errors = compare(history(0.0, 1234.0, 1.0), history(0.0, 1240.0, 0.5));
        let freq_error = value(&errors, "peak_1_freq_error");
        let expected = 1240.0 / 1234.0 - 1.0;
        // Within a tenth of the 0.5 % detuning, although it is a twentieth of a bin.
        assert!(
            (freq_error - expected).abs() < 0.1 * expected,
            "{freq_error:e} against {expected:e}"
        );
        let level = value(&errors, "peak_1_level_error_db");
        // Half the amplitude: a quarter of the energy, its oscillation 12 dB lower in power.
        assert!((level + 12.04).abs() < 0.5, "{level} dB");
    }
}
