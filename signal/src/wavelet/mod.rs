//! `wavelet`: Morlet continuous wavelet transform of one column of a signal table.
//!
//! # Definition
//!
//! Mother wavelet and daughters (`docs/science.md` §7):
//!
//! ```text
//! φ(t)      = e^{i k₀ t} e^{−t²/2}
//! φ_{a,b}(t) = a^{−1/2} φ((t − b)/a)
//! W(a, b)   = ∫ s(t) φ*_{a,b}(t) dt
//! ```
//!
//! **Scale ↔ frequency**: `a = k₀ / (2π f)`. The Fourier transform of the daughter,
//! `φ̂_{a,b}(ω) = a^{1/2} √(2π) e^{−(aω − k₀)²/2} e^{−iωb}`, peaks at `ω = k₀/a`, i.e. at
//! `f = k₀/(2π a)`. For a tone `cos(2π f₀ t)`, `|W|²/a` is largest exactly at `f = f₀`;
//! `|W|²` itself (the `power` output) carries the `a^{−1/2}` normalisation and peaks slightly
//! lower, at `f₀ · 2k₀ / (k₀ + √(k₀² + 2))` (0.9865 f₀ for k₀ = 6). Both facts are tested.
//!
//! # Evaluation
//!
//! The transform is computed by FFT, exactly equal to the rectangle rule of the integral
//! (`cwt.rs`, [`MorletCwt`]); the time–frequency map is drawn in `figure.rs`.
//!
//! # Cone of influence
//!
//! The e-folding time of the Morlet power at scale `a` is `√2 a` (Torrence & Compo 1998):
//! a point is **in the cone of influence** (`in_coi = true`, edge effects matter, read with
//! care) when it lies within `√2 a` of either end of the record.

mod cwt;
mod figure;

use std::f64::consts::PI;

use super::{UniformSeries, log_spaced, uniform_series};
use crate::artifact::{Artifact, ArtifactType};
use crate::plot;
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

pub use cwt::{MorletCwt, next_fast_len};
use figure::PowerMap;

/// Largest power table the stage builds (rows = frequencies × output times); beyond it the
/// user should decimate with `dt_out_s` rather than exhaust memory.
const MAX_POWER_ROWS: usize = 100_000_000;

/// Scale of the Morlet daughter whose spectrum peaks at `freq_hz` (see the module doc).
pub fn scale_of_frequency(k0: f64, freq_hz: f64) -> f64 {
    k0 / (2.0 * PI * freq_hz)
}

/// The e-folding time of the Morlet power at scale `scale`: the half-width of the cone of
/// influence.
pub fn e_folding_time(scale: f64) -> f64 {
    std::f64::consts::SQRT_2 * scale
}

/// `wavelet`: Morlet CWT power of one column on a log-spaced frequency grid.
pub struct Wavelet;

crate::stage_params! {
    /// The parameters of `wavelet`.
    pub struct WaveletParams {
        /// the signal column to transform
        column: String,
        /// Morlet central wavenumber k₀ (rad)
        #[min = 0.0]
        k0: f64 = 6.0,
        /// lowest frequency of the grid
        #[unit = "Hz"]
        #[min = 0.0]
        f_min_hz: f64,
        /// highest frequency, at most Nyquist
        #[unit = "Hz"]
        #[min = 0.0]
        f_max_hz: f64,
        /// number of frequencies, log-spaced
        #[min = 1]
        n_freqs: usize = 100,
        /// output time step, rounded to a multiple of the sample step (0: every sample)
        #[unit = "s"]
        #[min = 0.0]
        dt_out_s: f64 = 0.0,
        /// colour range of the map below its maximum
        #[unit = "dB"]
        #[min = 1.0]
        map_range_db: f64 = 60.0,
    }
}

impl HasParams for Wavelet {
    type Params = WaveletParams;
}

impl Stage for Wavelet {
    fn kind(&self) -> &'static str {
        "wavelet"
    }
    fn version(&self) -> u32 {
        // 2: the power of narrow bands from their sampled envelope (CHANGELOG.md, "wavelet")
        2
    }
    fn doc(&self) -> &'static str {
        "Morlet wavelet power of one signal column on a log-spaced time-frequency grid, with its cone of influence"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "signal",
            ArtifactType::Table,
            "signal table: time `t` (s, uniform) and signal columns",
        )]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "power",
                ArtifactType::Table,
                "long table: t (s), freq_hz, power = |W|² (round-off ~1e-15 of each frequency's peak), in_coi (edge effects matter)",
            ),
            PortSpec::one(
                "map",
                ArtifactType::Figure,
                "time-frequency map of the power (dB), log frequency axis, cone of influence",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: WaveletParams = params.read::<Self>()?;
        let column = params.column.as_str();
        let series = uniform_series(inputs.table("signal")?, column)?;
        let grid = TransformGrid::from_params(&params, &series)?;
        let scales: Vec<f64> = grid
            .freqs_hz
            .iter()
            .map(|&freq| scale_of_frequency(grid.k0, freq))
            .collect();
        let cwt = MorletCwt::new(series.values, series.dt, grid.k0, &scales, grid.decimation);
        let power = cwt.power();
        let times: Vec<f64> = (0..cwt.n_out())
            .map(|q| series.t_first + (q * grid.decimation) as f64 * series.dt)
            .collect();
        let map = PowerMap {
            column,
            times: &times,
            freqs_hz: &grid.freqs_hz,
            power: &power,
            k0: grid.k0,
            t_first: series.t_first,
            t_last: series.t_last(),
            range_db: params.map_range_db,
        };
        let figure = plot::render(&map, plot::DEFAULT_SIZE)?;
        let table = power_table(&times, &grid.freqs_hz, &scales, power, &series);
        Ok(Outputs::from([
            ("power".to_string(), Artifact::Table(table)),
            ("map".to_string(), Artifact::Figure(figure)),
        ]))
    }
}

/// The validated frequency grid and output step of one run.
struct TransformGrid {
    k0: f64,
    freqs_hz: Vec<f64>,
    decimation: usize,
}

impl TransformGrid {
    fn from_params(params: &WaveletParams, series: &UniformSeries) -> Result<Self, StageError> {
        let k0 = params.k0;
        let (f_min, f_max) = (params.f_min_hz, params.f_max_hz);
        let n_freqs = params.n_freqs;
        let nyquist = 0.5 / series.dt;
        if k0 <= 0.0 {
            return Err(StageError::new(format!("k0 = {k0} must be positive")));
        }
        if f_min <= 0.0 {
            return Err(StageError::new(format!(
                "f_min_hz = {f_min} Hz must be positive"
            )));
        }
        if f_max < f_min {
            return Err(StageError::new(format!(
                "f_max_hz = {f_max} Hz is below f_min_hz = {f_min} Hz"
            )));
        }
        if f_max > nyquist * (1.0 + 1e-12) {
            return Err(StageError::new(format!(
                "f_max_hz = {f_max} Hz is above the Nyquist frequency {nyquist} Hz of the signal (dt = {} s)",
                series.dt
            )));
        }
        let decimation =
            ((params.dt_out_s / series.dt).round().max(1.0) as usize).min(series.len());
        let n_times = (series.len() - 1) / decimation + 1;
        let n_rows = n_times.saturating_mul(n_freqs);
        if n_rows > MAX_POWER_ROWS {
            return Err(StageError::new(format!(
                "the power table would have {n_rows} rows ({n_freqs} frequencies × {n_times} times), more than {MAX_POWER_ROWS}: raise dt_out_s"
            )));
        }
        Ok(TransformGrid {
            k0,
            freqs_hz: log_spaced(f_min, f_max, n_freqs),
            decimation,
        })
    }
}

/// The long table, frequency-major like `power` (which becomes its column without a copy).
fn power_table(
    times: &[f64],
    freqs_hz: &[f64],
    scales: &[f64],
    power: Vec<f64>,
    series: &UniformSeries,
) -> Table {
    let n_rows = power.len();
    let mut t_column = Vec::with_capacity(n_rows);
    let mut freq_column = Vec::with_capacity(n_rows);
    let mut coi_column = Vec::with_capacity(n_rows);
    for (&freq, &scale) in freqs_hz.iter().zip(scales) {
        let e_folding = e_folding_time(scale);
        t_column.extend_from_slice(times);
        freq_column.extend(std::iter::repeat_n(freq, times.len()));
        coi_column.extend(
            times
                .iter()
                .map(|&t| in_cone_of_influence(t, series.t_first, series.t_last(), e_folding)),
        );
    }
    Table::new()
        .with("t", t_column)
        .with("freq_hz", freq_column)
        .with("power", power)
        .with("in_coi", coi_column)
}

/// True when `t` is within one e-folding time of either end of the record.
pub fn in_cone_of_influence(t: f64, t_first: f64, t_last: f64, e_folding: f64) -> bool {
    (t - t_first).min(t_last - t) < e_folding
}

#[cfg(test)]
mod tests;
