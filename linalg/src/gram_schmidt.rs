//! Gram–Schmidt: classical, twice where it must be.
//!
//! Against a tall orthonormal basis (the Krylov bases), classical Gram–Schmidt is a pair of
//! tall products ([`crate::tall`]) per pass, matrix–matrix rather than vector by vector. One
//! pass is not enough after a large cancellation in floating point; a second follows unless no
//! column lost more than `1 − 1/√2` of its norm (Daniel–Gragg–Kaufman–Stewart).
//!
//! The real Lanczos basis is orthonormal in the `M` inner product; its Gram–Schmidt is in
//! [`crate::lanczos`], where `M V` is kept beside `V`.

use faer::{Mat, MatRef, Par, c64};

use crate::rng::SplitMix64;
use crate::tall::{add_times, adjoint_times};

/// Removes from `W` its components along the orthonormal columns of `V`; returns the
/// coefficients. A second pass follows unless no column lost more than 1 − 1/√2 of its norm
/// in the first (Daniel–Gragg–Kaufman–Stewart): after a large cancellation one pass is not
/// enough in floating point. (Against the first-half basis the second pass always runs, its
/// update folded into `T`: [`crate::toar::HalfBasis::extend`].) The products go through [`crate::tall`].
pub fn project_out(V: MatRef<'_, c64>, W: &mut Mat<c64>, par: Par) -> Mat<c64> {
    let mut coefficients = Mat::<c64>::zeros(V.ncols(), W.ncols());
    if V.ncols() == 0 {
        return coefficients;
    }
    let norms = |W: &Mat<c64>| -> Vec<f64> {
        (0..W.ncols())
            .map(|col| column_norm(W.as_ref(), col))
            .collect()
    };
    let before = norms(W);
    for pass_index in 0..2 {
        let pass = adjoint_times(V, W.as_ref(), par);
        add_times(W.as_mut(), V, (-&pass).as_ref(), par);
        coefficients += &pass;
        if pass_index == 0
            && norms(W)
                .iter()
                .zip(&before)
                .all(|(after, before)| *after >= std::f64::consts::FRAC_1_SQRT_2 * before)
        {
            break;
        }
    }
    coefficients
}

pub fn column_norm(W: MatRef<'_, c64>, col: usize) -> f64 {
    W.col(col).iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt()
}

/// Orthonormalises the columns of `W` against `V` and among themselves: `W_in = V H + W_out R`.
/// A column that vanishes (an invariant subspace was found) is replaced by a fresh random
/// direction, with a zero on R's diagonal.
pub fn orthonormalise(
    V: MatRef<'_, c64>,
    W: &mut Mat<c64>,
    random: &mut SplitMix64,
    par: Par,
) -> (Mat<c64>, Mat<c64>) {
    let H = project_out(V, W, par);
    let b = W.ncols();
    let mut R = Mat::<c64>::zeros(b, b);
    for j in 0..b {
        let before = column_norm(W.as_ref(), j);
        let mut column = W.subcols(j, 1).to_owned();
        let coefficients = project_out(W.subcols(0, j), &mut column, par);
        for i in 0..j {
            R[(i, j)] = coefficients[(i, 0)];
        }
        let norm = column_norm(column.as_ref(), 0);
        if norm > 1e-10 * before && norm > 0.0 {
            R[(j, j)] = c64::new(norm, 0.0);
        } else {
            column = random.complex_block(W.nrows(), 1);
            project_out(V, &mut column, par);
            project_out(W.subcols(0, j), &mut column, par);
        }
        let norm = column_norm(column.as_ref(), 0);
        for row in 0..W.nrows() {
            W[(row, j)] = column[(row, 0)] / norm;
        }
    }
    (H, R)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::toar::HalfBasis;

    /// Gram–Schmidt twice on a tall basis, over several row chunks, for vectors that lie
    /// almost wholly in its span (the case it is made for): the remainder must be orthogonal to
    /// the basis to round-off, and basis times coefficients plus remainder must give back the
    /// vectors.
    #[test]
    fn gram_schmidt_twice_leaves_a_remainder_orthogonal_to_a_tall_basis() {
        let (rows, rank, b) = (5000, 40, 8);
        let mut random = SplitMix64::new(7);
        let mut half = HalfBasis::new(rows, rank, crate::par());
        half.extend(random.complex_block(rows, rank));
        assert_eq!(half.rank(), rank);
        let basis = half.basis();
        let Q = basis.as_ref();
        let mixture = random.complex_block(rank, b);
        let W = Q * &mixture + random.complex_block(rows, b) * faer::Scale(c64::new(1e-6, 0.0));
        let mut remainder = W.clone();
        let coefficients = project_out(Q, &mut remainder, crate::par());
        let leak = (Q.adjoint() * &remainder).norm_max() / remainder.norm_max();
        assert!(
            leak < 1e-13,
            "remainder not orthogonal to the basis: {leak:.1e}"
        );
        let rebuilt = Q * &coefficients + &remainder;
        let error = (&rebuilt - &W).norm_max() / W.norm_max();
        assert!(
            error < 1e-13,
            "basis × coefficients + remainder ≠ vectors: {error:.1e}"
        );
        // The basis itself is orthonormal.
        let gram = Q.adjoint() * Q;
        let off = (&gram - Mat::<c64>::identity(rank, rank)).norm_max();
        assert!(off < 1e-13, "basis not orthonormal: {off:.1e}");
    }
}
