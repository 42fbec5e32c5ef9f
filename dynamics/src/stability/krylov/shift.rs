//! One shift: block Arnoldi on the two-level basis until the trusted disk is wide enough or
//! the basis is full, then the eigenvectors of the band's eigenvalues inside it.

use std::f64::consts::PI;
use std::time::Instant;

use faer::{Mat, MatRef, c64};
use squeal_linalg::gram_schmidt::{column_norm, orthonormalise};
use squeal_linalg::rng::SplitMix64;
use squeal_linalg::toar::{HalfBasis, deinterleave, interleave};

use super::{BandReport, EigenPair, KrylovOptions, ShiftSeconds};
use crate::stability::shift_invert::{EmbeddedPattern, ShiftedSolver};
use crate::stability::sliding::SlidingSystem;
use crate::stage::StageError;

/// Block steps before a shift's Ritz values are first examined (module doc, "Why none is
/// missed").
const MIN_BLOCK_STEPS: usize = 6;
/// A Ritz vector's first half is its eigenvector when its residual is below this (round-off is
/// about 1e-15); otherwise the second half is tried too.
const ROUND_OFF_RESIDUAL: f64 = 1e-12;

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

/// What one shift resolved.
pub(super) struct ShiftResult {
    pub(super) sigma: c64,
    pub(super) radius: f64,
    pub(super) basis: usize,
    /// Every converged eigenvalue.
    pub(super) converged: Vec<c64>,
    /// The converged eigenpairs that `wanted` selects, with their vectors.
    pub(super) pairs: Vec<EigenPair>,
    pub(super) seconds: ShiftSeconds,
}

/// Block Arnoldi at `sigma` until the trusted radius reaches `radius_needed` (and the basis
/// holds at least `options.basis` vectors); eigenvectors for the converged eigenvalues that
/// `wanted` selects.
pub(super) fn solve_shift(
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
    let mut half = HalfBasis::new(m, (max_basis + 2 * b).min(m), options.par);
    // Coordinates, interleaved so that those in use are the leading rows: Arnoldi vector j is
    // [Q u₁; Q u₂] with (u₁)_i = U[2i, j] and (u₂)_i = U[2i + 1, j].
    let mut U = Mat::<c64>::zeros(2 * half.capacity(), max_basis + b);
    let mut H = Mat::<c64>::zeros(max_basis + b, max_basis);
    // A random start block, its two halves side by side.
    let start_coordinates = half.extend(random.complex_block(m, 2 * b));
    let mut W = interleave(start_coordinates.as_ref(), b);
    let no_basis = U.submatrix(0, 0, W.nrows(), 0);
    orthonormalise(no_basis, &mut W, &mut random, options.par);
    U.submatrix_mut(0, 0, W.nrows(), b).copy_from(&W);
    let mut k = b;
    let mut next_check = options.basis.max(MIN_BLOCK_STEPS * b).min(max_basis).max(b);
    // The last check that trusted a radius: (basis, radius).
    let mut previous_check: Option<(usize, f64)> = None;
    loop {
        let phase = Instant::now();
        // Op V[:, k−b..k] = V[:, ..k] H + W R, in coordinates.
        let rank = half.rank();
        let block = U.submatrix(0, k - b, 2 * rank, b);
        let halves = half.expand(deinterleave(block).as_ref());
        let z1 = operator.first_half(halves.subcols(0, b), halves.subcols(b, b));
        seconds.operator += phase.elapsed().as_secs_f64();
        let phase = Instant::now();
        let z_coordinates = half.extend(z1);
        while 2 * half.rank() < k + b && half.rank() < m {
            half.add_random(&mut random);
        }
        let new_rank = half.rank();
        let mut W = next_block(
            z_coordinates.as_ref(),
            U.submatrix(0, k - b, 2 * rank, b),
            new_rank,
            sigma,
            scale,
        );
        let (coefficients, R) = orthonormalise(
            U.submatrix(0, 0, 2 * new_rank, k),
            &mut W,
            &mut random,
            options.par,
        );
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
        let check = ritz_check(H.as_ref(), k, b, sigma, options.arnoldi_tolerance)?;
        let radius = check.radius;
        seconds.ritz += phase.elapsed().as_secs_f64();
        tracing::debug!(
            "stability: shift {:.0} Hz, basis {k}, {} converged, trusted radius {:.0} Hz, {:.1} s",
            sigma.im / (2.0 * PI),
            check.converged.len(),
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
        let basis = U.submatrix(0, 0, 2 * half.rank(), k);
        let (converged, pairs) =
            shift_eigenpairs(system, &half, basis, &check, sigma, wanted, scale);
        seconds.vectors = phase.elapsed().as_secs_f64();
        report.seconds_arnoldi += clock.elapsed().as_secs_f64();
        return Ok(ShiftResult {
            sigma,
            radius: 0.99 * radius,
            basis: k,
            converged,
            pairs,
            seconds,
        });
    }
}

/// The new Arnoldi block in coordinates (interleaved, `2 × new_rank` rows), from the operator's
/// first half `z₁` (coordinates of `Q`) and the block it was applied to (`x₁` its first half):
/// `w₁ = z₁` and `w₂ = (x₁ + σ z₁)/s`.
fn next_block(
    z_coordinates: MatRef<'_, c64>,
    block: MatRef<'_, c64>,
    new_rank: usize,
    sigma: c64,
    scale: f64,
) -> Mat<c64> {
    let zero = c64::new(0.0, 0.0);
    Mat::<c64>::from_fn(2 * new_rank, block.ncols(), |row, j| {
        let i = row / 2;
        let w1 = if i < z_coordinates.nrows() {
            z_coordinates[(i, j)]
        } else {
            zero
        };
        if row % 2 == 0 {
            w1
        } else {
            let x1 = if 2 * i < block.nrows() {
                block[(2 * i, j)]
            } else {
                zero
            };
            (x1 + sigma * w1) / scale
        }
    })
}

/// The Ritz values of an Arnoldi matrix's leading k × k section, and which have converged.
struct RitzCheck {
    theta: Vec<c64>,
    /// The Ritz vectors (columns).
    S: Mat<c64>,
    /// Indices of the converged Ritz values, nearest σ first: all those nearer than the
    /// nearest unconverged one.
    converged: Vec<usize>,
    /// `|λ − σ|` of the nearest unconverged Ritz value: the radius the shift can trust.
    radius: f64,
}

fn ritz_check(
    H: MatRef<'_, c64>,
    k: usize,
    b: usize,
    sigma: c64,
    arnoldi_tolerance: f64,
) -> Result<RitzCheck, StageError> {
    let eigen = H.submatrix(0, 0, k, k).to_owned().eigen().map_err(|err| {
        StageError::new(format!(
            "dense eigensolver failed on the Arnoldi matrix: {err:?}"
        ))
    })?;
    let theta: Vec<c64> = eigen.S().column_vector().iter().copied().collect();
    let S = eigen.U().to_owned();
    let residual_block = H.submatrix(k, k - b, b, b);
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|&a, &c| theta[c].norm().total_cmp(&theta[a].norm()));
    let mut radius = f64::INFINITY;
    let mut converged = Vec::new();
    for &i in &order {
        let arnoldi_residual =
            column_norm((residual_block * S.submatrix(k - b, i, b, 1)).as_ref(), 0);
        let scale = theta[i].norm() * column_norm(S.as_ref(), i);
        if arnoldi_residual > arnoldi_tolerance * scale {
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
    Ok(RitzCheck {
        theta,
        S,
        converged,
        radius,
    })
}

/// The converged eigenvalues `λ = σ + 1/θ` of a shift, and the eigenpairs of those that
/// `wanted` selects (the others, damped beyond d_max, only bound the disk), from the Arnoldi
/// `basis` (interleaved coordinates).
fn shift_eigenpairs(
    system: &SlidingSystem,
    half: &HalfBasis,
    basis: MatRef<'_, c64>,
    check: &RitzCheck,
    sigma: c64,
    wanted: &dyn Fn(c64) -> bool,
    scale: f64,
) -> (Vec<c64>, Vec<EigenPair>) {
    let eigenvalue = |i: usize| sigma + check.theta[i].inv();
    let reported: Vec<usize> = check
        .converged
        .iter()
        .copied()
        .filter(|&i| wanted(eigenvalue(i)))
        .collect();
    let lambdas: Vec<c64> = reported.iter().map(|&i| eigenvalue(i)).collect();
    let coordinates = ritz_coordinates(basis, check.S.as_ref(), &reported);
    let pairs = eigenpairs(system, half, coordinates.as_ref(), &lambdas, scale);
    let converged = check.converged.iter().map(|&i| eigenvalue(i)).collect();
    (converged, pairs)
}

/// The coordinates in `Q` of the Ritz vectors `columns` of `S` (Schur vectors of the Arnoldi
/// section) over the basis `U` (interleaved): first halves, then second halves, side by side.
fn ritz_coordinates(U: MatRef<'_, c64>, S: MatRef<'_, c64>, columns: &[usize]) -> Mat<c64> {
    let selected = Mat::<c64>::from_fn(S.nrows(), columns.len(), |row, col| S[(row, columns[col])]);
    deinterleave((U * &selected).as_ref())
}

/// The eigenpairs `λ` of the Ritz vectors whose Arnoldi coordinates are `coordinates` (the
/// first halves `x₁`, then the second ones `x₂`, side by side): `q` is either half of
/// `y = V s`, `x₁` or `s x₂/λ`. The first is kept when its residual is at round-off level,
/// else the better of the two.
fn eigenpairs(
    system: &SlidingSystem,
    half: &HalfBasis,
    coordinates: MatRef<'_, c64>,
    lambdas: &[c64],
    scale: f64,
) -> Vec<EigenPair> {
    let n_reported = lambdas.len();
    let first = half.expand(coordinates.subcols(0, n_reported));
    let residuals = system.residuals(lambdas, first.as_ref());
    let mut pairs: Vec<EigenPair> = (0..n_reported)
        .map(|col| EigenPair {
            lambda: lambdas[col],
            q: first.col(col).iter().copied().collect(),
            residual: residuals[col],
            condition: f64::NAN,
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
    pairs
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

#[cfg(test)]
mod tests {
    use super::*;

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
