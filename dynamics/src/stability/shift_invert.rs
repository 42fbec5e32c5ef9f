//! Solves with `Q̃(σ) = σ² M̃ + σ C̃ + K̃` for a complex shift σ, in real arithmetic.
//!
//! `Q̃ = A + U Vᵀ` ([`super::sliding`]): `A = Tᴺᵀ Q(σ) Tᴺ` is complex *symmetric* (not
//! Hermitian) and `U Vᵀ` has rank ≤ the number of closed pairs. `A = A_r + i A_i` is factorised
//! through its real symmetric embedding, the interleaved matrix with 2×2 blocks
//!
//! ```text
//! E_ij = [ A_r,ij   A_i,ij ]        E [x; −y] = [f; g]  ⟺  A (x + i y) = f + i g
//!        [ A_i,ij  −A_r,ij ]
//! ```
//!
//! by a sparse LBLᵀ with Bunch–Kaufman pivoting inside supernodes (faer), on a
//! nested-dissection ordering of the reduced node graph (both halves of a DOF kept together),
//! and solved by the row-major kernels of [`squeal_linalg::lblt`].
//! The correction is applied by Sherman–Morrison–Woodbury:
//!
//! ```text
//! Q̃⁻¹ f = A⁻¹ f − Y (I + Vᵀ Y)⁻¹ Vᵀ A⁻¹ f,    Y = A⁻¹ U
//! ```
//!
//! `Y` costs one block solve with as many right-hand sides as closed pairs, per shift. `U`'s
//! columns have a few nonzeros each, so their forward sweep visits only the supernodes on the
//! paths from those rows to the root ([`squeal_linalg::lblt`]), a small part of the tree. The
//! split is logged at debug level.

use faer::linalg::solvers::{PartialPivLu, Solve};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Mat, MatRef, Par, Side, c64};
use rayon::prelude::*;

use super::sliding::{Part, SlidingSystem, mul_complex, norm};
use crate::stage::StageError;
use squeal_linalg::lblt::Lblt;
use squeal_linalg::ordering;
use squeal_linalg::tall::add_times;

/// Largest backward error of the check solve of a factorisation.
const SOLVE_CHECK_TOLERANCE: f64 = 1e-11;

/// Where each stored entry of the embedding's lower triangle comes from.
#[derive(Debug, Clone, Copy)]
enum Source {
    Real(usize),
    Imaginary(usize),
    MinusReal(usize),
}

/// The symbolic analysis of the embedding, shared by every shift.
pub struct EmbeddedPattern {
    m: usize,
    /// Lower triangle of the union pattern of M_sym, C_sym, K_sym (reduced, size m), with the
    /// three matrices' values on it.
    union_values: [Vec<f64>; 3],
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    sources: Vec<Source>,
    symbolic: SymbolicCholesky<usize>,
    /// Low-rank correction: U's columns (δ_s = test − trial rows, reduced indices) and, per
    /// slave, the full DOF whose column of Q(σ) gives V's column.
    U_columns: Vec<Vec<(usize, f64)>>,
}

impl EmbeddedPattern {
    pub fn new(system: &SlidingSystem) -> Result<EmbeddedPattern, StageError> {
        let m = system.dim();
        let matrices = [Part::M, Part::C, Part::K].map(|part| system.symmetric(part));
        // Union of the lower columns.
        let mut union_ptr = vec![0usize];
        let mut union_rows = Vec::new();
        let mut union_values: [Vec<f64>; 3] = Default::default();
        for col in 0..m {
            let mut rows: Vec<usize> = matrices
                .iter()
                .flat_map(|A| {
                    A.row_idx[A.col_ptr[col]..A.col_ptr[col + 1]]
                        .iter()
                        .copied()
                        .filter(|&row| row >= col)
                })
                .collect();
            rows.sort_unstable();
            rows.dedup();
            for (which, A) in matrices.iter().enumerate() {
                let (start, end) = (A.col_ptr[col], A.col_ptr[col + 1]);
                let column_rows = &A.row_idx[start..end];
                union_values[which].extend(rows.iter().map(|row| {
                    column_rows
                        .binary_search(row)
                        .map_or(0.0, |position| A.values[start + position])
                }));
            }
            union_rows.extend(rows);
            union_ptr.push(union_rows.len());
        }
        // The embedding's lower triangle, column by column.
        let mut col_ptr = vec![0usize];
        let mut row_idx = Vec::new();
        let mut sources = Vec::new();
        for col in 0..m {
            let entries = union_ptr[col]..union_ptr[col + 1];
            // Column 2j: rows 2i (A_r), 2i+1 (A_i) for i ≥ j.
            for entry in entries.clone() {
                let row = union_rows[entry];
                row_idx.push(2 * row);
                sources.push(Source::Real(entry));
                row_idx.push(2 * row + 1);
                sources.push(Source::Imaginary(entry));
            }
            col_ptr.push(row_idx.len());
            // Column 2j+1: row 2j+1 (−A_r,jj), then rows 2i (A_i), 2i+1 (−A_r) for i > j.
            for entry in entries {
                let row = union_rows[entry];
                if row == col {
                    row_idx.push(2 * row + 1);
                    sources.push(Source::MinusReal(entry));
                } else {
                    row_idx.push(2 * row);
                    sources.push(Source::Imaginary(entry));
                    row_idx.push(2 * row + 1);
                    sources.push(Source::MinusReal(entry));
                }
            }
            col_ptr.push(row_idx.len());
        }
        let groups = ordering::dof_groups(&system.dof_of_node, m);
        let order = ordering::nested_dissection(&groups, &matrices, m);
        let n2 = 2 * m;
        let forward: Option<Vec<usize>> = order.map(|order| {
            order
                .iter()
                .flat_map(|&dof| [2 * dof, 2 * dof + 1])
                .collect()
        });
        let inverse = forward.as_ref().map(|forward| {
            let mut inverse = vec![0usize; n2];
            for (position, &index) in forward.iter().enumerate() {
                inverse[index] = position;
            }
            inverse
        });
        let pattern = SymbolicSparseColMatRef::new_checked(n2, n2, &col_ptr, None, &row_idx);
        let fill_ordering = match (&forward, &inverse) {
            (Some(forward), Some(inverse)) => {
                SymmetricOrdering::Custom(PermRef::new_checked(forward, inverse, n2))
            }
            _ => SymmetricOrdering::Amd,
        };
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            fill_ordering,
            CholeskySymbolicParams::default(),
        )
        .map_err(|err| {
            StageError::new(format!(
                "symbolic factorisation of the sliding problem failed ({m} DOFs): {err:?}"
            ))
        })?;
        let U_columns = system
            .slaves
            .iter()
            .map(|slave| {
                let mut column: Vec<(usize, f64)> = slave.test.clone();
                for &(reduced, value) in &slave.trial {
                    match column.iter_mut().find(|(index, _)| *index == reduced) {
                        Some(entry) => entry.1 -= value,
                        None => column.push((reduced, -value)),
                    }
                }
                column
            })
            .collect();
        Ok(EmbeddedPattern {
            m,
            union_values,
            col_ptr,
            row_idx,
            sources,
            symbolic,
            U_columns,
        })
    }

    /// Entries of the factor (for reports).
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// The symbolic analysis of the embedding, shared by every shift.
    pub fn symbolic(&self) -> &SymbolicCholesky<usize> {
        &self.symbolic
    }

    /// The lower triangle's values of the embedding of `A = K + σ C + σ² M`.
    pub fn values_at(&self, sigma: c64) -> Vec<f64> {
        let sigma2 = sigma * sigma;
        let [M, C, K] = &self.union_values;
        let real: Vec<f64> = (0..K.len())
            .map(|e| K[e] + sigma.re * C[e] + sigma2.re * M[e])
            .collect();
        let imaginary: Vec<f64> = (0..K.len())
            .map(|e| sigma.im * C[e] + sigma2.im * M[e])
            .collect();
        self.sources
            .iter()
            .map(|source| match *source {
                Source::Real(e) => real[e],
                Source::Imaginary(e) => imaginary[e],
                Source::MinusReal(e) => -real[e],
            })
            .collect()
    }

    /// The embedding's lower triangle with `values` from [`Self::values_at`].
    pub fn matrix<'a>(&'a self, values: &'a [f64]) -> SparseColMatRef<'a, usize, f64> {
        let n2 = 2 * self.m;
        SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(n2, n2, &self.col_ptr, None, &self.row_idx),
            values,
        )
    }
}

/// `Q̃(σ)⁻¹`, ready to apply.
pub struct ShiftedSolver<'a> {
    pattern: &'a EmbeddedPattern,
    system: &'a SlidingSystem,
    pub sigma: c64,
    factor: Lblt,
    /// Y = A⁻¹ U (m × slaves), Vᵀ's rows as sparse rows, and the LU of I + Vᵀ Y.
    Y: Mat<c64>,
    V_columns: Vec<Vec<(usize, c64)>>,
    capacitance: Option<PartialPivLu<c64>>,
}

impl<'a> ShiftedSolver<'a> {
    pub fn new(
        pattern: &'a EmbeddedPattern,
        system: &'a SlidingSystem,
        sigma: c64,
        par: Par,
    ) -> Result<ShiftedSolver<'a>, StageError> {
        let m = pattern.m;
        let clock = std::time::Instant::now();
        let values = pattern.values_at(sigma);
        let A = pattern.matrix(&values);
        let factor = Lblt::factorize(pattern.symbolic(), A, par);
        let factorised = clock.elapsed().as_secs_f64();
        let mut solver = ShiftedSolver {
            pattern,
            system,
            sigma,
            factor,
            Y: Mat::zeros(m, 0),
            V_columns: Vec::new(),
            capacitance: None,
        };
        solver.check_symmetric_part()?;
        let checked = clock.elapsed().as_secs_f64();
        solver.prepare_correction()?;
        tracing::debug!(
            "stability: shift {:.0} Hz factorised in {factorised:.2} s, checked in {:.2} s, contact correction in {:.2} s",
            sigma.im / (2.0 * std::f64::consts::PI),
            checked - factorised,
            clock.elapsed().as_secs_f64() - checked
        );
        Ok(solver)
    }

    /// `A⁻¹ F` for the symmetric part, columns of F complex, through the embedding.
    fn solve_symmetric(&self, F: MatRef<'_, c64>) -> Mat<c64> {
        let m = self.pattern.m;
        let mut R = Mat::<f64>::from_fn(2 * m, F.ncols(), |row, col| {
            let value = F[(row / 2, col)];
            if row % 2 == 0 { value.re } else { value.im }
        });
        self.factor
            .solve_in_place(&self.pattern.symbolic, R.as_mut());
        Mat::from_fn(m, F.ncols(), |row, col| {
            c64::new(R[(2 * row, col)], -R[(2 * row + 1, col)])
        })
    }

    /// `A x` with A = Tᴺᵀ Q(σ) Tᴺ (the symmetric part).
    fn mul_symmetric(&self, x: &[c64]) -> Vec<c64> {
        let [Mx, Cx, Kx] =
            [Part::M, Part::C, Part::K].map(|part| mul_complex(self.system.symmetric(part), x));
        let sigma2 = self.sigma * self.sigma;
        (0..x.len())
            .map(|i| Kx[i] + self.sigma * Cx[i] + sigma2 * Mx[i])
            .collect()
    }

    /// Backward error of one solve with the symmetric part: the factorisation is not trusted
    /// without it (pivoting is local to supernodes).
    fn check_symmetric_part(&self) -> Result<(), StageError> {
        let m = self.pattern.m;
        let b = Mat::<c64>::from_fn(m, 1, |i, _| {
            c64::new(
                1.0 + (i as f64 * 0.618_033_988_75).fract(),
                (i as f64 * 0.414_213_562).fract(),
            )
        });
        let x = self.solve_symmetric(b.as_ref());
        let x: Vec<c64> = x.col(0).iter().copied().collect();
        let Ax = self.mul_symmetric(&x);
        let residual: Vec<c64> = (0..m).map(|i| Ax[i] - b[(i, 0)]).collect();
        let [nM, nC, nK] = self.system.norms;
        let scale = self.sigma.norm_sqr() * nM + self.sigma.norm() * nC + nK;
        let b_norm = norm(&b.col(0).iter().copied().collect::<Vec<_>>());
        let backward_error = norm(&residual) / (scale * norm(&x) + b_norm);
        if !(backward_error <= SOLVE_CHECK_TOLERANCE) {
            return Err(StageError::new(format!(
                "factorisation of the sliding problem at shift {:.1} Hz is unstable: backward error {backward_error:.2e} > {SOLVE_CHECK_TOLERANCE:e}",
                self.sigma.im / (2.0 * std::f64::consts::PI)
            )));
        }
        Ok(())
    }

    /// Y = A⁻¹ U and the LU of the capacitance matrix I + Vᵀ Y.
    fn prepare_correction(&mut self) -> Result<(), StageError> {
        let m = self.pattern.m;
        let n_slaves = self.pattern.U_columns.len();
        if n_slaves == 0 {
            return Ok(());
        }
        let mut U = Mat::<c64>::zeros(m, n_slaves);
        for (s, column) in self.pattern.U_columns.iter().enumerate() {
            for &(row, value) in column {
                U[(row, s)] += c64::new(value, 0.0);
            }
        }
        self.Y = self.solve_symmetric(U.as_ref());
        // v_s = Tᴺᵀ Q(σ) e_s: column s of Q(σ), restricted.
        let sigma = self.sigma;
        let system = self.system;
        self.V_columns = system
            .slaves
            .par_iter()
            .map(|slave| {
                let mut column = vec![c64::new(0.0, 0.0); system.full_dim()];
                for (part, factor) in [
                    (Part::K, c64::new(1.0, 0.0)),
                    (Part::C, sigma),
                    (Part::M, sigma * sigma),
                ] {
                    let A = system.full(part);
                    for entry in A.col_ptr[slave.dof]..A.col_ptr[slave.dof + 1] {
                        column[A.row_idx[entry]] += factor * A.values[entry];
                    }
                }
                system
                    .restrict(&column, false)
                    .into_iter()
                    .enumerate()
                    .filter(|(_, value)| *value != c64::new(0.0, 0.0))
                    .collect()
            })
            .collect();
        let mut capacitance = Mat::<c64>::identity(n_slaves, n_slaves);
        for (s, v) in self.V_columns.iter().enumerate() {
            for t in 0..n_slaves {
                let mut sum = c64::new(0.0, 0.0);
                for &(row, value) in v {
                    sum += value * self.Y[(row, t)];
                }
                capacitance[(s, t)] += sum;
            }
        }
        self.capacitance = Some(capacitance.partial_piv_lu());
        Ok(())
    }

    /// `Q̃(σ)⁻¹ F`, columns of F complex.
    pub fn solve(&self, F: MatRef<'_, c64>) -> Mat<c64> {
        let mut X = self.solve_symmetric(F);
        if let Some(capacitance) = &self.capacitance {
            let k = X.ncols();
            let n_slaves = self.V_columns.len();
            let VtX = Mat::<c64>::from_fn(n_slaves, k, |s, col| {
                self.V_columns[s]
                    .iter()
                    .map(|&(row, value)| value * X[(row, col)])
                    .sum()
            });
            let c = capacitance.solve(&VtX);
            add_times(
                X.as_mut(),
                self.Y.as_ref(),
                (-&c).as_ref(),
                squeal_linalg::par(),
            );
        }
        X
    }
}
