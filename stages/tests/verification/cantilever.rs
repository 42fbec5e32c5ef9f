//! Euler–Bernoulli cantilever: the bending frequencies of a slender steel beam, and the order
//! at which the finite-element frequency converges as the mesh is refined.

use serde::Deserialize;

use crate::real_modes::{
    STEEL_E, STEEL_RHO, cantilever, check_residuals_and_normalisation, frequencies_hz, lowest,
};
use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Frequencies {
    length_m: f64,
    side_m: f64,
    n_length: usize,
    /// Roots β_k L of cos βL cosh βL = −1, first three.
    beta_l: Vec<f64>,
    /// |f − f_EB| / f_EB.
    tolerance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Convergence {
    length_m: f64,
    side_m: f64,
    /// Elements along the length of the measured meshes.
    n_lengths: Vec<usize>,
    /// Elements along the length of the reference mesh.
    n_reference: usize,
    /// The mode whose error is fitted (0-based, in frequency order).
    mode: usize,
    expected_slope: f64,
    slope_tolerance: f64,
}

/// ω_k = (β_k L)² / L² √(E I / (ρ A)) for a square section of side `side`.
fn euler_bernoulli_hz(length: f64, side: f64, beta_l: f64) -> f64 {
    let radius_of_gyration_squared = side * side / 12.0;
    beta_l * beta_l / (length * length) * (STEEL_E * radius_of_gyration_squared / STEEL_RHO).sqrt()
        / (2.0 * std::f64::consts::PI)
}

#[test]
fn cantilever_bending_frequencies_match_euler_bernoulli() {
    let case: Frequencies = reference::load("cantilever_frequencies");
    let model = cantilever(case.length_m, case.side_m, case.n_length, 1);
    let solution = lowest(&model, 2 * case.beta_l.len());
    assert!(!solution.report.dense, "exercise the Lanczos path");
    check_residuals_and_normalisation(&model, &solution);
    let frequencies = frequencies_hz(&solution);
    // Square section: the two bending directions give pairs.
    for (pair, &beta_l) in case.beta_l.iter().enumerate() {
        let exact = euler_bernoulli_hz(case.length_m, case.side_m, beta_l);
        for frequency in &frequencies[2 * pair..2 * pair + 2] {
            let error = (frequency - exact).abs() / exact;
            assert!(
                error < case.tolerance,
                "mode pair {pair}: {frequency} Hz vs {exact} Hz ({:.3} %)",
                100.0 * error
            );
        }
    }
}

#[test]
fn cantilever_frequency_converges_at_second_order() {
    let case: Convergence = reference::load("cantilever_convergence");
    let frequency = |n_length: usize| {
        let model = cantilever(case.length_m, case.side_m, n_length, 1);
        let solution = lowest(&model, case.mode + 2);
        check_residuals_and_normalisation(&model, &solution);
        frequencies_hz(&solution)[case.mode]
    };
    let reference = frequency(case.n_reference);
    let points: Vec<(f64, f64)> = case
        .n_lengths
        .iter()
        .map(|&n| {
            let error = (frequency(n) - reference).abs() / reference;
            (case.length_m / n as f64, error)
        })
        .collect();
    let slope = crate::fit::log_log_slope(&points);
    assert!(
        (slope - case.expected_slope).abs() < case.slope_tolerance,
        "log-log slope {slope}, points {points:?}"
    );
}
