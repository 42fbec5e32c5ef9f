//! Sparse LDLᵀ factorisations of the shifted pencil `K − σ M`, their solves and their inertia.
//!
//! `K − σ M = P L D Lᵀ Pᵀ` with `L` unit lower triangular, `D` diagonal and `P` the
//! fill-reducing permutation ([`super::ordering`]). The symbolic analysis (ordering,
//! elimination tree, supernodes) depends on the pattern only: it is done once and reused for
//! every shift. No pivoting is done, which is sound for a shift that is not (numerically) an
//! eigenvalue; each factorisation is checked by the residual of one solve.
//!
//! Sylvester's law of inertia: `L D Lᵀ` is congruent to `K − σ M`, so the number of negative
//! pivots in `D` equals the number of negative eigenvalues of `K − σ M`, that is, the number of
//! eigenvalues λ of `K φ = λ M φ` below σ (`M` positive definite). This Sturm count proves that
//! no mode was missed.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::perm::PermRef;
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LdltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky, simplicial::SimplicialLdltRef, supernodal::SupernodalLdltRef,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, Par, Side};

use crate::Error;
use crate::csc::CscMatrix;
use crate::ordering;

/// Largest backward error of the check solve before a factorisation is declared unstable (no
/// pivoting: a shift too close to an eigenvalue can ruin it).
const SOLVE_CHECK_TOLERANCE: f64 = 1e-10;

/// The fill-reducing ordering of the factorisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FillOrdering {
    /// METIS nested dissection of the node graph ([`super::ordering`]).
    NestedDissection,
    /// faer's approximate minimum degree.
    MinimumDegree,
}

/// The lower triangle of `K − σ M` for any σ, and its symbolic factorisation.
pub struct ShiftedPencil {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    K_lower: Vec<f64>,
    M_lower: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    /// Whether the ordering is METIS nested dissection (else faer's minimum degree).
    pub nested_dissection: bool,
}

/// A numeric factorisation `K − σ M = P L D Lᵀ Pᵀ`.
pub struct Factor<'a> {
    pencil: &'a ShiftedPencil,
    pub sigma: f64,
    values: Vec<f64>,
    /// Number of negative pivots of `D`: eigenvalues below σ.
    pub negative_pivots: usize,
}

/// Entries of column `col` of `A` in rows ≥ `col`, as (rows, values).
fn lower_column(A: &CscMatrix, col: usize) -> (&[usize], &[f64]) {
    let (start, end) = (A.col_ptr[col], A.col_ptr[col + 1]);
    let rows = &A.row_idx[start..end];
    let first = rows.partition_point(|&row| row < col);
    (&rows[first..], &A.values[start + first..end])
}

impl ShiftedPencil {
    /// Analyses the pattern of `K` and `M` (checked symmetric, size `n`) with a
    /// nested-dissection ordering; `dof_of_node` groups the DOFs by node for it.
    pub fn new(
        K: &CscMatrix,
        M: &CscMatrix,
        dof_of_node: &[[Option<u32>; 3]],
    ) -> Result<ShiftedPencil, Error> {
        ShiftedPencil::with_ordering(K, M, dof_of_node, FillOrdering::NestedDissection)
    }

    /// As [`ShiftedPencil::new`], with the fill-reducing ordering `fill_ordering` (nested
    /// dissection falls back to minimum degree if METIS declines the graph).
    pub fn with_ordering(
        K: &CscMatrix,
        M: &CscMatrix,
        dof_of_node: &[[Option<u32>; 3]],
        fill_ordering: FillOrdering,
    ) -> Result<ShiftedPencil, Error> {
        let n = K.n_rows;
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        let mut K_lower = Vec::new();
        let mut M_lower = Vec::new();
        for col in 0..n {
            // Merge the two sorted lower columns into the union pattern.
            let (K_rows, K_values) = lower_column(K, col);
            let (M_rows, M_values) = lower_column(M, col);
            let (mut k, mut m) = (0, 0);
            while k < K_rows.len() || m < M_rows.len() {
                let K_row = K_rows.get(k).copied().unwrap_or(usize::MAX);
                let M_row = M_rows.get(m).copied().unwrap_or(usize::MAX);
                let row = K_row.min(M_row);
                row_idx.push(row);
                K_lower.push(if K_row == row { K_values[k] } else { 0.0 });
                M_lower.push(if M_row == row { M_values[m] } else { 0.0 });
                k += usize::from(K_row == row);
                m += usize::from(M_row == row);
            }
            col_ptr.push(row_idx.len());
        }
        let groups = ordering::dof_groups(dof_of_node, n);
        let order = match fill_ordering {
            FillOrdering::NestedDissection => ordering::nested_dissection(&groups, &[K, M], n),
            FillOrdering::MinimumDegree => None,
        };
        let nested_dissection = order.is_some();
        let inverse = order.as_ref().map(|forward| {
            let mut inverse = vec![0usize; n];
            for (position, &dof) in forward.iter().enumerate() {
                inverse[dof] = position;
            }
            inverse
        });
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let ordering = match (&order, &inverse) {
            (Some(forward), Some(inverse)) => {
                SymmetricOrdering::Custom(PermRef::new_checked(forward, inverse, n))
            }
            _ => SymmetricOrdering::Amd,
        };
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            ordering,
            CholeskySymbolicParams::default(),
        )
        .map_err(|err| {
            Error::Breakdown(format!(
                "symbolic factorisation of K - sigma M failed ({n} DOFs): {err:?}"
            ))
        })?;
        Ok(ShiftedPencil {
            n,
            col_ptr,
            row_idx,
            K_lower,
            M_lower,
            symbolic,
            nested_dissection,
        })
    }

    /// Order of the matrices.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries of the factor `L`.
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// The numeric factorisation of `K − σ M`.
    pub fn factor(&self, sigma: f64, par: Par) -> Result<Factor<'_>, Error> {
        let values: Vec<f64> = self
            .K_lower
            .iter()
            .zip(&self.M_lower)
            .map(|(k, m)| k - sigma * m)
            .collect();
        let A = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(
                self.n,
                self.n,
                &self.col_ptr,
                None,
                &self.row_idx,
            ),
            &values,
        );
        let mut L_values = vec![0.0; self.symbolic.len_val()];
        let mut buffer = MemBuffer::new(
            self.symbolic
                .factorize_numeric_ldlt_scratch::<f64>(par, Default::default()),
        );
        self.symbolic
            .factorize_numeric_ldlt(
                &mut L_values,
                A,
                Side::Lower,
                LdltRegularization::default(),
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|err| {
                Error::Breakdown(format!(
                    "LDL^T of K - sigma M failed at sigma = {sigma:e} rad^2/s^2: {err:?} (sigma is an eigenvalue)"
                ))
            })?;
        let pivots = pivots(&self.symbolic, &L_values);
        if let Some(bad) = pivots.iter().position(|pivot| !pivot.is_finite()) {
            return Err(Error::Breakdown(format!(
                "LDL^T of K - sigma M at sigma = {sigma:e} rad^2/s^2 has a non-finite pivot at position {bad}"
            )));
        }
        let negative_pivots = pivots.iter().filter(|&&pivot| pivot < 0.0).count();
        let factor = Factor {
            pencil: self,
            sigma,
            values: L_values,
            negative_pivots,
        };
        factor.check_solve(par)?;
        Ok(factor)
    }

    /// `‖K − σ M‖₁`, the largest absolute column sum.
    fn shifted_norm_1(&self, sigma: f64) -> f64 {
        let mut column_sums = vec![0.0; self.n];
        for col in 0..self.n {
            for entry in self.col_ptr[col]..self.col_ptr[col + 1] {
                let row = self.row_idx[entry];
                let value = (self.K_lower[entry] - sigma * self.M_lower[entry]).abs();
                column_sums[col] += value;
                if row != col {
                    column_sums[row] += value;
                }
            }
        }
        column_sums.into_iter().fold(0.0, f64::max)
    }

    /// `y = (K − σ M) x` with the stored lower triangle.
    fn shifted_mul(&self, sigma: f64, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for col in 0..self.n {
            for entry in self.col_ptr[col]..self.col_ptr[col + 1] {
                let row = self.row_idx[entry];
                let value = self.K_lower[entry] - sigma * self.M_lower[entry];
                y[row] += value * x[col];
                if row != col {
                    y[col] += value * x[row];
                }
            }
        }
        y
    }
}

/// The diagonal `D` of an LDLᵀ factor, in elimination order.
fn pivots(symbolic: &SymbolicCholesky<usize>, L_values: &[f64]) -> Vec<f64> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(simplicial) => {
            let factor = SimplicialLdltRef::new(simplicial, L_values);
            let pattern = simplicial.factor();
            let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
            (0..simplicial.nrows())
                .map(|col| {
                    (col_ptr[col]..col_ptr[col + 1])
                        .find(|&entry| row_idx[entry] == col)
                        .map_or(f64::NAN, |entry| factor.values()[entry])
                })
                .collect()
        }
        SymbolicCholeskyRaw::Supernodal(supernodal) => {
            let factor = SupernodalLdltRef::new(supernodal, L_values);
            let mut diagonal = Vec::with_capacity(supernodal.nrows());
            for s in 0..supernodal.n_supernodes() {
                let block = factor.supernode(s).val();
                for k in 0..block.ncols() {
                    diagonal.push(block[(k, k)]);
                }
            }
            diagonal
        }
    }
}

impl Factor<'_> {
    /// Overwrites the columns of `rhs` with `(K − σ M)⁻¹ rhs`.
    pub fn solve_in_place(&self, rhs: MatMut<'_, f64>, par: Par) {
        let factor = LdltRef::new(&self.pencil.symbolic, &self.values);
        let mut buffer = MemBuffer::new(
            self.pencil
                .symbolic
                .solve_in_place_scratch::<f64>(rhs.ncols(), par),
        );
        factor.solve_in_place_with_conj(Conj::No, rhs, par, MemStack::new(&mut buffer));
    }

    /// Solves one system and checks its normwise backward error
    /// `‖A x − b‖ / (‖A‖₁ ‖x‖ + ‖b‖)`, which is at roundoff level for a stable factorisation.
    fn check_solve(&self, par: Par) -> Result<(), Error> {
        let n = self.pencil.n;
        let b: Vec<f64> = (0..n)
            .map(|i| 1.0 + ((i as f64) * 0.618_033_988_75).fract())
            .collect();
        let mut x = Mat::from_fn(n, 1, |i, _| b[i]);
        self.solve_in_place(x.rb_mut(), par);
        let x: Vec<f64> = x.col(0).iter().copied().collect();
        let Ax = self.pencil.shifted_mul(self.sigma, &x);
        let norm = |v: &[f64]| v.iter().map(|value| value * value).sum::<f64>().sqrt();
        let residual: Vec<f64> = Ax.iter().zip(&b).map(|(ax, b)| ax - b).collect();
        let backward_error =
            norm(&residual) / (self.pencil.shifted_norm_1(self.sigma) * norm(&x) + norm(&b));
        if !(backward_error <= SOLVE_CHECK_TOLERANCE) {
            return Err(Error::Breakdown(format!(
                "LDL^T of K - sigma M at sigma = {:e} rad^2/s^2 is unstable: backward error of a solve {backward_error:.2e} > {SOLVE_CHECK_TOLERANCE:e}",
                self.sigma
            )));
        }
        Ok(())
    }
}
