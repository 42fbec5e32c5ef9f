//! The complex modes of the stability stage's tables, read back: `shapes` (wide, one row per
//! DOF, f64 columns `mode_NNNN_re` and `mode_NNNN_im`) with `eigenvalues` (`mode`,
//! `freq_hz`). Shared by the stages that take complex modes (`svd_projection`, `basis`).

use std::collections::BTreeMap;

use faer::Mat;

use crate::table::{ColumnData, Table};
use crate::value::StageError;

/// The two columns of one mode in a wide table, as they are found.
#[derive(Default)]
struct ModeColumns<'a> {
    real: Option<&'a [f64]>,
    imag: Option<&'a [f64]>,
}

/// Complex modes read from a wide table, with their frequencies.
pub struct ComplexModes {
    pub numbers: Vec<i64>,
    pub freqs_hz: Vec<f64>,
    pub real: Mat<f64>,
    pub imag: Mat<f64>,
}

impl ComplexModes {
    pub fn from_tables(modes: &Table, frequencies: &Table) -> Result<ComplexModes, StageError> {
        let mut parts: BTreeMap<i64, ModeColumns> = BTreeMap::new();
        for column in modes.columns() {
            let Some(rest) = column.name.strip_prefix("mode_") else {
                continue;
            };
            let (number, is_real) = if let Some(number) = rest.strip_suffix("_re") {
                (number, true)
            } else if let Some(number) = rest.strip_suffix("_im") {
                (number, false)
            } else {
                continue;
            };
            let number: i64 = number.parse().map_err(|_| {
                StageError::new(format!(
                    "modes: column `{}` has no mode number",
                    column.name
                ))
            })?;
            let ColumnData::F64(values) = &column.data else {
                return Err(StageError::new(format!(
                    "modes: column `{}` is not f64",
                    column.name
                )));
            };
            let entry = parts.entry(number).or_default();
            if is_real {
                entry.real = Some(values);
            } else {
                entry.imag = Some(values);
            }
        }
        if parts.is_empty() {
            return Err(StageError::new(
                "modes: no `mode_NNNN_re` / `mode_NNNN_im` columns: no mode to take (did the stability stage find none in its band?)",
            ));
        }
        let mode_column = match frequencies.column("mode") {
            Some(ColumnData::I64(values)) => values,
            _ => return Err(StageError::new("frequencies: no i64 column `mode`")),
        };
        let freq_column = match frequencies.column("freq_hz") {
            Some(ColumnData::F64(values)) => values,
            _ => return Err(StageError::new("frequencies: no f64 column `freq_hz`")),
        };
        let freq_of: BTreeMap<i64, f64> = mode_column
            .iter()
            .copied()
            .zip(freq_column.iter().copied())
            .collect();

        let n_dofs = modes.n_rows();
        let n_modes = parts.len();
        let mut real = Mat::<f64>::zeros(n_dofs, n_modes);
        let mut imag = Mat::<f64>::zeros(n_dofs, n_modes);
        let mut numbers = Vec::with_capacity(n_modes);
        let mut freqs_hz = Vec::with_capacity(n_modes);
        for (idx, (&number, columns)) in parts.iter().enumerate() {
            let (Some(re), Some(im)) = (columns.real, columns.imag) else {
                return Err(StageError::new(format!(
                    "modes: mode {number} needs both mode_{number:04}_re and mode_{number:04}_im"
                )));
            };
            let freq = freq_of
                .get(&number)
                .ok_or_else(|| StageError::new(format!("frequencies: no row for mode {number}")))?;
            real.col_as_slice_mut(idx).copy_from_slice(re);
            imag.col_as_slice_mut(idx).copy_from_slice(im);
            numbers.push(number);
            freqs_hz.push(*freq);
        }
        Ok(ComplexModes {
            numbers,
            freqs_hz,
            real,
            imag,
        })
    }
}
