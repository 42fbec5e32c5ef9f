//! Eigenvalue condition numbers (`stability::conditioning`): exact on a normal problem; near
//! Hoffmann's coalescence, growing as |μ − μ_c|^(−1/2) and bounding how far perturbations of
//! the matrices move the eigenvalue.

use serde::Deserialize;
use squeal_stages::artifact::CscMatrix;
use squeal_stages::stability::matrices::solve_matrices;

use crate::hoffmann::Hoffmann;
use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Conditioning {
    diagonal_stiffness: Vec<f64>,
    diagonal_tolerance: f64,
    /// |μ − μ_c| of the sweep above the coalescence.
    distances: Vec<f64>,
    slope: f64,
    slope_tolerance: f64,
    /// ε / |μ − μ_c|.
    perturbation_ratio: f64,
    perturbations: usize,
    bound_slack: f64,
    attained_fraction: f64,
}

#[test]
fn a_normal_problem_has_the_condition_numbers_of_its_closed_form() {
    let case: Conditioning = reference::load("eigenvalue_conditioning");
    let k = &case.diagonal_stiffness;
    let n = k.len();
    let diagonal = |values: &dyn Fn(usize) -> f64| {
        CscMatrix::from_triplets(n, n, (0..n).map(|i| (i, i, values(i))).collect())
    };
    let (M, C, K) = (
        diagonal(&|_| 1.0),
        CscMatrix::from_triplets(n, n, Vec::new()),
        diagonal(&|i| k[i]),
    );
    let pairs = solve_matrices(&M, &C, &K, 0.0, 1e-12).unwrap();
    let k_max = k.iter().copied().fold(0.0, f64::max);
    assert_eq!(pairs.len(), n);
    for (pair, &k_i) in pairs.iter().zip(k) {
        let expected = (k_i + k_max) / (2.0 * k_i);
        assert!(
            (pair.condition - expected).abs() < case.diagonal_tolerance * expected,
            "k = {k_i}: κ = {} vs {expected}",
            pair.condition
        );
    }
}

/// SplitMix64 in [−1, 1).
fn signed_uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    2.0 * (((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64) - 1.0
}

/// `A` plus a random perturbation of `‖·‖₁ = epsilon ‖A‖₁` on its 2×2 pattern.
fn perturbed(A: &CscMatrix, epsilon: f64, state: &mut u64) -> CscMatrix {
    let delta: Vec<f64> = (0..4).map(|_| signed_uniform(state)).collect();
    let delta_norm = (delta[0].abs() + delta[1].abs()).max(delta[2].abs() + delta[3].abs());
    let dense = A.to_dense();
    let scale = epsilon * A.norm_1() / delta_norm;
    CscMatrix::from_triplets(
        2,
        2,
        (0..4)
            .map(|entry| {
                let (row, col) = (entry % 2, entry / 2);
                (row, col, dense[(row, col)] + scale * delta[entry])
            })
            .collect(),
    )
}

#[test]
fn near_hoffmanns_coalescence_kappa_grows_as_the_inverse_square_root_and_bounds_perturbations() {
    let case: Conditioning = reference::load("eigenvalue_conditioning");
    let hoffmann: Hoffmann = reference::load("hoffmann");
    let [k11, k12, k22] = hoffmann.stiffness();
    let k3 = hoffmann.k[2];
    let mu_c = -((k11 - k22 - k3).powi(2) + 4.0 * k12 * k12) / (4.0 * k12 * k3);
    let growing = |pairs: &[squeal_stages::stability::EigenPair]| {
        pairs
            .iter()
            .max_by(|a, b| a.lambda.re.total_cmp(&b.lambda.re))
            .expect("two eigenvalues")
            .clone()
    };
    let mut state = 11;
    let mut points = Vec::new();
    for &distance in &case.distances {
        let [M, C, K] = hoffmann.matrices(mu_c + distance);
        let pair = growing(&solve_matrices(&M, &C, &K, 0.0, 1e-12).unwrap());
        let kappa = pair.condition;
        assert!(
            kappa.is_finite() && kappa > 1.0,
            "{distance:e}: κ = {kappa}"
        );
        let epsilon = case.perturbation_ratio * distance;
        let mut largest: f64 = 0.0;
        for _ in 0..case.perturbations {
            let (M2, K2) = (
                perturbed(&M, epsilon, &mut state),
                perturbed(&K, epsilon, &mut state),
            );
            let moved = solve_matrices(&M2, &C, &K2, 0.0, 1e-12)
                .unwrap()
                .iter()
                .map(|other| (other.lambda - pair.lambda).norm())
                .fold(f64::INFINITY, f64::min);
            let bound = kappa * epsilon * pair.lambda.norm();
            assert!(
                moved <= (1.0 + case.bound_slack) * bound,
                "|μ − μ_c| = {distance:e}: moved {moved:e} > κ ε |λ| = {bound:e}"
            );
            largest = largest.max(moved / bound);
        }
        assert!(
            largest >= case.attained_fraction,
            "|μ − μ_c| = {distance:e}: the perturbations reach {largest:.3} of the bound"
        );
        eprintln!(
            "|μ − μ_c| = {distance:.0e}: κ = {kappa:.3e}, error bound {:.1e}, perturbations reach {largest:.2} of κ ε |λ|",
            pair.condition * pair.residual
        );
        points.push((distance, kappa));
    }
    let slope = crate::fit::log_log_slope(&points);
    assert!(
        (slope - case.slope).abs() < case.slope_tolerance,
        "κ ∝ |μ − μ_c|^{slope:.4}"
    );
}
