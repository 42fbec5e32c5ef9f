//! A reduction basis and the reduced matrices of a model on it, with the interface's static
//! modes `Ψ_o = −K_oo⁻¹ K_oi` that map between full and reduced coordinates.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{CscMatrix, Model};
use crate::value::StageError;

/// `u = T x` with `x = [u_i; q]`: the interface DOFs `u_i` (every free DOF of the contact
/// pairs' nodes) kept as they are, with their static modes, and the weights `q` of vectors
/// `Φ` that vanish on the interface:
///
/// ```text
/// T = [[I, 0], [Ψ_o, Φ_o]],   Ψ_o = −K_oo⁻¹ K_oi,   Φᵀ M Φ = I
/// ```
///
/// (`o`: the other DOFs). `Ψ_o` is computed by the stages' `basis::StaticModes`
/// and stored body by body ([`StaticBlock`]): a run lifts its snapshots to every DOF by
/// products with it, where a solve by `K_oo` would first factorise `K_oo` again.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Basis {
    /// Which family the vectors come from (`fc`, `real`, `craig_bampton`, `modes`).
    pub kind: String,
    /// [`Model::fingerprint`] of the model the reduced matrices come from.
    pub model: [u8; 32],
    /// The interface DOFs, ascending: the first coordinates of `x`.
    pub interface: Vec<u32>,
    /// `Φ` over the free DOFs, one vector per column of `T` after the interface's.
    pub vectors: Vec<Vec<f64>>,
    /// `Tᵀ M T`, `Tᵀ C T`, `Tᵀ K T`, of size [`Basis::n_reduced`], both triangles, their
    /// exact zeros left out: the static modes of separate bodies (disc, pads) do not couple,
    /// so neither do their blocks, and the steps' products and factorisation skip them.
    pub mass: CscMatrix,
    pub damping: CscMatrix,
    pub stiffness: CscMatrix,
    /// DOFs of the model.
    pub n_dofs: usize,
    /// `Ψ_o`, one block per body: the static modes do not couple separate bodies.
    pub static_modes: Vec<StaticBlock>,
}

/// One body's block of `Ψ_o`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StaticBlock {
    /// The body's DOFs off the interface, ascending.
    pub rows: Vec<u32>,
    /// The positions in [`Basis::interface`] of the body's interface DOFs.
    pub columns: Vec<u32>,
    /// `Ψ_o[rows, columns]`, column-major.
    pub values: Vec<f64>,
}

impl StaticBlock {
    fn matrix(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.values, self.rows.len(), self.columns.len())
    }
}

impl Basis {
    /// Coordinates of the reduced model: interface DOFs plus vectors.
    pub fn n_reduced(&self) -> usize {
        self.interface.len() + self.vectors.len()
    }

    /// The reduced coordinates of `u`: `u_i` itself, and the `M`-orthogonal projection of the
    /// rest, `q = Φᵀ M (u − S u_i) = Φᵀ M u − (Φᵀ M S) u_i`, `Φᵀ M S` read off the reduced
    /// mass (exact when `u` lies in the span of `T`; no solve by `K_oo`).
    pub fn restrict(&self, M: &CscMatrix, u: &[f64]) -> Vec<f64> {
        let n_i = self.interface.len();
        let u_i: Vec<f64> = self.interface.iter().map(|&dof| u[dof as usize]).collect();
        let M_u = M.mul_vec(u);
        // (Φᵀ M S) u_i: the reduced mass's rows of the vectors, its columns of the interface.
        let mut coupling = vec![0.0; self.vectors.len()];
        let mass = &self.mass;
        for (j, &u_j) in u_i.iter().enumerate() {
            for entry in mass.col_ptr[j]..mass.col_ptr[j + 1] {
                if let Some(row) = mass.row_idx[entry].checked_sub(n_i) {
                    coupling[row] += mass.values[entry] * u_j;
                }
            }
        }
        let q = self
            .vectors
            .iter()
            .zip(&coupling)
            .map(|(vector, coupling)| {
                vector.iter().zip(&M_u).map(|(a, b)| a * b).sum::<f64>() - coupling
            });
        u_i.iter().copied().chain(q).collect()
    }

    /// `u = T x` for each column of `X` (`n_reduced × p`). Every part is a product over fixed
    /// chunks of rows, sequential within a chunk, so the bits do not depend on the thread
    /// count.
    pub fn lift(&self, X: MatRef<'_, f64>) -> Mat<f64> {
        let (n_i, p) = (self.interface.len(), X.ncols());
        let mut U = Mat::<f64>::zeros(self.n_dofs, p);
        for (j, &dof) in self.interface.iter().enumerate() {
            for k in 0..p {
                U[(dof as usize, k)] = X[(j, k)];
            }
        }
        for block in &self.static_modes {
            let X_i = Mat::from_fn(block.columns.len(), p, |j, k| {
                X[(block.columns[j] as usize, k)]
            });
            let mut Psi_X = Mat::<f64>::zeros(block.rows.len(), p);
            Psi_X
                .as_mut()
                .par_row_chunks_mut(LIFT_ROWS)
                .enumerate()
                .for_each(|(chunk, out)| {
                    let rows = block.matrix().subrows(chunk * LIFT_ROWS, out.nrows());
                    matmul(out, Accum::Replace, rows, X_i.as_ref(), 1.0, Par::Seq);
                });
            for (r, &dof) in block.rows.iter().enumerate() {
                for k in 0..p {
                    U[(dof as usize, k)] = Psi_X[(r, k)];
                }
            }
        }
        // U += Φ Q, each chunk gathering its slice of every vector once into a block of Φ.
        let Q = X.subrows(n_i, self.vectors.len());
        U.as_mut()
            .par_row_chunks_mut(LIFT_ROWS)
            .enumerate()
            .for_each(|(chunk, U_chunk)| {
                let first = chunk * LIFT_ROWS;
                let Phi = Mat::from_fn(U_chunk.nrows(), self.vectors.len(), |i, k| {
                    self.vectors[k][first + i]
                });
                matmul(U_chunk, Accum::Add, Phi.as_ref(), Q, 1.0, Par::Seq);
            });
        U
    }

    /// An error naming what does not fit a model of `n` DOFs, if anything does.
    pub fn check_fits(&self, n: usize) -> Result<(), String> {
        let n_i = self.interface.len();
        if self.n_dofs != n {
            return Err(format!("it spans {} DOFs, the model {n}", self.n_dofs));
        }
        if let Some(vector) = self.vectors.iter().find(|vector| vector.len() != n) {
            return Err(format!(
                "a vector has {} entries, the model {n} DOFs",
                vector.len()
            ));
        }
        if self.interface.iter().any(|&dof| dof as usize >= n)
            || !self.interface.is_sorted_by(|a, b| a < b)
        {
            return Err(format!(
                "its interface DOFs are not ascending DOFs below {n}"
            ));
        }
        let n_r = self.n_reduced();
        for matrix in [&self.mass, &self.damping, &self.stiffness] {
            let fits = matrix.n_rows == n_r
                && matrix.n_cols == n_r
                && matrix.col_ptr.len() == n_r + 1
                && matrix.col_ptr.first() == Some(&0)
                && matrix.col_ptr.is_sorted()
                && matrix.col_ptr[n_r] == matrix.row_idx.len()
                && matrix.row_idx.len() == matrix.values.len()
                && matrix.row_idx.iter().all(|&row| row < n_r);
            if !fits {
                return Err(format!(
                    "a reduced matrix ({} × {}, {} entries) is not a valid matrix of its {n_r} coordinates",
                    matrix.n_rows,
                    matrix.n_cols,
                    matrix.values.len()
                ));
            }
        }
        for block in &self.static_modes {
            if block.rows.iter().any(|&dof| dof as usize >= n)
                || block.columns.iter().any(|&k| k as usize >= n_i)
                || block.values.len() != block.rows.len() * block.columns.len()
            {
                return Err(format!(
                    "a block of its static modes ({} rows, {} columns, {} values) does not fit {n} DOFs and {n_i} interface DOFs",
                    block.rows.len(),
                    block.columns.len(),
                    block.values.len()
                ));
            }
        }
        Ok(())
    }

    /// An error unless the basis was built on `model` (its reduced matrices are that model's).
    pub fn check_built_on(&self, model: &Model) -> Result<(), StageError> {
        if self.model == model.fingerprint() {
            return Ok(());
        }
        let what = if self.n_dofs != model.n_dofs() {
            format!(
                "it spans {} DOFs, the model has {}",
                self.n_dofs,
                model.n_dofs()
            )
        } else {
            "its reduced matrices come from other mass, damping or stiffness matrices".to_string()
        };
        Err(StageError::new(format!(
            "the basis was built on another model: {what}; wire the basis stage's `model` input to this stage's model"
        )))
    }
}

/// Rows of each fixed chunk of a lift (independent of the thread count).
const LIFT_ROWS: usize = 256;
