//! Hoffmann's two-DOF friction model (`stability`'s quadratic eigensolver on lumped matrices):
//! the flutter onset μ_c and frequency ω_c in closed form, and the eigenvalue at μ = 0.38.
//!
//! A mass on springs k1, k2 at angles α1, α2, pressed on a belt through a contact spring k3
//! with friction μ: `M = I`, `C = 0`, `K = [[k11, k12 + μ k3], [k12, k22 + k3]]` with
//! `k11 = Σ kᵢ cos² αᵢ`, `k12 = Σ kᵢ cos αᵢ sin αᵢ`, `k22 = Σ kᵢ sin² αᵢ`. The two modes
//! merge at `μ_c = −((k11 − k22 − k3)² + 4 k12²) / (4 k12 k3)`, at `ω_c² = (k11 + k22 + k3)/2`.

use faer::c64;
use serde::Deserialize;
use squeal_stages::artifact::CscMatrix;
use squeal_stages::stability::matrices::solve_matrices;

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hoffmann {
    pub k: [f64; 3],
    angles_deg: [f64; 2],
    mu_c: f64,
    omega_c: f64,
    /// Tolerance of the closed forms against the tabulated μ_c, ω_c (their rounding).
    closed_form_tolerance: f64,
    mu: f64,
    /// The growing eigenvalue at `mu`: [Re λ, Im λ].
    lambda: [f64; 2],
    lambda_tolerance: f64,
    /// The onset found by bisection on the sign of max Re λ, against μ_c and ω_c.
    onset_tolerance: f64,
    onset_frequency_tolerance: f64,
}

impl Hoffmann {
    pub fn stiffness(&self) -> [f64; 3] {
        let [k1, k2, _] = self.k;
        let [a1, a2] = self.angles_deg.map(f64::to_radians);
        [
            k1 * a1.cos().powi(2) + k2 * a2.cos().powi(2),
            k1 * a1.cos() * a1.sin() + k2 * a2.cos() * a2.sin(),
            k1 * a1.sin().powi(2) + k2 * a2.sin().powi(2),
        ]
    }

    pub fn matrices(&self, mu: f64) -> [CscMatrix; 3] {
        let [k11, k12, k22] = self.stiffness();
        let k3 = self.k[2];
        let K = CscMatrix::from_triplets(
            2,
            2,
            vec![
                (0, 0, k11),
                (0, 1, k12 + mu * k3),
                (1, 0, k12),
                (1, 1, k22 + k3),
            ],
        );
        let M = CscMatrix::from_triplets(2, 2, vec![(0, 0, 1.0), (1, 1, 1.0)]);
        let C = CscMatrix::from_triplets(2, 2, Vec::new());
        [M, C, K]
    }

    fn most_unstable(&self, mu: f64) -> c64 {
        let [M, C, K] = self.matrices(mu);
        solve_matrices(&M, &C, &K, 0.0, 1e-12)
            .expect("dense quadratic eigensolve")
            .into_iter()
            .map(|pair| pair.lambda)
            .max_by(|a, b| a.re.total_cmp(&b.re))
            .expect("two eigenvalues")
    }
}

#[test]
fn hoffmann_two_dof_model_matches_its_closed_forms() {
    let case: Hoffmann = reference::load("hoffmann");
    let [k11, k12, k22] = case.stiffness();
    let k3 = case.k[2];
    let mu_c = -((k11 - k22 - k3).powi(2) + 4.0 * k12 * k12) / (4.0 * k12 * k3);
    let omega_c = ((k11 + k22 + k3) / 2.0).sqrt();
    assert!(
        (mu_c - case.mu_c).abs() < case.closed_form_tolerance,
        "{mu_c}"
    );
    assert!(
        (omega_c - case.omega_c).abs() < case.closed_form_tolerance,
        "{omega_c}"
    );

    let lambda = case.most_unstable(case.mu);
    assert!(
        (lambda.re - case.lambda[0]).abs() < case.lambda_tolerance,
        "{lambda}"
    );
    assert!(
        (lambda.im - case.lambda[1]).abs() < case.lambda_tolerance,
        "{lambda}"
    );

    // The flutter onset by bisection on the sign of max Re λ.
    let (mut stable, mut unstable) = (0.2, case.mu);
    while unstable - stable > 1e-10 {
        let mid = 0.5 * (stable + unstable);
        if case.most_unstable(mid).re > 1e-9 {
            unstable = mid;
        } else {
            stable = mid;
        }
    }
    assert!(
        (unstable - mu_c).abs() < case.onset_tolerance,
        "{unstable} vs {mu_c}"
    );
    let at_onset = case.most_unstable(unstable);
    assert!(
        (at_onset.im - omega_c).abs() < case.onset_frequency_tolerance,
        "{at_onset}"
    );
}
