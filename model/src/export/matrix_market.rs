//! `matrix_market`: the model's `M`, `K`, `C` as Matrix Market files for scipy and MATLAB, with
//! the table that maps their rows to mesh nodes; and a reader for such files.
//!
//! # What is written
//!
//! ```text
//! %%MatrixMarket matrix coordinate real symmetric
//! % squeal: stiffness matrix K (N/m) over 3 free DOFs; row r is dof r - 1 of the dofs table
//! 3 3 5                                      rows, columns, entries written
//! 1 1 2.0000000000000000e0                   row, column (1-based), value
//! 2 1 -1.0000000000000000e0
//! ...
//! ```
//!
//! A symmetric matrix (equal to its transpose bit for bit) is written as its lower triangle,
//! column by column; any other as `general` with every stored entry. Values carry 17
//! significant digits, which identify an IEEE double uniquely, so readers get the exact bits
//! back: `scipy.io.mmread("K.mtx").tocsc()` in Python, `K = mmread('K.mtx')` in MATLAB (the
//! NIST `mmread.m`).
//!
//! Rows and columns are the model's free DOFs. The `dofs` table (`dof`, `node`, `dir`) says
//! which node and direction (`x`, `y`, `z`) each one is: row `r` of the file (1-based) is
//! `dof = r - 1`. Clamped DOFs are not in the matrices.

use crate::artifact::{Artifact, ArtifactType, Model};
use crate::params::{HasParams, NoParams};
use crate::stage::{Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;
use squeal_linalg::matrix_market::write_matrix_market;

/// `matrix_market`: writes `M.mtx`, `K.mtx`, `C.mtx` and the `dofs` table.
pub struct MatrixMarket;

impl HasParams for MatrixMarket {
    type Params = NoParams;
}

impl Stage for MatrixMarket {
    fn kind(&self) -> &'static str {
        "matrix_market"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Export M, K, C as Matrix Market files (scipy.io.mmread, MATLAB mmread) with the DOF-to-node table"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "model",
            ArtifactType::Model,
            "the assembled model",
        )]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one("M", ArtifactType::Document, "mass matrix (kg), M.mtx"),
            PortSpec::one("K", ArtifactType::Document, "stiffness matrix (N/m), K.mtx"),
            PortSpec::one("C", ArtifactType::Document, "damping matrix (N s/m), C.mtx"),
            PortSpec::one(
                "dofs",
                ArtifactType::Table,
                "dof (0-based row), node, dir (x, y, z) of every matrix row",
            ),
        ]
    }
    fn run(&self, _params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let model = inputs.get::<Model>("model")?;
        model.check_dof_map()?;
        let n_dofs = model.n_dofs();
        let mut outputs = Outputs::new();
        for (name, matrix, what) in [
            ("M", &model.M, "mass matrix M (kg)"),
            ("K", &model.K, "stiffness matrix K (N/m)"),
            ("C", &model.C, "damping matrix C (N s/m)"),
        ] {
            if matrix.n_rows != n_dofs || matrix.n_cols != n_dofs {
                return Err(StageError::new(format!(
                    "{name} is {} x {}, the model has {n_dofs} DOFs",
                    matrix.n_rows, matrix.n_cols
                )));
            }
            let comment = format!(
                "squeal: {what} over {n_dofs} free DOFs; row r is dof r - 1 of the dofs table"
            );
            let text = write_matrix_market(matrix, &comment)
                .map_err(|err| StageError::new(format!("{name}: {err}")))?;
            outputs.insert(name.to_string(), Artifact::document("mtx", text));
        }
        outputs.insert("dofs".to_string(), Artifact::Table(dof_table(model)));
        Ok(outputs)
    }
}

/// One row per free DOF, in DOF order: `dof`, `node`, `dir`.
fn dof_table(model: &crate::artifact::Model) -> Table {
    let mut rows: Vec<(i64, i64, &str)> = Vec::with_capacity(model.n_dofs());
    for (node, dofs) in model.dof_of_node.iter().enumerate() {
        for (dof, dir) in dofs.iter().zip(["x", "y", "z"]) {
            if let Some(dof) = dof {
                rows.push((i64::from(*dof), node as i64, dir));
            }
        }
    }
    rows.sort_unstable();
    Table::new()
        .with("dof", rows.iter().map(|row| row.0).collect::<Vec<_>>())
        .with("node", rows.iter().map(|row| row.1).collect::<Vec<_>>())
        .with(
            "dir",
            rows.iter().map(|row| row.2.to_string()).collect::<Vec<_>>(),
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artifact::CscMatrix;
    use crate::artifact::Model;
    use crate::mesh::structured::block;
    use crate::stage::Input;
    use crate::table::ColumnData;
    use squeal_linalg::matrix_market::read_matrix_market;
    use std::collections::BTreeMap;
    use std::sync::Arc;

    #[test]
    fn stage_writes_three_matrices_and_the_dof_table() {
        // Two nodes of a block mesh, node 0 clamped in x: 5 DOFs.
        let mut mesh = block([1.0, 1.0, 1.0], [1, 1, 1], "steel");
        mesh.nodes.truncate(2);
        mesh.elements = Default::default();
        mesh.node_sets.clear();
        let dof_of_node = vec![[None, Some(0), Some(1)], [Some(2), Some(3), Some(4)]];
        let identity =
            |scale: f64| CscMatrix::from_triplets(5, 5, (0..5).map(|i| (i, i, scale)).collect());
        let model = Model {
            mesh,
            dof_of_node,
            M: identity(2.0),
            K: identity(3.0),
            C: identity(0.5),
            tied: Vec::new(),
        };
        let inputs = crate::stage::Inputs(BTreeMap::from([(
            "model".to_string(),
            Input::One(Arc::new(Artifact::Model(Box::new(model.clone())))),
        )]));
        let outputs = MatrixMarket.run(&Params::default(), &inputs).unwrap();
        let Artifact::Document(k) = &outputs["K"] else {
            panic!("K is not a document")
        };
        assert_eq!(k.extension, "mtx");
        let text = String::from_utf8(k.bytes.clone()).unwrap();
        assert!(
            text.contains("stiffness matrix K (N/m) over 5 free DOFs"),
            "{text}"
        );
        assert_eq!(read_matrix_market(&text).unwrap(), model.K);
        let dofs = outputs["dofs"].as_table().unwrap();
        assert_eq!(
            dofs.column("dof"),
            Some(&ColumnData::I64(vec![0, 1, 2, 3, 4]))
        );
        assert_eq!(
            dofs.column("node"),
            Some(&ColumnData::I64(vec![0, 0, 1, 1, 1]))
        );
        let dirs = ["y", "z", "x", "y", "z"].map(String::from).to_vec();
        assert_eq!(dofs.column("dir"), Some(&ColumnData::Str(dirs)));

        // A model whose DOF map skips a DOF is refused, not written.
        let mut broken = model;
        broken.dof_of_node[1][0] = None;
        let inputs = crate::stage::Inputs(BTreeMap::from([(
            "model".to_string(),
            Input::One(Arc::new(Artifact::Model(Box::new(broken)))),
        )]));
        let err = MatrixMarket.run(&Params::default(), &inputs).unwrap_err();
        assert!(err.message.contains("no node maps to DOF 2"), "{err}");
    }
}
