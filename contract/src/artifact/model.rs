//! The assembled finite-element model: sparse mass, stiffness and damping matrices over the
//! free degrees of freedom, the map from nodes to those DOFs, and the tied nodes, whose
//! displacements follow other nodes' (`assemble`'s `ties`).
//!
//! A node's displacement is read from a vector over the free DOFs by
//! [`Model::node_displacement`]: its own DOFs (0 on a clamped axis), or, for a tied node
//! ([`TiedNode`]), the weighted sum of its masters' displacements, u_s = Σ_l w_l u_l. A tied
//! node has no DOF of its own (`None` on all three axes of `dof_of_node`).

use serde::{Deserialize, Serialize};

use super::mesh::Mesh;
use crate::table::Table;
use crate::value::StageError;
pub use squeal_linalg::CscMatrix;

/// `M`, `K`, `C = α M + β K` (α, β per part) over the free DOFs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Model {
    pub mesh: Mesh,
    /// Free DOF index of each node's x, y, z displacement; `None` where clamped or tied.
    pub dof_of_node: Vec<[Option<u32>; 3]>,
    pub M: CscMatrix,
    pub K: CscMatrix,
    pub C: CscMatrix,
    /// The tied nodes, by increasing node: each displacement the weighted sum of its masters'
    /// (empty without ties).
    pub tied: Vec<TiedNode>,
}

/// A node whose displacement follows other nodes': u = Σ_l w_l u_l over its `masters`
/// (node l, weight w_l), the same weights on x, y and z. The weights sum to 1, so that a
/// rigid translation moves the node with its masters; no master is itself tied.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TiedNode {
    pub node: u32,
    /// (master node, weight), each master once.
    pub masters: Vec<(u32, f64)>,
}

/// How far from 1 the weights of a tied node may sum.
pub const TIE_WEIGHT_TOLERANCE: f64 = 1e-9;

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
        self.check_ties()
    }

    /// Checks the tied nodes: in increasing order, each once, in range, without DOFs of their
    /// own; their masters in range, not tied, each once, with finite weights summing to 1
    /// within [`TIE_WEIGHT_TOLERANCE`].
    pub fn check_ties(&self) -> Result<(), StageError> {
        let n_nodes = self.mesh.n_nodes();
        // In order first: the checks below look nodes up by binary search.
        if let Some(pair) = self
            .tied
            .windows(2)
            .find(|pair| pair[0].node >= pair[1].node)
        {
            return Err(StageError::new(format!(
                "model's tied nodes are not in increasing order, or node {} is tied twice",
                pair[1].node
            )));
        }
        for tied in &self.tied {
            let node = tied.node;
            if node as usize >= n_nodes {
                return Err(StageError::new(format!(
                    "model ties node {node}, but its mesh has {n_nodes} nodes"
                )));
            }
            if self
                .dof_of_node
                .get(node as usize)
                .is_some_and(|dofs| dofs.iter().any(Option::is_some))
            {
                return Err(StageError::new(format!(
                    "model ties node {node}, which has DOFs of its own"
                )));
            }
            if tied.masters.is_empty() {
                return Err(StageError::new(format!(
                    "model ties node {node} to no master"
                )));
            }
            for (index, &(master, weight)) in tied.masters.iter().enumerate() {
                if master as usize >= n_nodes {
                    return Err(StageError::new(format!(
                        "model ties node {node} to node {master}, but its mesh has {n_nodes} nodes"
                    )));
                }
                if self.masters(master).is_some() {
                    return Err(StageError::new(format!(
                        "model ties node {node} to node {master}, which is tied itself"
                    )));
                }
                if !weight.is_finite() {
                    return Err(StageError::new(format!(
                        "model ties node {node} to node {master} with weight {weight}"
                    )));
                }
                if tied.masters[..index]
                    .iter()
                    .any(|&(other, _)| other == master)
                {
                    return Err(StageError::new(format!(
                        "model ties node {node} to node {master} twice"
                    )));
                }
            }
            let sum: f64 = tied.masters.iter().map(|(_, weight)| weight).sum();
            if !((sum - 1.0).abs() <= TIE_WEIGHT_TOLERANCE) {
                return Err(StageError::new(format!(
                    "model ties node {node} with weights summing to {sum}, not 1"
                )));
            }
        }
        Ok(())
    }

    /// The masters of `node` and their weights if it is tied, `None` otherwise.
    pub fn masters(&self, node: u32) -> Option<&[(u32, f64)]> {
        self.tied
            .binary_search_by_key(&node, |tied| tied.node)
            .ok()
            .map(|index| self.tied[index].masters.as_slice())
    }

    /// The nodes whose displacements make `node`'s, with their weights: its masters if it is
    /// tied, itself with weight 1 otherwise.
    pub fn node_terms(&self, node: u32) -> impl Iterator<Item = (u32, f64)> + '_ {
        let masters = self.masters(node);
        let own = masters.is_none().then_some((node, 1.0));
        masters.unwrap_or(&[]).iter().copied().chain(own)
    }

    /// The displacement (x, y, z) of `node` from `field` over the free DOFs: its own DOFs' values
    /// (0 on clamped axes), or the weighted sum of its masters' if it is tied.
    pub fn node_displacement(&self, node: u32, field: &[f64]) -> [f64; 3] {
        let own = |node: u32| -> [f64; 3] {
            self.dof_of_node[node as usize].map(|dof| dof.map_or(0.0, |dof| field[dof as usize]))
        };
        match self.masters(node) {
            None => own(node),
            Some(masters) => {
                let mut sum = [0.0; 3];
                for &(master, weight) in masters {
                    let u = own(master);
                    for axis in 0..3 {
                        sum[axis] += weight * u[axis];
                    }
                }
                sum
            }
        }
    }

    /// [`Model::node_displacement`] of every node, node by node: 3 values per node.
    pub fn nodal_displacements(&self, field: &[f64]) -> Vec<f64> {
        let mut vectors = vec![0.0; 3 * self.dof_of_node.len()];
        for (node, dofs) in self.dof_of_node.iter().enumerate() {
            for (axis, dof) in dofs.iter().enumerate() {
                if let Some(dof) = dof {
                    vectors[3 * node + axis] = field[*dof as usize];
                }
            }
        }
        for tied in &self.tied {
            let u = self.node_displacement(tied.node, field);
            let node = tied.node as usize;
            vectors[3 * node..3 * node + 3].copy_from_slice(&u);
        }
        vectors
    }

    /// Adds the nodal force `force` (N) on `node` to `forces` over the free DOFs: on its own
    /// DOFs, or spread on its masters' by their weights if it is tied (the virtual work of the
    /// force is kept, f_l = w_l f). Returns the part that falls on clamped axes.
    pub fn add_nodal_force(&self, node: u32, force: [f64; 3], forces: &mut [f64]) -> [f64; 3] {
        let mut on_clamped = [0.0; 3];
        let mut add = |node: u32, force: [f64; 3]| {
            for axis in 0..3 {
                match self.dof_of_node[node as usize][axis] {
                    Some(dof) => forces[dof as usize] += force[axis],
                    None => on_clamped[axis] += force[axis],
                }
            }
        };
        match self.masters(node) {
            None => add(node, force),
            Some(masters) => {
                for &(master, weight) in masters {
                    add(master, force.map(|component| weight * component));
                }
            }
        }
        on_clamped
    }

    /// The connected bodies of the model: [`Mesh::bodies_of_nodes`], a tied node joining the
    /// body of its masters (a part tied to another moves with it).
    pub fn bodies_of_nodes(&self) -> (Vec<usize>, usize) {
        let links: Vec<(u32, u32)> = self
            .tied
            .iter()
            .flat_map(|tied| tied.masters.iter().map(|&(master, _)| (tied.node, master)))
            .collect();
        self.mesh.bodies_of_linked_nodes(&links)
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
        // The ties decide what the free DOFs mean at the tied nodes; a model without ties
        // keeps the digest it had before ties existed.
        if !self.tied.is_empty() {
            let mut buffer = Vec::new();
            for tied in &self.tied {
                buffer.extend_from_slice(&u64::from(tied.node).to_le_bytes());
                buffer.extend_from_slice(&(tied.masters.len() as u64).to_le_bytes());
                for &(master, weight) in &tied.masters {
                    buffer.extend_from_slice(&u64::from(master).to_le_bytes());
                    buffer.extend_from_slice(&weight.to_bits().to_le_bytes());
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

    /// A wide table of fields over the free DOFs: columns `node`, `dir`, `dof` (−1 where clamped
    /// or tied), then one f64 column per field; one row per node and direction, zeros on
    /// clamped DOFs, a tied node's rows its masters' values by their weights
    /// ([`Model::node_displacement`]).
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
            let mut values: Vec<f64> = dofs
                .iter()
                .map(|dof| dof.and_then(|dof| field.get(dof)).copied().unwrap_or(0.0))
                .collect();
            if field.len() == model.n_dofs() && !model.dof_of_node.is_empty() {
                for tied in &model.tied {
                    let node = tied.node as usize;
                    values[3 * node..3 * node + 3]
                        .copy_from_slice(&model.node_displacement(tied.node, &field));
                }
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Three nodes, the third tied to the first two; DOFs 0..6 on the first two.
    fn tied_model() -> Model {
        let identity = || CscMatrix::from_triplets(5, 5, (0..5).map(|i| (i, i, 1.0)).collect());
        Model {
            mesh: Mesh {
                nodes: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.25, 0.0, 0.0]],
                ..Mesh::default()
            },
            dof_of_node: vec![
                [Some(0), Some(1), Some(2)],
                [Some(3), None, Some(4)],
                [None; 3],
            ],
            M: identity(),
            K: identity(),
            C: identity(),
            tied: vec![TiedNode {
                node: 2,
                masters: vec![(0, 0.75), (1, 0.25)],
            }],
        }
    }

    #[test]
    fn a_tied_node_moves_and_is_loaded_through_its_masters() {
        let model = tied_model();
        model.check_dof_map().unwrap();
        let u = [1.0, 2.0, 3.0, 5.0, 7.0];
        assert_eq!(model.node_displacement(0, &u), [1.0, 2.0, 3.0]);
        // Node 1 is clamped along y.
        assert_eq!(model.node_displacement(1, &u), [5.0, 0.0, 7.0]);
        assert_eq!(model.node_displacement(2, &u), [2.0, 1.5, 4.0]);
        assert_eq!(
            model.nodal_displacements(&u),
            vec![1.0, 2.0, 3.0, 5.0, 0.0, 7.0, 2.0, 1.5, 4.0]
        );
        let mut forces = vec![0.0; 5];
        let on_clamped = model.add_nodal_force(2, [4.0, 8.0, 12.0], &mut forces);
        assert_eq!(forces, vec![3.0, 6.0, 9.0, 1.0, 3.0]);
        assert_eq!(on_clamped, [0.0, 2.0, 0.0]);
        assert_eq!(
            model.node_terms(2).collect::<Vec<_>>(),
            vec![(0, 0.75), (1, 0.25)]
        );
        assert_eq!(model.node_terms(1).collect::<Vec<_>>(), vec![(1, 1.0)]);
        let table = model.nodal_table(vec![("u".into(), u.to_vec())]);
        assert_eq!(
            table.column("u"),
            Some(&crate::table::ColumnData::F64(vec![
                1.0, 2.0, 3.0, 5.0, 0.0, 7.0, 2.0, 1.5, 4.0
            ]))
        );
        // One body: the tied node joins its masters'.
        assert_eq!(model.bodies_of_nodes().0[2], model.bodies_of_nodes().0[0]);
        // The ties are part of the fingerprint; none, the digest of the matrices alone.
        let mut untied = model.clone();
        untied.tied.clear();
        assert_ne!(model.fingerprint(), untied.fingerprint());
    }

    #[test]
    fn broken_ties_are_named() {
        let check = |edit: &dyn Fn(&mut Model)| {
            let mut model = tied_model();
            edit(&mut model);
            model.check_ties().unwrap_err().message
        };
        assert_eq!(
            check(&|model| model.tied[0].masters[1].1 = 0.3),
            "model ties node 2 with weights summing to 1.05, not 1"
        );
        assert_eq!(
            check(&|model| model.tied[0].masters[1].0 = 7),
            "model ties node 2 to node 7, but its mesh has 3 nodes"
        );
        assert_eq!(
            check(&|model| model.tied[0].node = 5),
            "model ties node 5, but its mesh has 3 nodes"
        );
        assert_eq!(
            check(&|model| model.dof_of_node[2] = [Some(0), None, None]),
            "model ties node 2, which has DOFs of its own"
        );
        assert_eq!(
            check(&|model| {
                model.dof_of_node[1] = [None; 3];
                model.tied.insert(
                    0,
                    TiedNode {
                        node: 1,
                        masters: vec![(0, 1.0)],
                    },
                )
            }),
            "model ties node 2 to node 1, which is tied itself"
        );
        assert_eq!(
            check(&|model| {
                model.tied.push(TiedNode {
                    node: 1,
                    masters: vec![(0, 1.0)],
                })
            }),
            "model's tied nodes are not in increasing order, or node 1 is tied twice"
        );
        assert_eq!(
            check(&|model| model.tied[0].masters = vec![(0, 0.5), (0, 0.5)]),
            "model ties node 2 to node 0 twice"
        );
        assert_eq!(
            check(&|model| model.tied[0].masters.clear()),
            "model ties node 2 to no master"
        );
    }
}
