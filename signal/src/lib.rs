//! Signal processing: read a time series, its Morlet wavelet transform, its power spectrum, and
//! the principal shapes of a set of snapshots projected on the complex modes (§3.7 of the design).
//!
//! A *signal table* has an f64 time column `t` (seconds, uniformly sampled, increasing) and one
//! f64 column per signal. [`read::Read`] produces one from a user file; a transient stage
//! produces one from a simulation. Every stage here checks the sampling itself and names the
//! row that breaks it.
//!
//! The transient (`squeal-dynamics`) writes signal tables, but this crate reads them only as
//! tables: the two build side by side.

#![allow(non_snake_case)]
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use squeal_contract::{artifact, choice, stage, stage_params, table};
use squeal_plot as plot;

pub mod compare;
pub mod read;
pub mod spectrum;
pub mod svd_projection;
pub mod wavelet;

use std::sync::Arc;

use crate::stage::{Stage, StageError};
use crate::table::Table;

/// The name of the time column of a signal table.
pub const TIME_COLUMN: &str = "t";

/// Relative tolerance on each time step of a uniformly sampled signal, as a fraction of the
/// mean step: wide enough for times written as `i * dt` in f64 or decimal text, narrow enough
/// to catch a dropped or repeated sample.
const UNIFORM_STEP_TOLERANCE: f64 = 1e-6;

pub fn kinds() -> Vec<Arc<dyn Stage>> {
    vec![
        Arc::new(read::Read),
        Arc::new(wavelet::Wavelet),
        Arc::new(spectrum::Spectrum),
        Arc::new(svd_projection::SvdProjection),
        Arc::new(compare::Compare),
    ]
}

/// One column of a signal table, sampled at `t_first + i * dt`.
#[derive(Debug, Clone, PartialEq)]
pub struct UniformSeries<'a> {
    pub t_first: f64,
    pub dt: f64,
    pub values: &'a [f64],
}

impl UniformSeries<'_> {
    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    pub fn t_last(&self) -> f64 {
        self.t_first + (self.len() - 1) as f64 * self.dt
    }
}

/// Column `column` of a signal table with its time step, after checking that `t` is uniformly
/// sampled and every value is finite.
pub fn uniform_series<'a>(table: &'a Table, column: &str) -> Result<UniformSeries<'a>, StageError> {
    if column == TIME_COLUMN {
        return Err(StageError::new(
            "`column` names the time column `t`: choose a signal column",
        ));
    }
    let time = table.f64(TIME_COLUMN)?;
    let values = table.f64(column)?;
    if time.len() < 2 {
        return Err(StageError::new(format!(
            "the signal has {} sample(s): at least 2 are needed",
            time.len()
        )));
    }
    let dt = (time[time.len() - 1] - time[0]) / (time.len() - 1) as f64;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(StageError::new(format!(
            "time does not increase: t[0] = {}, t[{}] = {}",
            time[0],
            time.len() - 1,
            time[time.len() - 1]
        )));
    }
    // Steps against their median, so a dropped or repeated sample is named where it is.
    let mut steps: Vec<f64> = time.windows(2).map(|pair| pair[1] - pair[0]).collect();
    let middle = steps.len() / 2;
    let typical_step = *steps.select_nth_unstable_by(middle, f64::total_cmp).1;
    for row in 1..time.len() {
        let step = time[row] - time[row - 1];
        let deviation = (step - typical_step).abs();
        if deviation.is_nan() || deviation > UNIFORM_STEP_TOLERANCE * typical_step {
            return Err(StageError::new(format!(
                "time is not uniformly sampled: t[{row}] − t[{}] = {step} where the typical step is {typical_step}",
                row - 1
            )));
        }
    }
    if let Some(row) = values.iter().position(|value| !value.is_finite()) {
        return Err(StageError::new(format!(
            "column `{column}` row {row} is {}",
            values[row]
        )));
    }
    Ok(UniformSeries {
        t_first: time[0],
        dt,
        values,
    })
}

/// `n` frequencies from `f_min` to `f_max` (both included), evenly spaced in log.
pub fn log_spaced(f_min: f64, f_max: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![f_min];
    }
    let ratio = (f_max / f_min).ln() / (n - 1) as f64;
    (0..n)
        .map(|idx| {
            if idx == n - 1 {
                f_max
            } else {
                f_min * (ratio * idx as f64).exp()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series_table(time: Vec<f64>) -> Table {
        let n = time.len();
        Table::new().with("t", time).with("x", vec![1.0; n])
    }

    #[test]
    fn uniform_series_accepts_decimal_times() {
        let time: Vec<f64> = (0..1000).map(|i| 0.1 + i as f64 * 1e-4).collect();
        let table = series_table(time);
        let series = uniform_series(&table, "x").unwrap();
        assert!((series.dt - 1e-4).abs() < 1e-15);
        assert_eq!(series.len(), 1000);
    }

    #[test]
    fn uniform_series_names_the_row_of_a_dropped_sample() {
        let mut time: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
        time.remove(40);
        let err = uniform_series(&series_table(time), "x").unwrap_err();
        assert!(err.message.contains("t[40]"), "{err}");
    }

    #[test]
    fn uniform_series_rejects_missing_column_and_nan() {
        let table = series_table(vec![0.0, 1.0, 2.0]);
        let err = uniform_series(&table, "y").unwrap_err();
        assert!(err.message.contains("no column `y`"), "{err}");
        let table = Table::new()
            .with("t", vec![0.0, 1.0, 2.0])
            .with("x", vec![0.0, f64::NAN, 1.0]);
        let err = uniform_series(&table, "x").unwrap_err();
        assert!(err.message.contains("row 1"), "{err}");
    }

    #[test]
    fn log_spaced_hits_both_ends() {
        let freqs = log_spaced(10.0, 1000.0, 3);
        assert_eq!(freqs[0], 10.0);
        assert!((freqs[1] - 100.0).abs() < 1e-12);
        assert_eq!(freqs[2], 1000.0);
    }
}
