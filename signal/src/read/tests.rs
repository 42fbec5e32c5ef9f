use std::collections::BTreeMap;
use std::sync::Arc;

use arrow_array::{ArrayRef, Float64Array, Int32Array, RecordBatch, StringArray};
use arrow_schema::{Field, Schema};
use parquet::arrow::ArrowWriter;

use super::*;
use crate::stage::Value;
use crate::table::ColumnData;

fn params(path: &Path, time_column: &str, columns: &str) -> Params {
    Params(BTreeMap::from([
        (
            "path".into(),
            Value::Str(path.to_string_lossy().into_owned()),
        ),
        ("time_column".into(), Value::Str(time_column.into())),
        ("columns".into(), Value::Str(columns.into())),
        ("format".into(), Value::Str("auto".into())),
    ]))
}

fn read(path: &Path, time_column: &str, columns: &str) -> Result<Table, StageError> {
    let outputs = Read.run(&params(path, time_column, columns), &Inputs::default())?;
    Ok(outputs["signal"].as_table().expect("a table").clone())
}

fn f64s(table: &Table, name: &str) -> Vec<f64> {
    match table.column(name) {
        Some(ColumnData::F64(values)) => values.clone(),
        other => panic!("column {name}: {other:?}"),
    }
}

#[test]
fn is_impure() {
    assert!(!Read.pure());
}

#[test]
fn csv_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("signal.csv");
    let time: Vec<f64> = (0..50).map(|i| i as f64 * 1e-4).collect();
    let force: Vec<f64> = time.iter().map(|t| (1e4 * t).sin() * 1e3).collect();
    let mut text = String::from("# brake test rig\n\"time\", force, label_free\n");
    for (t, f) in time.iter().zip(&force) {
        // `{}` prints the shortest representation that round-trips exactly.
        text.push_str(&format!("{t},{f},{}\n", 2.0 * f));
    }
    text.push('\n');
    std::fs::write(&path, text).unwrap();
    let table = read(&path, "time", "").unwrap();
    assert_eq!(f64s(&table, "t"), time);
    assert_eq!(f64s(&table, "force"), force);
    let names: Vec<&str> = table.columns().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["t", "force", "label_free"]);
    let only_force = read(&path, "time", "force").unwrap();
    assert_eq!(only_force.columns().len(), 2);
}

fn write_parquet(path: &Path, columns: Vec<(&str, ArrayRef)>) {
    let fields: Vec<Field> = columns
        .iter()
        .map(|(name, array)| Field::new(*name, array.data_type().clone(), true))
        .collect();
    let batch = RecordBatch::try_new(
        Arc::new(Schema::new(fields)),
        columns.into_iter().map(|(_, array)| array).collect(),
    )
    .unwrap();
    let mut writer =
        ArrowWriter::try_new(File::create(path).unwrap(), batch.schema(), None).unwrap();
    writer.write(&batch).unwrap();
    writer.close().unwrap();
}

#[test]
fn parquet_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("signal.parquet");
    let time: Vec<f64> = (0..300).map(|i| 0.5 + i as f64 * 1e-5).collect();
    let velocity: Vec<f64> = time.iter().map(|t| (3e4 * t).cos()).collect();
    let counts: Vec<i32> = (0..300).collect();
    write_parquet(
        &path,
        vec![
            ("t", Arc::new(Float64Array::from(time.clone()))),
            ("velocity", Arc::new(Float64Array::from(velocity.clone()))),
            ("counts", Arc::new(Int32Array::from(counts))),
        ],
    );
    let table = read(&path, "t", "").unwrap();
    assert_eq!(f64s(&table, "t"), time);
    assert_eq!(f64s(&table, "velocity"), velocity);
    assert_eq!(f64s(&table, "counts")[299], 299.0);
}

#[test]
fn missing_file_is_named() {
    let err = read(Path::new("no/such/file.csv"), "t", "").unwrap_err();
    assert!(err.message.starts_with("no/such/file.csv: "), "{err}");
}

#[test]
fn missing_columns_are_named_with_the_ones_there() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.csv");
    std::fs::write(&path, "time,x\n0,1\n1,2\n").unwrap();
    let err = read(&path, "t", "").unwrap_err();
    assert!(
        err.message.ends_with("no column `t` (columns: time, x)"),
        "{err}"
    );
    let err = read(&path, "time", "y").unwrap_err();
    assert!(err.message.contains("no column `y`"), "{err}");
}

#[test]
fn non_monotonic_time_names_the_line_and_row() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("a.csv");
    std::fs::write(&csv, "t,x\n0,1\n0.1,2\n\n0.1,3\n").unwrap();
    let err = read(&csv, "t", "").unwrap_err();
    assert!(
        err.message
            .contains("does not increase at line 5: 0.1 after 0.1"),
        "{err}"
    );

    let parquet = dir.path().join("a.parquet");
    write_parquet(
        &parquet,
        vec![
            ("t", Arc::new(Float64Array::from(vec![0.0, 2.0, 1.0]))),
            ("x", Arc::new(Float64Array::from(vec![0.0, 0.0, 0.0]))),
        ],
    );
    let err = read(&parquet, "t", "").unwrap_err();
    assert!(
        err.message
            .contains("does not increase at row 2: 1 after 2"),
        "{err}"
    );
}

#[test]
fn non_numeric_values_name_file_column_and_row() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("a.csv");
    std::fs::write(&csv, "t,x\n0,1\n1,abc\n").unwrap();
    let err = read(&csv, "t", "").unwrap_err();
    let expected = format!(
        "{}: line 3 column `x`: \"abc\" is not a finite number",
        csv.display()
    );
    assert_eq!(err.message, expected);
    std::fs::write(&csv, "t,x\n0,1\n1\n").unwrap();
    let err = read(&csv, "t", "").unwrap_err();
    assert!(
        err.message
            .contains("line 3 has 1 fields, the header has 2"),
        "{err}"
    );

    let parquet = dir.path().join("a.parquet");
    write_parquet(
        &parquet,
        vec![
            ("t", Arc::new(Float64Array::from(vec![0.0, 1.0]))),
            ("x", Arc::new(Float64Array::from(vec![Some(1.0), None]))),
            ("label", Arc::new(StringArray::from(vec!["a", "b"]))),
        ],
    );
    let err = read(&parquet, "t", "").unwrap_err();
    assert!(
        err.message.contains("column `label` is Utf8, not numeric"),
        "{err}"
    );
    let err = read(&parquet, "t", "x").unwrap_err();
    assert!(err.message.contains("column `x` row 1 is null"), "{err}");
}
