//! `table.gather`: every point of a sweep in one long table, swept parameters as columns.

use crate::artifact::ArtifactType;
use crate::params::{HasParams, NoParams};
use crate::stage::{Coords, Inputs, Outputs, Params, PortSpec, Stage, StageError, single_output};
use crate::table::Table;

/// `table.gather`: every point of a sweep in one long table, swept parameters as columns.
pub struct Gather;

impl HasParams for Gather {
    type Params = NoParams;
}

impl Stage for Gather {
    fn kind(&self) -> &'static str {
        "table.gather"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Stack one table from every point of a sweep, with the swept parameters as columns"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::many(
            "tables",
            ArtifactType::Table,
            "the table of every sweep point",
        )]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("table", "gathered")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "gathered",
            ArtifactType::Table,
            "all points, coordinates first",
        )]
    }
    fn run(&self, _params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let points = inputs.many("tables")?;
        let tables: Vec<(Coords, &Table)> = points
            .iter()
            .map(|(coords, artifact)| {
                let table = artifact
                    .as_table()
                    .ok_or_else(|| StageError::new("not a table"))?;
                Ok((coords.clone(), table))
            })
            .collect::<Result<_, StageError>>()?;
        Ok(single_output("gathered", Table::gather(&tables)?))
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::sync::Arc;

    use super::*;
    use crate::artifact::Artifact;
    use crate::stage::{Input, Value};
    use crate::table::ColumnData;

    #[test]
    fn gather_prepends_coordinates_and_stacks_rows() {
        let a = Table::new().with("f", vec![1.0, 2.0]);
        let b = Table::new().with("f", vec![3.0]);
        let points = vec![
            (
                vec![("mu".to_string(), Value::Float(0.1))],
                Arc::new(Artifact::Table(a)),
            ),
            (
                vec![("mu".to_string(), Value::Float(0.2))],
                Arc::new(Artifact::Table(b)),
            ),
        ];
        let inputs = Inputs(BTreeMap::from([(
            "tables".to_string(),
            Input::Many(points),
        )]));
        let outputs = Gather.run(&Params::default(), &inputs).unwrap();
        let table = outputs["gathered"].as_table().unwrap();
        assert_eq!(
            table.column("mu"),
            Some(&ColumnData::F64(vec![0.1, 0.1, 0.2]))
        );
        assert_eq!(
            table.column("f"),
            Some(&ColumnData::F64(vec![1.0, 2.0, 3.0]))
        );
    }
}
