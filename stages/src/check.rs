//! `check`: one figure of a table against its acceptance range, as a one-row verdict table.
//! Gathered over a study (`table.gather`), the verdicts make a stress or acceptance table:
//! case, what was expected, what was observed, whether it holds.
//!
//! The figure is a quantity of a stage's summary (`quantity`, `value` rows), or the largest
//! value of a column (the worst residual or error bound of an eigenvalue table). NaN never
//! passes: a figure that was not computed is not a pass.

use crate::artifact::{Artifact, ArtifactType};
use crate::stage::{Inputs, Outputs, ParamSpec, Params, PortSpec, Stage, StageError};
use crate::table::{ColumnData, Table};

/// `check`.
pub struct Check;

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckParams {
    case: String,
    expected: String,
    quantity: String,
    /// `None`: no bound (the default, infinite, reads back as null).
    at_least: Option<f64>,
    at_most: Option<f64>,
}

/// The figure named `quantity`: a summary's quantity, else the largest of a numeric column.
fn observed(table: &Table, quantity: &str) -> Result<f64, StageError> {
    if let Some(value) = table.quantity(quantity) {
        return Ok(value);
    }
    let largest = |values: &mut dyn Iterator<Item = f64>| {
        values.fold(f64::NEG_INFINITY, |largest, value| {
            if value.is_nan() || largest.is_nan() {
                f64::NAN
            } else {
                largest.max(value)
            }
        })
    };
    match table.column(quantity) {
        Some(ColumnData::F64(values)) => Ok(largest(&mut values.iter().copied())),
        Some(ColumnData::I64(values)) => Ok(largest(&mut values.iter().map(|&v| v as f64))),
        Some(ColumnData::Bool(values)) => {
            Ok(largest(&mut values.iter().map(|&v| f64::from(u8::from(v)))))
        }
        _ => Err(StageError::new(format!(
            "the table has no quantity or numeric column `{quantity}` (columns: {})",
            table
                .columns()
                .iter()
                .map(|column| column.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

impl Stage for Check {
    fn kind(&self) -> &'static str {
        "check"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "One figure of a table (a summary's quantity, or a column's largest value) against its acceptance range: a one-row verdict to gather into a stress table"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::string("case", "", "what is tried, in a few words").required(),
            ParamSpec::string("expected", "", "the behaviour expected, in a few words").required(),
            ParamSpec::string(
                "quantity",
                "",
                "a quantity of a summary table, or a column whose largest value is checked",
            )
            .required(),
            ParamSpec::float("at_least", f64::NEG_INFINITY, "", "lowest accepted value"),
            ParamSpec::float("at_most", f64::INFINITY, "", "highest accepted value"),
        ]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "table",
            ArtifactType::Table,
            "a stage's summary or any table with the figure",
        )]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "verdict",
            ArtifactType::Table,
            "case, expected, quantity, observed, at_least, at_most, holds",
        )]
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<CheckParams>().map(drop)
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: CheckParams = params.typed()?;
        let value = observed(inputs.table("table")?, &params.quantity)?;
        let at_least = params.at_least.unwrap_or(f64::NEG_INFINITY);
        let at_most = params.at_most.unwrap_or(f64::INFINITY);
        let holds = value >= at_least && value <= at_most;
        let verdict = Table::new()
            .with("case", vec![params.case])
            .with("expected", vec![params.expected])
            .with("quantity", vec![params.quantity])
            .with("observed", vec![value])
            .with("at_least", vec![at_least])
            .with("at_most", vec![at_most])
            .with("holds", vec![holds]);
        Ok(Outputs::from([(
            "verdict".to_string(),
            Artifact::Table(verdict),
        )]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::{Input, Value};
    use std::sync::Arc;

    fn verdict(table: Table, quantity: &str, at_most: f64) -> Result<(f64, bool), StageError> {
        let params = Params(
            [
                ("case", Value::Str("c".into())),
                ("expected", Value::Str("e".into())),
                ("quantity", Value::Str(quantity.into())),
                ("at_least", Value::Float(f64::NEG_INFINITY)),
                ("at_most", Value::Float(at_most)),
            ]
            .into_iter()
            .map(|(name, value)| (name.to_string(), value))
            .collect(),
        );
        let inputs = Inputs(
            [(
                "table".to_string(),
                Input::One(Arc::new(Artifact::Table(table))),
            )]
            .into(),
        );
        let outputs = Check.run(&params, &inputs)?;
        let Artifact::Table(verdict) = &outputs["verdict"] else {
            panic!("a table")
        };
        let observed = match verdict.column("observed") {
            Some(ColumnData::F64(values)) => values[0],
            _ => panic!("observed"),
        };
        let holds = match verdict.column("holds") {
            Some(ColumnData::Bool(values)) => values[0],
            _ => panic!("holds"),
        };
        Ok((observed, holds))
    }

    #[test]
    fn a_summary_quantity_or_a_columns_largest_value_is_checked() {
        let summary = Table::quantities(&[("worst_residual", 3e-13), ("eigenvalues", 12.0)]);
        assert_eq!(
            verdict(summary.clone(), "worst_residual", 1e-10).unwrap(),
            (3e-13, true)
        );
        assert_eq!(
            verdict(summary, "eigenvalues", 10.0).unwrap(),
            (12.0, false)
        );
        let column = Table::new().with("error_bound", vec![1e-15, 4e-12, 2e-14]);
        assert_eq!(
            verdict(column.clone(), "error_bound", 1e-10).unwrap(),
            (4e-12, true)
        );
        // A figure that was not computed does not pass.
        let missing = Table::new().with("error_bound", vec![1e-15, f64::NAN]);
        let (value, holds) = verdict(missing, "error_bound", 1.0).unwrap();
        assert!(value.is_nan() && !holds);
        let error = verdict(column, "condition", 1.0).unwrap_err();
        assert!(
            error
                .message
                .contains("no quantity or numeric column `condition` (columns: error_bound)")
        );
    }
}
