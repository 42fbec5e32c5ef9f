//! Dense solves of small quadratic eigenproblems: the reference for the Krylov solver, the
//! reduced problem of the real-mode projection, and lumped models.
//!
//! `(λ² M + λ C + K) q = 0` is linearised on `y = [q; λ q / s]`, `s = √(‖K‖₁/‖M‖₁)` (both
//! halves of y on one scale), and solved densely (`linearised_eigen`):
//!
//! ```text
//! [ 0   s I ] y = λ [ I  0  ] y
//! [ −K −s C ]       [ 0  s M ]
//! ```
//!
//! Each q is taken from whichever half of y has the smaller residual. Where the solver returns no
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

/// `(α, β, Y)`: eigenvalues `α/β` of a pencil and their vectors (columns of Y).
type PencilEigen = (Vec<c64>, Vec<c64>, Mat<c64>);

/// Eigenvalues of the pencil `A y = λ B y` as `α/β` with their vectors: Hessenberg QR on
/// `B⁻¹ A` when B is well conditioned (a mass matrix is), QZ otherwise (faer's QZ is two
/// orders of magnitude slower on these pencils, so it is the fallback).
fn linearised_eigen(A: Mat<f64>, B: Mat<f64>) -> Result<PencilEigen, StageError> {
    use faer::linalg::solvers::Solve;
    let n = A.nrows();
    let lu = B.partial_piv_lu();
    let pivots: Vec<f64> = (0..n).map(|i| lu.U()[(i, i)].abs()).collect();
    let (smallest, largest) = pivots
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(low, high), &p| {
            (low.min(p), high.max(p))
        });
    let unsolved = |err: &dyn std::fmt::Debug| {
        StageError::new(format!(
            "the dense eigensolver did not converge ({n} unknowns): {err:?}"
        ))
    };
    if smallest > 1e-10 * largest {
        let eigen = lu.solve(&A).eigen().map_err(|err| unsolved(&err))?;
        let values: Vec<c64> = eigen.S().column_vector().iter().copied().collect();
        return Ok((values, vec![c64::new(1.0, 0.0); n], eigen.U().to_owned()));
    }
    let eigen = A.generalized_eigen(&B).map_err(|err| unsolved(&err))?;
    Ok((
        eigen.S_a().column_vector().iter().copied().collect(),
        eigen.S_b().column_vector().iter().copied().collect(),
        eigen.U().to_owned(),
    ))
}

/// Eigenvalues λ for which `wanted(λ)` holds, with their vectors q, of a dense quadratic
/// eigenproblem; infinite eigenvalues (a singular M) are dropped.
pub fn quadratic_eigen(
    M: MatRef<'_, f64>,
    C: MatRef<'_, f64>,
    K: MatRef<'_, f64>,
    wanted: impl Fn(c64) -> bool,
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
    let (alpha, beta, U) = linearised_eigen(A, B)?;

    let largest = (0..2 * n).map(|i| alpha[i].norm()).fold(0.0, f64::max);
    let mut pairs = Vec::new();
    let mut fallbacks: Vec<c64> = Vec::new();
    for i in 0..2 * n {
        if !(beta[i].norm() > 1e-14 * alpha[i].norm().max(1e-300 * largest)) {
            continue;
        }
        let lambda = alpha[i] / beta[i];
        if !wanted(lambda) {
            continue;
        }
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
    let X = Mat::from_fn(X.nrows(), X.ncols(), |row, col| {
        c64::new(X[(row, col)], 0.0)
    });
    let product = system.apply_block(part, X.as_ref());
    Mat::from_fn(product.nrows(), product.ncols(), |row, col| {
        product[(row, col)].re
    })
}

/// `(M̃, C̃, K̃)` as dense matrices (small systems only).
pub fn dense_matrices(system: &SlidingSystem) -> [Mat<f64>; 3] {
    let identity = Mat::<f64>::identity(system.dim(), system.dim());
    [Part::M, Part::C, Part::K].map(|part| reduced_times(system, part, identity.as_ref()))
}
