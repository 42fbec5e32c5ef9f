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
//! W = Op V_j = A⁻¹ (M V_j),   W ← W − V ((M V)ᵀ W)   (full reorthogonalisation, also
//!                                                  against locked vectors X)
//! W = V_{j+1} R_j          (M-orthonormal QR: Cholesky QR, twice)
//! Op V_m = V_m T_m + V_{m+1} R_m E_mᵀ,   T_m = V_mᵀ M Op V_m   (block tridiagonal)
//! ```
//!
//! `M V` is kept beside `V`, so a block costs one solve and one product by `M`. The
//! reorthogonalisation projects first on the last two blocks (where the recursion puts almost
//! all of `W`), then on everything; a further pass is made only where that one removed much of
//! a column (the Daniel–Gragg–Kaufman–Stewart test), which keeps orthogonality at roundoff.
//!
//! Ritz pairs `T_m y = θ y`, `x = V_m y` have `‖Op x − θ x‖_M = ‖R_m y_last‖` (`y_last` the last
//! `b` entries of `y`), which decides convergence without touching `n`-vectors. Blocks find
//! repeated eigenvalues (up to multiplicity `b`) that a single-vector recursion only finds
//! through roundoff. When the basis is full, converged Ritz vectors are locked (deflated: every
//! new vector is kept `M`-orthogonal to them) and the recursion restarts thickly from the best
//! unconverged Ritz vectors (see [`block_lanczos`]).

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

use faer::{Mat, MatMut, MatRef, Par};

use crate::Error;
use crate::csc::CscMatrix;
use crate::csc::symmetric_mul;
use crate::dense::{select_columns, symmetric_eigen, symmetrised};
use crate::gram_schmidt::{Orthonormal, Orthonormalized, orthonormalize_block};
use crate::ldlt::Factor;
use crate::rng::SplitMix64;
use crate::tall::times;

/// `Op = (K − σ M)⁻¹ M`, applied to blocks of vectors; counts the vectors solved for.
pub struct ShiftInvert<'a> {
    pub factor: &'a Factor<'a>,
    pub M: &'a CscMatrix,
    pub par: Par,
    pub n_solves: AtomicUsize,
    pub solve_nanoseconds: AtomicU64,
}

impl<'a> ShiftInvert<'a> {
    pub fn new(factor: &'a Factor<'a>, M: &'a CscMatrix, par: Par) -> Self {
        ShiftInvert {
            factor,
            M,
            par,
            n_solves: AtomicUsize::new(0),
            solve_nanoseconds: AtomicU64::new(0),
        }
    }

    pub fn apply(&self, X: MatRef<'_, f64>) -> Mat<f64> {
        let started = Instant::now();
        let mut Y = symmetric_mul(self.M, X);
        self.factor.solve_in_place(Y.as_mut(), self.par);
        self.n_solves.fetch_add(X.ncols(), Ordering::Relaxed);
        self.solve_nanoseconds
            .fetch_add(started.elapsed().as_nanos() as u64, Ordering::Relaxed);
        Y
    }

    /// `A⁻¹ (M X)` from `M X`.
    pub fn apply_to_product(&self, MX: MatRef<'_, f64>) -> Mat<f64> {
        let started = Instant::now();
        let mut Y = MX.to_owned();
        self.factor.solve_in_place(Y.as_mut(), self.par);
        self.n_solves.fetch_add(MX.ncols(), Ordering::Relaxed);
        self.solve_nanoseconds
            .fetch_add(started.elapsed().as_nanos() as u64, Ordering::Relaxed);
        Y
    }

    pub fn solve_seconds(&self) -> f64 {
        self.solve_nanoseconds.load(Ordering::Relaxed) as f64 * 1e-9
    }

    pub fn sigma(&self) -> f64 {
        self.factor.sigma
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
    /// `M` times the vectors.
    pub M_vectors: Mat<f64>,
    /// Largest basis used.
    pub basis_size: usize,
    pub restarts: usize,
    /// Time in solves with the factor (all of this operator's so far), in
    /// reorthogonalisation, and in Ritz extraction.
    pub solve_seconds: f64,
    pub orthogonalize_seconds: f64,
    pub ritz_seconds: f64,
}

/// Copies `block` into the columns `first..first + block.ncols()` of `target`.
fn set_columns(target: MatMut<'_, f64>, first: usize, block: MatRef<'_, f64>) {
    target.subcols_mut(first, block.ncols()).copy_from(block);
}

/// Appends `extra` columns to `target`.
fn append_columns(target: &mut Mat<f64>, extra: MatRef<'_, f64>) {
    let mut grown = Mat::<f64>::zeros(target.nrows(), target.ncols() + extra.ncols());
    set_columns(grown.as_mut(), 0, target.as_ref());
    set_columns(grown.as_mut(), target.ncols(), extra);
    *target = grown;
}

/// Runs the recursion until `done` accepts the converged eigenvalues θ (descending, including
/// those locked in this run), keeping every vector `M`-orthogonal to `locked`.
///
/// When the basis is full it restarts thickly: converged Ritz vectors are locked, the best
/// unconverged ones `X` are kept as the start of the new basis together with the next block
/// `V_{m+1}`, and the projection becomes the arrowhead `[[Θ, Sᵀ], [S, ·]]` with
/// `S = R_m Y_last` (from `Op X = X Θ + V_{m+1} S`), so no Krylov information on them is lost.
pub fn block_lanczos(
    op: &ShiftInvert<'_>,
    locked: MatRef<'_, f64>,
    options: LanczosOptions,
    done: &dyn Fn(&[f64]) -> bool,
) -> Result<RitzPairs, Error> {
    let M = op.M;
    let par = op.par;
    let n = M.n_rows;
    let b = options.block_size;
    let max_basis = options.max_basis.max(4 * b);
    let mut random = SplitMix64::new(options.seed);
    let mut stats = Stats::default();
    let M_locked = symmetric_mul(M, locked);
    let locked = Orthonormal {
        vectors: locked,
        M_vectors: M_locked.as_ref(),
    };
    let mut found = Found {
        theta: Vec::new(),
        vectors: Mat::zeros(n, 0),
        M_vectors: Mat::zeros(n, 0),
    };
    let mut basis = Basis {
        V: Mat::zeros(n, max_basis),
        MV: Mat::zeros(n, max_basis),
        T: Mat::zeros(max_basis, max_basis),
        size: 0,
    };
    let (start, M_start) = start_block(op, locked, b, &mut random)?;
    basis.append(start.as_ref(), M_start.as_ref(), None);
    stats.largest_basis = b;
    let mut blocks_since_check = 0usize;
    let check_every = (max_basis / (4 * b)).max(1);

    loop {
        let block_start = basis.size - b;
        let mut W = op.apply_to_product(basis.MV.as_ref().subcols(block_start, b));
        let started = Instant::now();
        // Against every locked vector, and (in exact arithmetic, only) the last two blocks.
        let Orthonormalized {
            M_vectors: MW,
            coefficients,
            R,
        } = orthonormalize_block(
            &mut W,
            &[locked, found.basis()],
            basis.vectors(),
            basis.size.saturating_sub(2 * b),
            M,
            &mut random,
            par,
        )?;
        stats.orthogonalize_seconds += started.elapsed().as_secs_f64();
        basis
            .T
            .as_mut()
            .submatrix_mut(0, block_start, basis.size, b)
            .copy_from(&coefficients);
        blocks_since_check += 1;

        let basis_full = basis.size + b > max_basis;
        if basis_full || blocks_since_check >= check_every {
            blocks_since_check = 0;
            let started = Instant::now();
            let check = ritz_check(
                basis.T.as_ref().submatrix(0, 0, basis.size, basis.size),
                R.as_ref(),
                options.tolerance,
                par,
            )?;
            let converged = check.converged_prefix;
            let finished = done(&found.theta_with(&check.theta[..converged]))
                || (basis_full && converged == basis.size);
            if finished || basis_full {
                // Ritz vectors of the converged prefix, and on a restart those kept.
                let n_keep = if finished {
                    0
                } else {
                    (basis.size - converged)
                        .min(max_basis / 2)
                        .min(max_basis - 2 * b)
                };
                let ritz = basis.ritz_vectors(check.Y.as_ref().subcols(0, converged + n_keep));
                found.lock(
                    &check.theta[..converged],
                    ritz.vectors.as_ref().subcols(0, converged),
                    ritz.M_vectors.as_ref().subcols(0, converged),
                );
                stats.ritz_seconds += started.elapsed().as_secs_f64();
                if finished {
                    return Ok(found.into_pairs(stats, op.solve_seconds()));
                }
                stats.restarts += 1;
                if stats.restarts > options.max_restarts {
                    return Err(Error::NotConverged(format!(
                        "Lanczos did not converge: {} Ritz pairs converged after {} restarts with a basis of {max_basis} vectors",
                        found.theta.len(),
                        options.max_restarts
                    )));
                }
                basis.thick_restart(
                    Orthonormal {
                        vectors: ritz.vectors.as_ref().subcols(converged, n_keep),
                        M_vectors: ritz.M_vectors.as_ref().subcols(converged, n_keep),
                    },
                    &check.theta[converged..converged + n_keep],
                    check.S.as_ref().subcols(converged, n_keep),
                    Orthonormal {
                        vectors: W.as_ref(),
                        M_vectors: MW.as_ref(),
                    },
                );
                continue;
            }
            stats.ritz_seconds += started.elapsed().as_secs_f64();
        }
        basis.append(W.as_ref(), MW.as_ref(), Some(R.as_ref()));
        stats.largest_basis = stats.largest_basis.max(basis.size);
    }
}

/// A start block in the range of Op, `M`-orthonormal and orthogonal to `locked`, with its
/// `M` products: Op applied to random vectors is smooth, with no components Op cannot
/// produce.
fn start_block(
    op: &ShiftInvert<'_>,
    locked: Orthonormal<'_>,
    b: usize,
    random: &mut SplitMix64,
) -> Result<(Mat<f64>, Mat<f64>), Error> {
    let n = op.M.n_rows;
    let mut start = op.apply(random.block(n, b).as_ref());
    let empty = Mat::<f64>::zeros(n, 0);
    let no_basis = Orthonormal {
        vectors: empty.as_ref(),
        M_vectors: empty.as_ref(),
    };
    let products = orthonormalize_block(&mut start, &[locked], no_basis, 0, op.M, random, op.par)?;
    Ok((start, products.M_vectors))
}

/// Ritz pairs locked in this run (converged before a restart).
struct Found {
    theta: Vec<f64>,
    vectors: Mat<f64>,
    M_vectors: Mat<f64>,
}

impl Found {
    fn basis(&self) -> Orthonormal<'_> {
        Orthonormal {
            vectors: self.vectors.as_ref(),
            M_vectors: self.M_vectors.as_ref(),
        }
    }

    /// The locked θ and `more`, descending.
    fn theta_with(&self, more: &[f64]) -> Vec<f64> {
        let mut all = self.theta.clone();
        all.extend_from_slice(more);
        all.sort_by(|a, b| b.total_cmp(a));
        all
    }

    fn lock(&mut self, theta: &[f64], vectors: MatRef<'_, f64>, M_vectors: MatRef<'_, f64>) {
        self.theta.extend_from_slice(theta);
        append_columns(&mut self.vectors, vectors);
        append_columns(&mut self.M_vectors, M_vectors);
    }

    fn into_pairs(self, stats: Stats, solve_seconds: f64) -> RitzPairs {
        RitzPairs {
            theta: self.theta,
            vectors: self.vectors,
            M_vectors: self.M_vectors,
            basis_size: stats.largest_basis,
            restarts: stats.restarts,
            solve_seconds,
            orthogonalize_seconds: stats.orthogonalize_seconds,
            ritz_seconds: stats.ritz_seconds,
        }
    }
}

/// Figures of a run, for [`RitzPairs`].
#[derive(Default)]
struct Stats {
    largest_basis: usize,
    restarts: usize,
    orthogonalize_seconds: f64,
    ritz_seconds: f64,
}

/// The Lanczos basis `V` (its first `size` columns), `M V`, and the projection `T` of `Op`.
struct Basis {
    V: Mat<f64>,
    MV: Mat<f64>,
    T: Mat<f64>,
    size: usize,
}

impl Basis {
    fn vectors(&self) -> Orthonormal<'_> {
        Orthonormal {
            vectors: self.V.as_ref().subcols(0, self.size),
            M_vectors: self.MV.as_ref().subcols(0, self.size),
        }
    }

    /// Appends the block `W` (`M W`), coupled to the last block by `R` (`T`'s subdiagonal).
    fn append(&mut self, W: MatRef<'_, f64>, MW: MatRef<'_, f64>, R: Option<MatRef<'_, f64>>) {
        let b = W.ncols();
        set_columns(self.V.as_mut(), self.size, W);
        set_columns(self.MV.as_mut(), self.size, MW);
        if let Some(R) = R {
            self.T
                .as_mut()
                .submatrix_mut(self.size, self.size - b, b, b)
                .copy_from(R);
        }
        self.size += b;
    }

    /// The Ritz vectors `V Y` and their `M` products.
    fn ritz_vectors(&self, Y: MatRef<'_, f64>) -> RitzVectors {
        let Orthonormal { vectors, M_vectors } = self.vectors();
        RitzVectors {
            vectors: times(vectors, Y),
            M_vectors: times(M_vectors, Y),
        }
    }

    /// Restarts as `[X_keep, V_{m+1}]`: the kept Ritz vectors, then the next block; `T`
    /// becomes the arrowhead `diag(θ_keep)` with the kept pairs' residual coefficients
    /// `S_keep` as its last block of rows.
    fn thick_restart(
        &mut self,
        kept: Orthonormal<'_>,
        theta_kept: &[f64],
        S_kept: MatRef<'_, f64>,
        next: Orthonormal<'_>,
    ) {
        let n_keep = theta_kept.len();
        set_columns(self.V.as_mut(), 0, kept.vectors);
        set_columns(self.MV.as_mut(), 0, kept.M_vectors);
        set_columns(self.V.as_mut(), n_keep, next.vectors);
        set_columns(self.MV.as_mut(), n_keep, next.M_vectors);
        self.T.fill(0.0);
        for (k, &theta) in theta_kept.iter().enumerate() {
            self.T[(k, k)] = theta;
        }
        self.T
            .as_mut()
            .submatrix_mut(n_keep, 0, S_kept.nrows(), n_keep)
            .copy_from(S_kept);
        self.size = n_keep + next.vectors.ncols();
    }
}

/// Ritz vectors and their `M` products (columns).
struct RitzVectors {
    vectors: Mat<f64>,
    M_vectors: Mat<f64>,
}

/// The Ritz pairs of a Lanczos basis: θ descending (nearest above σ first), their
/// coordinates `Y` in the basis, the residual coefficients `S = R Y_last`, and how many
/// pairs, from the first, have converged.
struct RitzCheck {
    theta: Vec<f64>,
    Y: Mat<f64>,
    S: Mat<f64>,
    converged_prefix: usize,
}

/// The Ritz pairs of the projection `T_m` whose last block of rows is coupled to the next
/// block by `R`.
fn ritz_check(
    T_m: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    tolerance: f64,
    par: Par,
) -> Result<RitzCheck, Error> {
    let basis_size = T_m.nrows();
    let b = R.nrows();
    let (theta_ascending, Y_ascending) = symmetric_eigen(symmetrised(T_m).as_ref(), par)?;
    let order: Vec<usize> = (0..basis_size).rev().collect();
    let theta: Vec<f64> = order.iter().map(|&i| theta_ascending[i]).collect();
    let Y = select_columns(Y_ascending.as_ref(), &order);
    // Op V_m Y = V_m Y Θ + V_{m+1} (R Y_last): the residual of each Ritz pair.
    let S = R * Y.as_ref().subrows(basis_size - b, b);
    // Lanczos cannot resolve a Ritz value better than roundoff in the largest one.
    let floor = 64.0 * f64::EPSILON * theta.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    let converged_prefix = (0..basis_size)
        .take_while(|&i| S.col(i).norm_l2() <= tolerance * theta[i].abs() + floor)
        .count();
    Ok(RitzCheck {
        theta,
        Y,
        S,
        converged_prefix,
    })
}
