//! Real modes (`modes` stage's eigensolver): the rigid-body modes of a free body and their
//! mass, and the block Lanczos eigenvalues (repeated ones included), band and shift selection
//! and Sturm count against a dense solve of the same `(K, M)`.

use faer::Par;
use serde::Deserialize;
use squeal_linalg::dense;
use squeal_linalg::eigensolver::{self, Band, Eigensolution, RESIDUAL_TOLERANCE, SolveOptions};
use squeal_stages::artifact::Model;
use squeal_stages::assemble::with_default_materials;
use squeal_stages::mesh::structured;
use squeal_stages::modes::omega_of;

use crate::reference;

/// Steel, the default disc material.
pub const STEEL_E: f64 = 2.02e11;
pub const STEEL_RHO: f64 = 7850.0;

pub fn lowest(model: &Model, n_modes: usize) -> Eigensolution {
    solve_band(
        model,
        Band {
            n_modes,
            lambda_lo: 0.0,
            lambda_hi: f64::INFINITY,
        },
    )
}

pub fn solve_band(model: &Model, band: Band) -> Eigensolution {
    eigensolver::solve(
        &model.K,
        &model.M,
        &model.dof_of_node,
        band,
        SolveOptions::default(),
    )
    .unwrap_or_else(|err| panic!("modes failed: {err}"))
}

pub fn frequencies_hz(solution: &Eigensolution) -> Vec<f64> {
    solution
        .lambda
        .iter()
        .map(|lambda| omega_of(*lambda) / (2.0 * std::f64::consts::PI))
        .collect()
}

/// Every residual below the solver's tolerance, `φᵀ M φ = 1`, and the Sturm count equal to
/// the modes found below its shift.
pub fn check_residuals_and_normalisation(model: &Model, solution: &Eigensolution) {
    for (mode, residual) in solution.residuals.iter().enumerate() {
        assert!(
            *residual <= RESIDUAL_TOLERANCE,
            "mode {mode}: residual {residual:e}"
        );
    }
    for mode in 0..solution.shapes.ncols() {
        let phi: Vec<f64> = solution.shapes.col(mode).iter().copied().collect();
        let M_phi = model.M.mul_vec(&phi);
        let mass: f64 = phi.iter().zip(&M_phi).map(|(a, b)| a * b).sum();
        assert!(
            (mass - 1.0).abs() < 1e-10,
            "mode {mode}: phi^T M phi = {mass}"
        );
    }
    let report = &solution.report;
    assert_eq!(
        report.sturm_count, report.found_below_sturm_shift,
        "{report:?}"
    );
}

/// A steel cantilever of length `length` and square section `side`, clamped at x = 0.
pub fn cantilever(length: f64, side: f64, n_length: usize, n_side: usize) -> Model {
    let mesh = structured::block([length, side, side], [n_length, n_side, n_side], "disc");
    with_default_materials(&mesh, "x0", &[])
        .expect("assembly")
        .0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FreeBody {
    lengths_m: [f64; 3],
    counts: [usize; 3],
    /// Largest |f| of a rigid-body mode, relative to the first elastic frequency.
    rigid_frequency_tolerance: f64,
    /// Σ Γ_x² against the body's mass ρ V, relative.
    mass_tolerance: f64,
}

#[test]
fn a_free_body_has_six_rigid_body_modes_carrying_its_whole_mass() {
    let case: FreeBody = reference::load("free_body");
    let mesh = structured::block(case.lengths_m, case.counts, "disc");
    let (model, _) = with_default_materials(&mesh, "", &[]).expect("assembly");
    assert!(model.n_dofs() > 1000, "exercise the Lanczos path");
    let solution = lowest(&model, 10);
    check_residuals_and_normalisation(&model, &solution);
    assert!(!solution.report.dense);
    let frequencies = frequencies_hz(&solution);
    let first_elastic = frequencies[6];
    for rigid in &frequencies[..6] {
        assert!(
            rigid.abs() < case.rigid_frequency_tolerance * first_elastic,
            "{frequencies:?}"
        );
    }
    // The rigid modes carry the whole mass along each axis: Σ Γ_x² = m.
    let total_mass = STEEL_RHO * case.lengths_m.iter().product::<f64>();
    let translation: Vec<f64> = (0..model.n_dofs())
        .map(|dof| if dof % 3 == 0 { 1.0 } else { 0.0 })
        .collect();
    let M_translation = model.M.mul_vec(&translation);
    let captured: f64 = (0..6)
        .map(|mode| {
            let gamma: f64 = solution
                .shapes
                .col(mode)
                .iter()
                .zip(&M_translation)
                .map(|(phi, m)| phi * m)
                .sum();
            gamma * gamma
        })
        .sum();
    assert!(
        (captured - total_mass).abs() < case.mass_tolerance * total_mass,
        "{captured} vs {total_mass}"
    );
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AgainstDense {
    length_m: f64,
    side_m: f64,
    counts: [usize; 2],
    n_modes: usize,
    /// |λ − λ_dense| / λ_dense.
    eigenvalue_tolerance: f64,
    /// Repeated pairs (square section: both bending directions) that must be found twice.
    least_repeated_pairs: usize,
}

fn dense_eigenvalues(model: &Model) -> Vec<f64> {
    dense::generalized_symmetric_eigen(
        model.K.to_dense().as_ref(),
        model.M.to_dense().as_ref(),
        Par::rayon(0),
    )
    .expect("dense eigensolve")
    .0
}

/// A square-section cantilever has repeated bending eigenvalues; block Lanczos must find both
/// copies of each: compared with a dense solve of the same (K, M), and by the Sturm count.
#[test]
fn repeated_eigenvalues_match_a_dense_solve() {
    let case: AgainstDense = reference::load("real_modes_against_dense");
    let [n_length, n_side] = case.counts;
    let model = cantilever(case.length_m, case.side_m, n_length, n_side);
    let solution = lowest(&model, case.n_modes);
    assert!(!solution.report.dense, "exercise the Lanczos path");
    check_residuals_and_normalisation(&model, &solution);
    let dense_lambda = dense_eigenvalues(&model);
    for (mode, (lanczos, dense)) in solution.lambda.iter().zip(&dense_lambda).enumerate() {
        assert!(
            (lanczos - dense).abs() <= case.eigenvalue_tolerance * dense.abs(),
            "mode {mode}: {lanczos} vs dense {dense}"
        );
    }
    let repeated = (1..case.n_modes)
        .filter(|&j| {
            (solution.lambda[j] - solution.lambda[j - 1]).abs()
                < case.eigenvalue_tolerance * solution.lambda[j]
        })
        .count();
    assert!(
        repeated >= case.least_repeated_pairs,
        "pairs found: {repeated}, {:?}",
        solution.lambda
    );
    // The Sturm count at τ equals the dense count below τ.
    let tau = solution.report.sturm_shift;
    let dense_below = dense_lambda.iter().filter(|lambda| **lambda < tau).count();
    assert_eq!(solution.report.sturm_count, dense_below);
}

#[test]
fn band_and_shift_select_the_same_modes_as_a_dense_solve() {
    let case: AgainstDense = reference::load("real_modes_against_dense");
    let [n_length, n_side] = case.counts;
    let model = cantilever(case.length_m, case.side_m, n_length, n_side);
    let dense_lambda = dense_eigenvalues(&model);
    // Every mode up to the first gap after the 12th eigenvalue (not inside a repeated pair).
    let above = (12..dense_lambda.len())
        .find(|&j| dense_lambda[j] - dense_lambda[j - 1] > 1e-6 * dense_lambda[j])
        .expect("a gap");
    let lambda_hi = 0.5 * (dense_lambda[above - 1] + dense_lambda[above]);
    let band = solve_band(
        &model,
        Band {
            n_modes: 0,
            lambda_lo: 0.0,
            lambda_hi,
        },
    );
    check_residuals_and_normalisation(&model, &band);
    assert_eq!(band.lambda.len(), above);
    // Five modes from a shift between the 4th and 5th eigenvalues.
    let lambda_lo = 0.5 * (dense_lambda[3] + dense_lambda[4]);
    let shifted = solve_band(
        &model,
        Band {
            n_modes: 5,
            lambda_lo,
            lambda_hi: f64::INFINITY,
        },
    );
    check_residuals_and_normalisation(&model, &shifted);
    for (got, want) in shifted.lambda.iter().zip(&dense_lambda[4..9]) {
        assert!(
            (got - want).abs() <= case.eigenvalue_tolerance * want,
            "{got} vs {want}"
        );
    }
}
