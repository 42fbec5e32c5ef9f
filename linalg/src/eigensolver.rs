//! The lowest eigenpairs of `K φ = λ M φ` in a band, proved complete by a Sturm count.
//!
//! 1. Factorise `K − σ M` once, σ at the bottom of the band (slightly below zero when the band
//!    starts at 0, so that a free body's rigid-body modes, λ ≈ 0, lie above it).
//! 2. Block shift-invert Lanczos ([`super::lanczos`]) until enough Ritz pairs have converged,
//!    with a few beyond the last wanted one.
//! 3. Refine: one or more steps of subspace iteration `Z = (K − σ M)⁻¹ M Q` followed by a
//!    Rayleigh–Ritz projection of `(K, M)` on `Z` (`Zᵀ K Z y = λ Zᵀ M Z y`, `φ = Z y`). This
//!    removes the high-frequency roundoff that `K` would amplify in the residual, and resolves
//!    repeated eigenvalues into `M`-orthonormal vectors.
//! 4. Prove completeness: factorise `K − τ M` with τ in a gap above the last wanted eigenvalue;
//!    its negative pivots minus those of `K − σ M` count the eigenvalues in `[σ, τ)`. If fewer
//!    were found, continue Lanczos deflated against those found; if that fails, report it.
//!
//! Residuals: `‖K φ − λ M φ‖ / ‖K φ‖`. A rigid-body mode has `K φ = 0` up to roundoff, where
//! that ratio means nothing; for a mode with `‖K φ‖ ≤ 1e-10 ‖K‖₁ ‖φ‖` the residual is the
//! normwise backward error `‖K φ − λ M φ‖ / (‖K‖₁ ‖φ‖)` instead.
//!
//! A residual cannot be smaller than the roundoff of the eigenvector itself: rounding φ to
//! double precision perturbs it in every mode, and `K` amplifies the high ones, so the floor of
//! `‖K φ − λ M φ‖ / ‖K φ‖` is about `ε λ_max / λ`. Very slender or very finely meshed models
//! (λ_max / λ₁ above ~10⁷) can therefore fail the 1e-8 bound; the error then gives the figures.
//!
//! Small models (a few hundred DOFs) are solved densely, and checked the same way.

use std::time::Instant;

use faer::{Mat, MatRef, Par};

use crate::Error;
use crate::csc::CscMatrix;
use crate::csc::{check_symmetric, diagonal, symmetric_mul};
use crate::dense::{generalized_symmetric_eigen, select_columns, symmetrised};
use crate::lanczos::{LanczosOptions, ShiftInvert, block_lanczos};
use crate::ldlt::{Factor, ShiftedPencil};
use crate::tall::{times, transpose_times};

/// Largest residual of a reported mode.
pub const RESIDUAL_TOLERANCE: f64 = 1e-8;
const MAX_REFINEMENTS: usize = 4;
/// Lanczos attempts (the first, then deflated continuations after a failed Sturm count).
const MAX_ATTEMPTS: usize = 3;
/// Models up to this many DOFs are solved densely.
const DENSE_LIMIT: usize = 600;
const LANCZOS_TOLERANCE: f64 = 1e-9;
/// σ = −SHIFT_FRACTION · (median of K_ii / M_ii) when the band starts at 0: far above the
/// roundoff of rigid-body eigenvalues, far below the first elastic one.
const SHIFT_FRACTION: f64 = 1e-8;
/// Eigenvalues closer than this (relative) form a cluster the Sturm shift must not split.
const CLUSTER_GAP: f64 = 1e-6;
/// `‖K φ‖ ≤ RIGID_BODY · ‖K‖₁ ‖φ‖` marks a zero-frequency (rigid-body) mode.
const RIGID_BODY: f64 = 1e-10;

/// Tuning of [`solve`]; the defaults suit models of 10⁴–10⁶ DOFs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Vectors per Lanczos block: multiplicities up to this (the six rigid-body modes of a free
    /// body, the pairs of an axisymmetric disc) are found without relying on roundoff.
    pub block_size: usize,
    /// Refinement stops once every wanted mode has a residual below this (at most
    /// [`RESIDUAL_TOLERANCE`], which a mode must meet to be reported).
    pub refined_residual: f64,
    /// Parallelism of faer's kernels (factorisation, solves, small dense problems). `Par::Seq`
    /// makes results independent of the thread count; the tall products and the sparse
    /// products are parallel (and deterministic) either way.
    pub par: Par,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            block_size: 8,
            refined_residual: 1e-9,
            par: Par::Seq,
        }
    }
}

/// Which eigenvalues λ = ω² are wanted: the lowest `n_modes` (0: all) in `[lambda_lo,
/// lambda_hi]` (`lambda_hi` infinite: no upper bound).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    pub n_modes: usize,
    pub lambda_lo: f64,
    pub lambda_hi: f64,
}

/// Figures of a solve, for benchmarks and diagnostics (not part of any artifact: timings vary).
#[derive(Debug, Clone, Default)]
pub struct SolveReport {
    pub n_dofs: usize,
    pub dense: bool,
    pub nested_dissection: bool,
    /// Entries of the factor `L`.
    pub factor_entries: usize,
    pub sigma: f64,
    pub analyse_seconds: f64,
    /// Total time of the numeric factorisations, and how many there were.
    pub factor_seconds: f64,
    pub n_factorizations: usize,
    pub lanczos_seconds: f64,
    /// Parts of the Lanczos time: solves, reorthogonalisation, Ritz extraction.
    pub solve_seconds: f64,
    pub orthogonalize_seconds: f64,
    pub ritz_seconds: f64,
    pub refine_seconds: f64,
    pub refinement_steps: usize,
    pub n_solves: usize,
    pub basis_size: usize,
    pub restarts: usize,
    pub attempts: usize,
    /// The Sturm shift τ, the eigenvalue count in [σ, τ) it proves, and how many were found.
    pub sturm_shift: f64,
    pub sturm_count: usize,
    pub found_below_sturm_shift: usize,
    pub worst_residual: f64,
}

/// Mass-normalised eigenpairs, λ ascending.
pub struct Eigensolution {
    pub lambda: Vec<f64>,
    pub shapes: Mat<f64>,
    pub residuals: Vec<f64>,
    pub report: SolveReport,
}

/// Eigenpairs with their residual figures.
struct Candidates {
    lambda: Vec<f64>,
    vectors: Mat<f64>,
    M_vectors: Mat<f64>,
    residuals: Vec<f64>,
}

fn column_norm(A: MatRef<'_, f64>, j: usize) -> f64 {
    A.col(j).iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Residual of each pair (see the module docs) from `K φ` and `M φ`.
fn residuals(
    lambda: &[f64],
    vectors: MatRef<'_, f64>,
    K_vectors: MatRef<'_, f64>,
    M_vectors: MatRef<'_, f64>,
    K_norm: f64,
) -> Vec<f64> {
    (0..lambda.len())
        .map(|j| {
            let residual = K_vectors
                .col(j)
                .iter()
                .zip(M_vectors.col(j).iter())
                .map(|(k, m)| (k - lambda[j] * m).powi(2))
                .sum::<f64>()
                .sqrt();
            let K_phi = column_norm(K_vectors, j);
            let backward_scale = K_norm * column_norm(vectors, j);
            if K_phi <= RIGID_BODY * backward_scale {
                residual / backward_scale
            } else {
                residual / K_phi
            }
        })
        .collect()
}

/// Median of `K_ii / M_ii`: the scale of the eigenvalues of a single DOF.
fn diagonal_eigenvalue_scale(K: &CscMatrix, M: &CscMatrix) -> Result<f64, Error> {
    let K_diagonal = diagonal(K);
    let M_diagonal = diagonal(M);
    if let Some(dof) = M_diagonal.iter().position(|&m| !(m > 0.0)) {
        return Err(Error::InvalidInput(format!(
            "M is not positive definite: M[{dof}, {dof}] = {:e}",
            M_diagonal[dof]
        )));
    }
    let mut ratios: Vec<f64> = K_diagonal
        .iter()
        .zip(&M_diagonal)
        .map(|(k, m)| k / m)
        .filter(|ratio| *ratio > 0.0)
        .collect();
    if ratios.is_empty() {
        return Err(Error::InvalidInput(
            "K has no positive diagonal entry".to_string(),
        ));
    }
    ratios.sort_by(f64::total_cmp);
    Ok(ratios[ratios.len() / 2])
}

/// Factorises `K − s M` at `target`, nudging `s` if it is (numerically) an eigenvalue.
fn factor_at<'a>(
    pencil: &'a ShiftedPencil,
    target: f64,
    scale: f64,
    par: Par,
    report: &mut SolveReport,
) -> Result<Factor<'a>, Error> {
    let mut last_error = None;
    for attempt in 0..4 {
        let nudge = [0.0, -1e-7, 1e-7, -1e-5][attempt] * target.abs().max(scale);
        let started = Instant::now();
        let result = pencil.factor(target + nudge, par);
        report.factor_seconds += started.elapsed().as_secs_f64();
        report.n_factorizations += 1;
        match result {
            Ok(factor) => return Ok(factor),
            Err(err) => last_error = Some(err),
        }
    }
    Err(last_error.unwrap_or_else(|| Error::Breakdown("no factorisation attempted".to_string())))
}

/// The smallest `j ≥ first` with a gap between `sorted[j − 1]` and `sorted[j]`.
fn gap_at_or_above(sorted: &[f64], first: usize, absolute_floor: f64) -> Option<usize> {
    (first.max(1)..sorted.len()).find(|&j| {
        let (below, above) = (sorted[j - 1], sorted[j]);
        above - below > CLUSTER_GAP * below.abs().max(above.abs()) + absolute_floor
    })
}

/// Ritz pairs `(λ, Φ)` with the products `K Φ` and `M Φ`.
struct RitzProducts {
    lambda: Vec<f64>,
    vectors: Mat<f64>,
    K_vectors: Mat<f64>,
    M_vectors: Mat<f64>,
}

/// Rayleigh–Ritz of `(K, M)` on the span of `Z`.
fn rayleigh_ritz(
    Z: MatRef<'_, f64>,
    K: &CscMatrix,
    M: &CscMatrix,
    par: Par,
) -> Result<RitzProducts, Error> {
    let KZ = symmetric_mul(K, Z);
    let MZ = symmetric_mul(M, Z);
    let K_projected = transpose_times(Z, KZ.as_ref());
    let M_projected = transpose_times(Z, MZ.as_ref());
    let (lambda, Y) = generalized_symmetric_eigen(
        symmetrised(K_projected.as_ref()).as_ref(),
        symmetrised(M_projected.as_ref()).as_ref(),
        par,
    )?;
    let product = |A: MatRef<'_, f64>| times(A, Y.as_ref());
    Ok(RitzProducts {
        vectors: product(Z),
        K_vectors: product(KZ.as_ref()),
        M_vectors: product(MZ.as_ref()),
        lambda,
    })
}

/// Subspace-iteration refinement of approximate eigenvectors `Q` (eigenvalues `lambda`), from
/// their products `M Q`, until the `n_checked` lowest have residual ≤ `target`.
fn refine(
    op: &ShiftInvert<'_>,
    K: &CscMatrix,
    MQ: Mat<f64>,
    lambda: Vec<f64>,
    n_checked: usize,
    target: f64,
    K_norm: f64,
) -> Result<(Candidates, usize), Error> {
    let (M, par, sigma) = (op.M, op.par, op.sigma());
    let mut MQ = MQ;
    let mut lambda = lambda;
    let mut candidates = None;
    let mut steps = 0;
    for _ in 0..MAX_REFINEMENTS {
        steps += 1;
        let mut Z = op.apply_to_product(MQ.as_ref());
        // Z ≈ Q / (λ − σ): rescale so that the projected mass matrix is well conditioned.
        for (j, value) in lambda.iter().enumerate() {
            let scale = value - sigma;
            if scale.is_finite() && scale != 0.0 {
                for i in 0..Z.nrows() {
                    Z[(i, j)] *= scale;
                }
            }
        }
        let RitzProducts {
            lambda: new_lambda,
            vectors,
            K_vectors,
            M_vectors,
        } = rayleigh_ritz(Z.as_ref(), K, M, par)?;
        let new_residuals = residuals(
            &new_lambda,
            vectors.as_ref(),
            K_vectors.as_ref(),
            M_vectors.as_ref(),
            K_norm,
        );
        let worst = new_residuals
            .iter()
            .take(n_checked)
            .fold(0.0f64, |worst, r| worst.max(*r));
        MQ = M_vectors.clone();
        lambda = new_lambda.clone();
        candidates = Some(Candidates {
            lambda: new_lambda,
            vectors,
            M_vectors,
            residuals: new_residuals,
        });
        if worst <= target {
            break;
        }
    }
    let candidates =
        candidates.ok_or_else(|| Error::NotConverged("no refinement step ran".to_string()))?;
    Ok((candidates, steps))
}

/// All eigenpairs of a small model, densely: λ ascending, `M`-orthonormal vectors.
fn dense_candidates(K: &CscMatrix, M: &CscMatrix, par: Par) -> Result<(Vec<f64>, Mat<f64>), Error> {
    generalized_symmetric_eigen(
        symmetrised(K.to_dense().as_ref()).as_ref(),
        symmetrised(M.to_dense().as_ref()).as_ref(),
        par,
    )
}

/// What a Lanczos attempt must find: enough eigenvalues above σ, beyond the wanted ones, for
/// the Sturm check ([`solve`]).
struct LanczosTarget {
    sigma: f64,
    n_wanted: usize,
    n_needed: usize,
    /// The band's top and its count, when the whole band is wanted.
    band_shift: Option<(usize, f64)>,
    absolute_gap: f64,
    /// Eigenvalues a failed Sturm check found missing below the previous Sturm shift.
    n_missing: usize,
}

/// One Lanczos attempt, deflated against the candidates found so far: returns `M Q` and the
/// eigenvalues of the previous candidates and of the new Ritz vectors, side by side.
fn lanczos_candidates(
    op: &ShiftInvert<'_>,
    candidates: &Candidates,
    target: &LanczosTarget,
    block_size: usize,
    attempt: usize,
    report: &mut SolveReport,
) -> Result<(Mat<f64>, Vec<f64>), Error> {
    let n = candidates.vectors.nrows();
    let LanczosTarget {
        sigma,
        n_wanted,
        n_needed,
        band_shift,
        absolute_gap,
        n_missing,
    } = *target;
    let lanczos_started = Instant::now();
    let max_basis = (5 * n_needed / 2)
        .max(n_needed + 10 * block_size)
        .min(n / 3);
    let lanczos_options = LanczosOptions {
        block_size,
        max_basis,
        tolerance: LANCZOS_TOLERANCE,
        max_restarts: 8,
        seed: 0x5eed_0000 + attempt as u64,
    };
    let locked_lambda = candidates.lambda.clone();
    let previous_shift = report.sturm_shift;
    let done = |theta_descending: &[f64]| {
        let mut lambda: Vec<f64> = theta_descending
            .iter()
            .filter(|theta| **theta > 0.0)
            .map(|theta| sigma + 1.0 / theta)
            .collect();
        let new_below_previous_shift = lambda
            .iter()
            .filter(|value| **value < previous_shift)
            .count();
        if new_below_previous_shift < n_missing {
            return false;
        }
        lambda.extend_from_slice(&locked_lambda);
        lambda.sort_by(f64::total_cmp);
        match band_shift {
            Some((count, tau)) => {
                lambda.iter().filter(|value| **value < tau).count() >= count
                    && lambda.iter().any(|value| *value >= tau)
            }
            None => {
                lambda.len() > n_wanted
                    && gap_at_or_above(&lambda, n_wanted, absolute_gap).is_some()
            }
        }
    };
    let ritz = block_lanczos(op, candidates.vectors.as_ref(), lanczos_options, &done)?;
    report.basis_size = report.basis_size.max(ritz.basis_size);
    report.restarts += ritz.restarts;
    report.solve_seconds = ritz.solve_seconds;
    report.orthogonalize_seconds += ritz.orthogonalize_seconds;
    report.ritz_seconds += ritz.ritz_seconds;
    report.lanczos_seconds += lanczos_started.elapsed().as_secs_f64();
    let n_previous = candidates.lambda.len();
    let mut MQ = Mat::<f64>::zeros(n, n_previous + ritz.vectors.ncols());
    MQ.as_mut()
        .subcols_mut(0, n_previous)
        .copy_from(&candidates.M_vectors);
    MQ.as_mut()
        .subcols_mut(n_previous, ritz.vectors.ncols())
        .copy_from(&ritz.M_vectors);
    let mut lambda = candidates.lambda.clone();
    lambda.extend(ritz.theta.iter().map(|theta| sigma + 1.0 / theta));
    Ok((MQ, lambda))
}

/// The wanted eigenpairs of `(K, M)` (symmetric, `M` positive definite) in `band`, proved
/// complete; `dof_of_node` groups DOFs by node for the ordering.
pub fn solve(
    K: &CscMatrix,
    M: &CscMatrix,
    dof_of_node: &[[Option<u32>; 3]],
    band: Band,
    options: SolveOptions,
) -> Result<Eigensolution, Error> {
    check_input(K, M, band)?;
    let n = K.n_rows;
    let mut report = SolveReport {
        n_dofs: n,
        ..SolveReport::default()
    };
    let scale = diagonal_eigenvalue_scale(K, M)?;
    let analyse_started = Instant::now();
    let pencil = ShiftedPencil::new(K, M, dof_of_node)?;
    report.analyse_seconds = analyse_started.elapsed().as_secs_f64();
    report.nested_dissection = pencil.nested_dissection;
    report.factor_entries = pencil.factor_len();

    let plan = Plan::new(&pencil, band, scale, options, &mut report)?;
    if plan.n_wanted == 0 {
        return Ok(Eigensolution {
            lambda: Vec::new(),
            shapes: Mat::zeros(n, 0),
            residuals: Vec::new(),
            report,
        });
    }
    let K_norm = K.norm_1();
    let candidates = plan.find(K, M, options, K_norm, &mut report)?;
    select_band(candidates, band, plan.n_wanted, K_norm / M.norm_1(), report)
}

fn check_input(K: &CscMatrix, M: &CscMatrix, band: Band) -> Result<(), Error> {
    let n = K.n_rows;
    if n == 0 {
        return Err(Error::InvalidInput("the model has no DOF".to_string()));
    }
    check_symmetric(K, n, "K")?;
    check_symmetric(M, n, "M")?;
    if band.n_modes == 0 && !band.lambda_hi.is_finite() {
        return Err(Error::InvalidInput(
            "n_modes = 0 asks for every mode below f_max_hz, but f_max_hz is not set".to_string(),
        ));
    }
    Ok(())
}

/// What a solve looks for and how: the shift σ below the band and its factorisation, how many
/// eigenvalues are wanted (from the Sturm count of the band when it has a top), and whether
/// the problem is small enough to be solved densely.
struct Plan<'p> {
    pencil: &'p ShiftedPencil,
    band: Band,
    scale: f64,
    factor_sigma: Factor<'p>,
    sigma: f64,
    /// Eigenvalues below σ, and those above it.
    below_sigma: usize,
    available: usize,
    n_wanted: usize,
    /// Candidates to find: the wanted ones and a block more, for the Sturm gap.
    n_needed: usize,
    /// The band's top and its count, when the whole band is wanted.
    band_shift: Option<(usize, f64)>,
    absolute_gap: f64,
    dense: bool,
}

impl<'p> Plan<'p> {
    fn new(
        pencil: &'p ShiftedPencil,
        band: Band,
        scale: f64,
        options: SolveOptions,
        report: &mut SolveReport,
    ) -> Result<Plan<'p>, Error> {
        let (par, n) = (options.par, pencil.n());
        let block_size = options.block_size.max(1);
        let sigma_target = if band.lambda_lo > 0.0 {
            band.lambda_lo
        } else {
            -SHIFT_FRACTION * scale
        };
        let factor_sigma = factor_at(pencil, sigma_target, scale, par, report)?;
        let sigma = factor_sigma.sigma;
        report.sigma = sigma;
        if band.lambda_lo <= 0.0 && factor_sigma.negative_pivots > 0 {
            return Err(Error::InvalidInput(format!(
                "K is not positive semi-definite: {} eigenvalue(s) below sigma = {sigma:e} rad^2/s^2",
                factor_sigma.negative_pivots
            )));
        }
        let below_sigma = factor_sigma.negative_pivots;
        let available = n - below_sigma;
        // With an upper bound, count the band first: the Sturm count then fixes how many to
        // find.
        let band_count = if band.lambda_hi.is_finite() {
            let factor_hi = factor_at(pencil, band.lambda_hi, scale, par, report)?;
            Some((
                factor_hi.negative_pivots.saturating_sub(below_sigma),
                factor_hi.sigma,
            ))
        } else {
            None
        };
        let n_wanted = match band_count {
            Some((count, _)) if band.n_modes == 0 => count,
            Some((count, _)) => band.n_modes.min(count),
            None => band.n_modes.min(available),
        };
        let n_needed = n_wanted + block_size;
        let dense = n <= DENSE_LIMIT || (3 * n_needed > n && n <= 3 * DENSE_LIMIT);
        if n_wanted > 0 {
            report.dense = dense;
        }
        if n_wanted > 0 && !dense && 3 * n_needed > n {
            return Err(Error::InvalidInput(format!(
                "{n_wanted} modes are too many for a model of {n} DOFs: ask for at most {}",
                n / 3 - block_size
            )));
        }
        Ok(Plan {
            pencil,
            band,
            scale,
            factor_sigma,
            sigma,
            below_sigma,
            available,
            n_wanted,
            n_needed,
            // When the whole band is wanted, the Sturm shift is its top: its count is known.
            band_shift: band_count.filter(|(count, _)| *count == n_wanted),
            absolute_gap: 1e-9 * scale,
            dense,
        })
    }

    /// Candidates found (densely, or by Lanczos from σ, restarted while the Sturm count finds
    /// some missing), refined, and proved complete by the Sturm count.
    fn find(
        &self,
        K: &CscMatrix,
        M: &CscMatrix,
        options: SolveOptions,
        K_norm: f64,
        report: &mut SolveReport,
    ) -> Result<Candidates, Error> {
        let (par, n, sigma) = (options.par, K.n_rows, self.sigma);
        let op = ShiftInvert::new(&self.factor_sigma, M, par);
        // Dense: every eigenpair at once; the lowest wanted ones (and a few more, for the Sturm
        // gap) are then refined like Lanczos vectors.
        let dense_start = if self.dense {
            let all = dense_candidates(K, M, par)?;
            let columns: Vec<usize> = (0..n)
                .filter(|&j| self.band.lambda_lo <= 0.0 || all.0[j] >= sigma)
                .take(self.n_needed)
                .collect();
            Some((
                columns.iter().map(|&j| all.0[j]).collect::<Vec<f64>>(),
                select_columns(all.1.as_ref(), &columns),
            ))
        } else {
            None
        };
        let mut candidates = Candidates {
            lambda: Vec::new(),
            vectors: Mat::zeros(n, 0),
            M_vectors: Mat::zeros(n, 0),
            residuals: Vec::new(),
        };
        let sturm = SturmCheck {
            pencil: self.pencil,
            scale: self.scale,
            par,
            lambda_lo: self.band.lambda_lo,
            sigma,
            below_sigma: self.below_sigma,
            available: self.available,
            n_wanted: self.n_wanted,
            band_shift: self.band_shift,
            absolute_gap: self.absolute_gap,
        };
        let mut sturm_failure = None;
        for attempt in 0..MAX_ATTEMPTS {
            report.attempts = attempt + 1;
            let (MQ, lambda) = if let Some((lambda, vectors)) = &dense_start {
                (symmetric_mul(M, vectors.as_ref()), lambda.clone())
            } else {
                let target = LanczosTarget {
                    sigma,
                    n_wanted: self.n_wanted,
                    n_needed: self.n_needed,
                    band_shift: self.band_shift,
                    absolute_gap: self.absolute_gap,
                    n_missing: sturm_failure
                        .map_or(0, |(expected, found): (usize, usize)| expected - found),
                };
                let block_size = options.block_size.max(1);
                lanczos_candidates(&op, &candidates, &target, block_size, attempt, report)?
            };
            let refine_started = Instant::now();
            let steps;
            (candidates, steps) = refine(
                &op,
                K,
                MQ,
                lambda,
                self.n_wanted,
                options.refined_residual.min(RESIDUAL_TOLERANCE),
                K_norm,
            )?;
            report.refinement_steps += steps;
            report.refine_seconds += refine_started.elapsed().as_secs_f64();
            let (expected, found) = sturm.count(&candidates.lambda, report)?;
            if found == expected {
                sturm_failure = None;
                break;
            }
            sturm_failure = Some((expected, found));
            if dense_start.is_some() || found > expected {
                break;
            }
        }
        report.n_solves = op.n_solves.load(std::sync::atomic::Ordering::Relaxed);
        if let Some((expected, found)) = sturm_failure {
            let worst = candidates
                .residuals
                .iter()
                .fold(0.0f64, |worst, r| worst.max(*r));
            return Err(Error::NotConverged(format!(
                "Sturm count: {expected} eigenvalues lie in [{sigma:e}, {:e}) rad^2/s^2 but {found} were found (worst residual {worst:.2e})",
                report.sturm_shift
            )));
        }
        Ok(candidates)
    }
}

/// The Sturm check of [`solve`]: the eigenvalues in `[σ, τ)` counted by the inertia of
/// `K − τ M` against those found there. τ is the band's top when the whole band is wanted,
/// else in a gap above the wanted eigenvalues.
struct SturmCheck<'a> {
    pencil: &'a ShiftedPencil,
    scale: f64,
    par: Par,
    lambda_lo: f64,
    sigma: f64,
    /// Negative pivots of `K − σ M`.
    below_sigma: usize,
    /// Eigenvalues above σ.
    available: usize,
    n_wanted: usize,
    band_shift: Option<(usize, f64)>,
    absolute_gap: f64,
}

impl SturmCheck<'_> {
    /// (expected, found) for the candidate eigenvalues `lambda`; the shift and the counts go
    /// into `report`.
    fn count(&self, lambda: &[f64], report: &mut SolveReport) -> Result<(usize, usize), Error> {
        let found_above_sigma: Vec<f64> = lambda
            .iter()
            .copied()
            .filter(|value| *value >= self.sigma || self.lambda_lo <= 0.0)
            .collect();
        let (tau, expected) = match self.band_shift {
            Some((count, tau)) => (tau, count),
            None => {
                let tau = match gap_at_or_above(
                    &found_above_sigma,
                    self.n_wanted,
                    self.absolute_gap,
                ) {
                    Some(j) => 0.5 * (found_above_sigma[j - 1] + found_above_sigma[j]),
                    // Every eigenvalue above σ was found: count them all.
                    None if found_above_sigma.len() == self.available => {
                        2.0 * found_above_sigma.last().copied().unwrap_or(0.0).abs() + self.scale
                    }
                    None => {
                        return Err(Error::NotConverged(format!(
                            "found {} eigenvalues but no gap above the {}th to place a Sturm shift",
                            found_above_sigma.len(),
                            self.n_wanted
                        )));
                    }
                };
                let factor_tau = factor_at(self.pencil, tau, self.scale, self.par, report)?;
                (
                    factor_tau.sigma,
                    factor_tau.negative_pivots.saturating_sub(self.below_sigma),
                )
            }
        };
        let found = found_above_sigma
            .iter()
            .filter(|value| **value < tau)
            .count();
        report.sturm_shift = tau;
        report.sturm_count = expected;
        report.found_below_sturm_shift = found;
        Ok((expected, found))
    }
}

/// The first `n_wanted` candidates in the band, each checked against the residual tolerance;
/// `lambda_max` (estimated by ‖K‖₁ / ‖M‖₁) gives the round-off floor an error reports.
fn select_band(
    candidates: Candidates,
    band: Band,
    n_wanted: usize,
    lambda_max: f64,
    mut report: SolveReport,
) -> Result<Eigensolution, Error> {
    let selected: Vec<usize> = (0..candidates.lambda.len())
        .filter(|&j| {
            let value = candidates.lambda[j];
            (band.lambda_lo <= 0.0 || value >= band.lambda_lo) && value <= band.lambda_hi
        })
        .take(n_wanted)
        .collect();
    if selected.len() < n_wanted {
        return Err(Error::NotConverged(format!(
            "{n_wanted} modes wanted in the band but only {} were found",
            selected.len()
        )));
    }
    let lambda: Vec<f64> = selected.iter().map(|&j| candidates.lambda[j]).collect();
    let residuals: Vec<f64> = selected.iter().map(|&j| candidates.residuals[j]).collect();
    let worst = residuals.iter().fold(0.0f64, |worst, r| worst.max(*r));
    report.worst_residual = worst;
    if !(worst <= RESIDUAL_TOLERANCE) {
        let mode = residuals
            .iter()
            .position(|r| !(*r <= RESIDUAL_TOLERANCE))
            .unwrap_or(0);
        // λ_max bounds the roundoff floor of this mode's residual.
        let floor = f64::EPSILON * lambda_max / lambda[mode].abs().max(f64::MIN_POSITIVE);
        return Err(Error::NotConverged(format!(
            "mode {} (omega^2 = {:e}) has residual {:.2e} > {RESIDUAL_TOLERANCE:e} (worst {worst:.2e}; roundoff floor about {floor:.1e})",
            mode + 1,
            lambda[mode],
            residuals[mode]
        )));
    }
    let shapes = select_columns(candidates.vectors.as_ref(), &selected);
    Ok(Eigensolution {
        lambda,
        shapes,
        residuals,
        report,
    })
}
