//! Dense solves of small quadratic eigenproblems: the reference for the Krylov solver, the
//! reduced problem of the real-mode projection, and lumped models.
//!
//! `(λ² M + λ C + K) q = 0` is linearised on `y = [q; λ q / s]`, `s = √(‖K‖₁/‖M‖₁)` (both
//! halves of y on one scale), and solved by QZ (faer's generalized eigensolver):
//!
//! ```text
//! [ 0   s I ] y = λ [ I  0  ] y
//! [ −K −s C ]       [ 0  s M ]
//! ```
//!
//! Each q is taken from whichever half of y has the smaller residual. Where QZ returns no
//! usable vector (an exactly repeated eigenvalue can give non-finite ones), q is the right
//! singular vector of `λ² M + λ C + K` for its smallest singular value (the next smallest for
//! a second copy).

use faer::{Mat, MatRef, c64};

use super::sliding::{Part, SlidingSystem};
use crate::stage::StageError;

fn norm_1(A: MatRef<'_, f64>) -> f64 {
    (0..A.ncols())
        .map(|col| A.col(col).iter().map(|value| value.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// `‖Q(λ) q‖ / ‖q‖` and the matrix Q(λ) = λ² M + λ C + K.
fn quadratic_at(
    M: MatRef<'_, f64>,
    C: MatRef<'_, f64>,
    K: MatRef<'_, f64>,
    lambda: c64,
) -> Mat<c64> {
    Mat::from_fn(M.nrows(), M.ncols(), |i, j| {
        lambda * lambda * M[(i, j)] + lambda * C[(i, j)] + K[(i, j)]
    })
}

fn relative_residual(Q: &Mat<c64>, q: &[c64]) -> f64 {
    let norm: f64 = q.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt();
    let residual: f64 = (0..Q.nrows())
        .map(|i| {
            (0..Q.ncols())
                .map(|j| Q[(i, j)] * q[j])
                .sum::<c64>()
                .norm_sqr()
        })
        .sum::<f64>()
        .sqrt();
    if norm > 0.0 && residual.is_finite() {
        residual / norm
    } else {
        f64::INFINITY
    }
}

/// Eigenvalues λ and vectors q of a dense quadratic eigenproblem; infinite eigenvalues (a
/// singular M) are dropped.
pub fn quadratic_eigen(
    M: MatRef<'_, f64>,
    C: MatRef<'_, f64>,
    K: MatRef<'_, f64>,
) -> Result<Vec<(c64, Vec<c64>)>, StageError> {
    let n = M.nrows();
    let scale = (norm_1(K) / norm_1(M)).sqrt();
    let scale = if scale.is_finite() && scale > 0.0 {
        scale
    } else {
        1.0
    };
    let A = Mat::<f64>::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
        (true, true) => 0.0,
        (true, false) => scale * f64::from(u8::from(j - n == i)),
        (false, true) => -K[(i - n, j)],
        (false, false) => -scale * C[(i - n, j - n)],
    });
    let B = Mat::<f64>::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
        (true, true) => f64::from(u8::from(i == j)),
        (false, false) => scale * M[(i - n, j - n)],
        _ => 0.0,
    });
    let eigen = A.generalized_eigen(&B).map_err(|err| {
        StageError::new(format!(
            "the dense QZ solve did not converge ({} unknowns): {err:?}",
            2 * n
        ))
    })?;
    let (alpha, beta, U) = (eigen.S_a(), eigen.S_b(), eigen.U());
    let largest = (0..2 * n).map(|i| alpha[i].norm()).fold(0.0, f64::max);
    let mut pairs = Vec::new();
    let mut fallbacks: Vec<c64> = Vec::new();
    for i in 0..2 * n {
        if !(beta[i].norm() > 1e-14 * alpha[i].norm().max(1e-300 * largest)) {
            continue;
        }
        let lambda = alpha[i] / beta[i];
        let Q = quadratic_at(M, C, K, lambda);
        let halves = [
            (0..n).map(|row| U[(row, i)]).collect::<Vec<c64>>(),
            (0..n).map(|row| U[(n + row, i)] * scale / lambda).collect(),
        ];
        let (best, residual) = halves
            .into_iter()
            .map(|q| {
                let residual = relative_residual(&Q, &q);
                (q, residual)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("two halves");
        let q = if residual.is_finite() {
            best
        } else {
            // The copies of λ already given a singular vector pick the next one.
            let copy = fallbacks
                .iter()
                .filter(|other| (**other - lambda).norm() <= 1e-8 * lambda.norm())
                .count();
            fallbacks.push(lambda);
            let svd = Q
                .svd()
                .map_err(|err| StageError::new(format!("SVD of Q(lambda) failed: {err:?}")))?;
            let column = n.saturating_sub(1 + copy);
            svd.V().col(column).iter().copied().collect()
        };
        pairs.push((lambda, q));
    }
    Ok(pairs)
}

/// `Tᵘᵀ A Tᴺ X` for real columns X (reduced DOFs), as a dense real matrix.
pub fn reduced_times(system: &SlidingSystem, part: Part, X: MatRef<'_, f64>) -> Mat<f64> {
    use rayon::prelude::*;
    let columns: Vec<Vec<c64>> = (0..X.ncols())
        .into_par_iter()
        .map(|col| {
            let x: Vec<c64> = X.col(col).iter().map(|&v| c64::new(v, 0.0)).collect();
            system.apply(part, &x)
        })
        .collect();
    Mat::from_fn(system.dim(), X.ncols(), |row, col| columns[col][row].re)
}

/// `(M̃, C̃, K̃)` as dense matrices (small systems only).
pub fn dense_matrices(system: &SlidingSystem) -> [Mat<f64>; 3] {
    let identity = Mat::<f64>::identity(system.dim(), system.dim());
    [Part::M, Part::C, Part::K].map(|part| reduced_times(system, part, identity.as_ref()))
}
