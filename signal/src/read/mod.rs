//! `signal.read`: a time series from a user's Parquet or CSV file, as a signal table.
//!
//! **Not pure.** This is the one stage of the crate that reads a file: its result depends on
//! bytes the engine does not hash, so it declares [`Stage::pure`] `false` and the engine never
//! caches it (it reruns every time; its *output* digest still lets unchanged data stop the
//! cascade downstream). The engine resolves a relative `path` against the study's folder.
//!
//! The file holds a time column (seconds, strictly increasing) and signal columns. The output
//! table names the time column `t` whatever its name in the file, and keeps the signal columns
//! as f64: all of them in file order, or those listed in `columns` in the listed order.
//!
//! - **Parquet**: any integer or floating-point column type; nulls are errors. Pandas' index
//!   columns (`__index_level_N__`) are skipped unless listed.
//! - **CSV**: a header line of column names, then one line of numbers per sample, separated by
//!   commas. Blank lines and lines starting with `#` are skipped; names may be double-quoted.
//!
//! Errors name the file, the column and the row (0-based data row for Parquet, 1-based line
//! number for CSV, as an editor shows it).

use std::fs::File;
use std::path::{Path, PathBuf};

use arrow_array::Array;
use arrow_array::cast::AsArray;
use arrow_array::types::{
    ArrowPrimitiveType, Float16Type, Float32Type, Float64Type, Int8Type, Int16Type, Int32Type,
    Int64Type, UInt8Type, UInt16Type, UInt32Type, UInt64Type,
};
use arrow_schema::DataType;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use super::TIME_COLUMN;
use crate::artifact::ArtifactType;
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError, single_output,
};
use crate::table::Table;

crate::choice! {
    /// The format of the file to read, as a study names it.
    pub enum FileFormat {
        /// By the file's extension: `.parquet`, `.pq` or `.csv`.
        Auto = "auto",
        Csv = "csv",
        Parquet = "parquet",
    }
}

/// `signal.read`: a signal table from a Parquet or CSV file (impure, never cached).
pub struct Read;

crate::stage_params! {
    /// The parameters of `signal.read`.
    pub struct ReadParams {
        /// the CSV or Parquet file (relative to the study's folder)
        path: PathBuf,
        /// the time column (s, strictly increasing); named `t` in the output
        time_column: String = TIME_COLUMN.into(),
        /// signal columns to keep (empty: every other column)
        columns: Vec<String> = Vec::new(),
        /// file format; auto: by extension (.parquet, .pq or .csv)
        format: FileFormat = FileFormat::Auto,
    }
}

impl HasParams for Read {
    type Params = ReadParams;
}

impl Stage for Read {
    fn kind(&self) -> &'static str {
        "signal.read"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Read a time series (time column + signal columns) from a Parquet or CSV file; never cached"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "signal",
            ArtifactType::Table,
            "signal table: time `t` (s) and the signal columns (f64)",
        )]
    }
    fn pure(&self) -> bool {
        false
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let params = params.read::<Self>()?;
        let request = ReadRequest {
            path: &params.path,
            time_column: &params.time_column,
            columns: params.columns.iter().map(String::as_str).collect(),
        };
        let format = match params.format {
            FileFormat::Auto => Format::from_extension(request.path)?,
            FileFormat::Csv => Format::Csv,
            FileFormat::Parquet => Format::Parquet,
        };
        let table = match format {
            Format::Csv => read_csv(&request)?,
            Format::Parquet => read_parquet(&request)?,
        };
        Ok(single_output("signal", table))
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Csv,
    Parquet,
}

impl Format {
    fn from_extension(path: &Path) -> Result<Format, StageError> {
        let extension = path
            .extension()
            .and_then(|ext| ext.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("csv") => Ok(Format::Csv),
            Some("parquet" | "pq") => Ok(Format::Parquet),
            _ => Err(StageError::new(format!(
                "{}: unknown extension; set `format` to csv or parquet",
                path.display()
            ))),
        }
    }
}

struct ReadRequest<'a> {
    path: &'a Path,
    time_column: &'a str,
    /// Empty: every column but the time column.
    columns: Vec<&'a str>,
}

impl ReadRequest<'_> {
    fn error(&self, message: impl std::fmt::Display) -> StageError {
        StageError::new(format!("{}: {message}", self.path.display()))
    }

    /// Indices (into `available`) of the time column and of the signal columns to keep.
    fn select(
        &self,
        available: &[String],
        skip_by_default: impl Fn(&str) -> bool,
    ) -> Result<(usize, Vec<usize>), StageError> {
        let find = |name: &str| {
            available
                .iter()
                .position(|column| column == name)
                .ok_or_else(|| {
                    self.error(format_args!(
                        "no column `{name}` (columns: {})",
                        available.join(", ")
                    ))
                })
        };
        let time_idx = find(self.time_column)?;
        let signal_idx: Vec<usize> = if self.columns.is_empty() {
            (0..available.len())
                .filter(|&idx| idx != time_idx && !skip_by_default(&available[idx]))
                .collect()
        } else {
            self.columns
                .iter()
                .map(|name| find(name))
                .collect::<Result<_, _>>()?
        };
        if signal_idx.is_empty() {
            return Err(self.error("no signal column besides the time column"));
        }
        for &idx in &signal_idx {
            if available[idx] == TIME_COLUMN && idx != time_idx {
                return Err(self.error(format_args!(
                    "signal column `{TIME_COLUMN}` would clash with the time column, which is renamed `{TIME_COLUMN}`"
                )));
            }
        }
        Ok((time_idx, signal_idx))
    }

    /// The output table, after checking that time strictly increases. `row_name` formats a
    /// data row index as the file's reader would see it.
    fn finish(
        &self,
        names: Vec<String>,
        time: Vec<f64>,
        signals: Vec<Vec<f64>>,
        row_name: impl Fn(usize) -> String,
    ) -> Result<Table, StageError> {
        if time.is_empty() {
            return Err(self.error("no data rows"));
        }
        if let Some(row) = (1..time.len()).find(|&row| time[row] <= time[row - 1]) {
            return Err(self.error(format_args!(
                "time column `{}` does not increase at {}: {} after {}",
                self.time_column,
                row_name(row),
                time[row],
                time[row - 1]
            )));
        }
        let mut table = Table::new().with(TIME_COLUMN, time);
        for (name, values) in names.into_iter().zip(signals) {
            table = table.with(name, values);
        }
        Ok(table)
    }
}

fn read_csv(request: &ReadRequest) -> Result<Table, StageError> {
    let text = std::fs::read_to_string(request.path).map_err(|err| request.error(err))?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(idx, line)| (idx + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty() && !line.starts_with('#'));
    let Some((_, header)) = lines.next() else {
        return Err(request.error("empty file: no header line"));
    };
    let available: Vec<String> = header
        .split(',')
        .map(|name| name.trim().trim_matches('"').to_string())
        .collect();
    let (time_idx, signal_idx) = request.select(&available, |_| false)?;

    let mut line_numbers = Vec::new();
    let mut time = Vec::new();
    let mut signals: Vec<Vec<f64>> = vec![Vec::new(); signal_idx.len()];
    let mut fields: Vec<&str> = Vec::with_capacity(available.len());
    for (line_number, line) in lines {
        fields.clear();
        fields.extend(line.split(',').map(str::trim));
        if fields.len() != available.len() {
            return Err(request.error(format_args!(
                "line {line_number} has {} fields, the header has {}",
                fields.len(),
                available.len()
            )));
        }
        let number = |idx: usize| -> Result<f64, StageError> {
            let field = fields[idx];
            match field.parse::<f64>() {
                Ok(value) if value.is_finite() => Ok(value),
                _ => Err(request.error(format_args!(
                    "line {line_number} column `{}`: \"{field}\" is not a finite number",
                    available[idx]
                ))),
            }
        };
        time.push(number(time_idx)?);
        for (signal, &idx) in signals.iter_mut().zip(&signal_idx) {
            signal.push(number(idx)?);
        }
        line_numbers.push(line_number);
    }
    let names = signal_idx
        .iter()
        .map(|&idx| available[idx].clone())
        .collect();
    request.finish(names, time, signals, |row| {
        format!("line {}", line_numbers[row])
    })
}

/// A numeric column's values as f64 (`None` where null), as a cast would give them; `None`
/// for a column that is not numeric.
fn numbers_of(array: &dyn Array) -> Option<Vec<Option<f64>>> {
    fn widened<T: ArrowPrimitiveType>(
        array: &dyn Array,
        to_f64: impl Fn(T::Native) -> f64,
    ) -> Vec<Option<f64>> {
        array
            .as_primitive::<T>()
            .iter()
            .map(|value| value.map(&to_f64))
            .collect()
    }
    Some(match array.data_type() {
        DataType::Int8 => widened::<Int8Type>(array, f64::from),
        DataType::Int16 => widened::<Int16Type>(array, f64::from),
        DataType::Int32 => widened::<Int32Type>(array, f64::from),
        DataType::Int64 => widened::<Int64Type>(array, |value| value as f64),
        DataType::UInt8 => widened::<UInt8Type>(array, f64::from),
        DataType::UInt16 => widened::<UInt16Type>(array, f64::from),
        DataType::UInt32 => widened::<UInt32Type>(array, f64::from),
        DataType::UInt64 => widened::<UInt64Type>(array, |value| value as f64),
        DataType::Float16 => widened::<Float16Type>(array, f64::from),
        DataType::Float32 => widened::<Float32Type>(array, f64::from),
        DataType::Float64 => widened::<Float64Type>(array, |value| value),
        _ => return None,
    })
}

fn read_parquet(request: &ReadRequest) -> Result<Table, StageError> {
    let file = File::open(request.path).map_err(|err| request.error(err))?;
    let builder =
        ParquetRecordBatchReaderBuilder::try_new(file).map_err(|err| request.error(err))?;
    let available: Vec<String> = builder
        .schema()
        .fields()
        .iter()
        .map(|field| field.name().clone())
        .collect();
    let (time_idx, signal_idx) =
        request.select(&available, |name| name.starts_with("__index_level_"))?;
    let schema = builder.schema().clone();
    for &idx in std::iter::once(&time_idx).chain(&signal_idx) {
        let data_type = schema.field(idx).data_type();
        if !is_plain_number(data_type) {
            return Err(request.error(format_args!(
                "column `{}` is {data_type}, not numeric",
                available[idx]
            )));
        }
    }
    let reader = builder.build().map_err(|err| request.error(err))?;

    let mut time = Vec::new();
    let mut signals: Vec<Vec<f64>> = vec![Vec::new(); signal_idx.len()];
    let mut rows_before = 0;
    for batch in reader {
        let batch = batch.map_err(|err| request.error(err))?;
        let append = |idx: usize, out: &mut Vec<f64>| -> Result<(), StageError> {
            let values = numbers_of(batch.column(idx)).ok_or_else(|| {
                request.error(format_args!("column `{}` is not numeric", available[idx]))
            })?;
            for (row, value) in values.into_iter().enumerate() {
                match value {
                    Some(value) if value.is_finite() => out.push(value),
                    _ => {
                        let shown = value.map_or("null".to_string(), |value| value.to_string());
                        return Err(request.error(format_args!(
                            "column `{}` row {} is {shown}, not a finite number",
                            available[idx],
                            rows_before + row
                        )));
                    }
                }
            }
            Ok(())
        };
        append(time_idx, &mut time)?;
        for (signal, &idx) in signals.iter_mut().zip(&signal_idx) {
            append(idx, signal)?;
        }
        rows_before += batch.num_rows();
    }
    let names = signal_idx
        .iter()
        .map(|&idx| available[idx].clone())
        .collect();
    request.finish(names, time, signals, |row| format!("row {row}"))
}

/// Integer and floating-point types: the ones that mean a number of SI units.
fn is_plain_number(data_type: &DataType) -> bool {
    matches!(
        data_type,
        DataType::Int8
            | DataType::Int16
            | DataType::Int32
            | DataType::Int64
            | DataType::UInt8
            | DataType::UInt16
            | DataType::UInt32
            | DataType::UInt64
            | DataType::Float16
            | DataType::Float32
            | DataType::Float64
    )
}

#[cfg(test)]
mod tests;
