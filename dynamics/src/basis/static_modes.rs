//! The interface's static modes `S = [I; Ψ_o]`, `Ψ_o = −K_oo⁻¹ K_oi`: `K_oo` factorised once,
//! then solved for whichever interface displacements or loads a basis needs.

use faer::{Mat, MatMut, MatRef, Par};
use rayon::prelude::*;
use squeal_linalg::cholesky::Cholesky;

use crate::artifact::{Basis, Model};
use crate::value::StageError;

/// Right-hand sides per sequential solve: the solves run in parallel over fixed chunks of
/// columns, so the result does not depend on the thread count.
const SOLVE_COLUMNS: usize = 64;

/// `K_oo` factorised, and `K_oi` by interface DOF.
pub struct StaticModes {
    n: usize,
    interface: Vec<usize>,
    /// The DOFs off the interface, ascending (`o`).
    others: Vec<usize>,
    /// `None` when every DOF is on the interface (every body kept whole).
    cholesky: Option<Cholesky>,
    /// Column `j` of `K_oi`: `(index among the others, value)`.
    coupling: Vec<Vec<(usize, f64)>>,
}

impl StaticModes {
    /// `interface`: free DOFs, ascending.
    pub fn new(model: &Model, interface: &[usize]) -> Result<StaticModes, StageError> {
        let n = model.n_dofs();
        let mut other_index: Vec<Option<usize>> = vec![None; n];
        let mut on_interface = vec![false; n];
        for &dof in interface {
            on_interface[dof] = true;
        }
        let others: Vec<usize> = (0..n).filter(|&dof| !on_interface[dof]).collect();
        for (index, &dof) in others.iter().enumerate() {
            other_index[dof] = Some(index);
        }
        let K = &model.K;
        let K_oo = K.principal_submatrix(&others);
        let dof_of_node: Vec<[Option<u32>; 3]> = model
            .dof_of_node
            .iter()
            .map(|dofs| {
                dofs.map(|dof| dof.and_then(|dof| other_index[dof as usize].map(|i| i as u32)))
            })
            .collect();
        let cholesky = if others.is_empty() {
            None
        } else {
            let cholesky = Cholesky::new(&[(1.0, &K_oo)], &dof_of_node, &[], Par::Seq).map_err(
                |err| {
                    StageError::new(format!(
                        "basis: K off the interface ({} DOFs) cannot be factorised: {err} (is the structure held away from the contact?)",
                        others.len()
                    ))
                },
            )?;
            Some(cholesky)
        };
        let coupling = interface
            .iter()
            .map(|&col| {
                (K.col_ptr[col]..K.col_ptr[col + 1])
                    .filter_map(|entry| {
                        other_index[K.row_idx[entry]].map(|row| (row, K.values[entry]))
                    })
                    .collect()
            })
            .collect();
        Ok(StaticModes {
            n,
            interface: interface.to_vec(),
            others,
            cholesky,
            coupling,
        })
    }

    pub fn interface(&self) -> &[usize] {
        &self.interface
    }

    /// `K_oo⁻¹ B` in place, `B` over the DOFs off the interface.
    fn solve_in_place(&self, B: MatMut<'_, f64>) {
        if let Some(cholesky) = &self.cholesky {
            cholesky.solve_in_place(B, Par::Seq);
        }
    }

    /// `S X_i` over every free DOF, `S = [I; Ψ_o]` the static modes: the displacement with the
    /// interface at `X_i` (`n_i × p`) and no load off it.
    pub fn static_displacement(&self, X_i: MatRef<'_, f64>) -> Mat<f64> {
        let p = X_i.ncols();
        let mut B = Mat::<f64>::zeros(self.others.len(), p);
        for (j, column) in self.coupling.iter().enumerate() {
            for k in 0..p {
                let x = X_i[(j, k)];
                if x != 0.0 {
                    for &(row, value) in column {
                        B[(row, k)] -= value * x;
                    }
                }
            }
        }
        B.as_mut()
            .par_col_chunks_mut(SOLVE_COLUMNS)
            .for_each(|chunk| self.solve_in_place(chunk));
        let mut U = Mat::<f64>::zeros(self.n, p);
        for k in 0..p {
            for (j, &dof) in self.interface.iter().enumerate() {
                U[(dof, k)] = X_i[(j, k)];
            }
            for (index, &dof) in self.others.iter().enumerate() {
                U[(dof, k)] = B[(index, k)];
            }
        }
        U
    }

    /// `K_oo⁻¹ F_o` over every free DOF, zero on the interface: the static response to loads
    /// `F` (`n × p`) with the interface held.
    pub fn fixed_interface_response(&self, F: MatRef<'_, f64>) -> Mat<f64> {
        let p = F.ncols();
        let mut B = Mat::from_fn(self.others.len(), p, |row, k| F[(self.others[row], k)]);
        B.as_mut()
            .par_col_chunks_mut(SOLVE_COLUMNS)
            .for_each(|chunk| self.solve_in_place(chunk));
        let mut U = Mat::<f64>::zeros(self.n, p);
        for k in 0..p {
            for (index, &dof) in self.others.iter().enumerate() {
                U[(dof, k)] = B[(index, k)];
            }
        }
        U
    }

    /// The basis `T` as a dense matrix, `n × n_reduced`.
    pub fn basis_matrix(&self, basis: &Basis) -> Mat<f64> {
        let n_i = self.interface.len();
        let mut T = Mat::<f64>::zeros(self.n, n_i + basis.vectors.len());
        let static_modes = self.static_displacement(Mat::<f64>::identity(n_i, n_i).as_ref());
        T.as_mut().subcols_mut(0, n_i).copy_from(&static_modes);
        for (k, vector) in basis.vectors.iter().enumerate() {
            T.col_mut(n_i + k)
                .iter_mut()
                .zip(vector)
                .for_each(|(slot, value)| *slot = *value);
        }
        T
    }
}

/// The interface of a model: every free DOF of every node on either side of its contact
/// pairs, ascending.
pub fn interface_dofs(model: &Model) -> Vec<usize> {
    let mut dofs: Vec<usize> = model
        .mesh
        .contact_pairs
        .iter()
        .flat_map(|pair| pair.nodes())
        .flat_map(|node| model.dof_of_node[node as usize])
        .flatten()
        .map(|dof| dof as usize)
        .collect();
    dofs.sort_unstable();
    dofs.dedup();
    dofs
}
