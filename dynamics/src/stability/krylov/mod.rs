//! Every eigenvalue of the sliding problem in a frequency band: shift-invert block Arnoldi at
//! shifts placed along the imaginary axis until their trusted disks cover the band.
//!
//! # One shift (`shift`)
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
//! residuals `‖R s_last‖`. Eigenvalues nearest σ converge first. The basis is held in two
//! levels, `V = [Q U₁; Q U₂]` with one orthonormal `Q` of the reduced size
//! ([`squeal_linalg::toar`]).
//!
//! # Why none is missed
//!
//! A shift's **trusted disk** is `|λ − σ| < ρ`, with ρ the distance to the nearest Ritz value
//! that has *not* converged: every Ritz value inside has converged, and an eigenvalue inside
//! that the Krylov space had not seen at all would have to be orthogonal to a random start
//! block of several vectors. The radius is trusted only once the space has resolved
//! something: after `MIN_BLOCK_STEPS` block steps and once the Ritz value nearest σ has
//! converged. Before that, Ritz values lie inside the spectrum's hull and understate how near
//! the nearest eigenvalue is. The disks are made to overlap; in each overlap the eigenvalues
//! both shifts found must agree one to one (within the merging tolerance), which a missed
//! eigenvalue would break. Eigenvalues are then kept from the shift whose cell they lie in
//! (cells cut in the middle of each overlap), so none is reported twice.
//!
//! The band is `0 < Im λ ≤ ω_max` with `|2 Re λ / Im λ| ≤ d_max` (divergence rates beyond
//! ±d_max, far from any squeal mode, are not sought). Those damped eigenvalues still have to
//! converge where they lie inside a disk, but they get no eigenvector.
//!
//! # Cost and spacing (`band`)
//!
//! A shift costs one factorisation plus a contact correction (a solve with one right-hand
//! side per closed pair), then, per block of b Arnoldi vectors, one solve with b right-hand
//! sides and one orthogonalisation against the basis, which grows with the basis. Ritz values
//! are checked from a small basis on, so that a nearly empty disk stops early, then where the
//! trusted radius's growth predicts the disk is wide enough (`next_check_at`). Each shift
//! is placed from the density the previous one met in its upper half, aiming at `per_shift`
//! eigenvalues. Density can grow faster than that estimate allows for, so a disk may fall
//! short of the covered band at `max_basis`: it is kept, and a shift halfway below fills the
//! gap, overlapping both. Where the band's wedge `|Re λ| ≤ (d_max/2) Im λ` is nearly as wide
//! as the disks the basis allows, no shift can cover more than a sliver, and the search stops
//! with an error naming both settings.
//!
//! The factor is swept twice per solve whatever its width, so blocks of several vectors cost
//! less per vector than single ones, and the orthogonalisation becomes matrix–matrix; blocks
//! of eight beat both fewer and more. Wide disks beat narrow ones: factorisations and the
//! overlaps' double work are paid fewer times. Beyond about 900 vectors, though, the
//! orthogonalisation and the Ritz checks cost more per eigenvalue than another shift would,
//! hence `max_basis` 960. The defaults' figures, and the alternatives tried, are in
//! PERFORMANCE.md.

mod band;
mod shift;

pub use band::solve_band;

use faer::Par;
use faer::c64;

/// Tuning of [`solve_band`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KrylovOptions {
    pub block_size: usize,
    /// Basis size at which a shift's Ritz values are first examined (at least
    /// `MIN_BLOCK_STEPS` blocks), and the most it may grow to.
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
            par: squeal_linalg::par(),
        }
    }
}

/// An eigenpair of the sliding problem: λ and q over the reduced DOFs.
#[derive(Debug, Clone)]
pub struct EigenPair {
    pub lambda: c64,
    pub q: Vec<c64>,
    pub residual: f64,
    /// κ(λ) ([`crate::stability::conditioning`]); NaN where it was not computed.
    pub condition: f64,
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
