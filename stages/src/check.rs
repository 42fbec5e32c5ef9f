//! `check`: one figure of a table against its acceptance range, a verdict row per point of a
//! sweep. Checks chain (`previous`: the verdicts of the check before, to which this one's rows
//! are added), so that the last check of a study holds its whole stress or acceptance table:
//! case, sweep point, what was expected, what was observed, whether it holds.
//!
//! The figure is a quantity of a stage's summary (`quantity`, `value` rows), or the largest
//! value of a column (the worst residual or error bound of an eigenvalue table). NaN never
//! passes: a figure that was not computed is not a pass.

use crate::artifact::{Artifact, ArtifactType};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::{ColumnData, Table};

/// `check`.
pub struct Check;

crate::stage_params! {
    /// The parameters of `check`.
    pub struct CheckParams {
        /// what is tried, in a few words
        case: String,
        /// the behaviour expected, in a few words
        expected: String,
        /// a quantity of a summary table, or a column whose largest value is checked
        quantity: String,
        /// lowest accepted value
        at_least: f64 = f64::NEG_INFINITY,
        /// highest accepted value
        at_most: f64 = f64::INFINITY,
    }
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

impl HasParams for Check {
    type Params = CheckParams;
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
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::many(
                "tables",
                ArtifactType::Table,
                "a stage's summary or any table with the figure, at every point of its sweep",
            ),
            PortSpec::one(
                "previous",
                ArtifactType::Table,
                "the verdicts of the check before, to which this check's rows are added",
            )
            .optional(),
        ]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "verdicts",
            ArtifactType::Table,
            "case, point (the sweep coordinates), expected, quantity, observed, at_least, at_most, holds: the previous check's rows, then one per point",
        )]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: CheckParams = params.read::<Self>()?;
        let (at_least, at_most) = (params.at_least, params.at_most);
        let mut rows = match inputs.get_optional::<Table>("previous")? {
            Some(previous) => Verdicts::read(previous)?,
            None => Verdicts::default(),
        };
        for (coords, artifact) in inputs.many("tables")? {
            let table = artifact
                .as_table()
                .ok_or_else(|| StageError::new("tables: not a table"))?;
            let value = observed(table, &params.quantity)?;
            rows.case.push(params.case.clone());
            rows.point.push(
                coords
                    .iter()
                    .map(|(name, value)| format!("{name}={value}"))
                    .collect::<Vec<_>>()
                    .join(" "),
            );
            rows.expected.push(params.expected.clone());
            rows.quantity.push(params.quantity.clone());
            rows.observed.push(value);
            rows.at_least.push(at_least);
            rows.at_most.push(at_most);
            rows.holds.push(value >= at_least && value <= at_most);
        }
        Ok(Outputs::from([(
            "verdicts".to_string(),
            Artifact::Table(rows.table()),
        )]))
    }
}

/// The columns of a verdict table.
#[derive(Debug, Default)]
struct Verdicts {
    case: Vec<String>,
    point: Vec<String>,
    expected: Vec<String>,
    quantity: Vec<String>,
    observed: Vec<f64>,
    at_least: Vec<f64>,
    at_most: Vec<f64>,
    holds: Vec<bool>,
}

impl Verdicts {
    fn read(table: &Table) -> Result<Verdicts, StageError> {
        let strings = |name: &str| match table.column(name) {
            Some(ColumnData::Str(values)) => Ok(values.clone()),
            _ => Err(StageError::new(format!(
                "previous: not a check's verdicts (no string column `{name}`)"
            ))),
        };
        let floats = |name: &str| match table.column(name) {
            Some(ColumnData::F64(values)) => Ok(values.clone()),
            _ => Err(StageError::new(format!(
                "previous: not a check's verdicts (no f64 column `{name}`)"
            ))),
        };
        let Some(ColumnData::Bool(holds)) = table.column("holds") else {
            return Err(StageError::new(
                "previous: not a check's verdicts (no bool column `holds`)",
            ));
        };
        Ok(Verdicts {
            case: strings("case")?,
            point: strings("point")?,
            expected: strings("expected")?,
            quantity: strings("quantity")?,
            observed: floats("observed")?,
            at_least: floats("at_least")?,
            at_most: floats("at_most")?,
            holds: holds.clone(),
        })
    }

    fn table(self) -> Table {
        Table::new()
            .with("case", self.case)
            .with("point", self.point)
            .with("expected", self.expected)
            .with("quantity", self.quantity)
            .with("observed", self.observed)
            .with("at_least", self.at_least)
            .with("at_most", self.at_most)
            .with("holds", self.holds)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::{Input, Value};
    use std::sync::Arc;

    fn params(quantity: &str, at_most: f64) -> Params {
        Params(
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
        )
    }

    fn run(
        points: Vec<(crate::stage::Coords, Table)>,
        previous: Option<Table>,
        quantity: &str,
        at_most: f64,
    ) -> Result<Table, StageError> {
        let mut inputs = Inputs::default();
        inputs.0.insert(
            "tables".to_string(),
            Input::Many(
                points
                    .into_iter()
                    .map(|(coords, table)| (coords, Arc::new(Artifact::Table(table))))
                    .collect(),
            ),
        );
        if let Some(previous) = previous {
            inputs.0.insert(
                "previous".to_string(),
                Input::One(Arc::new(Artifact::Table(previous))),
            );
        }
        let outputs = Check.run(&params(quantity, at_most), &inputs)?;
        let Artifact::Table(verdicts) = &outputs["verdicts"] else {
            panic!("a table")
        };
        Ok(verdicts.clone())
    }

    fn verdict(table: Table, quantity: &str, at_most: f64) -> Result<(f64, bool), StageError> {
        let verdicts = run(vec![(Vec::new(), table)], None, quantity, at_most)?;
        let (Some(ColumnData::F64(observed)), Some(ColumnData::Bool(holds))) =
            (verdicts.column("observed"), verdicts.column("holds"))
        else {
            panic!("observed, holds")
        };
        Ok((observed[0], holds[0]))
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

    #[test]
    fn a_chain_of_checks_adds_a_row_per_point_to_the_verdicts_before() {
        let summary = |value: f64| Table::quantities(&[("worst_residual", value)]);
        let first = run(
            vec![(Vec::new(), summary(1e-13))],
            None,
            "worst_residual",
            1e-10,
        )
        .unwrap();
        let points = vec![
            (vec![("mu".to_string(), Value::Float(0.5))], summary(1e-12)),
            (vec![("mu".to_string(), Value::Float(1.5))], summary(1e-9)),
        ];
        let all = run(points, Some(first), "worst_residual", 1e-10).unwrap();
        assert_eq!(all.n_rows(), 3);
        let (Some(ColumnData::Str(point)), Some(ColumnData::Bool(holds))) =
            (all.column("point"), all.column("holds"))
        else {
            panic!("point, holds")
        };
        assert_eq!(point, &["", "mu=0.5", "mu=1.5"]);
        assert_eq!(holds, &[true, true, false]);
        let not_verdicts = run(Vec::new(), Some(summary(1.0)), "worst_residual", 1.0).unwrap_err();
        assert!(
            not_verdicts
                .message
                .contains("previous: not a check's verdicts")
        );
    }
}
