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
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// A random sparse SPD matrix: a 1D Laplacian-like band plus a diagonal shift, on `n`
    /// unknowns, and a second term to combine with.
    fn matrices(n: usize) -> (CscMatrix, CscMatrix) {
        let mut rng = SplitMix64::new(7);
        let mut stiffness = Vec::new();
        let mut mass = Vec::new();
        for i in 0..n {
            stiffness.push((i, i, 4.0 + rng.next_signed().abs()));
            mass.push((i, i, 1.0 + rng.next_signed().abs()));
            for offset in [1usize, 7] {
                if i + offset < n {
                    let value = -0.5 * rng.next_signed().abs();
                    stiffness.push((i, i + offset, value));
                    stiffness.push((i + offset, i, value));
                }
            }
        }
        (
            CscMatrix::from_triplets(n, n, stiffness),
            CscMatrix::from_triplets(n, n, mass),
        )
    }

    /// A 3D grid Laplacian (7-point stencil, `side³` unknowns) with a mass term, and its
    /// node grouping for the nested-dissection ordering.
    fn grid(side: usize) -> (CscMatrix, CscMatrix, Vec<[Option<u32>; 3]>) {
        let n = side * side * side;
        let index = |i: usize, j: usize, k: usize| (k * side + j) * side + i;
        let mut stiffness = Vec::new();
        for k in 0..side {
            for j in 0..side {
                for i in 0..side {
                    let p = index(i, j, k);
                    stiffness.push((p, p, 6.0));
                    for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (a, b, c) = (i + di, j + dj, k + dk);
                        if a < side && b < side && c < side {
                            let q = index(a, b, c);
                            stiffness.push((p, q, -1.0));
                            stiffness.push((q, p, -1.0));
                        }
                    }
                }
            }
        }
        let mass = CscMatrix::from_triplets(n, n, (0..n).map(|i| (i, i, 1.0)).collect());
        // One unknown per node: the ordering groups by node.
        let groups = (0..n).map(|i| [Some(i as u32), None, None]).collect();
        (CscMatrix::from_triplets(n, n, stiffness), mass, groups)
    }

    /// The subtree sweeps against faer's sequential ones: equal to round-off, and the same
    /// bits on one thread and on three.
    #[test]
    fn a_light_factor_is_swept_sequentially_as_faer_sweeps_it() {
        // A few hundred unknowns: waking tasks would cost more than the sweep.
        let (K, M, groups) = grid(4);
        let n = K.n_rows;
        let cholesky = Cholesky::new(&[(1.0, &K), (0.5, &M)], &groups, &[], Par::Seq)
            .expect("positive definite");
        assert_eq!(cholesky.parallel_subtrees(), 0);
        let mut random = SplitMix64::new(5);
        let b: Vec<f64> = (0..n).map(|_| random.next_signed()).collect();
        let mut reference = Mat::from_fn(n, 1, |i, _| b[i]);
        cholesky.forward_in_place(reference.as_mut(), Par::Seq);
        cholesky.backward_in_place(reference.as_mut(), Par::Seq);
        let mut y = b.clone();
        cholesky.forward_vector(&mut y);
        cholesky.backward_vector(&mut y);
        let scale = reference.col(0).iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = y
            .iter()
            .zip(reference.col(0).iter())
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst < 1e-13 * scale, "{worst:e}");
    }

    #[test]
    fn subtree_sweeps_equal_the_sequential_ones_on_any_thread_count() {
        let (K, M, groups) = grid(14);
        let n = K.n_rows;
        let interface: Vec<usize> = (0..n).step_by(97).collect();
        let cholesky = Cholesky::new(&[(1.0, &K), (0.5, &M)], &groups, &interface, Par::Seq)
            .expect("positive definite");
        assert!(
            cholesky.parallel_subtrees() >= 4,
            "{}",
            cholesky.parallel_subtrees()
        );
        let mut random = SplitMix64::new(11);
        let b: Vec<f64> = (0..n).map(|_| random.next_signed()).collect();
        let mut reference = Mat::from_fn(n, 1, |i, _| b[i]);
        cholesky.forward_in_place(reference.as_mut(), Par::Seq);
        let forward: Vec<f64> = reference.col(0).iter().copied().collect();
        cholesky.backward_in_place(reference.as_mut(), Par::Seq);
        let sweep = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool")
                .install(|| {
                    let mut y = b.clone();
                    cholesky.forward_vector(&mut y);
                    let after_forward = y.clone();
                    cholesky.backward_vector(&mut y);
                    (after_forward, y)
                })
        };
        let (forward_one, solution_one) = sweep(1);
        let (forward_three, solution_three) = sweep(3);
        assert!(forward_one == forward_three && solution_one == solution_three);
        let relative = |got: &[f64], want: &[f64]| {
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            got.iter()
                .zip(want)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
                / scale
        };
        let want: Vec<f64> = reference.col(0).iter().copied().collect();
        assert!(relative(&forward_one, &forward) < 1e-13);
        assert!(relative(&solution_one, &want) < 1e-13);
        // solve_vector: the permutation around the two sweeps.
        let mut x = b.clone();
        cholesky.solve_vector(&mut x);
        let residual: f64 = {
            let Ax = K.mul_vec(&x);
            let Mx = M.mul_vec(&x);
            (0..n)
                .map(|i| (Ax[i] + 0.5 * Mx[i] - b[i]).abs())
                .fold(0.0, f64::max)
        };
        assert!(residual < 1e-12, "residual {residual:e}");
    }

    /// `InterfaceSolve::solve` against a direct solve of `A x = b + Gᵀ r`, `A = K + 3 M`:
    /// the free quantities it hands the reaction are `G A⁻¹ b`, the Delassus operator is
    /// `G A⁻¹ Gᵀ`, the solution `A⁻¹ (b + Gᵀ r)`; the response is kept or not as `response_kept` says.
    fn check_split_solve(
        (K, M): (&CscMatrix, &CscMatrix),
        interface: &[usize],
        G_rows: &[Vec<(usize, f64)>],
        response_kept: bool,
    ) {
        let n = K.n_cols;
        let terms = [(1.0, K), (3.0, M)];
        let cholesky = Cholesky::new(&terms, &[], interface, Par::Seq).unwrap();
        let interface_solve = InterfaceSolve::new(&cholesky, G_rows);
        assert_eq!(interface_solve.has_response(), response_kept);
        let mut rng = SplitMix64::new(3);
        let b: Vec<f64> = (0..n).map(|_| rng.next_signed().abs() - 0.5).collect();
        let r: Vec<f64> = (0..G_rows.len())
            .map(|i| [0.3, -1.2, 2.0][i % 3] * (1.0 + i as f64))
            .collect();
        let direct = |reaction: &[f64]| -> Vec<f64> {
            let mut rhs = Mat::from_fn(n, 1, |i, _| b[i]);
            for (row, entries) in G_rows.iter().enumerate() {
                for &(unknown, coefficient) in entries {
                    rhs[(unknown, 0)] += coefficient * reaction[row];
                }
            }
            cholesky.solve_in_place(rhs.as_mut(), Par::Seq);
            rhs.col(0).iter().copied().collect()
        };
        let G_times = |x: &[f64]| -> Vec<f64> {
            G_rows
                .iter()
                .map(|entries| entries.iter().map(|&(u, c)| c * x[u]).sum())
                .collect()
        };
        let (x_direct, g_free_direct) = (direct(&r), G_times(&direct(&vec![0.0; r.len()])));
        let (mut g_free, mut y, mut x) = (vec![0.0; r.len()], vec![0.0; n], vec![0.0; n]);
        interface_solve
            .solve(&cholesky, &b, (&mut g_free, &mut y, &mut x), |free| {
                for (split, direct) in free.iter().zip(&g_free_direct) {
                    assert!((split - direct).abs() < 1e-13, "{split} vs {direct}");
                }
                Ok::<_, ()>(&r[..])
            })
            .unwrap();
        for (split, direct) in x.iter().zip(&x_direct) {
            assert!((split - direct).abs() < 1e-13, "{split} vs {direct}");
        }
        let W_r = &interface_solve.W * Mat::from_fn(r.len(), 1, |i, _| r[i]);
        for (row, g) in G_times(&x_direct).iter().enumerate() {
            let g_split = g_free[row] + W_r[(row, 0)];
            assert!((g_split - g).abs() < 1e-13, "{g_split} vs {g}");
        }
    }

    /// A few interface unknowns eliminated last: `Y` lives on a few rows, read twice.
    #[test]
    fn split_solve_through_a_short_y_equals_a_direct_solve() {
        let n = 60;
        let (K, M) = matrices(n);
        let G_rows = vec![
            vec![(5, 1.0), (17, -1.0)],
            vec![(40, 0.6), (41, 0.8)],
            vec![(17, 1.0)],
        ];
        let interface = [5usize, 17, 40, 41];
        let cholesky = Cholesky::new(&[(1.0, &K), (3.0, &M)], &[], &interface, Par::Seq).unwrap();
        assert!(InterfaceSolve::new(&cholesky, &G_rows).rows.len() <= interface.len());
        check_split_solve((&K, &M), &interface, &G_rows, false);
    }

    /// Most unknowns on the interface of a dense matrix (a reduced model's case): `Y` fills
    /// its rows, and the response is read once instead.
    #[test]
    fn split_solve_through_the_response_equals_a_direct_solve() {
        let n = 30;
        let mut rng = SplitMix64::new(11);
        let B = Mat::from_fn(n, n, |_, _| rng.next_signed());
        let dense = &B * B.transpose();
        let K = CscMatrix::from_triplets(
            n,
            n,
            (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .map(|(i, j)| (i, j, dense[(i, j)] + if i == j { 1.0 } else { 0.0 }))
                .collect(),
        );
        let M = CscMatrix::from_triplets(n, n, (0..n).map(|i| (i, i, 1.0)).collect());
        let G_rows: Vec<Vec<(usize, f64)>> =
            (0..18).map(|k| vec![(k, 1.0), (k + 12, -0.5)]).collect();
        check_split_solve((&K, &M), &[], &G_rows, true);
    }

    #[test]
    fn an_indefinite_matrix_is_refused() {
        let (K, M) = matrices(20);
        let error = Cholesky::new(&[(1.0, &K), (-10.0, &M)], &[], &[], Par::Seq)
            .err()
            .expect("K - 10 M is indefinite");
        assert!(
            error.to_string().contains("not positive definite"),
            "{error}"
        );
    }
}
