//! Block shift-invert Lanczos with full reorthogonalisation, in the `M` inner product.
//!
//! With `A = K − σ M` factorised, the operator `Op = A⁻¹ M` is self-adjoint for
//! `⟨x, y⟩_M = xᵀ M y` and has the eigenvectors of `K φ = λ M φ` with eigenvalues
//! `θ = 1 / (λ − σ)`: the eigenvalues λ nearest above σ become the largest θ, well separated,
//! which Lanczos finds first.
//!
//! Blocks `V_0, V_1, …` of `b` vectors, `M`-orthonormal, span the block Krylov space of `Op`:
//!
//! ```text
//! W = Op V_j,   W ← W − V (Vᵀ M W)   (twice: full reorthogonalisation, also against locked
//!                                     vectors X), W = V_{j+1} R_j        (M-orthonormal QR)
//! Op V_m = V_m T_m + V_{m+1} R_m E_mᵀ,   T_m = V_mᵀ M Op V_m   (block tridiagonal)
//! ```
//!
//! Ritz pairs `T_m y = θ y`, `x = V_m y` have `‖Op x − θ x‖_M = ‖R_m y_last‖` (`y_last` the last
//! `b` entries of `y`), which decides convergence without touching `n`-vectors. Blocks find
//! repeated eigenvalues (up to multiplicity `b`) that a single-vector recursion only finds
//! through roundoff. When the basis is full, converged Ritz vectors are locked (deflated: every
//! new vector is kept `M`-orthogonal to them) and the recursion restarts from the best
//! unconverged Ritz vectors.

use std::sync::atomic::{AtomicUsize, Ordering};

use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use super::dense::{select_columns, symmetric_eigen, symmetrised};
use super::factor::Factor;
use super::sparse_ops::symmetric_mul;
use crate::model::CscMatrix;
use crate::stage::StageError;

/// `Op = (K − σ M)⁻¹ M`, applied to blocks of vectors; counts the vectors solved for.
pub struct ShiftInvert<'a> {
    pub factor: &'a Factor<'a>,
    pub M: &'a CscMatrix,
    pub par: Par,
    pub n_solves: AtomicUsize,
}

impl ShiftInvert<'_> {
    pub fn apply(&self, X: MatRef<'_, f64>) -> Mat<f64> {
        let mut Y = symmetric_mul(self.M, X);
        self.factor.solve_in_place(Y.as_mut(), self.par);
        self.n_solves.fetch_add(X.ncols(), Ordering::Relaxed);
        Y
    }

    pub fn sigma(&self) -> f64 {
        self.factor.sigma
    }
}

/// Deterministic pseudo-random numbers (SplitMix64) for start and replacement vectors: the
/// results must not change from run to run.
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// Uniform in [−1, 1).
    pub fn next_signed(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    pub fn block(&mut self, n: usize, n_cols: usize) -> Mat<f64> {
        let mut block = Mat::<f64>::zeros(n, n_cols);
        for j in 0..n_cols {
            for i in 0..n {
                block[(i, j)] = self.next_signed();
            }
        }
        block
    }
}

/// Tuning of the recursion.
#[derive(Debug, Clone, Copy)]
pub struct LanczosOptions {
    /// Vectors per block `b`: the largest multiplicity found without help from roundoff.
    pub block_size: usize,
    /// Largest basis (columns of `V`) before a restart.
    pub max_basis: usize,
    /// A Ritz pair is converged when `‖Op x − θ x‖_M ≤ tolerance · |θ|`.
    pub tolerance: f64,
    pub max_restarts: usize,
    pub seed: u64,
}

/// Converged Ritz pairs of `Op`: `θ` (descending) and `M`-orthonormal vectors (columns).
pub struct RitzPairs {
    pub theta: Vec<f64>,
    pub vectors: Mat<f64>,
    /// Largest basis used.
    pub basis_size: usize,
    pub restarts: usize,
}

/// `W ← W − Q (Qᵀ M W)` for each `Q` in `bases` (each `M`-orthonormal), twice. Returns the
/// summed coefficients for each basis and the `M`-norms of the columns of `W` on entry.
fn project_out(
    W: &mut Mat<f64>,
    bases: &[MatRef<'_, f64>],
    M: &CscMatrix,
    par: Par,
) -> (Vec<Mat<f64>>, Vec<f64>) {
    let p = W.ncols();
    let mut coefficients: Vec<Mat<f64>> = bases.iter().map(|Q| Mat::zeros(Q.ncols(), p)).collect();
    let mut entry_norms = Vec::new();
    for pass in 0..2 {
        let MW = symmetric_mul(M, W.as_ref());
        if pass == 0 {
            entry_norms = (0..p)
                .map(|j| {
                    let w = W.col(j);
                    let Mw = MW.col(j);
                    dot(w, Mw).max(0.0).sqrt()
                })
                .collect();
        }
        for (Q, total) in bases.iter().zip(coefficients.iter_mut()) {
            if Q.ncols() == 0 {
                continue;
            }
            let mut H = Mat::<f64>::zeros(Q.ncols(), p);
            matmul(
                H.as_mut(),
                Accum::Replace,
                Q.transpose(),
                MW.as_ref(),
                1.0,
                par,
            );
            matmul(W.as_mut(), Accum::Add, *Q, H.as_ref(), -1.0, par);
            *total += &H;
        }
    }
    (coefficients, entry_norms)
}

/// `M`-orthonormal QR of a block by Cholesky QR, twice (`W = Q R`), or `None` if the block is
/// numerically rank deficient relative to `reference_norms`.
fn cholesky_qr2(
    W: &mut Mat<f64>,
    M: &CscMatrix,
    reference_norms: &[f64],
    par: Par,
) -> Option<Mat<f64>> {
    let p = W.ncols();
    let mut R = Mat::<f64>::identity(p, p);
    for _ in 0..2 {
        let MW = symmetric_mul(M, W.as_ref());
        let mut G = Mat::<f64>::zeros(p, p);
        matmul(
            G.as_mut(),
            Accum::Replace,
            W.as_ref().transpose(),
            MW.as_ref(),
            1.0,
            par,
        );
        let G = symmetrised(G.as_ref());
        for (j, reference) in reference_norms.iter().enumerate() {
            if !(G[(j, j)] > (1e-8 * reference).powi(2)) {
                return None;
            }
        }
        let L = G.as_ref().llt(faer::Side::Lower).ok()?;
        let L = L.L().to_owned();
        // W ← W L⁻ᵀ, computed as (L⁻¹ Wᵀ)ᵀ through the small inverse L⁻¹.
        let mut L_inverse = Mat::<f64>::identity(p, p);
        solve_lower_triangular_in_place(L.as_ref(), L_inverse.as_mut(), par);
        let mut orthonormal = Mat::<f64>::zeros(W.nrows(), p);
        matmul(
            orthonormal.as_mut(),
            Accum::Replace,
            W.as_ref(),
            L_inverse.as_ref().transpose(),
            1.0,
            par,
        );
        *W = orthonormal;
        // The accumulated R: W_in = W_out (Lᵀ R).
        let mut updated = Mat::<f64>::zeros(p, p);
        matmul(
            updated.as_mut(),
            Accum::Replace,
            L.as_ref().transpose(),
            R.as_ref(),
            1.0,
            par,
        );
        R = updated;
    }
    Some(R)
}

/// Column-by-column `M`-orthonormalisation that replaces dependent columns by random vectors
/// orthogonal to everything (their column of `R` is zero on the diagonal): the rare path when
/// the Krylov space has (nearly) become invariant.
fn orthonormalize_columnwise(
    W: &mut Mat<f64>,
    bases: &[MatRef<'_, f64>],
    M: &CscMatrix,
    reference_norms: &[f64],
    random: &mut SplitMix64,
    par: Par,
) -> Result<Mat<f64>, StageError> {
    let (n, p) = (W.nrows(), W.ncols());
    let mut R = Mat::<f64>::zeros(p, p);
    for c in 0..p {
        let mut column = select_columns(W.as_ref(), &[c]);
        for _ in 0..2 {
            let M_column = symmetric_mul(M, column.as_ref());
            for r in 0..c {
                let coefficient = dot(W.col(r), M_column.col(0));
                R[(r, c)] += coefficient;
                for i in 0..n {
                    column[(i, 0)] -= coefficient * W[(i, r)];
                }
            }
        }
        let norm = m_norm(&column, M);
        if norm > 1e-10 * reference_norms[c] && norm > 0.0 {
            R[(c, c)] = norm;
        } else {
            // Dependent: continue the recursion in a fresh direction.
            column = random.block(n, 1);
            let previous = select_columns(W.as_ref(), &(0..c).collect::<Vec<_>>());
            let mut all_bases: Vec<MatRef<'_, f64>> = bases.to_vec();
            all_bases.push(previous.as_ref());
            project_out(&mut column, &all_bases, M, par);
            let fresh_norm = m_norm(&column, M);
            if !(fresh_norm > 1e-8) {
                return Err(StageError::new(format!(
                    "Lanczos: the Krylov space is exhausted ({n} DOFs): no new direction is M-orthogonal to the basis"
                )));
            }
            R[(c, c)] = 0.0;
            for i in 0..n {
                column[(i, 0)] /= fresh_norm;
            }
            for i in 0..n {
                W[(i, c)] = column[(i, 0)];
            }
            continue;
        }
        for i in 0..n {
            W[(i, c)] = column[(i, 0)] / norm;
        }
    }
    Ok(R)
}

fn m_norm(column: &Mat<f64>, M: &CscMatrix) -> f64 {
    let M_column = symmetric_mul(M, column.as_ref());
    dot(column.col(0), M_column.col(0)).max(0.0).sqrt()
}

/// Makes `W` `M`-orthonormal and `M`-orthogonal to `bases`; returns the coefficients on the
/// bases and `R` with `W_in = Σ Q H + W_out R`.
fn orthonormalize_block(
    W: &mut Mat<f64>,
    bases: &[MatRef<'_, f64>],
    M: &CscMatrix,
    random: &mut SplitMix64,
    par: Par,
) -> Result<(Vec<Mat<f64>>, Mat<f64>), StageError> {
    let (coefficients, entry_norms) = project_out(W, bases, M, par);
    let saved = W.clone();
    if let Some(R) = cholesky_qr2(W, M, &entry_norms, par) {
        return Ok((coefficients, R));
    }
    *W = saved;
    let R = orthonormalize_columnwise(W, bases, M, &entry_norms, random, par)?;
    Ok((coefficients, R))
}

/// Copies `block` into the columns `first..first + block.ncols()` of `target`.
fn set_columns(target: MatMut<'_, f64>, first: usize, block: MatRef<'_, f64>) {
    target.subcols_mut(first, block.ncols()).copy_from(block);
}

/// `xᵀ y` of two columns.
fn dot(x: faer::ColRef<'_, f64>, y: faer::ColRef<'_, f64>) -> f64 {
    x.iter().zip(y.iter()).map(|(a, b)| a * b).sum()
}

/// Runs the recursion until `done` accepts the converged eigenvalues θ (descending, including
/// those locked in this run), keeping every vector `M`-orthogonal to `locked`.
pub fn block_lanczos(
    op: &ShiftInvert<'_>,
    locked: MatRef<'_, f64>,
    options: LanczosOptions,
    done: &dyn Fn(&[f64]) -> bool,
) -> Result<RitzPairs, StageError> {
    let M = op.M;
    let par = op.par;
    let n = M.n_rows;
    let b = options.block_size;
    let max_basis = options.max_basis.max(2 * b) / b * b;
    let mut random = SplitMix64::new(options.seed);

    // Vectors locked in this run (converged before a restart), with their θ.
    let mut found_theta: Vec<f64> = Vec::new();
    let mut found = Mat::<f64>::zeros(n, 0);

    let mut V = Mat::<f64>::zeros(n, max_basis);
    let mut T = Mat::<f64>::zeros(max_basis, max_basis);
    // A start block in the range of Op: smooth, with no components Op cannot produce.
    let mut start = op.apply(random.block(n, b).as_ref());
    orthonormalize_block(&mut start, &[locked, found.as_ref()], M, &mut random, par)?;
    set_columns(V.as_mut(), 0, start.as_ref());
    let mut basis_size = b;
    let mut largest_basis = b;
    let mut restarts = 0;
    let mut blocks_since_check = 0usize;

    loop {
        let current = V.as_ref().subcols(basis_size - b, b).to_owned();
        let mut W = op.apply(current.as_ref());
        let (coefficients, R) = orthonormalize_block(
            &mut W,
            &[locked, found.as_ref(), V.as_ref().subcols(0, basis_size)],
            M,
            &mut random,
            par,
        )?;
        T.as_mut()
            .submatrix_mut(0, basis_size - b, basis_size, b)
            .copy_from(&coefficients[2]);
        blocks_since_check += 1;

        let basis_full = basis_size + b > max_basis;
        let check_every = (max_basis / (4 * b)).max(1);
        if basis_full || blocks_since_check >= check_every {
            blocks_since_check = 0;
            let T_m = symmetrised(T.as_ref().submatrix(0, 0, basis_size, basis_size));
            let (theta_ascending, Y_ascending) = symmetric_eigen(T_m.as_ref(), par)?;
            // Descending θ: nearest above σ first.
            let order: Vec<usize> = (0..basis_size).rev().collect();
            let theta: Vec<f64> = order.iter().map(|&i| theta_ascending[i]).collect();
            let Y = select_columns(Y_ascending.as_ref(), &order);
            let Y_last = Y.as_ref().subrows(basis_size - b, b);
            let mut RY = Mat::<f64>::zeros(b, basis_size);
            matmul(RY.as_mut(), Accum::Replace, R.as_ref(), Y_last, 1.0, par);
            let converged_prefix = (0..basis_size)
                .take_while(|&i| {
                    let estimate = RY.col(i).norm_l2();
                    estimate <= options.tolerance * theta[i].abs()
                })
                .count();
            let mut all_theta: Vec<f64> = found_theta.clone();
            all_theta.extend_from_slice(&theta[..converged_prefix]);
            all_theta.sort_by(|a, b| b.total_cmp(a));
            if done(&all_theta) || (basis_full && converged_prefix == basis_size) {
                let columns: Vec<usize> = (0..converged_prefix).collect();
                let mut vectors = Mat::<f64>::zeros(n, converged_prefix);
                matmul(
                    vectors.as_mut(),
                    Accum::Replace,
                    V.as_ref().subcols(0, basis_size),
                    select_columns(Y.as_ref(), &columns).as_ref(),
                    1.0,
                    par,
                );
                let mut theta_out = found_theta.clone();
                theta_out.extend_from_slice(&theta[..converged_prefix]);
                let mut all_vectors = Mat::<f64>::zeros(n, found.ncols() + converged_prefix);
                set_columns(all_vectors.as_mut(), 0, found.as_ref());
                set_columns(all_vectors.as_mut(), found.ncols(), vectors.as_ref());
                return Ok(RitzPairs {
                    theta: theta_out,
                    vectors: all_vectors,
                    basis_size: largest_basis,
                    restarts,
                });
            }
            if basis_full {
                // Restart: lock the converged, continue from the best unconverged.
                restarts += 1;
                if restarts > options.max_restarts {
                    return Err(StageError::new(format!(
                        "Lanczos did not converge: {} Ritz pairs converged after {} restarts with a basis of {max_basis} vectors",
                        found_theta.len() + converged_prefix,
                        options.max_restarts
                    )));
                }
                let n_next = b.min(basis_size - converged_prefix);
                let mut converged_vectors = Mat::<f64>::zeros(n, converged_prefix);
                let mut next_start = Mat::<f64>::zeros(n, n_next);
                let basis = V.as_ref().subcols(0, basis_size);
                let converged_columns: Vec<usize> = (0..converged_prefix).collect();
                let next_columns: Vec<usize> =
                    (converged_prefix..converged_prefix + n_next).collect();
                matmul(
                    converged_vectors.as_mut(),
                    Accum::Replace,
                    basis,
                    select_columns(Y.as_ref(), &converged_columns).as_ref(),
                    1.0,
                    par,
                );
                matmul(
                    next_start.as_mut(),
                    Accum::Replace,
                    basis,
                    select_columns(Y.as_ref(), &next_columns).as_ref(),
                    1.0,
                    par,
                );
                let mut grown = Mat::<f64>::zeros(n, found.ncols() + converged_prefix);
                set_columns(grown.as_mut(), 0, found.as_ref());
                set_columns(grown.as_mut(), found.ncols(), converged_vectors.as_ref());
                found = grown;
                found_theta.extend_from_slice(&theta[..converged_prefix]);
                let mut start = Mat::<f64>::zeros(n, b);
                set_columns(start.as_mut(), 0, next_start.as_ref());
                if n_next < b {
                    let fill = random.block(n, b - n_next);
                    set_columns(start.as_mut(), n_next, fill.as_ref());
                }
                orthonormalize_block(&mut start, &[locked, found.as_ref()], M, &mut random, par)?;
                V.fill(0.0);
                T.fill(0.0);
                set_columns(V.as_mut(), 0, start.as_ref());
                basis_size = b;
                continue;
            }
        }
        set_columns(V.as_mut(), basis_size, W.as_ref());
        T.as_mut()
            .submatrix_mut(basis_size, basis_size - b, b, b)
            .copy_from(&R);
        basis_size += b;
        largest_basis = largest_basis.max(basis_size);
    }
}
