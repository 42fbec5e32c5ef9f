//! `spectrum`: FFT power spectrum of one column over the last `window_s` seconds, its peaks,
//! and a figure.
//!
//! # Normalisation
//!
//! Over the last `n` samples `x_n` (detrended as asked), with window `w_n`:
//!
//! ```text
//! X_k     = Σ_n w_n x_n e^{−2πi k n / n}          k = 0 … ⌊n/2⌋,   f_k = k / (n Δt)
//! U       = (1/n) Σ_n w_n²                          (window power)
//! power_k = c_k |X_k|² / (n² U)                     c_0 = 1, c_{n/2} = 1 (n even), else 2
//! ```
//!
//! so that **Parseval** holds: `Σ_k power_k = (1/n) Σ_n (w_n x_n)² / U`, which is the mean square
//! of the signal for the `rect` window and its window-weighted mean square otherwise. `power`
//! is in squared signal units (a power spectrum, not a density). A tone `A sin(2π f t)` on a
//! bin puts `A²/2` in that bin with `rect`; a tapered window spreads the same total over its
//! main lobe (the peak bin keeps `A²/2 · (Σw)² / (n Σw²)`, 2/3 of it for `hann`).
//!
//! Windows are the periodic (DFT-even) forms, `θ_n = 2π n / n`: `rect` 1, `hann`
//! `0.5 − 0.5 cos θ`, `hamming` `0.54 − 0.46 cos θ`, `blackman` `0.42 − 0.5 cos θ + 0.08 cos 2θ`.
//!
//! # Peaks
//!
//! Local maxima of `power` (a bin above its left neighbour and not below its right one; the
//! zero-frequency and last bins are not candidates), at most `threshold_db` below the highest
//! of them, sorted by level (highest first), at most `n_peaks`. A peak's frequency is its bin's,
//! so it is known to within one bin `1/(n Δt)`; its `level` is the power of that bin.

use std::collections::BTreeMap;

use plotters::coord::Shift;
use plotters::prelude::*;
use realfft::RealFftPlanner;

use super::uniform_series;
use crate::artifact::{Artifact, ArtifactType};
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

crate::choice! {
    /// A tapering window, periodic form.
    pub enum Window {
        Hann = "hann",
        Rect = "rect",
        Hamming = "hamming",
        Blackman = "blackman",
    }
}

impl Window {
    pub fn samples(self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|idx| {
                let theta = 2.0 * std::f64::consts::PI * idx as f64 / n as f64;
                match self {
                    Window::Rect => 1.0,
                    Window::Hann => 0.5 - 0.5 * theta.cos(),
                    Window::Hamming => 0.54 - 0.46 * theta.cos(),
                    Window::Blackman => 0.42 - 0.5 * theta.cos() + 0.08 * (2.0 * theta).cos(),
                }
            })
            .collect()
    }
}

crate::choice! {
    /// What is removed from the samples before windowing.
    pub enum Detrend {
        Mean = "mean",
        None = "none",
        Linear = "linear",
    }
}

impl Detrend {
    fn apply(self, values: &[f64]) -> Vec<f64> {
        let n = values.len() as f64;
        match self {
            Detrend::None => values.to_vec(),
            Detrend::Mean => {
                let mean = values.iter().sum::<f64>() / n;
                values.iter().map(|value| value - mean).collect()
            }
            Detrend::Linear => {
                // Least-squares line over the sample index, centred so the fit is well conditioned.
                let center = (n - 1.0) / 2.0;
                let mean = values.iter().sum::<f64>() / n;
                let (mut sxy, mut sxx) = (0.0, 0.0);
                for (idx, value) in values.iter().enumerate() {
                    let x = idx as f64 - center;
                    sxy += x * (value - mean);
                    sxx += x * x;
                }
                let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
                values
                    .iter()
                    .enumerate()
                    .map(|(idx, value)| value - mean - slope * (idx as f64 - center))
                    .collect()
            }
        }
    }
}

/// One-sided power spectrum of `values` sampled every `dt`, normalised as in the module doc.
pub struct PowerSpectrum {
    pub freqs_hz: Vec<f64>,
    pub power: Vec<f64>,
}

pub fn power_spectrum(values: &[f64], dt: f64, window: Window, detrend: Detrend) -> PowerSpectrum {
    let n = values.len();
    let weights = window.samples(n);
    let window_power = weights.iter().map(|w| w * w).sum::<f64>() / n as f64;
    let mut windowed: Vec<f64> = detrend
        .apply(values)
        .iter()
        .zip(&weights)
        .map(|(value, weight)| value * weight)
        .collect();
    let forward = RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let mut spectrum = forward.make_output_vec();
    forward
        .process(&mut windowed, &mut spectrum)
        .expect("buffers sized by the plan");
    let scale = 1.0 / (n as f64 * n as f64 * window_power);
    let power = spectrum
        .iter()
        .enumerate()
        .map(|(k, value)| {
            let one_sided = if k == 0 || 2 * k == n { 1.0 } else { 2.0 };
            one_sided * value.norm_sqr() * scale
        })
        .collect();
    let df = 1.0 / (n as f64 * dt);
    PowerSpectrum {
        freqs_hz: (0..spectrum.len()).map(|k| k as f64 * df).collect(),
        power,
    }
}

/// Indices of the peaks of `power`, highest first (see the module doc).
pub fn find_peaks(power: &[f64], threshold_db: f64, n_peaks: usize) -> Vec<usize> {
    if power.len() < 3 {
        return Vec::new();
    }
    let mut maxima: Vec<usize> = (1..power.len() - 1)
        .filter(|&k| power[k] > power[k - 1] && power[k] >= power[k + 1])
        .collect();
    let highest = maxima.iter().map(|&k| power[k]).fold(0.0, f64::max);
    let floor = highest * 10f64.powf(threshold_db / 10.0);
    maxima.retain(|&k| power[k] >= floor && power[k] > 0.0);
    maxima.sort_by(|&a, &b| power[b].total_cmp(&power[a]).then(a.cmp(&b)));
    maxima.truncate(n_peaks);
    maxima
}

/// `spectrum`: power spectrum, peaks and a figure of one column.
pub struct Spectrum;

crate::stage_params! {
    /// The parameters of `spectrum`.
    pub struct SpectrumParams {
        /// the signal column to analyse
        column: String,
        /// length of the analysed window, ending at the last sample (0: the whole record)
        #[unit = "s"]
        #[min = 0.0]
        window_s: f64 = 0.0,
        /// tapering window
        window: Window = Window::Hann,
        /// removed before windowing
        detrend: Detrend = Detrend::Mean,
        /// most peaks reported
        #[min = 0]
        n_peaks: usize = 10,
        /// peaks at most this far below the highest one (<= 0)
        #[unit = "dB"]
        threshold_db: f64 = -40.0,
    }
}

impl HasParams for Spectrum {
    type Params = SpectrumParams;
}

impl Stage for Spectrum {
    fn kind(&self) -> &'static str {
        "spectrum"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "FFT power spectrum of one signal column over its last window_s seconds, with its peaks"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "signal",
            ArtifactType::Table,
            "signal table: time `t` (s, uniform) and signal columns",
        )]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("figure", "spectrum_figure")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "spectrum",
                ArtifactType::Table,
                "freq_hz, power (squared signal units; sums to the mean square)",
            ),
            PortSpec::one(
                "peaks",
                ArtifactType::Table,
                "freq_hz, level (power of the peak bin), highest first",
            ),
            PortSpec::one(
                "spectrum_figure",
                ArtifactType::Figure,
                "power against frequency, log scale, peaks marked",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: SpectrumParams = params.read::<Self>()?;
        let column = params.column.as_str();
        let series = uniform_series(inputs.table("signal")?, column)?;
        let threshold_db = params.threshold_db;
        if threshold_db > 0.0 {
            return Err(StageError::new(format!(
                "threshold_db = {threshold_db} dB must be <= 0 (below the highest peak)"
            )));
        }
        let window_s = params.window_s;
        let record_s = series.len() as f64 * series.dt;
        let n_window = if window_s == 0.0 {
            series.len()
        } else {
            (window_s / series.dt).round() as usize
        };
        if n_window > series.len() {
            return Err(StageError::new(format!(
                "window_s = {window_s} s is longer than the record ({record_s} s, {} samples)",
                series.len()
            )));
        }
        if n_window < 4 {
            return Err(StageError::new(format!(
                "window_s = {window_s} s holds {n_window} sample(s) at dt = {} s: at least 4 are needed",
                series.dt
            )));
        }
        let (window, detrend) = (params.window, params.detrend);
        let samples = &series.values[series.len() - n_window..];
        let spectrum = power_spectrum(samples, series.dt, window, detrend);
        let peaks = find_peaks(&spectrum.power, threshold_db, params.n_peaks);

        let plot = SpectrumPlot {
            column,
            window_name: window.name(),
            window_s: n_window as f64 * series.dt,
            spectrum: &spectrum,
            peaks: &peaks,
        };
        let figure = plot::render(&plot, plot::DEFAULT_SIZE)?;
        let peaks_table = Table::new()
            .with(
                "freq_hz",
                peaks
                    .iter()
                    .map(|&k| spectrum.freqs_hz[k])
                    .collect::<Vec<f64>>(),
            )
            .with(
                "level",
                peaks
                    .iter()
                    .map(|&k| spectrum.power[k])
                    .collect::<Vec<f64>>(),
            );
        let spectrum_table = Table::new()
            .with("freq_hz", spectrum.freqs_hz)
            .with("power", spectrum.power);
        Ok(BTreeMap::from([
            ("spectrum".to_string(), Artifact::Table(spectrum_table)),
            ("peaks".to_string(), Artifact::Table(peaks_table)),
            ("spectrum_figure".to_string(), Artifact::Figure(figure)),
        ]))
    }
}

/// Points drawn at most along the frequency axis (max-pooled, so peaks survive).
const PLOT_MAX_POINTS: usize = 2000;
/// The figure shows 12 decades below the highest bin.
const PLOT_FLOOR: f64 = 1e-12;

struct SpectrumPlot<'a> {
    column: &'a str,
    window_name: &'a str,
    window_s: f64,
    spectrum: &'a PowerSpectrum,
    peaks: &'a [usize],
}

impl Drawing for SpectrumPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let PowerSpectrum { freqs_hz, power } = self.spectrum;
        let highest = power.iter().copied().fold(0.0, f64::max);
        let top = if highest > 0.0 { highest * 3.0 } else { 1.0 };
        let floor = top * PLOT_FLOOR;
        let group = power.len().div_ceil(PLOT_MAX_POINTS).max(1);
        let curve: Vec<(f64, f64)> = freqs_hz
            .chunks(group)
            .zip(power.chunks(group))
            .map(|(freqs, powers)| {
                let (idx, &value) = powers
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.total_cmp(b.1))
                    .expect("chunks are not empty");
                (freqs[idx], value.max(floor))
            })
            .collect();
        let f_last = *freqs_hz.last().expect("at least 3 bins");

        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "Power spectrum of {} (last {} s, {} window)",
                    self.column,
                    plot::tick_label(self.window_s),
                    self.window_name
                ),
                (plot::FONT, 22),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..f_last, (floor..top).log_scale())
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .y_desc("power")
            .x_label_formatter(&|f| plot::tick_label(*f))
            .y_label_formatter(&|p| format!("{p:.0e}"))
            .label_style((plot::FONT, 15))
            .axis_desc_style((plot::FONT, 16))
            .light_line_style(WHITE)
            .draw()
            .map_err(drawing_error)?;
        chart
            .draw_series(LineSeries::new(
                curve,
                plot::series_color(0).stroke_width(1),
            ))
            .map_err(drawing_error)?;
        let marker = plot::series_color(1);
        chart
            .draw_series(self.peaks.iter().map(|&k| {
                Circle::new(
                    (freqs_hz[k], power[k].max(floor)),
                    5,
                    marker.stroke_width(2),
                )
            }))
            .map_err(drawing_error)?;
        chart
            .draw_series(self.peaks.iter().take(5).map(|&k| {
                Text::new(
                    format!("{} Hz", plot::tick_label(freqs_hz[k])),
                    (freqs_hz[k], power[k].max(floor) * 2.0),
                    (plot::FONT, 14).into_font().color(&marker),
                )
            }))
            .map_err(drawing_error)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests;
