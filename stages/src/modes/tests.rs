//! Verification of the modes: rigid-body modes of a free body, Euler–Bernoulli cantilever
//! frequencies and their convergence, Kirchhoff annular plate, repeated eigenvalues against a
//! dense solve, Sturm counts, residuals, reproducibility and errors.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Arc;

use faer::Par;

use super::Modes;
use crate::artifact::Artifact;
use crate::artifact::Model;
use crate::assemble::tests::{assemble, params_of, to_dense};
use crate::mesh::structured;
use crate::stage::{Input, Inputs, Stage, StageError, Value};
use crate::table::ColumnData;
use squeal_linalg::dense;
use squeal_linalg::eigensolver::{self, Band, Eigensolution, RESIDUAL_TOLERANCE, SolveOptions};

const STEEL_E: f64 = 2.02e11;
const STEEL_RHO: f64 = 7850.0;

fn lowest(model: &Model, n_modes: usize) -> Eigensolution {
    solve_band(
        model,
        Band {
            n_modes,
            lambda_lo: 0.0,
            lambda_hi: f64::INFINITY,
        },
    )
    .unwrap_or_else(|err| panic!("modes failed: {err}"))
}

fn solve_band(model: &Model, band: Band) -> Result<Eigensolution, StageError> {
    eigensolver::solve(
        &model.K,
        &model.M,
        &model.dof_of_node,
        band,
        SolveOptions::default(),
    )
    .map_err(StageError::from)
}

fn frequencies_hz(solution: &Eigensolution) -> Vec<f64> {
    solution
        .lambda
        .iter()
        .map(|lambda| super::omega_of(*lambda) / (2.0 * PI))
        .collect()
}

fn check_residuals_and_normalisation(model: &Model, solution: &Eigensolution) {
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

/// A cantilever of length `length` and square section `side`, clamped at x = 0.
fn cantilever(length: f64, side: f64, n_length: usize, n_side: usize) -> Model {
    let mesh = structured::block([length, side, side], [n_length, n_side, n_side], "disc");
    assemble(&mesh, "x0").0
}

/// Euler–Bernoulli cantilever: ω_k = (β_k L)² / L² √(E I / (ρ A)).
fn euler_bernoulli_hz(length: f64, side: f64, beta_l: f64) -> f64 {
    let radius_of_gyration_squared = side * side / 12.0;
    beta_l * beta_l / (length * length) * (STEEL_E * radius_of_gyration_squared / STEEL_RHO).sqrt()
        / (2.0 * PI)
}

#[test]
fn free_body_has_six_rigid_body_modes() {
    let mesh = structured::block([0.24, 0.12, 0.06], [12, 6, 3], "disc");
    let (model, _) = assemble(&mesh, "");
    assert!(model.n_dofs() > 1000, "exercise the Lanczos path");
    let solution = lowest(&model, 10);
    check_residuals_and_normalisation(&model, &solution);
    assert!(!solution.report.dense);
    let frequencies = frequencies_hz(&solution);
    let first_elastic = frequencies[6];
    for rigid in &frequencies[..6] {
        assert!(rigid.abs() < 1e-5 * first_elastic, "{frequencies:?}");
    }
    assert!(first_elastic > 1000.0, "{frequencies:?}");
    // The rigid modes carry the whole mass along each axis: Σ Γ_x² = m.
    let total_mass = STEEL_RHO * 0.24 * 0.12 * 0.06;
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
        (captured - total_mass).abs() < 1e-8 * total_mass,
        "{captured} vs {total_mass}"
    );
}

/// L/h = 40: the shear and rotary-inertia (Timoshenko) corrections to Euler–Bernoulli,
/// ½ (β r)² (1 + E/(κG)) with r² = h²/12, stay below 0.7 % up to the third mode. One element
/// through the thickness (the incompatible modes carry the bending), cubes along the length.
/// Slenderness also sets the conditioning: the roundoff floor of a residual is about
/// ε λ_max / λ₁ ≈ 3e-9 here, so a more slender beam could not meet the 1e-8 residual.
#[test]
fn cantilever_bending_frequencies_match_euler_bernoulli() {
    let (length, side) = (0.8, 0.02);
    let model = cantilever(length, side, 80, 1);
    let solution = lowest(&model, 6);
    assert!(!solution.report.dense, "exercise the Lanczos path");
    check_residuals_and_normalisation(&model, &solution);
    let frequencies = frequencies_hz(&solution);
    // Square section: the two bending directions give pairs.
    for (pair, beta_l) in [1.8751, 4.6941, 7.8548].into_iter().enumerate() {
        let exact = euler_bernoulli_hz(length, side, beta_l);
        for frequency in &frequencies[2 * pair..2 * pair + 2] {
            let error = (frequency - exact).abs() / exact;
            assert!(
                error < 0.01,
                "mode pair {pair}: {frequency} Hz vs {exact} Hz ({:.3} %)",
                100.0 * error
            );
        }
    }
}

/// Refining along the length, the frequency error of the third bending mode falls as h²
/// (eigenvalue error twice the order of the energy-norm error, O(h)). Errors against a mesh
/// four times finer than the finest measured (whose own error shifts the slope by about 0.04);
/// expected slope 2 ± 0.15.
#[test]
fn cantilever_frequency_converges_at_second_order() {
    let (length, side) = (0.8, 0.02);
    let third_bending = |n_length: usize| {
        let model = cantilever(length, side, n_length, 1);
        let solution = lowest(&model, 6);
        check_residuals_and_normalisation(&model, &solution);
        frequencies_hz(&solution)[4]
    };
    let reference = third_bending(160);
    let points: Vec<(f64, f64)> = [10usize, 20, 40]
        .iter()
        .map(|&n| {
            let error = (third_bending(n) - reference).abs() / reference;
            ((length / n as f64).ln(), error.ln())
        })
        .collect();
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / points.len() as f64;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / points.len() as f64;
    let slope = points
        .iter()
        .map(|p| (p.0 - mean_x) * (p.1 - mean_y))
        .sum::<f64>()
        / points.iter().map(|p| (p.0 - mean_x).powi(2)).sum::<f64>();
    assert!(
        (slope - 2.0).abs() < 0.15,
        "log-log slope {slope}, points {points:?}"
    );
}

/// Number of nodal diameters of a plate mode: the dominant Fourier harmonic of the
/// out-of-plane displacement around the outer rim (top face).
fn nodal_diameters(
    model: &Model,
    mesh: &crate::artifact::mesh::Mesh,
    shape: &[f64],
    max_n: usize,
) -> usize {
    let rim: Vec<u32> = mesh.node_sets["outer"]
        .iter()
        .copied()
        .filter(|node| mesh.node_sets["top"].binary_search(node).is_ok())
        .collect();
    let samples: Vec<(f64, f64)> = rim
        .iter()
        .map(|&node| {
            let [x, y, _] = mesh.nodes[node as usize];
            let w = model.dof_of_node[node as usize][2].map_or(0.0, |dof| shape[dof as usize]);
            (y.atan2(x), w)
        })
        .collect();
    // Amplitude of harmonic n: |Σ w| / N for n = 0, 2 |Σ w e^{inθ}| / N otherwise.
    let amplitude = |n: usize| {
        let (c, s) = samples.iter().fold((0.0, 0.0), |(c, s), (theta, w)| {
            (
                c + w * (n as f64 * theta).cos(),
                s + w * (n as f64 * theta).sin(),
            )
        });
        let factor = if n == 0 { 1.0 } else { 2.0 };
        factor * (c * c + s * s).sqrt() / samples.len() as f64
    };
    (0..=max_n)
        .max_by(|&m, &n| amplitude(m).total_cmp(&amplitude(n)))
        .unwrap_or(0)
}

/// Annular plate, b/a = 0.5, clamped inside, free outside (Kirchhoff, ν = 0.3):
/// ω = λ²/a² √(D/(ρh)), D = E h³ / (12 (1 − ν²)), within 2 %. h/a = 0.02 keeps the transverse
/// shear and rotary inertia corrections of the 3D model (∝ λ² (h/a)²) near 0.2 % for n = 4.
/// One and two elements through the thickness.
#[test]
fn annular_plate_matches_kirchhoff_theory() {
    let (a, b, h, nu) = (0.2, 0.1, 0.004, 0.3);
    for counts in [[8, 96, 1], [12, 96, 2]] {
        let mesh = structured::annulus(b, a, 0.0, h, counts, "disc");
        let params = params_of(
            &crate::assemble::Assemble,
            &[
                ("clamped", Value::Str("inner".into())),
                ("nu_disc", Value::Float(nu)),
            ],
        );
        let (model, _) =
            crate::assemble::assemble_model(&mesh, &params, &["inner".to_string()]).unwrap();
        let solution = lowest(&model, 9);
        check_residuals_and_normalisation(&model, &solution);
        let rigidity = STEEL_E * h.powi(3) / (12.0 * (1.0 - nu * nu));
        let theory =
            |lambda_squared: f64| lambda_squared / (a * a) * (rigidity / (STEEL_RHO * h)).sqrt();
        let expected = [13.024, 13.290, 14.704, 18.562, 25.596];
        let mut seen = [0usize; 5];
        for mode in 0..solution.lambda.len() {
            let shape: Vec<f64> = solution.shapes.col(mode).iter().copied().collect();
            let n = nodal_diameters(&model, &mesh, &shape, 8);
            assert!(n <= 4, "{counts:?}: mode {mode} has {n} nodal diameters");
            seen[n] += 1;
            let omega = solution.lambda[mode].sqrt();
            let error = (omega - theory(expected[n])).abs() / theory(expected[n]);
            assert!(
                error < 0.02,
                "{counts:?}: mode {mode}, n = {n}: omega = {omega}, Kirchhoff {} ({:.2} %)",
                theory(expected[n]),
                100.0 * error
            );
        }
        // n = 0 once, every n ≥ 1 as a repeated pair.
        assert_eq!(seen, [1, 2, 2, 2, 2], "{counts:?}");
    }
}

/// A square-section cantilever has repeated bending eigenvalues; block Lanczos must find both
/// copies of each: compared with a dense solve of the same (K, M), and by the Sturm count.
#[test]
fn repeated_eigenvalues_match_a_dense_solve() {
    let model = cantilever(0.48, 0.04, 24, 2);
    assert!(model.n_dofs() > 600 && model.n_dofs() < 700);
    let n_modes = 20;
    let solution = lowest(&model, n_modes);
    assert!(!solution.report.dense, "exercise the Lanczos path");
    check_residuals_and_normalisation(&model, &solution);
    let (dense_lambda, _) = dense::generalized_symmetric_eigen(
        to_dense(&model.K).as_ref(),
        to_dense(&model.M).as_ref(),
        Par::rayon(0),
    )
    .unwrap();
    // The dense eigenvalues are accurate to about ε λ_max / λ ≈ 1e-9 relative.
    for (mode, (lanczos, dense)) in solution.lambda.iter().zip(&dense_lambda).enumerate() {
        assert!(
            (lanczos - dense).abs() <= 1e-8 * dense.abs(),
            "mode {mode}: {lanczos} vs dense {dense}"
        );
    }
    let repeated = (1..n_modes)
        .filter(|&j| {
            (solution.lambda[j] - solution.lambda[j - 1]).abs() < 1e-8 * solution.lambda[j]
        })
        .count();
    assert!(
        repeated >= 4,
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
    let model = cantilever(0.48, 0.04, 24, 2);
    let (dense_lambda, _) = dense::generalized_symmetric_eigen(
        to_dense(&model.K).as_ref(),
        to_dense(&model.M).as_ref(),
        Par::rayon(0),
    )
    .unwrap();
    // Every mode up to the first gap after the 12th eigenvalue (not inside a repeated pair).
    let above = (12..dense_lambda.len())
        .find(|&j| dense_lambda[j] - dense_lambda[j - 1] > 1e-6 * dense_lambda[j])
        .unwrap();
    let lambda_hi = 0.5 * (dense_lambda[above - 1] + dense_lambda[above]);
    let band = solve_band(
        &model,
        Band {
            n_modes: 0,
            lambda_lo: 0.0,
            lambda_hi,
        },
    )
    .unwrap();
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
    )
    .unwrap();
    check_residuals_and_normalisation(&model, &shifted);
    for (got, want) in shifted.lambda.iter().zip(&dense_lambda[4..9]) {
        assert!((got - want).abs() <= 1e-8 * want, "{got} vs {want}");
    }
}

fn run_stage(
    model: &Model,
    overrides: &[(&str, Value)],
) -> Result<crate::stage::Outputs, StageError> {
    let params = params_of(&Modes, overrides);
    let inputs = Inputs(BTreeMap::from([(
        "model".to_string(),
        Input::One(Arc::new(Artifact::Model(Box::new(model.clone())))),
    )]));
    Modes.run(&params, &inputs)
}

#[test]
fn stage_outputs_are_reproducible_and_shaped_as_documented() {
    let model = cantilever(0.3, 0.03, 30, 2);
    let first = run_stage(&model, &[("n_modes", Value::Int(8))]).unwrap();
    let second = run_stage(&model, &[("n_modes", Value::Int(8))]).unwrap();
    for name in ["modes", "table", "shapes"] {
        assert_eq!(first[name].encode(), second[name].encode(), "output {name}");
    }
    let table = first["table"].as_table().unwrap();
    assert_eq!(table.n_rows(), 8);
    for column in [
        "mode",
        "freq_hz",
        "omega",
        "residual",
        "effective_mass_z_kg",
    ] {
        assert!(table.column(column).is_some(), "column {column}");
    }
    let shapes = first["shapes"].as_table().unwrap();
    assert_eq!(shapes.n_rows(), 3 * model.mesh.n_nodes());
    assert_eq!(shapes.columns().len(), 3 + 8);
    assert!(matches!(
        shapes.column("mode_0008"),
        Some(ColumnData::F64(_))
    ));
    match &first["modes"] {
        Artifact::RealModes(modes) => {
            assert_eq!(modes.omega.len(), 8);
            assert!(modes.omega.windows(2).all(|pair| pair[0] <= pair[1]));
            assert_eq!(modes.shapes[0].len(), model.n_dofs());
        }
        other => panic!("{other:?}"),
    }
}

/// The engine caches by content hash: one thread or several, the bytes must be the same.
#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mesh = structured::annulus(0.05, 0.12, 0.0, 0.01, [4, 40, 2], "disc");
    let (model, _) = assemble(&mesh, "inner");
    assert!(model.n_dofs() > 600, "exercise the Lanczos path");
    let run_with_threads = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let (model, _) = assemble(&mesh, "inner");
                let outputs = run_stage(&model, &[("n_modes", Value::Int(12))]).unwrap();
                (
                    Artifact::Model(Box::new(model)).encode(),
                    outputs["modes"].encode(),
                )
            })
    };
    let (model_one, modes_one) = run_with_threads(1);
    let (model_three, modes_three) = run_with_threads(3);
    assert!(model_one == model_three, "assembled model differs");
    assert!(modes_one == modes_three, "modes differ");
}

#[test]
fn empty_or_unbounded_bands_are_errors() {
    let model = cantilever(0.3, 0.03, 3, 1);
    let err = run_stage(&model, &[("n_modes", Value::Int(0))]).unwrap_err();
    assert!(err.message.contains("f_max_hz = 0"), "{err}");
    let err = run_stage(
        &model,
        &[
            ("f_max_hz", Value::Float(100.0)),
            ("shift_hz", Value::Float(200.0)),
        ],
    )
    .unwrap_err();
    assert!(err.message.contains("band is empty"), "{err}");
}
