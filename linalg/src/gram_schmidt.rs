//! Gram–Schmidt: classical, twice where it must be.
//!
//! Against a tall orthonormal basis (the Krylov bases), classical Gram–Schmidt is a pair of
//! tall products ([`crate::tall`]) per pass, matrix–matrix rather than vector by vector. One
//! pass is not enough after a large cancellation in floating point; a second follows unless no
//! column lost more than `1 − 1/√2` of its norm (Daniel–Gragg–Kaufman–Stewart).
//!
//! The real Lanczos basis is orthonormal in the `M` inner product, with `M V` kept beside `V`:
//! its blocks are made orthonormal by Cholesky QR, twice, after the same projections
//! (`orthonormalize_block`), column by column where the Krylov space has become invariant.
//!
//! [`MSpan`] grows an `M`-orthonormal basis from given vectors (a reduction basis), keeping a
//! vector only when enough of it lies outside the span so far: the span's rank is decided
//! vector by vector, against a norm the caller states.

use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, MatRef, Par, c64};

use crate::Error;
use crate::csc::{CscMatrix, symmetric_mul};
use crate::dense::{select_columns, symmetrised};
use crate::rng::SplitMix64;
use crate::tall::{add_product, add_times, adjoint_times, times, transpose_times};

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

/// A column whose norm falls below this fraction of its norm on entry, after projection on
/// the basis, lies in the span of the basis (to roundoff): the Krylov space is invariant there.
const DEPENDENT_NORM_DROP: f64 = 1e-13;
/// Daniel–Gragg–Kaufman–Stewart: project again where a pass left less than this fraction.
const REORTHOGONALIZE_BELOW: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// `M`-orthonormal vectors `Q` with their products `M Q`.
#[derive(Clone, Copy)]
pub(crate) struct Orthonormal<'a> {
    pub(crate) vectors: MatRef<'a, f64>,
    pub(crate) M_vectors: MatRef<'a, f64>,
}

/// `W ← W − Q ((M Q)ᵀ W)`; returns the coefficients `(M Q)ᵀ W`.
fn project(W: &mut Mat<f64>, basis: Orthonormal<'_>) -> Mat<f64> {
    let coefficients = transpose_times(basis.M_vectors, W.as_ref());
    if basis.vectors.ncols() > 0 {
        add_product(W.as_mut(), basis.vectors, coefficients.as_ref(), -1.0);
    }
    coefficients
}

fn column_norms(W: &Mat<f64>) -> Vec<f64> {
    (0..W.ncols()).map(|j| W.col(j).norm_l2()).collect()
}

/// Projects `W` out of `others` and of `basis` (whose coefficients are returned, for the
/// projected operator), with passes repeated per the DGKS test. `local` (the last blocks of
/// `basis`) goes first.
fn reorthogonalize(
    W: &mut Mat<f64>,
    others: &[Orthonormal<'_>],
    basis: Orthonormal<'_>,
    local_start: usize,
) -> Mat<f64> {
    let p = W.ncols();
    let m = basis.vectors.ncols();
    let mut coefficients = Mat::<f64>::zeros(m, p);
    if m > local_start {
        let local = Orthonormal {
            vectors: basis.vectors.subcols(local_start, m - local_start),
            M_vectors: basis.M_vectors.subcols(local_start, m - local_start),
        };
        let H = project(W, local);
        coefficients
            .as_mut()
            .subrows_mut(local_start, m - local_start)
            .copy_from(&H);
    }
    for _ in 0..3 {
        let before = column_norms(W);
        for other in others {
            if other.vectors.ncols() > 0 {
                project(W, *other);
            }
        }
        if m > 0 {
            coefficients += project(W, basis);
        }
        let after = column_norms(W);
        let repeat = before
            .iter()
            .zip(&after)
            .any(|(before, after)| *after < REORTHOGONALIZE_BELOW * before);
        if !repeat {
            break;
        }
    }
    coefficients
}

/// `M`-orthonormal QR `W = Q R` by Cholesky QR, twice, from `M W`; updates both in place.
/// `None` if the columns are (nearly) dependent on each other.
fn cholesky_qr2(W: &mut Mat<f64>, MW: &mut Mat<f64>, par: Par) -> Option<Mat<f64>> {
    let p = W.ncols();
    let mut R = Mat::<f64>::identity(p, p);
    for _ in 0..2 {
        let G = symmetrised(transpose_times(W.as_ref(), MW.as_ref()).as_ref());
        let norms: Vec<f64> = (0..p).map(|j| G[(j, j)].max(0.0).sqrt()).collect();
        if norms.iter().any(|norm| !(*norm > 0.0)) {
            return None;
        }
        // Cholesky of the scaled Gram matrix: its pivots measure the columns' independence.
        let G_scaled = Mat::from_fn(p, p, |i, j| G[(i, j)] / (norms[i] * norms[j]));
        let L_scaled = G_scaled.as_ref().llt(faer::Side::Lower).ok()?;
        let L_scaled = L_scaled.L();
        if (0..p).any(|j| !(L_scaled[(j, j)] * L_scaled[(j, j)] > 1e-10)) {
            return None;
        }
        // G = N Ĝ N with N = diag(norms), so L = N L̂; then W ← W L⁻ᵀ and M W ← M W L⁻ᵀ.
        let L = Mat::from_fn(p, p, |i, j| norms[i] * L_scaled[(i, j)]);
        let mut L_inverse = Mat::<f64>::identity(p, p);
        solve_lower_triangular_in_place(L.as_ref(), L_inverse.as_mut(), par);
        *W = times(W.as_ref(), L_inverse.as_ref().transpose());
        *MW = times(MW.as_ref(), L_inverse.as_ref().transpose());
        R = L.transpose() * &R;
    }
    Some(R)
}

/// Column-by-column `M`-orthonormalisation that replaces dependent columns by random vectors
/// orthogonal to everything (their column of `R` is zero on the diagonal): the rare path when
/// the Krylov space has (nearly) become invariant. Returns `M W` and `R`.
fn orthonormalize_columnwise(
    W: &mut Mat<f64>,
    bases: &[Orthonormal<'_>],
    M: &CscMatrix,
    entry_norms: &[f64],
    random: &mut SplitMix64,
) -> Result<(Mat<f64>, Mat<f64>), Error> {
    let (n, p) = (W.nrows(), W.ncols());
    let mut R = Mat::<f64>::zeros(p, p);
    let mut MW = Mat::<f64>::zeros(n, p);
    for c in 0..p {
        let mut column = select_columns(W.as_ref(), &[c]);
        let previous = Orthonormal {
            vectors: W.as_ref().subcols(0, c),
            M_vectors: MW.as_ref().subcols(0, c),
        };
        for _ in 0..2 {
            let H = project(&mut column, previous);
            for r in 0..c {
                R[(r, c)] += H[(r, 0)];
            }
        }
        let mut M_column = symmetric_mul(M, column.as_ref());
        let mut norm = dot(column.col(0), M_column.col(0)).max(0.0).sqrt();
        if norm > DEPENDENT_NORM_DROP * entry_norms[c] && norm > 0.0 {
            R[(c, c)] = norm;
        } else {
            // Dependent: continue the recursion in a fresh direction.
            column = random.block(n, 1);
            for _ in 0..2 {
                for basis in bases.iter().chain([&previous]) {
                    if basis.vectors.ncols() > 0 {
                        project(&mut column, *basis);
                    }
                }
            }
            M_column = symmetric_mul(M, column.as_ref());
            norm = dot(column.col(0), M_column.col(0)).max(0.0).sqrt();
            if !(norm > 1e-8 * column.col(0).norm_l2()) {
                return Err(Error::NotConverged(format!(
                    "Lanczos: the Krylov space is exhausted ({n} DOFs): no new direction is M-orthogonal to the basis"
                )));
            }
            R[(c, c)] = 0.0;
        }
        for i in 0..n {
            W[(i, c)] = column[(i, 0)] / norm;
            MW[(i, c)] = M_column[(i, 0)] / norm;
        }
    }
    Ok((MW, R))
}

/// What [`orthonormalize_block`] gives besides the orthonormal block `W_out`:
/// `W_in = others · (…) + basis · coefficients + W_out R`.
pub(crate) struct Orthonormalized {
    pub(crate) M_vectors: Mat<f64>,
    pub(crate) coefficients: Mat<f64>,
    pub(crate) R: Mat<f64>,
}

/// Makes `W` `M`-orthonormal and `M`-orthogonal to `others` and `basis`.
pub(crate) fn orthonormalize_block(
    W: &mut Mat<f64>,
    others: &[Orthonormal<'_>],
    basis: Orthonormal<'_>,
    local_start: usize,
    M: &CscMatrix,
    random: &mut SplitMix64,
    par: Par,
) -> Result<Orthonormalized, Error> {
    let entry_norms = column_norms(W);
    let coefficients = reorthogonalize(W, others, basis, local_start);
    let remaining = column_norms(W);
    let independent = remaining
        .iter()
        .zip(&entry_norms)
        .all(|(after, before)| *after > DEPENDENT_NORM_DROP * before);
    if independent {
        let saved = W.clone();
        let mut MW = symmetric_mul(M, W.as_ref());
        if let Some(R) = cholesky_qr2(W, &mut MW, par) {
            return Ok(Orthonormalized {
                M_vectors: MW,
                coefficients,
                R,
            });
        }
        *W = saved;
    }
    let mut all: Vec<Orthonormal<'_>> = others.to_vec();
    all.push(basis);
    let M_entry = symmetric_mul(M, W.as_ref());
    let entry_M_norms: Vec<f64> = (0..W.ncols())
        .map(|j| {
            dot(W.col(j), M_entry.col(j))
                .max(0.0)
                .sqrt()
                .max(f64::MIN_POSITIVE)
        })
        .zip(&entry_norms)
        .zip(&remaining)
        // Scale the reference so the dependence test compares against the norm on entry.
        .map(|((m_norm, entry), after)| m_norm * entry / after.max(f64::MIN_POSITIVE))
        .collect();
    let (MW, R) = orthonormalize_columnwise(W, &all, M, &entry_M_norms, random)?;
    Ok(Orthonormalized {
        M_vectors: MW,
        coefficients,
        R,
    })
}

/// Candidates are projected and tested this many at a time.
const SPAN_BLOCK: usize = 32;
/// Projections of one candidate at most.
const MAX_PASSES: usize = 5;

/// An `M`-orthonormal basis `Q` (`Qᵀ M Q = I`) with `M Q` beside it.
pub struct MSpan {
    vectors: Mat<f64>,
    M_vectors: Mat<f64>,
    len: usize,
}

impl MSpan {
    /// An empty span in `n` dimensions with room for `capacity` vectors.
    pub fn with_capacity(n: usize, capacity: usize) -> MSpan {
        MSpan {
            vectors: Mat::zeros(n, capacity),
            M_vectors: Mat::zeros(n, capacity),
            len: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The orthonormal vectors.
    pub fn vectors(&self) -> MatRef<'_, f64> {
        self.vectors.as_ref().subcols(0, self.len)
    }

    /// `M` times the vectors.
    pub fn M_vectors(&self) -> MatRef<'_, f64> {
        self.M_vectors.as_ref().subcols(0, self.len)
    }

    /// Adds the candidates (columns, in order), each projected `M`-orthogonally out of the
    /// span so far (classical Gram–Schmidt, twice) and kept, normalised, when the `M`-norm left
    /// is at least `tolerance × reference_norms[j]`. `M_candidates`: `M` times the candidates.
    /// Returns that norm over the reference for every candidate, kept or not.
    pub fn extend(
        &mut self,
        M: &CscMatrix,
        candidates: MatRef<'_, f64>,
        M_candidates: MatRef<'_, f64>,
        reference_norms: &[f64],
        tolerance: f64,
    ) -> Vec<f64> {
        assert_eq!(candidates.ncols(), reference_norms.len());
        assert_eq!(candidates.shape(), M_candidates.shape());
        let mut remaining = Vec::with_capacity(candidates.ncols());
        let mut first = 0;
        while first < candidates.ncols() {
            let width = SPAN_BLOCK.min(candidates.ncols() - first);
            let mut X = candidates.subcols(first, width).to_owned();
            let mut MX = M_candidates.subcols(first, width).to_owned();
            for _ in 0..2 {
                if self.len > 0 {
                    let coefficients = transpose_times(self.M_vectors(), X.as_ref());
                    add_product(X.as_mut(), self.vectors(), coefficients.as_ref(), -1.0);
                    add_product(MX.as_mut(), self.M_vectors(), coefficients.as_ref(), -1.0);
                }
            }
            let block_start = self.len;
            for j in 0..width {
                let mut x = X.col(j).to_owned();
                let mut Mx = MX.col(j).to_owned();
                let mut norm = dot(x.as_ref(), Mx.as_ref()).max(0.0).sqrt();
                // Twice against the block's vectors; again, against every vector, while a pass
                // still removes more than 1 − 1/√2 of what is left (DGKS): a vector mostly in
                // the span keeps the round-off of its projections, which normalising magnifies.
                for pass in 0..MAX_PASSES {
                    let before = norm;
                    let from = if pass < 2 { block_start } else { 0 };
                    for k in from..self.len {
                        let coefficient = dot(self.M_vectors.col(k), x.as_ref());
                        x -= faer::Scale(coefficient) * self.vectors.col(k);
                        Mx -= faer::Scale(coefficient) * self.M_vectors.col(k);
                    }
                    norm = dot(x.as_ref(), Mx.as_ref()).max(0.0).sqrt();
                    if pass >= 1 && norm >= REORTHOGONALIZE_BELOW * before {
                        break;
                    }
                }
                if norm >= tolerance * reference_norms[first + j] && norm > 0.0 {
                    // `M x` carried through the projections keeps the round-off of the
                    // cancelled parts: a kept vector gets its own product.
                    let fresh = symmetric_mul(M, x.as_mat());
                    Mx.copy_from(fresh.col(0));
                    norm = dot(x.as_ref(), Mx.as_ref()).max(0.0).sqrt();
                }
                let ratio = norm / reference_norms[first + j];
                remaining.push(ratio);
                if ratio >= tolerance && norm > 0.0 {
                    if self.len == self.vectors.ncols() {
                        let grown = (2 * self.len).max(SPAN_BLOCK);
                        self.vectors
                            .resize_with(self.vectors.nrows(), grown, |_, _| 0.0);
                        self.M_vectors
                            .resize_with(self.vectors.nrows(), grown, |_, _| 0.0);
                    }
                    self.vectors
                        .col_mut(self.len)
                        .copy_from(faer::Scale(1.0 / norm) * &x);
                    self.M_vectors
                        .col_mut(self.len)
                        .copy_from(faer::Scale(1.0 / norm) * &Mx);
                    self.len += 1;
                }
            }
            first += width;
        }
        remaining
    }
}

/// `xᵀ y` of two columns.
fn dot(x: faer::ColRef<'_, f64>, y: faer::ColRef<'_, f64>) -> f64 {
    x.iter().zip(y.iter()).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::toar::HalfBasis;

    /// Gram–Schmidt twice on a tall basis, over several row chunks, for vectors that lie
    /// almost wholly in its span (the case it is made for): the remainder must be orthogonal to
    /// the basis to round-off, and basis times coefficients plus remainder must give back the
    /// vectors.
    /// A span grown from vectors with exact and near dependences: `M`-orthonormal to
    /// round-off, the rank decided by the tolerance, and spanning every kept candidate.
    #[test]
    fn a_span_drops_dependent_vectors_and_is_M_orthonormal() {
        let n = 3000;
        // A diagonal mass matrix with entries spread over three decades.
        let M = CscMatrix {
            n_rows: n,
            n_cols: n,
            col_ptr: (0..=n).collect(),
            row_idx: (0..n).collect(),
            values: (0..n)
                .map(|i| 10f64.powf(3.0 * i as f64 / n as f64))
                .collect(),
        };
        let mut random = SplitMix64::new(3);
        let independent = random.block(n, 50);
        // Columns 50..70: combinations of the first 50; 70..80: the same plus 1e-3 of noise.
        let mixture = random.block(50, 30);
        let mut candidates = Mat::<f64>::zeros(n, 80);
        candidates
            .as_mut()
            .subcols_mut(0, 50)
            .copy_from(&independent);
        let combined = &independent * &mixture;
        candidates.as_mut().subcols_mut(50, 30).copy_from(&combined);
        let noise = random.block(n, 10);
        for j in 0..10 {
            let scale = 1e-3 * combined.col(20 + j).norm_l2() / noise.col(j).norm_l2();
            let column = combined.col(20 + j) + faer::Scale(scale) * noise.col(j);
            candidates.col_mut(70 + j).copy_from(&column);
        }
        let M_candidates = symmetric_mul(&M, candidates.as_ref());
        let norms: Vec<f64> = (0..80)
            .map(|j| dot(candidates.col(j), M_candidates.col(j)).sqrt())
            .collect();
        let mut span = MSpan::with_capacity(n, 8);
        let remaining = span.extend(&M, candidates.as_ref(), M_candidates.as_ref(), &norms, 1e-6);
        assert_eq!(span.len(), 60, "50 independent + 10 noisy: {remaining:?}");
        assert!(remaining[50..70].iter().all(|&r| r < 1e-12));
        assert!(remaining[70..].iter().all(|&r| r > 1e-5 && r < 1e-2));
        let Q = span.vectors();
        let gram = Q.transpose() * symmetric_mul(&M, Q);
        let off = (&gram - Mat::<f64>::identity(60, 60)).norm_max();
        assert!(off < 1e-13, "QᵀMQ − I = {off:.1e}");
        // Every candidate lies in the span: its M-orthogonal projection gives it back.
        let coefficients = span.M_vectors().transpose() * &candidates;
        let error = (Q * &coefficients - &candidates).norm_max() / candidates.norm_max();
        assert!(error < 1e-12, "candidates outside the span: {error:.1e}");
        // A tolerance above the noise keeps the 50 only.
        let mut strict = MSpan::with_capacity(n, 80);
        strict.extend(&M, candidates.as_ref(), M_candidates.as_ref(), &norms, 1e-2);
        assert_eq!(strict.len(), 50);
    }

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
