//! Every eigenvalue of the sliding problem in a frequency band: shift-invert block Arnoldi at
//! shifts placed along the imaginary axis until their trusted disks cover the band.
//!
//! # One shift
//!
//! The quadratic problem is linearised on `y = [q; λ q / s]` (first companion form, with
//! `s = √(‖K̃‖/‖M̃‖)` so that both halves of y have the same scale),
//!
//! ```text
//! [ 0   s I ] y = λ [ I  0  ] y          Op = (𝒜 − σ ℬ)⁻¹ ℬ,   θ = 1 / (λ − σ)
//! [ −K̃ −s C̃ ]       [ 0  s M̃ ]
//! Op [x₁; x₂] = [z₁; (x₁ + σ z₁)/s],   z₁ = −Q̃(σ)⁻¹ (M̃ (s x₂ + σ x₁) + C̃ x₁)
//! ```
//!
//! so each step costs one solve with `Q̃(σ)` ([`super::shift_invert`]). Block Arnoldi with full
//! Gram–Schmidt builds `Op V = V H + V₊ R Eᵀ`; the Ritz pairs `(θ, V s)` of `H` have Arnoldi
//! residuals `‖R s_last‖`. Eigenvalues nearest σ converge first.
//!
//! **Two-level basis** (TOAR, Su, Zhang & Bai 2008). The second half of `Op y` is a
//! combination of `x₁` and `z₁`, so the halves of every basis vector lie in the span of one
//! orthonormal `Q` (`m` rows) that grows by the new `z₁` alone: `V = [Q U₁; Q U₂]`. Only `Q` is
//! stored in full, at half the size of `V`; each step orthogonalises `z₁` against `Q` (vectors
//! of length `m`, not `2m`), and the Arnoldi Gram–Schmidt runs on the small coordinates
//! `[U₁; U₂]`, whose inner products are those of `V` since `Q` is orthonormal.
//!
//! **Second pass folded into T.** `z₁` lies almost wholly in the span of `Q` once the space
//! has converged, so Gram–Schmidt against `Q` always takes two passes (`project_out`): two
//! products `Qᴴ Z` and two updates `Z −= Q P`, each a sweep over all of `Q`. The second
//! update only removes round-off, `P₂ = Qᴴ z′` of size ε‖z₁‖, and is left out: `Q` is held as
//! `S T`, with `S` storing the once-projected remainders and `T` upper triangular, so that a
//! new column is `q = s − Q_old a` (`T`'s column `e − T_old a`) with `a = Q_oldᴴ s` carried
//! through the block's own Gram–Schmidt by the same recurrence as its coefficients. Inner
//! products and norms of the new columns then differ from those of the stored ones by `‖a‖²`,
//! below round-off while `‖a‖ ≤ 1e-8` (larger ones, after a near-total cancellation, are
//! applied in full). Every product with `Q` costs a small one with `T` (`r² b` against
//! `m r b`); the orthogonalisation of the default brake's 17 kHz band took 35.8 s instead of
//! 45.7 s, the band 152.4 s instead of 160.7 s (runs one after the other). What remains is one
//! sweep for `P₁`, and one that updates `Z` and projects it again strip by strip while each
//! strip of `S` is in cache ([`squeal_linalg::tall::subtract_then_adjoint_times`]): 25.3 s against
//! 30.1 s, the band 131.8 s against 137.2 s.
//!
//! # Why none is missed
//!
//! A shift's **trusted disk** is `|λ − σ| < ρ`, with ρ the distance to the nearest Ritz value
//! that has *not* converged: every Ritz value inside has converged, and an eigenvalue inside
//! that the Krylov space had not seen at all would have to be orthogonal to a random start
//! block of several vectors. The radius is trusted only once the space has resolved
//! something: after [`MIN_BLOCK_STEPS`] block steps and once the Ritz value nearest σ has
//! converged. Before that, Ritz values lie inside the spectrum's hull and understate how near
//! the nearest eigenvalue is (two steps of a block of 16 claimed a disk 2 kHz wide over 25
//! eigenvalues of the default brake; the μ = 0 test caught the same with blocks of eight and
//! no convergence required). The disks are made to overlap; in each overlap the eigenvalues
//! both shifts found must agree one to one (within the merging tolerance), which a missed
//! eigenvalue would break. Eigenvalues are then kept from the shift whose cell they lie in
//! (cells cut in the middle of each overlap), so none is reported twice.
//!
//! The band is `0 < Im λ ≤ ω_max` with `|2 Re λ / Im λ| ≤ d_max` (divergence rates beyond
//! ±d_max, far from any squeal mode, are not sought). Those damped eigenvalues still have to
//! converge where they lie inside a disk, but they get no eigenvector: a third of the default
//! brake's converged eigenvalues, 4.6 s and 290 MB less on its 17 kHz band.
//!
//! # Cost and spacing
//!
//! A shift costs one factorisation plus a contact correction (a solve with one right-hand
//! side per closed pair), then, per block of b Arnoldi vectors, one solve with b right-hand
//! sides and one orthogonalisation against the basis, which grows with the basis. Ritz values
//! are checked from a small basis on, so that a nearly empty disk stops early, then where the
//! trusted radius's growth predicts the disk is wide enough ([`next_check_at`]). Each shift
//! is placed from the density the previous one met in its upper half, aiming at `per_shift`
//! eigenvalues. Density can grow faster than that estimate allows for (fourfold from 2.6 to
//! 6 kHz on the default brake), so a disk may fall short of the covered band at `max_basis`:
//! it is kept, and a shift halfway below fills the gap, overlapping both. Where the band's
//! wedge `|Re λ| ≤ (d_max/2) Im λ` is nearly as wide as the disks the basis allows, no shift
//! can cover more than a sliver, and the search stops with an error naming both settings. The
//! default brake reaches that point at 11.2 kHz with d_max = 0.2 (disks of 960 vectors, 1.1 kHz
//! radius there), after 3.5 minutes; before, it went on for over 20 minutes, with shifts that
//! each covered about 1 % of the band and silent retries of closer ones. The default d_max is
//! therefore 0.1, which the default brake's 17 kHz band fits (squeal modes lie within a few %:
//! 7.9 % at most on that brake).
//!
//! The solves dominated at first. The factor (26 M entries on the default brake) is swept twice
//! per solve, whatever its width, so wide blocks cost less per vector: with faer's kernels a
//! block of eight cost 18 ms per vector against 38 ms for two (and the orthogonalisation
//! becomes matrix–matrix), so although blocks of eight need about a third more vectors for the
//! same disk, they halved the 17 kHz band of the default brake (407–424 s against 862 s). The
//! row-major kernels of [`squeal_linalg::lblt`] since cut a block of eight to 7 ms per vector; blocks
//! of sixteen still lose (99 s against 90 s on the 8 kHz band). Per vector of that band
//! (1,720), an operator step now takes 7.6 ms to solve, 5.3 ms to rebuild the block from `Q`,
//! 2.6 ms for the contact correction and 2.4 ms for the M̃ and C̃ products; the products with
//! `Q` (rebuilding, Gram–Schmidt, correction) go through the kernels of [`squeal_linalg::tall`]. Wide
//! disks beat narrow ones: factorisations and the overlaps' double work are paid fewer times,
//! and the band's width forces disks of 1 kHz radius at the top anyway. With the present
//! kernels, `per_shift` 320 did the default brake's 17 kHz band in 112.6 and 113.7 s (8
//! shifts, 5,648 vectors), 256 in 114.7 and 115.5 s (9, 6,008), 192 in 119.0 s (9, 6,264).
//! Beyond about 900 vectors, though, the orthogonalisation and the Ritz checks cost more per
//! eigenvalue than another shift would: a disk cut at 960 vectors and completed by a gap shift
//! did the band in 372 s against 379 s for one of 1280, with 120 MB less memory. Cut at 800 it
//! took 288 s against 310 s at 960 (one run each), and 263 s against 275 s in a later pair,
//! where the gap shift grew and the shifts above 6 kHz fell elsewhere (5,808 vectors against
//! 6,008, the same cost per vector): a gain of placement rather than of the cut. At 640 it
//! took 486 s: 8 of 18 disks fell short of the 1 kHz radius the band needs at the top. 960
//! keeps a margin for somewhat wider bands than the default; twice its `max_divergence_rate`
//! (a wedge 1.7 kHz wide at 17 kHz) needs more, as above.

use std::f64::consts::PI;
use std::time::Instant;

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Mat, MatMut, MatRef, Par, c64};

use super::shift_invert::{EmbeddedPattern, ShiftedSolver};
use super::sliding::SlidingSystem;
use crate::stage::StageError;
use squeal_linalg::rng::SplitMix64;
use squeal_linalg::tall::{add_times, adjoint_times, subtract_then_adjoint_times};

/// Block steps before a shift's Ritz values are first examined (module doc, "Why none is
/// missed").
const MIN_BLOCK_STEPS: usize = 6;
/// A disk that falls short with a radius below this multiple of the band's half-width at the
/// height covered so far ends the search with an error (`solve_band`): a shift there could
/// cover only a sliver of the band.
const WEDGE_MARGIN: f64 = 1.05;
/// A Ritz vector's first half is its eigenvector when its residual is below this (round-off is
/// about 1e-15); otherwise the second half is tried too.
const ROUND_OFF_RESIDUAL: f64 = 1e-12;

/// Tuning of [`solve_band`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KrylovOptions {
    pub block_size: usize,
    /// Basis size at which a shift's Ritz values are first examined (at least
    /// [`MIN_BLOCK_STEPS`] blocks), and the most it may grow to.
    pub basis: usize,
    pub max_basis: usize,
    /// Eigenvalues each shift's disk should hold: shifts are spaced by the density the previous
    /// one met. Fewer mean more factorisations, more mean longer orthogonalisations.
    pub per_shift: usize,
    /// Arnoldi residual `‖Op y − θ y‖ / |θ|` below which a Ritz pair has converged.
    pub arnoldi_tolerance: f64,
    /// Largest residual of a reported eigenpair.
    pub residual_tolerance: f64,
    pub par: Par,
}

impl Default for KrylovOptions {
    fn default() -> Self {
        KrylovOptions {
            block_size: 8,
            basis: 32,
            max_basis: 960,
            per_shift: 320,
            arnoldi_tolerance: 1e-10,
            residual_tolerance: 1e-8,
            par: Par::rayon(0),
        }
    }
}

/// An eigenpair of the sliding problem: λ and q over the reduced DOFs.
#[derive(Debug, Clone)]
pub struct EigenPair {
    pub lambda: c64,
    pub q: Vec<c64>,
    pub residual: f64,
}

/// What a band solve did, shift by shift.
#[derive(Debug, Clone, Default)]
pub struct BandReport {
    /// Per shift: frequency (Hz), trusted radius (rad/s), basis size, eigenvalues kept.
    pub shifts: Vec<ShiftReport>,
    pub factor_entries: usize,
    /// Shifts whose disk fell short at the basis limit and was kept, a shift below filling
    /// the gap (module doc, "Cost and spacing").
    pub fell_short: usize,
    pub seconds_factor: f64,
    pub seconds_arnoldi: f64,
}

#[derive(Debug, Clone, Default)]
pub struct ShiftReport {
    pub frequency_hz: f64,
    pub radius: f64,
    pub basis: usize,
    pub found: usize,
    pub kept: usize,
    /// Eigenvalues in the overlap with the previous shift found by both.
    pub overlap_matched: usize,
    pub seconds: ShiftSeconds,
}

/// Wall time of a shift's phases (s).
#[derive(Debug, Clone, Copy, Default)]
pub struct ShiftSeconds {
    /// Factorisation and contact correction.
    pub factor: f64,
    /// Each block rebuilt from `Q` and put through the operator (the solves).
    pub operator: f64,
    /// Gram–Schmidt of z₁ against `Q` and of the coordinates.
    pub orthogonalisation: f64,
    /// Eigenvalues of the Arnoldi matrix and their convergence checks.
    pub ritz: f64,
    /// Eigenvectors and their residuals.
    pub vectors: f64,
}

/// The shift-invert operator on the linearisation.
struct Operator<'a> {
    system: &'a SlidingSystem,
    solver: ShiftedSolver<'a>,
    /// The scale s of the second half of y.
    scale: f64,
}

impl Operator<'_> {
    /// `z₁ = −Q̃(σ)⁻¹ (M̃ (s x₂ + σ x₁) + C̃ x₁)` for the columns of `[X₁; X₂]`: the first half
    /// of `Op [X₁; X₂]`, whose second half is `(X₁ + σ z₁)/s`.
    fn first_half(&self, X1: MatRef<'_, c64>, X2: MatRef<'_, c64>) -> Mat<c64> {
        let (sigma, scale) = (self.solver.sigma, self.scale);
        let shifted = Mat::from_fn(X1.nrows(), X1.ncols(), |i, j| {
            X2[(i, j)] * scale + sigma * X1[(i, j)]
        });
        let rhs = self.system.apply_mass_damping(shifted.as_ref(), X1);
        -self.solver.solve(rhs.as_ref())
    }
}

/// The first-half basis `Q` of the two-level representation (module doc), held as `Q = S T`:
/// `S` stores one column per direction, `T` (upper triangular, `I` to within the size of the
/// second Gram–Schmidt pass's corrections) finishes that pass without a sweep over `S`.
struct HalfBasis {
    S: Mat<c64>,
    T: Mat<c64>,
    /// Columns in use.
    rank: usize,
}

/// The largest correction `‖a‖` (module doc, "Second pass folded into T") left to `T`: its
/// square, which the new column's norm and its inner products with the others ignore, is
/// below round-off.
const FOLDED_CORRECTION: f64 = 1e-8;

impl HalfBasis {
    /// An empty basis with room for `capacity` columns of length `rows`.
    fn new(rows: usize, capacity: usize) -> HalfBasis {
        HalfBasis {
            S: Mat::zeros(rows, capacity),
            T: Mat::zeros(capacity, capacity),
            rank: 0,
        }
    }

    fn capacity(&self) -> usize {
        self.S.ncols()
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
            Par::rayon(0),
        );
        product
    }

    /// `Qᴴ W` over the first `r` columns of `Q`.
    fn adjoint_times(&self, r: usize, W: MatRef<'_, c64>) -> Mat<c64> {
        self.adjoint_of_stored(adjoint_times(self.S.subcols(0, r), W, Par::rayon(0)))
    }

    /// `Z −= Q C`, then `Qᴴ Z` of the result, in one sweep over `S`
    /// ([`subtract_then_adjoint_times`]).
    fn subtract_then_adjoint_times(&self, Z: MatMut<'_, c64>, C: MatRef<'_, c64>) -> Mat<c64> {
        let stored = self.stored_coordinates(C);
        let raw = subtract_then_adjoint_times(
            Z,
            self.S.subcols(0, C.nrows()),
            stored.as_ref(),
            Par::rayon(0),
        );
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
            Par::rayon(0),
        );
        product
    }

    /// `X += Q C` for coordinates `C` over the first `C.nrows()` columns of `Q`.
    fn add_times(&self, X: MatMut<'_, c64>, C: MatRef<'_, c64>) {
        let stored = self.stored_coordinates(C);
        add_times(
            X,
            self.S.subcols(0, C.nrows()),
            stored.as_ref(),
            Par::rayon(0),
        );
    }

    /// `Q[:, ..rank] C`, for coordinates `C` over the first `rank` columns.
    fn expand(&self, C: MatRef<'_, c64>) -> Mat<c64> {
        let mut X = Mat::<c64>::zeros(self.S.nrows(), C.ncols());
        self.add_times(X.as_mut(), C);
        X
    }

    /// Expresses the columns of `Z` in `Q`, adding the directions it lacks: returns `C` with
    /// `Z = Q[:, ..rank] C` (the new rank). A column whose remainder is at round-off level
    /// (or with no room left) adds nothing.
    fn extend(&mut self, mut Z: Mat<c64>) -> Mat<c64> {
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
            let within = project_out(self.S.subcols(old, added), &mut column);
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
    fn add_random(&mut self, random: &mut SplitMix64) {
        self.extend(random_block(self.S.nrows(), 1, random));
    }

    /// `Q[:, ..rank]` in full (for tests).
    #[cfg(test)]
    fn basis(&self) -> Mat<c64> {
        self.expand(Mat::<c64>::identity(self.rank, self.rank).as_ref())
    }
}

/// Removes from `W` its components along the orthonormal columns of `V`; returns the
/// coefficients. A second pass follows unless no column lost more than 1 − 1/√2 of its norm
/// in the first (Daniel–Gragg–Kaufman–Stewart): after a large cancellation one pass is not
/// enough in floating point. (Against the first-half basis the second pass always runs, its
/// update folded into `T`: [`HalfBasis::extend`].) The products go through [`squeal_linalg::tall`].
fn project_out(V: MatRef<'_, c64>, W: &mut Mat<c64>) -> Mat<c64> {
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
        let pass = adjoint_times(V, W.as_ref(), Par::rayon(0));
        add_times(W.as_mut(), V, (-&pass).as_ref(), Par::rayon(0));
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

fn column_norm(W: MatRef<'_, c64>, col: usize) -> f64 {
    W.col(col).iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt()
}

/// Orthonormalises the columns of `W` against `V` and among themselves: `W_in = V H + W_out R`.
/// A column that vanishes (an invariant subspace was found) is replaced by a fresh random
/// direction, with a zero on R's diagonal.
fn orthonormalise(
    V: MatRef<'_, c64>,
    W: &mut Mat<c64>,
    random: &mut SplitMix64,
) -> (Mat<c64>, Mat<c64>) {
    let H = project_out(V, W);
    let b = W.ncols();
    let mut R = Mat::<c64>::zeros(b, b);
    for j in 0..b {
        let before = column_norm(W.as_ref(), j);
        let mut column = W.subcols(j, 1).to_owned();
        let coefficients = project_out(W.subcols(0, j), &mut column);
        for i in 0..j {
            R[(i, j)] = coefficients[(i, 0)];
        }
        let norm = column_norm(column.as_ref(), 0);
        if norm > 1e-10 * before && norm > 0.0 {
            R[(j, j)] = c64::new(norm, 0.0);
        } else {
            column = random_block(W.nrows(), 1, random);
            project_out(V, &mut column);
            project_out(W.subcols(0, j), &mut column);
        }
        let norm = column_norm(column.as_ref(), 0);
        for row in 0..W.nrows() {
            W[(row, j)] = column[(row, 0)] / norm;
        }
    }
    (H, R)
}

/// Coordinates `[C₁ C₂]` (rank × 2b, the halves side by side) interleaved into the layout of
/// `U`: rows 2i and 2i + 1 hold row i of `C₁` and `C₂`.
fn interleave(C: MatRef<'_, c64>, b: usize) -> Mat<c64> {
    Mat::from_fn(2 * C.nrows(), b, |row, j| C[(row / 2, j + (row % 2) * b)])
}

/// The inverse of [`interleave`]: `[U₁ U₂]` (rank × 2b) from interleaved rows.
fn deinterleave(U: MatRef<'_, c64>) -> Mat<c64> {
    let b = U.ncols();
    Mat::from_fn(U.nrows() / 2, 2 * b, |i, j| U[(2 * i + j / b, j % b)])
}

fn random_block(rows: usize, cols: usize, random: &mut SplitMix64) -> Mat<c64> {
    Mat::from_fn(rows, cols, |_, _| {
        c64::new(random.next_signed(), random.next_signed())
    })
}

/// What one shift resolved.
struct ShiftResult {
    sigma: c64,
    radius: f64,
    basis: usize,
    /// Every converged eigenvalue.
    converged: Vec<c64>,
    /// The converged eigenpairs that `wanted` selects, with their vectors.
    pairs: Vec<EigenPair>,
    seconds: ShiftSeconds,
}

/// Block Arnoldi at `sigma` until the trusted radius reaches `radius_needed` (and the basis
/// holds at least `options.basis` vectors); eigenvectors for the converged eigenvalues that
/// `wanted` selects.
fn solve_shift(
    system: &SlidingSystem,
    pattern: &EmbeddedPattern,
    sigma: c64,
    radius_needed: f64,
    wanted: &dyn Fn(c64) -> bool,
    options: &KrylovOptions,
    report: &mut BandReport,
) -> Result<ShiftResult, StageError> {
    let m = system.dim();
    let n = 2 * m;
    let clock = Instant::now();
    let solver = ShiftedSolver::new(pattern, system, sigma, options.par)?;
    let mut seconds = ShiftSeconds {
        factor: clock.elapsed().as_secs_f64(),
        ..ShiftSeconds::default()
    };
    report.seconds_factor += seconds.factor;
    let clock = Instant::now();
    let [M_norm, _, K_norm] = system.norms;
    let scale = (K_norm / M_norm).sqrt();
    let operator = Operator {
        system,
        solver,
        scale,
    };
    let b = options.block_size.max(1).min(n);
    // The basis may not exceed the dimension (less one block, for the residual block).
    let max_basis = (options.max_basis.min(n.saturating_sub(b)) / b * b).max(b);
    let mut random = SplitMix64::new(0x05EE_D0F5_1D1E);
    // Q gains at most one column per Arnoldi vector, after the start block's two halves.
    let mut half = HalfBasis::new(m, (max_basis + 2 * b).min(m));
    // Coordinates, interleaved so that those in use are the leading rows: Arnoldi vector j is
    // [Q u₁; Q u₂] with (u₁)_i = U[2i, j] and (u₂)_i = U[2i + 1, j].
    let mut U = Mat::<c64>::zeros(2 * half.capacity(), max_basis + b);
    let mut H = Mat::<c64>::zeros(max_basis + b, max_basis);
    // A random start block, its two halves side by side.
    let start_coordinates = half.extend(random_block(m, 2 * b, &mut random));
    let mut W = interleave(start_coordinates.as_ref(), b);
    orthonormalise(U.submatrix(0, 0, W.nrows(), 0), &mut W, &mut random);
    U.submatrix_mut(0, 0, W.nrows(), b).copy_from(&W);
    let mut k = b;
    let mut next_check = options.basis.max(MIN_BLOCK_STEPS * b).min(max_basis).max(b);
    // The last check that trusted a radius: (basis, radius).
    let mut previous_check: Option<(usize, f64)> = None;
    loop {
        let phase = Instant::now();
        // Op V[:, k−b..k] = V[:, ..k] H + W R, in coordinates.
        let rank = half.rank;
        let block = U.submatrix(0, k - b, 2 * rank, b);
        let halves = half.expand(deinterleave(block).as_ref());
        let z1 = operator.first_half(halves.subcols(0, b), halves.subcols(b, b));
        seconds.operator += phase.elapsed().as_secs_f64();
        let phase = Instant::now();
        let z_coordinates = half.extend(z1);
        while 2 * half.rank < k + b && half.rank < m {
            half.add_random(&mut random);
        }
        // w₁ = z₁ and w₂ = (x₁ + σ z₁)/s in coordinates.
        let new_rank = half.rank;
        let mut W = Mat::<c64>::from_fn(2 * new_rank, b, |row, j| {
            let i = row / 2;
            let w1 = if i < z_coordinates.nrows() {
                z_coordinates[(i, j)]
            } else {
                c64::new(0.0, 0.0)
            };
            if row % 2 == 0 {
                w1
            } else {
                let x1 = if i < rank {
                    U[(2 * i, k - b + j)]
                } else {
                    c64::new(0.0, 0.0)
                };
                (x1 + sigma * w1) / scale
            }
        });
        let (coefficients, R) =
            orthonormalise(U.submatrix(0, 0, 2 * new_rank, k), &mut W, &mut random);
        H.submatrix_mut(0, k - b, k, b).copy_from(&coefficients);
        H.submatrix_mut(k, k - b, b, b).copy_from(&R);
        U.submatrix_mut(0, k, 2 * new_rank, b).copy_from(&W);
        seconds.orthogonalisation += phase.elapsed().as_secs_f64();
        if k < next_check && k + b <= max_basis {
            k += b;
            continue;
        }
        // Ritz values of the k × k section, nearest σ (largest |θ|) first.
        let phase = Instant::now();
        let eigen = H.submatrix(0, 0, k, k).to_owned().eigen().map_err(|err| {
            StageError::new(format!(
                "dense eigensolver failed on the Arnoldi matrix: {err:?}"
            ))
        })?;
        let theta: Vec<c64> = eigen.S().column_vector().iter().copied().collect();
        let S = eigen.U();
        let residual_block = H.submatrix(k, k - b, b, b);
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &c| theta[c].norm().total_cmp(&theta[a].norm()));
        let mut radius = f64::INFINITY;
        let mut converged = Vec::new();
        for &i in &order {
            let arnoldi_residual =
                column_norm((residual_block * S.submatrix(k - b, i, b, 1)).as_ref(), 0);
            let scale = theta[i].norm() * column_norm(S, i);
            if arnoldi_residual > options.arnoldi_tolerance * scale {
                radius = theta[i].inv().norm();
                let lambda = sigma + theta[i].inv();
                tracing::debug!(
                    "stability: nearest unconverged Ritz value {:.1} Hz (divergence rate {:.2e}), Arnoldi residual {:.1e}",
                    lambda.im / (2.0 * PI),
                    2.0 * lambda.re / lambda.im,
                    arnoldi_residual / scale
                );
                break;
            }
            converged.push(i);
        }
        if converged.is_empty() {
            // Not even the dominant eigenvalue is resolved: the Ritz values say nothing yet.
            radius = 0.0;
        }
        seconds.ritz += phase.elapsed().as_secs_f64();
        tracing::debug!(
            "stability: shift {:.0} Hz, basis {k}, {} converged, trusted radius {:.0} Hz, {:.1} s",
            sigma.im / (2.0 * PI),
            converged.len(),
            radius / (2.0 * PI),
            clock.elapsed().as_secs_f64()
        );
        if radius < radius_needed && k + b <= max_basis {
            next_check = next_check_at(k, radius, previous_check, radius_needed, b);
            if radius > 0.0 {
                previous_check = Some((k, radius));
            }
            k += b;
            continue;
        }
        let phase = Instant::now();
        let eigenvalue = |i: usize| sigma + theta[i].inv();
        // Eigenvectors y = V s, only for the eigenvalues the band reports (the others, damped
        // beyond d_max, only bound the disk): q is either half of y, x₁ or s x₂/λ. The first
        // is kept when its residual is at round-off level, else the better of the two.
        let reported: Vec<usize> = converged
            .iter()
            .copied()
            .filter(|&i| wanted(eigenvalue(i)))
            .collect();
        let selected = Mat::<c64>::from_fn(k, reported.len(), |row, col| S[(row, reported[col])]);
        let coordinates = deinterleave((U.submatrix(0, 0, 2 * half.rank, k) * &selected).as_ref());
        let n_reported = reported.len();
        let first = half.expand(coordinates.subcols(0, n_reported));
        let lambdas: Vec<c64> = reported.iter().map(|&i| eigenvalue(i)).collect();
        let residuals = system.residuals(&lambdas, first.as_ref());
        let mut pairs: Vec<EigenPair> = (0..n_reported)
            .map(|col| EigenPair {
                lambda: lambdas[col],
                q: first.col(col).iter().copied().collect(),
                residual: residuals[col],
            })
            .collect();
        let retry: Vec<usize> = (0..n_reported)
            .filter(|&col| !(pairs[col].residual <= ROUND_OFF_RESIDUAL))
            .collect();
        if !retry.is_empty() {
            let second = Mat::<c64>::from_fn(coordinates.nrows(), retry.len(), |row, j| {
                coordinates[(row, n_reported + retry[j])]
            });
            let mut second = half.expand(second.as_ref());
            for (j, &col) in retry.iter().enumerate() {
                let factor = scale / lambdas[col];
                second
                    .col_mut(j)
                    .iter_mut()
                    .for_each(|value| *value *= factor);
            }
            let retry_lambdas: Vec<c64> = retry.iter().map(|&col| lambdas[col]).collect();
            let residuals = system.residuals(&retry_lambdas, second.as_ref());
            for (j, &col) in retry.iter().enumerate() {
                if residuals[j] < pairs[col].residual {
                    pairs[col].q = second.col(j).iter().copied().collect();
                    pairs[col].residual = residuals[j];
                }
            }
        }
        seconds.vectors = phase.elapsed().as_secs_f64();
        report.seconds_arnoldi += clock.elapsed().as_secs_f64();
        return Ok(ShiftResult {
            sigma,
            radius: 0.99 * radius,
            basis: k,
            converged: converged.iter().map(|&i| eigenvalue(i)).collect(),
            pairs,
            seconds,
        });
    }
}

/// Basis size of a shift's next Ritz check, after one at basis `k` trusted `radius` (0: none
/// yet) short of `needed`. Each check costs an eigensolve of the k × k Arnoldi matrix, and a
/// check late by a quarter of the basis wastes a tenth of the vectors on average. Once the
/// trusted radius has grown between two checks, it grows about linearly with the basis (as
/// many eigenvalues converge per block along a strip of the band), so the next check aims
/// at the basis that extrapolation predicts, a little beyond it, within `k + k/16 ..= 1.5 k`
/// (the growth comes in jumps as clusters converge); before that, checks come every quarter.
fn next_check_at(
    k: usize,
    radius: f64,
    previous: Option<(usize, f64)>,
    needed: f64,
    b: usize,
) -> usize {
    let quarter = k + (k / 4).max(b);
    let Some((previous_k, previous_radius)) = previous else {
        return quarter;
    };
    if radius <= previous_radius {
        return quarter;
    }
    let growth = (radius - previous_radius) / (k - previous_k) as f64;
    let predicted = k as f64 + (1.02 * needed - radius) / growth;
    let aim = predicted
        .clamp((k + (k / 16).max(b)) as f64, 1.5 * k as f64)
        .ceil() as usize;
    aim.div_ceil(b) * b
}

/// Heights y (rad/s) of the band the disk |λ − iω| < r covers: every point with that imaginary
/// part and |Re| ≤ (d_max/2) y is inside.
fn covered(omega: f64, radius: f64, half_rate: f64) -> (f64, f64) {
    let a = 1.0 + half_rate * half_rate;
    let discriminant = omega * omega - a * (omega * omega - radius * radius);
    if discriminant <= 0.0 {
        return (omega, omega);
    }
    let root = discriminant.sqrt();
    ((omega - root) / a, (omega + root) / a)
}

fn in_band(lambda: c64, omega_max: f64, half_rate: f64) -> bool {
    lambda.im > 0.0 && lambda.im <= omega_max && lambda.re.abs() <= half_rate * lambda.im
}

/// All eigenpairs with `0 < Im λ ≤ omega_max` and `|2 Re λ/Im λ| ≤ max_divergence_rate`,
/// ordered by frequency. `progress` receives the fraction of the band covered.
pub fn solve_band(
    system: &SlidingSystem,
    omega_max: f64,
    max_divergence_rate: f64,
    options: &KrylovOptions,
    progress: &dyn Fn(f64),
) -> Result<(Vec<EigenPair>, BandReport), StageError> {
    let half_rate = max_divergence_rate / 2.0;
    let pattern = EmbeddedPattern::new(system)?;
    let mut report = BandReport {
        factor_entries: pattern.factor_len(),
        ..BandReport::default()
    };
    let mut kept: Vec<EigenPair> = Vec::new();
    // The previous shift: its coverage top, its cell's lower cut, the eigenvalues inside its
    // disk and the band's eigenpairs among them.
    let mut previous: Option<(f64, f64, Vec<c64>, Vec<EigenPair>)> = None;
    let mut covered_to = 0.0_f64;
    let mut step = omega_max / 10.0;
    // A shift whose disk fell short of what is covered, kept until a shift below fills the gap.
    let mut pending: Option<ShiftResult> = None;
    while covered_to < omega_max {
        let gap_filled = pending.as_ref().is_some_and(|result| {
            covered(result.sigma.im, result.radius, half_rate).0 <= covered_to
        });
        let result = match pending.take() {
            Some(result) if gap_filled => result,
            short => {
                // Below a shift that fell short, halfway to it: the disk must reach up into
                // it as well as down to what is covered (the origin for the first shift).
                let short_low = short
                    .as_ref()
                    .map(|short| covered(short.sigma.im, short.radius, half_rate).0);
                let omega = match short_low {
                    Some(low) => 0.5 * (covered_to + low),
                    None => (covered_to + step).min(omega_max),
                };
                let height_gap = |y: f64| ((omega - y).powi(2) + (half_rate * y).powi(2)).sqrt();
                let needed = 1.05 * height_gap(covered_to).max(short_low.map_or(0.0, height_gap));
                pending = short;
                solve_shift(
                    system,
                    &pattern,
                    c64::new(0.0, omega),
                    needed,
                    &|lambda| in_band(lambda, omega_max, half_rate),
                    options,
                    &mut report,
                )?
            }
        };
        let omega = result.sigma.im;
        let (low, high) = covered(omega, result.radius, half_rate);
        let reaches = if previous.is_none() {
            result.radius >= omega
        } else {
            low <= covered_to
        };
        if !reaches {
            // The basis limit left the disk too small. Where the band's wedge is about as wide
            // as the disk, no shift can help: every disk must hold the wedge's cross-section
            // at the height covered so far, and barely wider ones would crawl up the band.
            let wedge = half_rate * covered_to;
            if result.radius < WEDGE_MARGIN * wedge {
                return Err(StageError::new(format!(
                    "at {:.0} Hz the band (|divergence rate| ≤ {max_divergence_rate}) reaches ±{:.0} Hz off the frequency axis, and a shift at {:.0} Hz resolves a disk of only {:.0} Hz radius with {} vectors (max_basis), too small to cover more than a sliver of it: lower max_divergence_rate or raise max_basis",
                    covered_to / (2.0 * PI),
                    wedge / (2.0 * PI),
                    omega / (2.0 * PI),
                    result.radius / (2.0 * PI),
                    result.basis
                )));
            }
            // Otherwise keep it, and fill the gap below it with a shift halfway; if that one
            // falls short too (or this is the first shift), start over closer.
            if step < 1e-4 * omega_max {
                return Err(StageError::new(format!(
                    "the shift at {:.1} Hz trusts only a radius of {:.1} Hz with {} vectors: raise max_basis",
                    omega / (2.0 * PI),
                    result.radius / (2.0 * PI),
                    result.basis
                )));
            }
            if previous.is_some() && pending.is_none() && low < high {
                tracing::info!(
                    "stability: shift at {:.0} Hz fell short ({} vectors, trusted radius {:.0} Hz); a shift below fills the gap",
                    omega / (2.0 * PI),
                    result.basis,
                    result.radius / (2.0 * PI)
                );
                report.fell_short += 1;
                pending = Some(result);
            } else {
                step = 0.5 * (omega - covered_to);
                pending = None;
                tracing::info!(
                    "stability: shift at {:.0} Hz fell short ({} vectors, trusted radius {:.0} Hz); starting over closer, at {:.0} Hz",
                    omega / (2.0 * PI),
                    result.basis,
                    result.radius / (2.0 * PI),
                    (covered_to + step).min(omega_max) / (2.0 * PI)
                );
            }
            continue;
        }
        let mut shift_report = ShiftReport {
            frequency_hz: omega / (2.0 * PI),
            radius: result.radius,
            basis: result.basis,
            found: result.converged.len(),
            seconds: result.seconds,
            ..ShiftReport::default()
        };
        let is_inside =
            |lambda: c64| (lambda - result.sigma).norm() < result.radius && lambda.im > 0.0;
        let inside: Vec<c64> = result
            .converged
            .iter()
            .copied()
            .filter(|&lambda| is_inside(lambda))
            .collect();
        let inside_pairs: Vec<EigenPair> = result
            .pairs
            .into_iter()
            .filter(|pair| is_inside(pair.lambda))
            .collect();
        let cut = match previous.take() {
            Some((previous_high, previous_cut, previous_inside, previous_pairs)) => {
                // Both disks cover [low, previous_high]: there the two sets must agree.
                let window = (low, previous_high);
                check_overlap(&previous_inside, &inside, window, omega_max, half_rate).map_err(
                    |(theirs, mine)| {
                        StageError::new(format!(
                            "shifts at {:.1} Hz and {:.1} Hz disagree on the eigenvalues between {:.1} and {:.1} Hz ({theirs} against {mine}): an eigenvalue was missed; raise max_basis",
                            report.shifts.last().map_or(0.0, |shift| shift.frequency_hz),
                            omega / (2.0 * PI),
                            window.0 / (2.0 * PI),
                            window.1 / (2.0 * PI),
                        ))
                    },
                )?;
                shift_report.overlap_matched = inside
                    .iter()
                    .filter(|lambda| lambda.im >= window.0 && lambda.im <= window.1)
                    .count();
                let cut = 0.5 * (window.0 + window.1);
                kept.extend(
                    previous_pairs
                        .into_iter()
                        .filter(|pair| pair.lambda.im >= previous_cut && pair.lambda.im < cut),
                );
                cut
            }
            None => 0.0,
        };
        shift_report.kept = inside.iter().filter(|lambda| lambda.im >= cut).count();
        tracing::info!(
            "stability: shift at {:.0} Hz, {} vectors, trusted radius {:.0} Hz, {} eigenvalues kept",
            shift_report.frequency_hz,
            shift_report.basis,
            shift_report.radius / (2.0 * PI),
            shift_report.kept
        );
        report.shifts.push(shift_report);
        covered_to = high;
        progress((covered_to / omega_max).min(1.0));
        // Aim the next disk at `per_shift` eigenvalues. It spans about twice the step in
        // height; the density is that of this disk's upper half, raised by half as modal
        // density grows with frequency.
        let above = inside.iter().filter(|lambda| lambda.im >= omega).count();
        step = if above == 0 {
            1.6 * result.radius
        } else {
            let density = 1.5 * above as f64 / result.radius;
            (options.per_shift as f64 / (2.0 * density))
                .clamp(0.1 * result.radius, 1.6 * result.radius)
        };
        previous = Some((high, cut, inside, inside_pairs));
    }
    if let Some((_, cut, _, pairs)) = previous {
        kept.extend(pairs.into_iter().filter(|pair| pair.lambda.im >= cut));
    }
    kept.retain(|pair| in_band(pair.lambda, omega_max, half_rate));
    kept.sort_by(|a, b| a.lambda.im.total_cmp(&b.lambda.im));
    Ok((kept, report))
}

/// Checks that two shifts found the same eigenvalues in the band part of `window` (heights):
/// each eigenvalue strictly inside, found by one, must be matched by the other. Returns the
/// two counts on failure.
fn check_overlap(
    theirs: &[c64],
    mine: &[c64],
    window: (f64, f64),
    omega_max: f64,
    half_rate: f64,
) -> Result<(), (usize, usize)> {
    let margin = 1e-6 * window.1;
    let within = |lambda: c64, slack: f64| {
        lambda.im >= window.0 - slack
            && lambda.im <= window.1 + slack
            && lambda.im <= omega_max + slack
            && lambda.re.abs() <= half_rate * lambda.im + slack
    };
    let strict = |set: &[c64]| -> Vec<c64> {
        set.iter()
            .copied()
            .filter(|&lambda| within(lambda, -margin))
            .collect()
    };
    let loose = |set: &[c64]| -> Vec<c64> {
        set.iter()
            .copied()
            .filter(|&lambda| within(lambda, margin))
            .collect()
    };
    let (theirs_strict, mine_strict) = (strict(theirs), strict(mine));
    if match_count(&mine_strict, &loose(theirs)) != mine_strict.len()
        || match_count(&theirs_strict, &loose(mine)) != theirs_strict.len()
    {
        return Err((theirs_strict.len(), mine_strict.len()));
    }
    Ok(())
}

/// Number of one-to-one matches between two sets of eigenvalues (relative distance 1e-6).
fn match_count(a: &[c64], b: &[c64]) -> usize {
    let mut used = vec![false; b.len()];
    let mut matched = 0;
    for lambda in a {
        let best = b
            .iter()
            .enumerate()
            .filter(|(j, _)| !used[*j])
            .map(|(j, other)| (j, (other - lambda).norm()))
            .min_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((j, distance)) = best
            && distance <= 1e-6 * lambda.norm()
        {
            used[j] = true;
            matched += 1;
        }
    }
    matched
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gram–Schmidt twice on a tall basis, over several row chunks, for vectors that lie
    /// almost wholly in its span (the case it is made for): the remainder must be orthogonal to
    /// the basis to round-off, and basis times coefficients plus remainder must give back the
    /// vectors.
    #[test]
    fn gram_schmidt_twice_leaves_a_remainder_orthogonal_to_a_tall_basis() {
        let (rows, rank, b) = (5000, 40, 8);
        let mut random = SplitMix64::new(7);
        let mut half = HalfBasis::new(rows, rank);
        half.extend(random_block(rows, rank, &mut random));
        assert_eq!(half.rank, rank);
        let basis = half.basis();
        let Q = basis.as_ref();
        let mixture = random_block(rank, b, &mut random);
        let W =
            Q * &mixture + random_block(rows, b, &mut random) * faer::Scale(c64::new(1e-6, 0.0));
        let mut remainder = W.clone();
        let coefficients = project_out(Q, &mut remainder);
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

    /// Blocks that lie almost wholly in the basis, as Krylov blocks do once the space has
    /// converged: with remainders of 1e-6 the second pass's corrections are folded into T,
    /// with 1e-11 they are too large for that (1e-16 / 1e-11) and are made in full. Either
    /// way the basis stays orthonormal and reproduces each block from its coefficients.
    #[test]
    fn the_half_basis_stays_orthonormal_with_its_second_pass_folded_into_t() {
        let (rows, b) = (3000, 8);
        let mut random = SplitMix64::new(11);
        for (remainder, folded) in [(1e-6, true), (1e-11, false)] {
            let mut half = HalfBasis::new(rows, 40 + 3 * b);
            half.extend(random_block(rows, 40, &mut random));
            for _ in 0..3 {
                let basis = half.basis();
                let mixture = random_block(half.rank, b, &mut random);
                let Z = &basis * &mixture
                    + random_block(rows, b, &mut random) * faer::Scale(c64::new(remainder, 0.0));
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

    #[test]
    fn ritz_checks_follow_the_growth_of_the_trusted_radius() {
        let b = 8;
        // Nothing trusted yet, or no growth: every quarter.
        assert_eq!(next_check_at(400, 0.0, None, 1000.0, b), 500);
        assert_eq!(next_check_at(400, 300.0, None, 1000.0, b), 500);
        assert_eq!(
            next_check_at(400, 300.0, Some((320, 300.0)), 1000.0, b),
            500
        );
        // Growth of 1 per vector, 100 short of 1.02 × 1000: 100 vectors on.
        assert_eq!(
            next_check_at(400, 920.0, Some((320, 840.0)), 1000.0, b),
            504
        );
        // Nearly there: at least a sixteenth more; far off: at most half as much again.
        assert_eq!(
            next_check_at(400, 1019.0, Some((320, 900.0)), 1000.0, b),
            432
        );
        assert_eq!(next_check_at(400, 100.0, Some((320, 99.0)), 1000.0, b), 600);
    }
}
