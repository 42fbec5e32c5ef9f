//! Long tables: named columns of equal length. Everything a person would plot or query is a
//! table; the engine writes each one as a Parquet file.

use serde::{Deserialize, Serialize};

use crate::value::{Coords, StageError, Value};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ColumnData {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Str(Vec<String>),
}

impl ColumnData {
    pub fn len(&self) -> usize {
        match self {
            ColumnData::F64(values) => values.len(),
            ColumnData::I64(values) => values.len(),
            ColumnData::Bool(values) => values.len(),
            ColumnData::Str(values) => values.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn type_name(&self) -> &'static str {
        match self {
            ColumnData::F64(_) => "f64",
            ColumnData::I64(_) => "i64",
            ColumnData::Bool(_) => "bool",
            ColumnData::Str(_) => "string",
        }
    }

    /// A column holding `value` `n_rows` times (sweep coordinates in a gathered table).
    fn repeat(value: &Value, n_rows: usize) -> ColumnData {
        match value {
            Value::Bool(value) => ColumnData::Bool(vec![*value; n_rows]),
            Value::Int(value) => ColumnData::I64(vec![*value; n_rows]),
            Value::Float(value) => ColumnData::F64(vec![*value; n_rows]),
            Value::Str(value) => ColumnData::Str(vec![value.clone(); n_rows]),
        }
    }

    fn extend(&mut self, other: &ColumnData) -> bool {
        match (self, other) {
            (ColumnData::F64(a), ColumnData::F64(b)) => a.extend_from_slice(b),
            (ColumnData::I64(a), ColumnData::I64(b)) => a.extend_from_slice(b),
            (ColumnData::Bool(a), ColumnData::Bool(b)) => a.extend_from_slice(b),
            (ColumnData::Str(a), ColumnData::Str(b)) => a.extend_from_slice(b),
            _ => return false,
        }
        true
    }
}

impl From<Vec<f64>> for ColumnData {
    fn from(values: Vec<f64>) -> Self {
        ColumnData::F64(values)
    }
}

impl From<Vec<i64>> for ColumnData {
    fn from(values: Vec<i64>) -> Self {
        ColumnData::I64(values)
    }
}

impl From<Vec<bool>> for ColumnData {
    fn from(values: Vec<bool>) -> Self {
        ColumnData::Bool(values)
    }
}

impl From<Vec<String>> for ColumnData {
    fn from(values: Vec<String>) -> Self {
        ColumnData::Str(values)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Column {
    pub name: String,
    pub data: ColumnData,
}

/// Named columns of equal length.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Table {
    columns: Vec<Column>,
}

impl Table {
    pub fn new() -> Self {
        Table::default()
    }

    /// The `value` of `name` in a table made by [`Table::quantities`].
    pub fn quantity(&self, name: &str) -> Option<f64> {
        match (self.column("quantity"), self.column("value")) {
            (Some(ColumnData::Str(names)), Some(ColumnData::F64(values))) => names
                .iter()
                .position(|quantity| quantity == name)
                .map(|row| values[row]),
            _ => None,
        }
    }

    /// A stage's summary: one row per named figure, columns `quantity` and `value`.
    pub fn quantities(rows: &[(&str, f64)]) -> Table {
        Table::new()
            .with(
                "quantity",
                rows.iter()
                    .map(|(name, _)| name.to_string())
                    .collect::<Vec<String>>(),
            )
            .with(
                "value",
                rows.iter().map(|(_, value)| *value).collect::<Vec<f64>>(),
            )
    }

    /// Appends a column. Panics if its length differs from the others': a table with ragged
    /// columns is a bug in the stage that builds it.
    pub fn with(mut self, name: impl Into<String>, data: impl Into<ColumnData>) -> Self {
        let name = name.into();
        let data = data.into();
        if let Some(first) = self.columns.first() {
            assert_eq!(
                first.data.len(),
                data.len(),
                "column `{name}` has a different length"
            );
        }
        self.columns.push(Column { name, data });
        self
    }

    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    pub fn column(&self, name: &str) -> Option<&ColumnData> {
        self.columns
            .iter()
            .find(|column| column.name == name)
            .map(|column| &column.data)
    }

    /// The f64 column `name`, or an error naming what is there instead.
    pub fn f64(&self, name: &str) -> Result<&[f64], StageError> {
        match self.column(name) {
            Some(ColumnData::F64(values)) => Ok(values),
            Some(other) => Err(StageError::new(format!(
                "column `{name}` is {}, not f64",
                other.type_name()
            ))),
            None => Err(StageError::new(format!(
                "no column `{name}` (columns: {})",
                self.column_names().join(", ")
            ))),
        }
    }

    /// The i64 column `name`, or an error naming what is there instead.
    pub fn i64(&self, name: &str) -> Result<&[i64], StageError> {
        match self.column(name) {
            Some(ColumnData::I64(values)) => Ok(values),
            Some(other) => Err(StageError::new(format!(
                "column `{name}` is {}, not i64",
                other.type_name()
            ))),
            None => Err(StageError::new(format!(
                "no column `{name}` (columns: {})",
                self.column_names().join(", ")
            ))),
        }
    }

    pub fn column_names(&self) -> Vec<&str> {
        self.columns
            .iter()
            .map(|column| column.name.as_str())
            .collect()
    }

    pub fn n_rows(&self) -> usize {
        self.columns.first().map_or(0, |column| column.data.len())
    }

    /// Stacks the tables of a sweep into one, with the sweep coordinates as leading columns.
    /// Every table must have the same columns (names and types) in the same order.
    pub fn gather(points: &[(Coords, &Table)]) -> Result<Table, StageError> {
        let Some((first_coords, first_table)) = points.first() else {
            return Ok(Table::new());
        };
        let mut columns: Vec<Column> = first_coords
            .iter()
            .map(|(name, value)| Column {
                name: name.clone(),
                data: ColumnData::repeat(value, 0),
            })
            .chain(first_table.columns.iter().map(|column| Column {
                name: column.name.clone(),
                data: empty_like(&column.data),
            }))
            .collect();
        for (point_idx, (coords, table)) in points.iter().enumerate() {
            let same_shape = coords.len() == first_coords.len()
                && table.columns.len() == first_table.columns.len()
                && table
                    .columns
                    .iter()
                    .zip(&first_table.columns)
                    .all(|(a, b)| a.name == b.name && a.data.type_name() == b.data.type_name());
            if !same_shape {
                return Err(StageError::new(format!(
                    "cannot gather: point {point_idx} has different columns from point 0"
                )));
            }
            let n_rows = table.n_rows();
            for (column, (name, value)) in columns.iter_mut().zip(coords) {
                if column.name != *name || !column.data.extend(&ColumnData::repeat(value, n_rows)) {
                    return Err(StageError::new(format!(
                        "cannot gather: sweep coordinate `{name}` differs in type or order at point {point_idx}"
                    )));
                }
            }
            for (column, source) in columns[coords.len()..].iter_mut().zip(&table.columns) {
                column.data.extend(&source.data);
            }
        }
        Ok(Table { columns })
    }
}

fn empty_like(data: &ColumnData) -> ColumnData {
    match data {
        ColumnData::F64(_) => ColumnData::F64(Vec::new()),
        ColumnData::I64(_) => ColumnData::I64(Vec::new()),
        ColumnData::Bool(_) => ColumnData::Bool(Vec::new()),
        ColumnData::Str(_) => ColumnData::Str(Vec::new()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_rejects_tables_with_different_columns() {
        let a = Table::new().with("f", vec![1.0]);
        let b = Table::new().with("g", vec![1.0]);
        let coords = vec![("mu".to_string(), Value::Float(0.1))];
        let err = Table::gather(&[(coords.clone(), &a), (coords, &b)]).unwrap_err();
        assert!(err.message.contains("point 1"), "{err}");
    }
}
