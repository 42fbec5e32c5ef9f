//! Sparse Cholesky `A = P L Lᵀ Pᵀ` of a symmetric positive definite combination `Σ cᵢ Aᵢ`,
//! with its solve split in two halves around a few *interface* unknowns.
//!
//! A time integrator with contact solves `A x = b + Gᵀ r` once per step, where `G` (a few
//! rows, each touching a few unknowns: the interface) maps the solution to the contact
//! quantities `g = G x`, and `r` is only known after a small problem in `g` has been solved.
//! Written with the two triangular halves,
//!
//! ```text
//! y = L⁻¹ Pᵀ b,    Y = L⁻¹ Pᵀ Gᵀ,    G A⁻¹ (b + Gᵀ r) = Yᵀ y + (Yᵀ Y) r,
//! x = P L⁻ᵀ (y + Y r)
//! ```
//!
//! so one forward and one backward sweep (one solve) give both the free contact quantities
//! `Yᵀ y` and the corrected solution, with the Delassus operator `Yᵀ Y = G A⁻¹ Gᵀ` formed once.
//! `Y` is nonzero only on the rows that the interface unknowns reach in the elimination tree;
//! the ordering puts the interface unknowns last in their component (after a nested
//! dissection of the rest), so that these rows are few and `Y` is stored compactly, as its
//! nonzero rows only.
//!
//! Where `Y` fills most rows anyway (a reduced model's dense factor), reading it twice a solve
//! costs more than reading once the *response* `Z = A⁻¹ Gᵀ = P L⁻ᵀ Y`: then
//!
//! ```text
//! x_free = A⁻¹ b,    G A⁻¹ (b + Gᵀ r) = G x_free + (Yᵀ Y) r,    x = x_free + Z r
//! ```
//!
//! one whole solve, `G` applied to its result (a few entries per row) and one pass over `Z`
//! ([`InterfaceSolve::solve`] takes whichever reads less). Where `A` falls into a few dense
//! blocks, their inverses read less still ([`crate::block_inverse`]); [`Cholesky::analyse`]
//! tells what the factor would hold before it is computed.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::linalg::matmul::matmul;
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky, supernodal::SupernodalLltRef,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, Par, Side};

use rayon::prelude::*;

use crate::Error;
use crate::csc::CscMatrix;
use crate::kernels::{axpy, dot};
use crate::ordering;
use crate::sweeps::SubtreeSweeps;

/// A symmetric positive definite matrix factorised as `P L Lᵀ Pᵀ` (supernodal).
pub struct Cholesky {
    n: usize,
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    /// Position in elimination order → unknown.
    forward: Vec<usize>,
    /// The subtrees of the elimination tree swept in parallel, for single vectors.
    sweeps: SubtreeSweeps,
}

/// Rows `lower` of `A` for one column, with `row ≥ col`.
fn lower_entries(A: &CscMatrix, col: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
    (A.col_ptr[col]..A.col_ptr[col + 1])
        .map(move |entry| (A.row_idx[entry], A.values[entry]))
        .filter(move |&(row, _)| row >= col)
}

/// The lower triangle of `Σ cᵢ Aᵢ` over the union of the patterns, in compressed columns.
pub(crate) struct Combination {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

impl Combination {
    /// Each `Aᵢ` symmetric with both triangles stored, all of one size `n > 0`, every entry
    /// of the combination finite.
    pub(crate) fn of(terms: &[(f64, &CscMatrix)]) -> Result<Combination, Error> {
        let Some(&(_, first)) = terms.first() else {
            return Err(Error::InvalidInput("no matrix to factorise".into()));
        };
        let n = first.n_rows;
        if n == 0 {
            // faer would analyse it as simplicial, which the sweeps cannot read.
            return Err(Error::InvalidInput(
                "a matrix of 0 unknowns to factorise".into(),
            ));
        }
        for (_, A) in terms {
            if A.n_rows != n || A.n_cols != n {
                return Err(Error::InvalidInput(format!(
                    "a term of the combination is {} x {}, the first is {n} x {n}",
                    A.n_rows, A.n_cols
                )));
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        let mut values = Vec::new();
        let mut column: Vec<(usize, f64)> = Vec::new();
        for col in 0..n {
            column.clear();
            for (coefficient, A) in terms {
                column.extend(lower_entries(A, col).map(|(row, value)| (row, coefficient * value)));
            }
            // A stable sort keeps the terms' order for equal rows: the sums do not depend on
            // anything but the input.
            column.sort_by_key(|&(row, _)| row);
            let mut last = usize::MAX;
            for &(row, value) in &column {
                if row == last {
                    *values.last_mut().expect("an entry was pushed") += value;
                } else {
                    row_idx.push(row);
                    values.push(value);
                    last = row;
                }
            }
            col_ptr.push(row_idx.len());
        }
        if let Some(bad) = values.iter().position(|value| !value.is_finite()) {
            return Err(Error::InvalidInput(format!(
                "the matrix to factorise has a non-finite entry (entry {bad} of its lower triangle)"
            )));
        }
        Ok(Combination {
            n,
            col_ptr,
            row_idx,
            values,
        })
    }
}

/// `out = G x` for `G` given by its sparse rows `(unknown, coefficient)`.
pub(crate) fn rows_times(G_rows: &[Vec<(usize, f64)>], x: &[f64], out: &mut [f64]) {
    for (slot, row) in out.iter_mut().zip(G_rows) {
        *slot = row.iter().map(|&(unknown, value)| value * x[unknown]).sum();
    }
}

/// `A = Σ cᵢ Aᵢ` ordered and analysed, not yet factorised: what its factor will hold.
pub struct Analysis {
    /// The combination, in the unknowns' own order.
    pub(crate) combination: Combination,
    symbolic: SymbolicCholesky<usize>,
    /// Position in elimination order → unknown.
    forward: Vec<usize>,
}

impl Analysis {
    /// Entries the supernodal factor will store.
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// The numeric factorisation.
    pub fn factorise(self, par: Par) -> Result<Cholesky, Error> {
        let Analysis {
            combination:
                Combination {
                    n,
                    col_ptr,
                    row_idx,
                    values,
                },
            symbolic,
            forward,
        } = self;
        let A = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx),
            &values,
        );
        let mut L_values = vec![0.0; symbolic.len_val()];
        let mut buffer =
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        symbolic
            .factorize_numeric_llt(
                &mut L_values,
                A,
                Side::Lower,
                LltRegularization::default(),
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|err| {
                Error::Breakdown(format!(
                    "Cholesky of the {n} x {n} matrix failed: it is not positive definite ({err:?})"
                ))
            })?;
        let mut cholesky = Cholesky {
            n,
            symbolic,
            values: L_values,
            forward,
            sweeps: SubtreeSweeps::default(),
        };
        cholesky.sweeps = SubtreeSweeps::new(cholesky.factor(), n);
        Ok(cholesky)
    }
}

impl Cholesky {
    /// Factorises `A = Σ cᵢ Aᵢ` (each `Aᵢ` symmetric, both triangles stored, size `n`), ordered
    /// by nested dissection of the node graph (`dof_of_node` groups the unknowns by node) with
    /// the unknowns of `interface` eliminated last.
    pub fn new(
        terms: &[(f64, &CscMatrix)],
        dof_of_node: &[[Option<u32>; 3]],
        interface: &[usize],
        par: Par,
    ) -> Result<Cholesky, Error> {
        Cholesky::analyse(terms, dof_of_node, interface)?.factorise(par)
    }

    /// The ordering and symbolic factorisation of [`Cholesky::new`].
    pub fn analyse(
        terms: &[(f64, &CscMatrix)],
        dof_of_node: &[[Option<u32>; 3]],
        interface: &[usize],
    ) -> Result<Analysis, Error> {
        let Combination {
            n,
            col_ptr,
            row_idx,
            values,
        } = Combination::of(terms)?;
        if let Some(&bad) = interface.iter().find(|&&unknown| unknown >= n) {
            return Err(Error::InvalidInput(format!(
                "interface unknown {bad} is out of range (n = {n})"
            )));
        }
        let matrices: Vec<&CscMatrix> = terms.iter().map(|(_, A)| *A).collect();
        let groups = ordering::dof_groups(dof_of_node, n);
        // A dense matrix (a reduced model) has nothing to reorder.
        let dense = values.len() == n * (n + 1) / 2;
        let order = if dense {
            (0..n).collect()
        } else {
            ordering::nested_dissection(&groups, &matrices, n).unwrap_or_else(|| (0..n).collect())
        };
        // The interface last, each part keeping its nested-dissection order.
        let mut on_interface = vec![false; n];
        for &unknown in interface {
            on_interface[unknown] = true;
        }
        let forward: Vec<usize> = order
            .iter()
            .copied()
            .filter(|&unknown| !on_interface[unknown])
            .chain(
                order
                    .iter()
                    .copied()
                    .filter(|&unknown| on_interface[unknown]),
            )
            .collect();
        let mut inverse = vec![0usize; n];
        for (position, &unknown) in forward.iter().enumerate() {
            inverse[unknown] = position;
        }
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, n)),
            CholeskySymbolicParams {
                // The split solves need the supernodal triangular sweeps.
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(|err| {
            Error::Breakdown(format!("symbolic Cholesky failed ({n} unknowns): {err:?}"))
        })?;
        let forward = match symbolic.perm() {
            Some(perm) => perm.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        Ok(Analysis {
            combination: Combination {
                n,
                col_ptr,
                row_idx,
                values,
            },
            symbolic,
            forward,
        })
    }

    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries of `L`.
    pub fn factor_len(&self) -> usize {
        self.values.len()
    }

    /// Position of each unknown in elimination order.
    pub fn positions(&self) -> Vec<usize> {
        let mut inverse = vec![0usize; self.n];
        for (position, &unknown) in self.forward.iter().enumerate() {
            inverse[unknown] = position;
        }
        inverse
    }

    fn factor(&self) -> SupernodalLltRef<'_, usize, f64> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(supernodal) => {
                SupernodalLltRef::new(supernodal, &self.values)
            }
            SymbolicCholeskyRaw::Simplicial(_) => {
                unreachable!("the symbolic analysis is forced supernodal")
            }
        }
    }

    /// `Y = L⁻¹ Pᵀ B` for `B` given in elimination order (`B` overwritten).
    pub fn forward_in_place(&self, B: MatMut<'_, f64>, par: Par) {
        let mut buffer = MemBuffer::new(self.scratch(B.ncols(), par));
        self.factor()
            .l_solve_with_conj(Conj::No, B, par, MemStack::new(&mut buffer));
    }

    /// `L⁻ᵀ Y` in elimination order (`Y` overwritten).
    pub fn backward_in_place(&self, Y: MatMut<'_, f64>, par: Par) {
        let mut buffer = MemBuffer::new(self.scratch(Y.ncols(), par));
        self.factor()
            .l_transpose_solve_with_conj(Conj::No, Y, par, MemStack::new(&mut buffer));
    }

    fn scratch(&self, n_rhs: usize, par: Par) -> faer::dyn_stack::StackReq {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(supernodal) => {
                supernodal.solve_in_place_scratch::<f64>(n_rhs, par)
            }
            SymbolicCholeskyRaw::Simplicial(simplicial) => {
                simplicial.solve_in_place_scratch::<f64>(n_rhs)
            }
        }
    }

    /// `y = L⁻¹ y` for one vector in elimination order, the independent subtrees of the
    /// elimination tree in parallel ([`crate::sweeps`]: bit-identical on any thread count).
    pub fn forward_vector(&self, y: &mut [f64]) {
        self.sweeps.forward(self.factor(), y);
    }

    /// `y = L⁻ᵀ y` for one vector in elimination order, as [`Cholesky::forward_vector`].
    pub fn backward_vector(&self, y: &mut [f64]) {
        self.sweeps.backward(self.factor(), y);
    }

    /// `b = A⁻¹ b` for one vector (indexed by unknown), by [`Cholesky::forward_vector`] and
    /// [`Cholesky::backward_vector`].
    pub fn solve_vector(&self, b: &mut [f64]) {
        let mut y = vec![0.0; self.n];
        self.permute(b, &mut y);
        self.forward_vector(&mut y);
        self.backward_vector(&mut y);
        self.unpermute(&y, b);
    }

    /// Subtrees of the elimination tree swept in parallel by the single-vector sweeps.
    pub fn parallel_subtrees(&self) -> usize {
        self.sweeps.n_tasks()
    }

    /// `b` (indexed by unknown) into elimination order.
    pub fn permute(&self, b: &[f64], out: &mut [f64]) {
        for (slot, &unknown) in out.iter_mut().zip(&self.forward) {
            *slot = b[unknown];
        }
    }

    /// `y` (in elimination order) back to unknowns.
    pub fn unpermute(&self, y: &[f64], out: &mut [f64]) {
        for (&value, &unknown) in y.iter().zip(&self.forward) {
            out[unknown] = value;
        }
    }

    /// `x = A⁻¹ b` for every column of `B` (indexed by unknown, overwritten).
    pub fn solve_in_place(&self, mut B: MatMut<'_, f64>, par: Par) {
        let mut work = Mat::<f64>::zeros(self.n, B.ncols());
        for col in 0..B.ncols() {
            for (position, &unknown) in self.forward.iter().enumerate() {
                work[(position, col)] = B[(unknown, col)];
            }
        }
        self.forward_in_place(work.as_mut(), par);
        self.backward_in_place(work.as_mut(), par);
        for col in 0..B.ncols() {
            for (position, &unknown) in self.forward.iter().enumerate() {
                B[(unknown, col)] = work[(position, col)];
            }
        }
    }
}

/// `Y = L⁻¹ Pᵀ Gᵀ` on its nonzero rows, and the Delassus operator `W = Yᵀ Y = G A⁻¹ Gᵀ`.
///
/// `Y` is mostly zero even there: the parts a contact joins share no node, so their
/// unknowns fall in separate blocks of `L`, and within a block `L⁻¹` fills a column only
/// below its first nonzero. Each column is kept as its runs of consecutive nonzero rows.
pub struct InterfaceSolve {
    /// Rows (in elimination order) where `Y` is nonzero, ascending.
    pub rows: Vec<usize>,
    /// Column `j`'s runs are `runs[col_runs[j]..col_runs[j + 1]]`.
    col_runs: Vec<usize>,
    runs: Vec<Run>,
    /// The runs' values, one after the other in run order.
    values: Vec<f64>,
    /// `G A⁻¹ Gᵀ`, symmetric positive semi-definite.
    pub W: Mat<f64>,
    /// `G` by its rows, for the free contact quantities `G x_free` with the response.
    G_rows: Vec<Vec<(usize, f64)>>,
    /// `Z = A⁻¹ Gᵀ` row by row (rows indexed by unknown), kept when one pass over it reads
    /// less than two over `Y`.
    response: Option<Vec<f64>>,
}

/// Rows of each fixed chunk of `x += Z r` (independent of the thread count).
const RESPONSE_CHUNK: usize = 64;

/// Positions `first..first + len` of `rows`, their values at `offset..offset + len`.
struct Run {
    first: usize,
    offset: usize,
    len: usize,
}

/// Zeros inside a column kept rather than starting a new run.
const RUN_GAP: usize = 8;

/// The runs `(start, end)` of nonzero entries of `column`, joined across gaps of at most
/// [`RUN_GAP`] zeros.
fn runs_of(column: &[f64]) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (i, value) in column.iter().enumerate() {
        if *value == 0.0 {
            continue;
        }
        match runs.last_mut() {
            Some((_, end)) if i - *end <= RUN_GAP => *end = i + 1,
            _ => runs.push((i, i + 1)),
        }
    }
    runs
}

impl InterfaceSolve {
    /// `G` given by its rows, each a list of (unknown, coefficient); the forward sweeps run in
    /// fixed blocks of columns on rayon, each sequential, so the bytes do not depend on the
    /// thread count.
    pub fn new(cholesky: &Cholesky, G_rows: &[Vec<(usize, f64)>]) -> InterfaceSolve {
        const BLOCK: usize = 32;
        let n = cholesky.n;
        let positions = cholesky.positions();
        let mut blocks: Vec<Mat<f64>> = G_rows
            .par_chunks(BLOCK)
            .map(|block| {
                let mut B = Mat::<f64>::zeros(n, block.len());
                for (col, row) in block.iter().enumerate() {
                    for &(unknown, coefficient) in row {
                        B[(positions[unknown], col)] += coefficient;
                    }
                }
                cholesky.forward_in_place(B.as_mut(), Par::Seq);
                B
            })
            .collect();
        let nonzero = |row: usize| {
            blocks
                .iter()
                .any(|B| (0..B.ncols()).any(|col| B[(row, col)] != 0.0))
        };
        let rows: Vec<usize> = (0..n).filter(|&row| nonzero(row)).collect();
        let m = G_rows.len();
        let mut Y = Mat::<f64>::zeros(rows.len(), m);
        let mut col = 0;
        for B in &blocks {
            for block_col in 0..B.ncols() {
                for (compact, &row) in rows.iter().enumerate() {
                    Y[(compact, col)] = B[(row, block_col)];
                }
                col += 1;
            }
        }
        let mut W = Mat::<f64>::zeros(m, m);
        matmul(
            W.as_mut(),
            Accum::Replace,
            Y.transpose(),
            Y.as_ref(),
            1.0,
            Par::Seq,
        );
        let (mut col_runs, mut runs, mut values) = (vec![0], Vec::new(), Vec::new());
        for col in 0..m {
            let column = Y.col(col).try_as_col_major().expect("a dense column");
            for (start, end) in runs_of(column.as_slice()) {
                runs.push(Run {
                    first: start,
                    offset: values.len(),
                    len: end - start,
                });
                values.extend_from_slice(&column.as_slice()[start..end]);
            }
            col_runs.push(runs.len());
        }
        let response = (n * m < 2 * values.len()).then(|| {
            blocks
                .par_iter_mut()
                .for_each(|B| cholesky.backward_in_place(B.as_mut(), Par::Seq));
            let mut Z = vec![0.0; n * m];
            for (unknown, row) in Z.chunks_exact_mut(m).enumerate() {
                let position = positions[unknown];
                let entries = blocks.iter().flat_map(|B| B.row(position).iter());
                for (slot, &value) in row.iter_mut().zip(entries) {
                    *slot = value;
                }
            }
            Z
        });
        InterfaceSolve {
            rows,
            col_runs,
            runs,
            values,
            W,
            G_rows: G_rows.to_vec(),
            response,
        }
    }

    /// Whether [`InterfaceSolve::solve`] corrects by the response `Z` rather than through `Y`.
    pub fn has_response(&self) -> bool {
        self.response.is_some()
    }

    /// `x = A⁻¹ (b + Gᵀ r)` (`b`, `x` indexed by unknown), `r` chosen by `react` from the free
    /// contact quantities `G A⁻¹ b`, written to `g_free`. `y` is a work vector of `n` values.
    /// By `Y` or by the response, whichever reads less (module doc); either way every sum's
    /// order is fixed, so the bits do not depend on the thread count.
    pub fn solve<'r, E>(
        &self,
        cholesky: &Cholesky,
        b: &[f64],
        (g_free, y, x): (&mut [f64], &mut [f64], &mut [f64]),
        react: impl FnOnce(&[f64]) -> Result<&'r [f64], E>,
    ) -> Result<(), E> {
        cholesky.permute(b, y);
        cholesky.forward_vector(y);
        match &self.response {
            None => {
                self.project(y, g_free);
                let r = react(g_free)?;
                self.lift(r, y);
                cholesky.backward_vector(y);
                cholesky.unpermute(y, x);
            }
            Some(Z) => {
                cholesky.backward_vector(y);
                cholesky.unpermute(y, x);
                rows_times(&self.G_rows, x, g_free);
                let r = react(g_free)?;
                let m = r.len();
                x.par_chunks_mut(RESPONSE_CHUNK)
                    .zip(Z.par_chunks(RESPONSE_CHUNK * m))
                    .for_each(|(x, Z)| {
                        for (slot, row) in x.iter_mut().zip(Z.chunks_exact(m)) {
                            *slot += dot(row, r);
                        }
                    });
            }
        }
        Ok(())
    }

    /// Column `j`'s runs, each with its values.
    fn column_runs(&self, j: usize) -> impl Iterator<Item = (&Run, &[f64])> {
        self.runs[self.col_runs[j]..self.col_runs[j + 1]]
            .iter()
            .map(|run| (run, &self.values[run.offset..run.offset + run.len]))
    }

    /// `Yᵀ y` for `y` in elimination order: `G A⁻¹ b` when `y = L⁻¹ Pᵀ b`.
    fn project(&self, y: &[f64], out: &mut [f64]) {
        let gathered: Vec<f64> = self.rows.iter().map(|&row| y[row]).collect();
        for (j, slot) in out.iter_mut().enumerate() {
            *slot = self
                .column_runs(j)
                .map(|(run, values)| dot(values, &gathered[run.first..run.first + run.len]))
                .sum();
        }
    }

    /// `y += Y r`.
    fn lift(&self, r: &[f64], y: &mut [f64]) {
        let mut product = vec![0.0; self.rows.len()];
        for (j, &r_j) in r.iter().enumerate() {
            if r_j == 0.0 {
                continue;
            }
            for (run, values) in self.column_runs(j) {
                axpy(r_j, values, &mut product[run.first..run.first + run.len]);
            }
        }
        for (value, &row) in product.iter().zip(&self.rows) {
            y[row] += value;
        }
    }
}

#[cfg(test)]
mod tests;
