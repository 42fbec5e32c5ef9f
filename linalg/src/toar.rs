//! The two-level orthonormal basis of TOAR (Su, Zhang & Bai 2008) for Arnoldi on a
//! first companion linearisation of a quadratic eigenproblem.
//!
//! With `y = [x₁; x₂]`, an operator whose second half `(x₁ + σ z₁)/s` is a combination of
//! `x₁` and the new `z₁` keeps the halves of every Arnoldi vector in the span of one
//! orthonormal `Q` (`m` rows) that grows by `z₁` alone: `V = [Q U₁; Q U₂]`. Only `Q` is stored
//! in full, at half the size of `V`; each step orthogonalises `z₁` against `Q` (vectors of
//! length `m`, not `2m`), and the Arnoldi Gram–Schmidt runs on the small coordinates
//! `[U₁; U₂]` ([`interleave`]), whose inner products are those of `V` since `Q` is
//! orthonormal.
//!
//! **Second pass folded into T.** `z₁` lies almost wholly in the span of `Q` once the space
//! has converged, so Gram–Schmidt against `Q` always takes two passes
//! ([`crate::gram_schmidt::project_out`]): two products `Qᴴ Z` and two updates `Z −= Q P`,
//! each a sweep over all of `Q`. The second update only removes round-off, `P₂ = Qᴴ z′` of
//! size ε‖z₁‖, and is left out: `Q` is held as `S T`, with `S` storing the once-projected
//! remainders and `T` upper triangular, so that a new column is `q = s − Q_old a` (`T`'s column
//! `e − T_old a`) with `a = Q_oldᴴ s` carried through the block's own Gram–Schmidt by the same
//! recurrence as its coefficients. Inner products and norms of the new columns then differ
//! from those of the stored ones by `‖a‖²`, below round-off while `‖a‖ ≤ 1e-8` (larger ones,
//! after a near-total cancellation, are applied in full). Every product with `Q` costs a small
//! one with `T` (`r² b` against `m r b`). What remains is one sweep for `P₁`, and one that
//! updates `Z` and projects it again strip by strip while each strip of `S` is in cache
//! ([`crate::tall::subtract_then_adjoint_times`]).

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Mat, MatMut, MatRef, Par, c64};

use crate::gram_schmidt::{column_norm, project_out};
use crate::rng::SplitMix64;
use crate::tall::{add_times, adjoint_times, subtract_then_adjoint_times};

/// The first-half basis `Q` of the two-level representation (module doc), held as `Q = S T`:
/// `S` stores one column per direction, `T` (upper triangular, `I` to within the size of the
/// second Gram–Schmidt pass's corrections) finishes that pass without a sweep over `S`.
pub struct HalfBasis {
    S: Mat<c64>,
    T: Mat<c64>,
    /// Columns in use.
    rank: usize,
    par: Par,
}

/// The largest correction `‖a‖` (module doc, "Second pass folded into T") left to `T`: its
/// square, which the new column's norm and its inner products with the others ignore, is
/// below round-off.
const FOLDED_CORRECTION: f64 = 1e-8;

impl HalfBasis {
    /// An empty basis with room for `capacity` columns of length `rows`.
    pub fn new(rows: usize, capacity: usize, par: Par) -> HalfBasis {
        HalfBasis {
            S: Mat::zeros(rows, capacity),
            T: Mat::zeros(capacity, capacity),
            rank: 0,
            par,
        }
    }

    pub fn capacity(&self) -> usize {
        self.S.ncols()
    }

    /// Columns in use.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// `T[..r, ..r] C` for coordinates `C` over the first `r` columns of `Q`.
    fn stored_coordinates(&self, C: MatRef<'_, c64>) -> Mat<c64> {
        let r = C.nrows();
        let mut product = Mat::<c64>::zeros(r, C.ncols());
        triangular::matmul(
            product.as_mut(),
            BlockStructure::Rectangular,
            Accum::Replace,
            self.T.submatrix(0, 0, r, r),
            BlockStructure::UnitTriangularUpper,
            C,
            BlockStructure::Rectangular,
            c64::new(1.0, 0.0),
            self.par,
        );
        product
    }

    /// `Qᴴ W` over the first `r` columns of `Q`.
    pub fn adjoint_times(&self, r: usize, W: MatRef<'_, c64>) -> Mat<c64> {
        self.adjoint_of_stored(adjoint_times(self.S.subcols(0, r), W, self.par))
    }

    /// `Z −= Q C`, then `Qᴴ Z` of the result, in one sweep over `S`
    /// ([`subtract_then_adjoint_times`]).
    pub fn subtract_then_adjoint_times(&self, Z: MatMut<'_, c64>, C: MatRef<'_, c64>) -> Mat<c64> {
        let stored = self.stored_coordinates(C);
        let raw =
            subtract_then_adjoint_times(Z, self.S.subcols(0, C.nrows()), stored.as_ref(), self.par);
        self.adjoint_of_stored(raw)
    }

    /// `Qᴴ W = Tᴴ Sᴴ W` from `raw = Sᴴ W` (over the first `raw.nrows()` columns).
    fn adjoint_of_stored(&self, raw: Mat<c64>) -> Mat<c64> {
        let r = raw.nrows();
        let mut product = Mat::<c64>::zeros(r, raw.ncols());
        triangular::matmul(
            product.as_mut(),
            BlockStructure::Rectangular,
            Accum::Replace,
            self.T.submatrix(0, 0, r, r).adjoint(),
            BlockStructure::UnitTriangularLower,
            raw.as_ref(),
            BlockStructure::Rectangular,
            c64::new(1.0, 0.0),
            self.par,
        );
        product
    }

    /// `X += Q C` for coordinates `C` over the first `C.nrows()` columns of `Q`.
    pub fn add_times(&self, X: MatMut<'_, c64>, C: MatRef<'_, c64>) {
        let stored = self.stored_coordinates(C);
        add_times(X, self.S.subcols(0, C.nrows()), stored.as_ref(), self.par);
    }

    /// `Q[:, ..rank] C`, for coordinates `C` over the first `rank` columns.
    pub fn expand(&self, C: MatRef<'_, c64>) -> Mat<c64> {
        let mut X = Mat::<c64>::zeros(self.S.nrows(), C.ncols());
        self.add_times(X.as_mut(), C);
        X
    }

    /// Expresses the columns of `Z` in `Q`, adding the directions it lacks: returns `C` with
    /// `Z = Q[:, ..rank] C` (the new rank). A column whose remainder is at round-off level
    /// (or with no room left) adds nothing.
    pub fn extend(&mut self, mut Z: Mat<c64>) -> Mat<c64> {
        let (b, old) = (Z.ncols(), self.rank);
        let original: Vec<f64> = (0..b).map(|j| column_norm(Z.as_ref(), j)).collect();
        let mut coefficients = Mat::<c64>::zeros(old + b, b);
        // Classical Gram–Schmidt twice against Q (see `project_out`), the second update
        // `Z −= Q P₂` left out: its corrections go into T as each column is added.
        let mut pending = Mat::<c64>::zeros(old, b);
        if old > 0 {
            let first = self.adjoint_times(old, Z.as_ref());
            pending = self.subtract_then_adjoint_times(Z.as_mut(), first.as_ref());
            coefficients
                .submatrix_mut(0, 0, old, b)
                .copy_from(&first + &pending);
        }
        // a_i: the components along the old Q of the stored new columns.
        let mut corrections: Vec<Mat<c64>> = Vec::new();
        for j in 0..b {
            let mut column = Z.subcols(j, 1).to_owned();
            let added = self.rank - old;
            let within = project_out(self.S.subcols(old, added), &mut column, self.par);
            let mut correction = pending.subcols(j, 1).to_owned();
            for i in 0..added {
                coefficients[(old + i, j)] = within[(i, 0)];
                correction -= &corrections[i] * faer::Scale(within[(i, 0)]);
            }
            let norm = column_norm(column.as_ref(), 0);
            if !(norm > 1e-12 * original[j] && norm > 0.0 && self.rank < self.capacity()) {
                continue;
            }
            let mut correction = correction * faer::Scale(c64::new(1.0 / norm, 0.0));
            let mut norm = norm;
            if correction.norm_l2() > FOLDED_CORRECTION {
                // Too large to leave to T: the update is made in full on this column.
                self.add_times(
                    column.as_mut(),
                    (&correction * faer::Scale(c64::new(-norm, 0.0))).as_ref(),
                );
                correction.fill(c64::new(0.0, 0.0));
                norm = column_norm(column.as_ref(), 0);
            }
            let r = self.rank;
            for row in 0..self.S.nrows() {
                self.S[(row, r)] = column[(row, 0)] / norm;
            }
            // q_r = s_r − Q_old a_r = S (e_r − T_old a_r).
            let folded = self.stored_coordinates(correction.as_ref());
            for i in 0..old {
                self.T[(i, r)] = -folded[(i, 0)];
            }
            self.T[(r, r)] = c64::new(1.0, 0.0);
            coefficients[(r, j)] = c64::new(norm, 0.0);
            corrections.push(correction);
            self.rank += 1;
        }
        coefficients.subrows(0, self.rank).to_owned()
    }

    /// Adds a random direction orthogonal to `Q`, for room when the Krylov space is exhausted.
    pub fn add_random(&mut self, random: &mut SplitMix64) {
        self.extend(random.complex_block(self.S.nrows(), 1));
    }

    /// `Q[:, ..rank]` in full (for checks; the products above never form it).
    pub fn basis(&self) -> Mat<c64> {
        self.expand(Mat::<c64>::identity(self.rank, self.rank).as_ref())
    }
}

/// Coordinates `[C₁ C₂]` (rank × 2b, the halves side by side) interleaved into the layout of
/// `U`: rows 2i and 2i + 1 hold row i of `C₁` and `C₂`.
pub fn interleave(C: MatRef<'_, c64>, b: usize) -> Mat<c64> {
    Mat::from_fn(2 * C.nrows(), b, |row, j| C[(row / 2, j + (row % 2) * b)])
}

/// The inverse of [`interleave`]: `[U₁ U₂]` (rank × 2b) from interleaved rows.
pub fn deinterleave(U: MatRef<'_, c64>) -> Mat<c64> {
    let b = U.ncols();
    Mat::from_fn(U.nrows() / 2, 2 * b, |i, j| U[(2 * i + j / b, j % b)])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks that lie almost wholly in the basis, as Krylov blocks do once the space has
    /// converged: with remainders of 1e-6 the second pass's corrections are folded into T,
    /// with 1e-11 they are too large for that (1e-16 / 1e-11) and are made in full. Either
    /// way the basis stays orthonormal and reproduces each block from its coefficients.
    #[test]
    fn the_half_basis_stays_orthonormal_with_its_second_pass_folded_into_t() {
        let (rows, b) = (3000, 8);
        let mut random = SplitMix64::new(11);
        for (remainder, folded) in [(1e-6, true), (1e-11, false)] {
            let mut half = HalfBasis::new(rows, 40 + 3 * b, crate::par());
            half.extend(random.complex_block(rows, 40));
            for _ in 0..3 {
                let basis = half.basis();
                let mixture = random.complex_block(half.rank, b);
                let Z = &basis * &mixture
                    + random.complex_block(rows, b) * faer::Scale(c64::new(remainder, 0.0));
                let coefficients = half.extend(Z.clone());
                let rebuilt = half.expand(coefficients.as_ref());
                let error = (&rebuilt - &Z).norm_max() / Z.norm_max();
                assert!(
                    error < 1e-13,
                    "Q C ≠ Z: {error:.1e} (remainder {remainder:.0e})"
                );
            }
            assert_eq!(half.rank, 40 + 3 * b);
            let basis = half.basis();
            let gram = basis.adjoint() * &basis;
            let off = (&gram - Mat::<c64>::identity(half.rank, half.rank)).norm_max();
            assert!(
                off < 1e-13,
                "basis not orthonormal: {off:.1e} (remainder {remainder:.0e})"
            );
            let strictly_upper = (0..half.rank)
                .flat_map(|j| (0..j).map(move |i| (i, j)))
                .map(|(i, j)| half.T[(i, j)].norm())
                .fold(0.0f64, f64::max);
            assert_eq!(
                strictly_upper > 0.0,
                folded,
                "T off its diagonal: {strictly_upper:.1e} (remainder {remainder:.0e})"
            );
        }
    }
}
