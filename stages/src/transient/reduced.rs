//! The transient on a reduction basis ([`crate::basis`]): the same scheme on
//! `(Tᵀ M T, Tᵀ C T, Tᵀ K T)` in the coordinates `x = [u_i; q]`. The interface DOFs are
//! coordinates of `x`, so `H` keeps its entries, renumbered; the departure from the
//! equilibrium starts at `x⁰ = [u⁰_i; Φᵀ M (u⁰ − S u⁰_i)]`, and the snapshots are lifted back
//! to every DOF, `u = T x`.

use faer::Mat;

use super::scheme::{Run, Snapshot, Structure};
use crate::artifact::basis::StaticModes;
use crate::artifact::{Basis, CscMatrix, Model};
use crate::stage::StageError;

/// The reduced matrices and the maps to and from the full DOFs.
pub struct ReducedModel {
    pub static_modes: StaticModes,
    pub M: CscMatrix,
    pub C: CscMatrix,
    pub K: CscMatrix,
    /// `H` on the reduced coordinates.
    pub H_rows: Vec<Vec<(usize, f64)>>,
}

/// A dense column-major matrix as compressed columns, its exact zeros left out: the static
/// modes of separate bodies (disc, pads) do not couple, so their blocks of the reduced
/// matrices are exactly zero, and the products and the factorisation skip them.
fn compressed(n: usize, values: &[f64]) -> CscMatrix {
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    let mut kept = Vec::new();
    col_ptr.push(0);
    for column in values.chunks_exact(n) {
        for (row, &value) in column.iter().enumerate() {
            if value != 0.0 {
                row_idx.push(row);
                kept.push(value);
            }
        }
        col_ptr.push(row_idx.len());
    }
    CscMatrix {
        n_rows: n,
        n_cols: n,
        col_ptr,
        row_idx,
        values: kept,
    }
}

impl ReducedModel {
    /// `full`: the full model's structure (its `H`).
    pub fn new(model: &Model, basis: &Basis, full: &Structure) -> Result<ReducedModel, StageError> {
        let n = model.n_dofs();
        let n_r = basis.n_reduced();
        let foreign = |what: String| {
            Err(StageError::new(format!(
                "transient: the basis does not belong to this model: {what}"
            )))
        };
        if let Some(vector) = basis.vectors.iter().find(|vector| vector.len() != n) {
            return foreign(format!(
                "a vector has {} entries, the model {n} DOFs",
                vector.len()
            ));
        }
        if basis.interface.iter().any(|&dof| dof as usize >= n)
            || !basis.interface.is_sorted_by(|a, b| a < b)
        {
            return foreign(format!(
                "its interface DOFs are not ascending DOFs below {n}"
            ));
        }
        for matrix in [&basis.mass, &basis.damping, &basis.stiffness] {
            if matrix.len() != n_r * n_r {
                return foreign(format!(
                    "a reduced matrix has {} entries for {n_r} coordinates",
                    matrix.len()
                ));
            }
        }
        let position = |dof: usize| basis.interface.binary_search(&(dof as u32)).ok();
        let H_rows = full
            .H_rows
            .iter()
            .map(|row| {
                row.iter()
                    .map(|&(dof, value)| position(dof).map(|index| (index, value)))
                    .collect::<Option<Vec<_>>>()
            })
            .collect::<Option<Vec<_>>>();
        let Some(H_rows) = H_rows else {
            return foreign("a contact DOF is not on its interface".to_string());
        };
        let interface: Vec<usize> = basis.interface.iter().map(|&dof| dof as usize).collect();
        Ok(ReducedModel {
            static_modes: StaticModes::new(model, &interface)?,
            M: compressed(n_r, &basis.mass),
            C: compressed(n_r, &basis.damping),
            K: compressed(n_r, &basis.stiffness),
            H_rows,
        })
    }

    /// The structure the scheme integrates.
    pub fn structure(&self) -> Structure<'_> {
        Structure {
            M: &self.M,
            C: &self.C,
            K: &self.K,
            dof_of_node: &[],
            H_rows: self.H_rows.clone(),
        }
    }

    /// Every snapshot's `u` and `v` lifted to the full DOFs.
    pub fn lift_snapshots(&self, basis: &Basis, run: &mut Run) {
        let n_r = basis.n_reduced();
        let columns = |field: fn(&Snapshot) -> &Vec<f64>| {
            Mat::from_fn(n_r, run.snapshots.len(), |i, k| field(&run.snapshots[k])[i])
        };
        let U = self.static_modes.lift(basis, columns(|s| &s.u).as_ref());
        let V = self.static_modes.lift(basis, columns(|s| &s.v).as_ref());
        for (k, snapshot) in run.snapshots.iter_mut().enumerate() {
            snapshot.u = U.col(k).iter().copied().collect();
            snapshot.v = V.col(k).iter().copied().collect();
        }
    }
}
