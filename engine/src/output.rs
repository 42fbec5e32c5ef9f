//! Parquet outputs: every table a stage produces, and the run manifest.
//!
//! Layout: `OUT/<stage>/<table>.parquet`; a swept instance writes under hive-style folders,
//! `OUT/<stage>/mu=0.38/<table>.parquet`, which polars, duckdb and pyarrow read back with the
//! swept parameter as a column. Files are zstd-compressed and written atomically.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use arrow_array::{
    Array, ArrayRef, BooleanArray, Float64Array, Int64Array, RecordBatch, RecordBatchOptions,
    StringArray,
};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;
use squeal_contract::{ColumnData, Table};

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename: a reader
/// sees the old file or the new one, never half of one. The file gets the mode the umask gives
/// (0644 under umask 022), as a file created in place would, not a temporary file's 0600. Not
/// fsynced: everything written here (outputs, manifest, record) can be regenerated from the
/// cache, which is. A process killed between the two leaves its temporary file, which
/// [`remove_stray_temporaries`] removes.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|dir| !dir.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let mut builder = tempfile::Builder::new();
    let prefix = format!("{TEMPORARY_PREFIX}{}-", std::process::id());
    builder.prefix(&prefix);
    #[cfg(unix)]
    {
        // The mode `open` gives a new file before the umask clears its bits.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.persist(path).map_err(|err| err.error)?;
    Ok(())
}

/// How [`write_atomic`]'s temporary files start, before the writer's process id.
const TEMPORARY_PREFIX: &str = ".squeal-tmp-";

/// Removes, under `dir`, the temporary files of [`write_atomic`] that a killed process left
/// (its process id no longer runs); those of live processes stay. Linux only (`/proc`).
pub fn remove_stray_temporaries(dir: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            remove_stray_temporaries(&path);
            continue;
        }
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|name| name.strip_prefix(TEMPORARY_PREFIX))
            .and_then(|rest| rest.split('-').next())
        else {
            continue;
        };
        if !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// [`write_atomic`], unless the file already holds exactly these bytes (small files rewritten
/// on every run: manifest, record).
pub fn write_if_changed(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if std::fs::read(path).is_ok_and(|existing| existing == bytes) {
        return Ok(());
    }
    write_atomic(path, bytes)
}

pub fn to_record_batch(table: &Table) -> RecordBatch {
    let mut fields = Vec::with_capacity(table.columns().len());
    let mut arrays: Vec<ArrayRef> = Vec::with_capacity(table.columns().len());
    for column in table.columns() {
        let (data_type, array): (DataType, ArrayRef) = match &column.data {
            ColumnData::F64(values) => (
                DataType::Float64,
                Arc::new(Float64Array::from(values.clone())),
            ),
            ColumnData::I64(values) => {
                (DataType::Int64, Arc::new(Int64Array::from(values.clone())))
            }
            ColumnData::Bool(values) => (
                DataType::Boolean,
                Arc::new(BooleanArray::from(values.clone())),
            ),
            ColumnData::Str(values) => {
                (DataType::Utf8, Arc::new(StringArray::from(values.clone())))
            }
        };
        fields.push(Field::new(&column.name, data_type, false));
        arrays.push(array);
    }
    let options = RecordBatchOptions::new().with_row_count(Some(table.n_rows()));
    RecordBatch::try_new_with_options(Arc::new(Schema::new(fields)), arrays, &options)
        .expect("tables have equal-length columns matching their schema")
}

/// Encodes a table as a zstd-compressed Parquet file in memory.
pub fn parquet_bytes(table: &Table) -> Result<Vec<u8>, parquet::errors::ParquetError> {
    let batch = to_record_batch(table);
    let properties = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::try_new(3)?))
        .set_created_by(format!("squeal {}", env!("CARGO_PKG_VERSION")))
        .build();
    let mut bytes = Vec::new();
    let mut writer = ArrowWriter::try_new(&mut bytes, batch.schema(), Some(properties))?;
    writer.write(&batch)?;
    writer.close()?;
    Ok(bytes)
}

/// Reads back a Parquet file of squeal's (the manifest): f64, i64, bool and string columns.
pub fn read_parquet(path: &Path) -> Result<Table, String> {
    let error = |err: &dyn std::fmt::Display| format!("{}: {err}", path.display());
    let file = std::fs::File::open(path).map_err(|err| error(&err))?;
    let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
        .and_then(|builder| builder.build())
        .map_err(|err| error(&err))?;
    let mut columns: Vec<(String, ColumnData)> = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|err| error(&err))?;
        if columns.is_empty() {
            columns = batch
                .schema()
                .fields()
                .iter()
                .map(|field| {
                    let empty = match field.data_type() {
                        DataType::Float64 => ColumnData::F64(Vec::new()),
                        DataType::Int64 => ColumnData::I64(Vec::new()),
                        DataType::Boolean => ColumnData::Bool(Vec::new()),
                        _ => ColumnData::Str(Vec::new()),
                    };
                    (field.name().clone(), empty)
                })
                .collect();
        }
        for ((name, data), array) in columns.iter_mut().zip(batch.columns()) {
            let any = array.as_any();
            let read = match data {
                ColumnData::F64(values) => any
                    .downcast_ref::<Float64Array>()
                    .map(|array| values.extend(array.values().iter())),
                ColumnData::I64(values) => any
                    .downcast_ref::<Int64Array>()
                    .map(|array| values.extend(array.values().iter())),
                ColumnData::Bool(values) => any
                    .downcast_ref::<BooleanArray>()
                    .map(|array| values.extend((0..array.len()).map(|row| array.value(row)))),
                ColumnData::Str(values) => any
                    .downcast_ref::<StringArray>()
                    .map(|array| values.extend(array.iter().map(|v| v.unwrap_or("").to_string()))),
            };
            read.ok_or_else(|| error(&format!("column `{name}` has an unexpected type")))?;
        }
    }
    Ok(columns
        .into_iter()
        .fold(Table::new(), |table, (name, data)| table.with(name, data)))
}

/// Writes a small table rewritten on every run (the manifest), unless unchanged.
pub fn write_parquet_if_changed(path: &Path, table: &Table) -> std::io::Result<()> {
    let bytes = parquet_bytes(table).map_err(std::io::Error::other)?;
    write_if_changed(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

    #[test]
    fn a_dead_writers_temporaries_are_removed_and_a_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let nested = dir.path().join("stage/mu=0.1");
        std::fs::create_dir_all(&nested).unwrap();
        // Above any pid_max Linux allows (2^22): no such process.
        let dead = nested.join(format!("{TEMPORARY_PREFIX}9999999-abc"));
        let live = nested.join(format!("{TEMPORARY_PREFIX}{}-abc", std::process::id()));
        let output = nested.join("table.parquet");
        for path in [&dead, &live, &output] {
            std::fs::write(path, b"x").unwrap();
        }
        remove_stray_temporaries(dir.path());
        assert!(!dead.exists());
        assert!(live.exists() && output.exists());
    }

    #[test]
    fn tables_round_trip_through_parquet() {
        let table = Table::new()
            .with("mode", vec![1i64, 2])
            .with("freq_hz", vec![3537.0, 11100.0])
            .with("unstable", vec![true, false])
            .with("label", vec!["pad".to_string(), "disc".into()]);
        let bytes = bytes::Bytes::from(parquet_bytes(&table).unwrap());
        let reader = ParquetRecordBatchReaderBuilder::try_new(bytes)
            .unwrap()
            .build()
            .unwrap();
        let batches: Vec<RecordBatch> = reader.map(Result::unwrap).collect();
        assert_eq!(batches.len(), 1);
        assert_eq!(batches[0], to_record_batch(&table));
    }

    #[test]
    fn an_empty_table_is_a_valid_file() {
        assert!(!parquet_bytes(&Table::new()).unwrap().is_empty());
    }
}
