//! Dense symmetric eigenproblems: the small projected problems of the Lanczos and
//! Rayleigh–Ritz steps, and the whole problem for small models.
//!
//! `K y = λ M y` with `M = L Lᵀ` (Cholesky) becomes the standard problem
//! `(L⁻¹ K L⁻ᵀ) z = λ z`, `y = L⁻ᵀ z`, whose eigenvectors give `Yᵀ M Y = I`.

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{
    LltRegularization, cholesky_in_place, cholesky_in_place_scratch,
};
use faer::linalg::evd::{ComputeEigenvectors, self_adjoint_evd, self_adjoint_evd_scratch};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, MatMut, MatRef, Par};

use crate::Error;

/// `(A + Aᵀ) / 2`: removes the roundoff asymmetry of a computed projection.
pub fn symmetrised(A: MatRef<'_, f64>) -> Mat<f64> {
    Mat::from_fn(A.nrows(), A.ncols(), |i, j| 0.5 * (A[(i, j)] + A[(j, i)]))
}

/// Eigenvalues (ascending) and orthonormal eigenvectors of the symmetric `A`.
///
/// `A` is scaled to a largest entry of 1 first: faer's tridiagonal eigensolver loses accuracy
/// on matrices of very large or very small norm (stiffness entries are ~1e11, Lanczos
/// projections ~1e-6), and scaling by a power of two is exact.
pub fn symmetric_eigen(A: MatRef<'_, f64>, par: Par) -> Result<(Vec<f64>, Mat<f64>), Error> {
    let n = A.nrows();
    let largest = A
        .col_iter()
        .flat_map(|column| column.iter().copied())
        .fold(0.0f64, |largest, value| largest.max(value.abs()));
    if !largest.is_finite() {
        return Err(Error::InvalidInput(format!(
            "dense symmetric eigensolver: the {n}×{n} matrix has a non-finite entry"
        )));
    }
    let scale = if largest > 0.0 {
        2f64.powi(largest.log2().round() as i32)
    } else {
        1.0
    };
    let A = Mat::from_fn(n, n, |i, j| A[(i, j)] / scale);
    let mut eigenvectors = Mat::<f64>::zeros(n, n);
    let mut eigenvalues = Diag::<f64>::zeros(n);
    let mut buffer = MemBuffer::new(self_adjoint_evd_scratch::<f64>(
        n,
        ComputeEigenvectors::Yes,
        par,
        Default::default(),
    ));
    self_adjoint_evd(
        A.as_ref(),
        eigenvalues.as_mut(),
        Some(eigenvectors.as_mut()),
        par,
        MemStack::new(&mut buffer),
        Default::default(),
    )
    .map_err(|err| {
        Error::Breakdown(format!(
            "dense symmetric eigensolver failed on a {n}×{n} matrix: {err:?}"
        ))
    })?;
    let eigenvalues = (0..n).map(|i| eigenvalues[i] * scale).collect();
    Ok((eigenvalues, eigenvectors))
}

/// `K y = λ M y` for symmetric `K` and symmetric positive definite `M`: eigenvalues ascending
/// and eigenvectors with `Yᵀ M Y = I`.
pub fn generalized_symmetric_eigen(
    K: MatRef<'_, f64>,
    M: MatRef<'_, f64>,
    par: Par,
) -> Result<(Vec<f64>, Mat<f64>), Error> {
    let n = K.nrows();
    let mut L = M.to_owned();
    cholesky_lower(L.as_mut(), par)
        .map_err(|err| format!("the {n}×{n} projected mass matrix is not positive definite: {err}"))
        .map_err(Error::Breakdown)?;
    // The factor is in the lower triangle; clear the rest for the triangular solves.
    for j in 0..n {
        for i in 0..j {
            L[(i, j)] = 0.0;
        }
    }
    // C = L⁻¹ K L⁻ᵀ = L⁻¹ (L⁻¹ K)ᵀ for symmetric K.
    let mut left = K.to_owned();
    solve_lower_triangular_in_place(L.as_ref(), left.as_mut(), par);
    let mut C = left.transpose().to_owned();
    solve_lower_triangular_in_place(L.as_ref(), C.as_mut(), par);
    let (eigenvalues, mut Y) = symmetric_eigen(symmetrised(C.as_ref()).as_ref(), par)?;
    solve_upper_triangular_in_place(L.as_ref().transpose(), Y.as_mut(), par);
    Ok((eigenvalues, Y))
}

/// `A = L Lᵀ` in place, `L` in the lower triangle (the strict upper one left as it was); the
/// error is faer's reason.
pub fn cholesky_lower(A: MatMut<'_, f64>, par: Par) -> Result<(), String> {
    let n = A.nrows();
    let mut buffer = MemBuffer::new(cholesky_in_place_scratch::<f64>(n, par, Default::default()));
    cholesky_in_place(
        A,
        LltRegularization::default(),
        par,
        MemStack::new(&mut buffer),
        Default::default(),
    )
    .map(|_| ())
    .map_err(|err| format!("{err:?}"))
}

/// `A` restricted to the columns `columns`.
pub fn select_columns(A: MatRef<'_, f64>, columns: &[usize]) -> Mat<f64> {
    Mat::from_fn(A.nrows(), columns.len(), |i, j| A[(i, columns[j])])
}
