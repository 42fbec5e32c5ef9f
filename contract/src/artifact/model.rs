//! The assembled finite-element model: sparse mass, stiffness and damping matrices over the
//! free degrees of freedom, and the map from nodes to those DOFs.

use serde::{Deserialize, Serialize};

use super::mesh::Mesh;
use crate::table::Table;
use crate::value::StageError;
pub use squeal_linalg::CscMatrix;

/// `M`, `K`, `C = α M + β K` (α, β per part) over the free DOFs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Model {
    pub mesh: Mesh,
    /// Free DOF index of each node's x, y, z displacement; `None` where clamped.
    pub dof_of_node: Vec<[Option<u32>; 3]>,
    pub M: CscMatrix,
    pub K: CscMatrix,
    pub C: CscMatrix,
}

impl Model {
    /// Checks that `dof_of_node` numbers the free DOFs 0..n once each, with one entry per node.
    pub fn check_dof_map(&self) -> Result<(), StageError> {
        let model = self;
        let n_dofs = model.n_dofs();
        if model.dof_of_node.len() != model.mesh.n_nodes() {
            return Err(StageError::new(format!(
                "model maps {} nodes to DOFs but its mesh has {}",
                model.dof_of_node.len(),
                model.mesh.n_nodes()
            )));
        }
        let mut seen = vec![false; n_dofs];
        for (node, dofs) in model.dof_of_node.iter().enumerate() {
            for dof in dofs.iter().flatten() {
                let dof = *dof as usize;
                if dof >= n_dofs || std::mem::replace(&mut seen[dof], true) {
                    return Err(StageError::new(format!(
                        "model maps node {node} to DOF {dof}, out of range or already taken (n = {n_dofs})"
                    )));
                }
            }
        }
        if let Some(missing) = seen.iter().position(|taken| !taken) {
            return Err(StageError::new(format!(
                "model has {n_dofs} DOFs but no node maps to DOF {missing}"
            )));
        }
        Ok(())
    }

    pub fn n_dofs(&self) -> usize {
        self.K.n_rows
    }

    /// A digest of `M`, `C`, `K` (patterns and values): what a reduction basis's reduced
    /// matrices were projected from, so that a basis meets only the model it was built on.
    pub fn fingerprint(&self) -> [u8; 32] {
        let mut hasher = blake3::Hasher::new();
        for A in [&self.M, &self.C, &self.K] {
            let words = [A.n_rows, A.n_cols]
                .into_iter()
                .chain(A.col_ptr.iter().copied())
                .chain(A.row_idx.iter().copied())
                .map(|count| count as u64)
                .chain(A.values.iter().map(|value| value.to_bits()));
            // Through a buffer: blake3 is fast on long updates, slow on 8-byte ones.
            let mut buffer = Vec::with_capacity(1 << 16);
            for word in words {
                buffer.extend_from_slice(&word.to_le_bytes());
                if buffer.len() == buffer.capacity() {
                    hasher.update(&buffer);
                    buffer.clear();
                }
            }
            hasher.update(&buffer);
        }
        *hasher.finalize().as_bytes()
    }

    /// The free DOF of each row of [`Model::nodal_table`] (node-major, x, y, z), `None` where
    /// clamped; one row per DOF for a model without a node map.
    pub fn dof_of_nodal_row(&self) -> Vec<Option<usize>> {
        if self.dof_of_node.is_empty() {
            return (0..self.n_dofs()).map(Some).collect();
        }
        self.dof_of_node
            .iter()
            .flatten()
            .map(|dof| dof.map(|dof| dof as usize))
            .collect()
    }

    /// A wide table of fields over the free DOFs: columns `node`, `dir`, `dof` (−1 where clamped),
    /// then one f64 column per field; one row per node and direction, zeros on clamped DOFs.
    pub fn nodal_table(&self, fields: Vec<(String, Vec<f64>)>) -> Table {
        let model = self;
        let (nodes, directions): (Vec<i64>, Vec<String>) = if model.dof_of_node.is_empty() {
            (
                vec![-1; model.n_dofs()],
                vec![String::new(); model.n_dofs()],
            )
        } else {
            (0..model.dof_of_node.len())
                .flat_map(|node| ["x", "y", "z"].map(|direction| (node as i64, direction.into())))
                .unzip()
        };
        let dofs = model.dof_of_nodal_row();
        let mut table = Table::new()
            .with("node", nodes)
            .with("dir", directions)
            .with(
                "dof",
                dofs.iter()
                    .map(|dof| dof.map_or(-1, |dof| dof as i64))
                    .collect::<Vec<i64>>(),
            );
        for (name, field) in fields {
            let values: Vec<f64> = dofs
                .iter()
                .map(|dof| dof.and_then(|dof| field.get(dof)).copied().unwrap_or(0.0))
                .collect();
            table = table.with(name, values);
        }
        table
    }
}

/// Real modes of (K, M): ω², mass-normalised shapes, residuals.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RealModes {
    /// Angular frequencies ω (rad/s), ascending.
    pub omega: Vec<f64>,
    /// Shapes over the free DOFs, one vector per mode, with φᵀ M φ = 1.
    pub shapes: Vec<Vec<f64>>,
    /// ‖K φ − ω² M φ‖ / ‖K φ‖ per mode.
    pub residuals: Vec<f64>,
}
