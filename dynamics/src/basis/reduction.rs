//! The reduced matrices `Tᵀ A T` of `A = M, C, K`, grown block by block, and the checks of
//! the basis they give.

use faer::{Mat, MatRef};
use squeal_linalg::csc::{symmetric_mul, symmetric_mul_rows};
use squeal_linalg::tall::transpose_times;

use super::static_modes::StaticModes;
use crate::artifact::basis::StaticBlock;
use crate::artifact::{Basis, CscMatrix, Model};

/// The index of `K` in [`Reduction::matrices`] (`M`, `C`, `K`).
pub(super) const STIFFNESS: usize = 2;

/// `max |Vᵀ M V − I|` over the vectors `V`, from the reduced mass (fresh products, not the
/// span's carried ones).
pub(super) fn orthonormality_error(reduction: &Reduction) -> f64 {
    let n_i = reduction.interface.len();
    let gram = reduction.matrices[0].as_ref().submatrix(
        n_i,
        n_i,
        reduction.V.ncols(),
        reduction.V.ncols(),
    );
    let mut worst = 0.0_f64;
    for j in 0..gram.ncols() {
        for i in 0..gram.nrows() {
            let expected = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((gram[(i, j)] - expected).abs());
        }
    }
    worst
}

/// `max |B − Bᵀ| / max |B|` of a square `B` (zero for a zero `B`).
fn asymmetry_of(B: MatRef<'_, f64>) -> f64 {
    let (mut largest, mut asymmetry) = (0.0_f64, 0.0_f64);
    for j in 0..B.ncols() {
        for i in 0..B.nrows() {
            largest = largest.max(B[(i, j)].abs());
            asymmetry = asymmetry.max((B[(i, j)] - B[(j, i)]).abs());
        }
    }
    if largest > 0.0 {
        asymmetry / largest
    } else {
        0.0
    }
}

/// `X[rows, :]`.
fn rows_of(X: MatRef<'_, f64>, rows: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), X.ncols(), |r, k| X[(rows[r], k)])
}

/// The reduced matrices `Tᵀ A T` of `A = M, C, K`, `T = [S, V]`, grown a block of vectors at a
/// time (an adaptive basis appends vectors to a span whose earlier vectors stay as they are).
///
/// No matrix couples two bodies (the connected components of the matrices' patterns; the
/// contact pairs are not in them), so neither do the static modes: the static mode of an
/// interface DOF lies on its body, and `Sᵀ A S` is block-diagonal by body. Each body's block,
/// and its rows of `Sᵀ A V`, are products over its DOFs alone: the disc's interface DOFs do
/// not sweep the pads' rows, nor the pads' the disc's.
pub(super) struct Reduction {
    /// The interface DOFs.
    interface: Vec<usize>,
    bodies: Vec<BodyModes>,
    /// The vectors `V`, after the static modes.
    V: Mat<f64>,
    /// `Tᵀ M T`, `Tᵀ C T`, `Tᵀ K T`, symmetrised.
    pub(super) matrices: [Mat<f64>; 3],
    /// The largest `max |B − Bᵀ| / max |B|` over the diagonal blocks `B` computed, per matrix.
    pub(super) asymmetry: [f64; 3],
    /// [`Model::fingerprint`] of the model the matrices are projected from.
    model: [u8; 32],
}

/// The static modes of the interface DOFs on one body.
struct BodyModes {
    /// The body's DOFs, ascending.
    dofs: Vec<usize>,
    /// The positions on the interface of the body's interface DOFs.
    columns: Vec<usize>,
    /// `S[dofs, columns]`: the static modes on their body (zero elsewhere).
    S: Mat<f64>,
}

impl Reduction {
    /// `T` = the static modes of the interface; `bodies`: the model's, `csc::components` of
    /// its matrices.
    pub(super) fn new(
        model: &Model,
        static_modes: &StaticModes,
        bodies: Vec<Vec<usize>>,
    ) -> Reduction {
        let interface = static_modes.interface();
        let n_i = interface.len();
        let matrices = [&model.M, &model.C, &model.K];
        let mut position = vec![usize::MAX; model.n_dofs()];
        for (k, &dof) in interface.iter().enumerate() {
            position[dof] = k;
        }
        let bodies: Vec<BodyModes> = bodies
            .into_iter()
            .filter_map(|dofs| {
                let columns: Vec<usize> = dofs
                    .iter()
                    .map(|&dof| position[dof])
                    .filter(|&k| k != usize::MAX)
                    .collect();
                if columns.is_empty() {
                    return None;
                }
                let mut X_i = Mat::<f64>::zeros(n_i, columns.len());
                for (j, &k) in columns.iter().enumerate() {
                    X_i[(k, j)] = 1.0;
                }
                let S = rows_of(
                    static_modes.static_displacement(X_i.as_ref()).as_ref(),
                    &dofs,
                );
                Some(BodyModes { dofs, columns, S })
            })
            .collect();
        let mut reduction = Reduction {
            interface: interface.to_vec(),
            bodies,
            V: Mat::zeros(model.n_dofs(), 0),
            matrices: std::array::from_fn(|_| Mat::zeros(n_i, n_i)),
            asymmetry: [0.0; 3],
            model: model.fingerprint(),
        };
        for (which, A) in matrices.into_iter().enumerate() {
            for body in &reduction.bodies {
                let A_body = A.principal_submatrix(&body.dofs);
                let B = if which == STIFFNESS {
                    // `K S` vanishes off the interface, where `S` is the identity.
                    let on_interface: Vec<usize> = (0..body.dofs.len())
                        .filter(|&r| position[body.dofs[r]] != usize::MAX)
                        .collect();
                    symmetric_mul_rows(&A_body, &on_interface, body.S.as_ref())
                } else {
                    transpose_times(
                        body.S.as_ref(),
                        symmetric_mul(&A_body, body.S.as_ref()).as_ref(),
                    )
                };
                let R = &mut reduction.matrices[which];
                for (j, &column) in body.columns.iter().enumerate() {
                    for (i, &row) in body.columns.iter().enumerate() {
                        R[(row, column)] = 0.5 * (B[(i, j)] + B[(j, i)]);
                    }
                }
                reduction.asymmetry[which] =
                    reduction.asymmetry[which].max(asymmetry_of(B.as_ref()));
            }
        }
        reduction
    }

    /// `V ← [V, W]`: the new rows and columns of each reduced matrix, `[S, V, W]ᵀ A W`.
    pub(super) fn extend(&mut self, model: &Model, W: MatRef<'_, f64>) {
        let (n_i, n_v, p) = (self.interface.len(), self.V.ncols(), W.ncols());
        let mut V = Mat::<f64>::zeros(self.V.nrows(), n_v + p);
        V.as_mut().subcols_mut(0, n_v).copy_from(&self.V);
        V.as_mut().subcols_mut(n_v, p).copy_from(W);
        let n_old = n_i + n_v;
        let vanishes_on_interface = self
            .interface
            .iter()
            .all(|&dof| W.row(dof).iter().all(|&w| w == 0.0));
        for (which, A) in [&model.M, &model.C, &model.K].into_iter().enumerate() {
            let AW = symmetric_mul(A, W);
            let mut R = Mat::<f64>::zeros(n_old + p, n_old + p);
            R.as_mut()
                .submatrix_mut(0, 0, n_old, n_old)
                .copy_from(&self.matrices[which]);
            // `Sᵀ K W = (K S)ᵀ W = 0`: `K S` vanishes off the interface, and `W` on it, as
            // every vector less its static part does.
            let bodies = if which == STIFFNESS && vanishes_on_interface {
                &[][..]
            } else {
                &self.bodies[..]
            };
            for body in bodies {
                let AW_body = rows_of(AW.as_ref(), &body.dofs);
                let B = transpose_times(body.S.as_ref(), AW_body.as_ref());
                for j in 0..p {
                    for (i, &row) in body.columns.iter().enumerate() {
                        R[(row, n_old + j)] = B[(i, j)];
                        R[(n_old + j, row)] = B[(i, j)];
                    }
                }
            }
            let B = transpose_times(V.as_ref(), AW.as_ref());
            for j in 0..p {
                for i in 0..n_v {
                    R[(n_i + i, n_old + j)] = B[(i, j)];
                    R[(n_old + j, n_i + i)] = B[(i, j)];
                }
                for i in 0..p {
                    R[(n_old + i, n_old + j)] = 0.5 * (B[(n_v + i, j)] + B[(n_v + j, i)]);
                }
            }
            self.asymmetry[which] =
                self.asymmetry[which].max(asymmetry_of(B.as_ref().subrows(n_v, p)));
            self.matrices[which] = R;
        }
        self.V = V;
    }

    /// The basis of the vectors `V`, with these matrices.
    pub(super) fn basis(&self, kind: &str) -> Basis {
        // Both triangles, the exact zeros between separate bodies left out.
        let compressed = |A: &Mat<f64>| {
            let entries = (0..A.ncols())
                .flat_map(|j| (0..A.nrows()).map(move |i| (i, j, A[(i, j)])))
                .filter(|&(_, _, value)| value != 0.0)
                .collect();
            CscMatrix::from_triplets(A.nrows(), A.ncols(), entries)
        };
        let column_major = |A: &Mat<f64>| -> Vec<f64> {
            (0..A.ncols())
                .flat_map(|j| A.col(j).iter().copied().collect::<Vec<_>>())
                .collect()
        };
        Basis {
            kind: kind.to_string(),
            model: self.model,
            interface: self.interface.iter().map(|&dof| dof as u32).collect(),
            vectors: (0..self.V.ncols())
                .map(|k| self.V.col(k).iter().copied().collect())
                .collect(),
            mass: compressed(&self.matrices[0]),
            damping: compressed(&self.matrices[1]),
            stiffness: compressed(&self.matrices[2]),
            n_dofs: self.V.nrows(),
            static_modes: self
                .bodies
                .iter()
                .map(|body| {
                    let (rows, dofs): (Vec<usize>, Vec<u32>) = body
                        .dofs
                        .iter()
                        .enumerate()
                        .filter(|&(_, &dof)| self.interface.binary_search(&dof).is_err())
                        .map(|(r, &dof)| (r, dof as u32))
                        .unzip();
                    StaticBlock {
                        values: column_major(&rows_of(body.S.as_ref(), &rows)),
                        rows: dofs,
                        columns: body.columns.iter().map(|&k| k as u32).collect(),
                    }
                })
                .filter(|block| !block.rows.is_empty())
                .collect(),
        }
    }
}
