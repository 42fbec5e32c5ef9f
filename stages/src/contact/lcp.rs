//! The condensed sliding-contact problem and its two solvers.
//!
//! On the contact pairs, with every closed pair sliding (r_t = μ r_n, r_b = 0), the normal
//! gaps depend linearly on the normal reactions through the condensed operator
//! W = H K⁻¹ Hᵀ:  g = q + A r,  A = W_nn + μ W_nt,  q = g₀ + (H K⁻¹ F)_n.
//! Signorini's law is then the linear complementarity problem
//!
//! ```text
//! r ≥ 0,   g = q + A r ≥ 0,   rᵀ g = 0
//! ```
//!
//! - [`fixed_point`]: the seed paper's augmented-Lagrangian iteration
//!   r ← proj_{R+}(r − ρ ∘ g(r)) with ρᵢ = ω / Aᵢᵢ (the diagonal approximation of the
//!   condensed operator for the augmentation parameters).
//! - [`semismooth_newton`]: a primal–dual active-set (semi-smooth Newton) method on
//!   min(r, c g) = 0: guess the closed set, solve A_CC r_C = −q_C, update, until the set repeats.
//!   It ends in a few iterations where the fixed point needs hundreds.
//!
//! Both report the complementarity residual ‖min(r, g/ρ̄)‖∞ scaled by the largest reaction,
//! and fail loudly with their residual history.

use faer::Mat;
use faer::linalg::solvers::Solve;

/// A solution of the condensed problem.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpSolution {
    /// Normal reactions (≥ 0: compression).
    pub r: Vec<f64>,
    /// Normal gaps (≥ 0: open).
    pub g: Vec<f64>,
    pub iterations: usize,
    /// Complementarity residual after each iteration.
    pub history: Vec<f64>,
}

impl LcpSolution {
    pub fn residual(&self) -> f64 {
        self.history.last().copied().unwrap_or(f64::INFINITY)
    }
}

/// Why a solver gave up, with the residual history.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpError {
    pub solver: &'static str,
    pub iterations: usize,
    pub history: Vec<f64>,
    pub tolerance: f64,
}

impl std::fmt::Display for LcpError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let shown: Vec<String> = self
            .history
            .iter()
            .rev()
            .take(5)
            .rev()
            .map(|value| format!("{value:.3e}"))
            .collect();
        write!(
            f,
            "{} did not converge in {} iterations: complementarity residual {:.3e} > {:.1e} (last residuals: {})",
            self.solver,
            self.iterations,
            self.history.last().copied().unwrap_or(f64::NAN),
            self.tolerance,
            shown.join(", ")
        )
    }
}

/// Settings shared by both solvers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LcpSettings {
    pub tolerance: f64,
    pub max_iterations: usize,
    /// Relaxation ω of the fixed point's augmentation parameters ρᵢ = ω / Aᵢᵢ.
    pub relaxation: f64,
}

impl Default for LcpSettings {
    fn default() -> Self {
        LcpSettings {
            tolerance: 1e-10,
            max_iterations: 10_000,
            relaxation: 1.0,
        }
    }
}

fn gaps(a: &Mat<f64>, q: &[f64], r: &[f64]) -> Vec<f64> {
    (0..q.len())
        .map(|i| q[i] + (0..r.len()).map(|j| a[(i, j)] * r[j]).sum::<f64>())
        .collect()
}

/// ‖min(r, Aᵢᵢ g)‖∞ / max(‖r‖∞, ‖Aᵢᵢ q‖∞): zero exactly at a solution, in units of force.
pub fn complementarity_residual(a: &Mat<f64>, q: &[f64], r: &[f64], g: &[f64]) -> f64 {
    let force = |i: usize, gap: f64| gap / a[(i, i)];
    let scale = (0..q.len())
        .map(|i| r[i].abs().max(force(i, q[i]).abs()))
        .fold(f64::MIN_POSITIVE, f64::max);
    let worst = (0..q.len())
        .map(|i| r[i].min(force(i, g[i])).abs())
        .fold(0.0, f64::max);
    worst / scale
}

fn check_diagonal(a: &Mat<f64>, solver: &'static str) -> Result<(), LcpError> {
    // A non-positive (or NaN) diagonal leaves the augmentation parameters undefined.
    if (0..a.nrows()).any(|i| a[(i, i)].is_nan() || a[(i, i)] <= 0.0) {
        return Err(LcpError {
            solver,
            iterations: 0,
            history: vec![f64::INFINITY],
            tolerance: 0.0,
        });
    }
    Ok(())
}

/// The seed paper's projected fixed point (Jacobi form).
pub fn fixed_point(
    a: &Mat<f64>,
    q: &[f64],
    settings: &LcpSettings,
) -> Result<LcpSolution, LcpError> {
    const SOLVER: &str = "fixed point";
    check_diagonal(a, SOLVER)?;
    let n = q.len();
    let rho: Vec<f64> = (0..n).map(|i| settings.relaxation / a[(i, i)]).collect();
    let mut r = vec![0.0; n];
    let mut history = Vec::new();
    for iteration in 1..=settings.max_iterations {
        let g = gaps(a, q, &r);
        for i in 0..n {
            r[i] = (r[i] - rho[i] * g[i]).max(0.0);
        }
        let g = gaps(a, q, &r);
        let residual = complementarity_residual(a, q, &r, &g);
        history.push(residual);
        if residual <= settings.tolerance {
            return Ok(LcpSolution {
                r,
                g,
                iterations: iteration,
                history,
            });
        }
        if !residual.is_finite() {
            break;
        }
    }
    Err(LcpError {
        solver: SOLVER,
        iterations: history.len(),
        history,
        tolerance: settings.tolerance,
    })
}

/// Primal–dual active set (semi-smooth Newton on min(r, c g) = 0, c = 1/mean Aᵢᵢ).
pub fn semismooth_newton(
    a: &Mat<f64>,
    q: &[f64],
    settings: &LcpSettings,
) -> Result<LcpSolution, LcpError> {
    const SOLVER: &str = "semi-smooth Newton";
    check_diagonal(a, SOLVER)?;
    let n = q.len();
    let mut r = vec![0.0; n];
    let mut g = q.to_vec();
    let mut history = Vec::new();
    let mut previous_closed: Option<Vec<bool>> = None;
    for iteration in 1..=settings.max_iterations.min(20 * n.max(1)) {
        // A pair is closed when its reaction, or the force its penetration would take, is positive.
        let closed: Vec<bool> = (0..n).map(|i| r[i] - g[i] / a[(i, i)] > 0.0).collect();
        let indices: Vec<usize> = (0..n).filter(|&i| closed[i]).collect();
        r = vec![0.0; n];
        if !indices.is_empty() {
            let block = Mat::from_fn(indices.len(), indices.len(), |row, col| {
                a[(indices[row], indices[col])]
            });
            let rhs = Mat::from_fn(indices.len(), 1, |row, _| -q[indices[row]]);
            let solution = block.partial_piv_lu().solve(&rhs);
            for (row, &i) in indices.iter().enumerate() {
                r[i] = solution[(row, 0)];
            }
        }
        g = gaps(a, q, &r);
        let residual = complementarity_residual(a, q, &r, &g);
        history.push(residual);
        if residual <= settings.tolerance {
            return Ok(LcpSolution {
                r,
                g,
                iterations: iteration,
                history,
            });
        }
        // The same closed set twice without convergence: the iteration cycles or stalls.
        if previous_closed.as_ref() == Some(&closed) {
            break;
        }
        previous_closed = Some(closed);
    }
    Err(LcpError {
        solver: SOLVER,
        iterations: history.len(),
        history,
        tolerance: settings.tolerance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reactions non-negative, penetrations within the tolerance (as forces), complementary.
    fn check_solution(a: &Mat<f64>, q: &[f64], solution: &LcpSolution) {
        let largest = solution.r.iter().fold(0.0f64, |max, r| max.max(*r));
        for i in 0..q.len() {
            assert!(solution.r[i] >= 0.0, "r[{i}] = {}", solution.r[i]);
            assert!(
                solution.g[i] / a[(i, i)] >= -1e-10 * largest,
                "g[{i}] = {}",
                solution.g[i]
            );
        }
        assert!(complementarity_residual(a, q, &solution.r, &solution.g) <= 1e-10);
    }

    /// A small symmetric positive definite operator with off-diagonal coupling.
    fn spd(n: usize) -> Mat<f64> {
        Mat::from_fn(n, n, |i, j| {
            if i == j {
                4.0
            } else {
                1.0 / (1.0 + (i as f64 - j as f64).abs())
            }
        })
    }

    #[test]
    fn both_solvers_agree_on_a_mixed_open_and_closed_problem() {
        let a = spd(8);
        let q: Vec<f64> = (0..8)
            .map(|i| {
                if i % 3 == 0 {
                    0.5
                } else {
                    -1.0 - i as f64 * 0.1
                }
            })
            .collect();
        let newton = semismooth_newton(&a, &q, &LcpSettings::default()).unwrap();
        let fixed = fixed_point(
            &a,
            &q,
            &LcpSettings {
                relaxation: 0.5,
                ..LcpSettings::default()
            },
        )
        .unwrap();
        check_solution(&a, &q, &newton);
        check_solution(&a, &q, &fixed);
        for i in 0..8 {
            assert!(
                (newton.r[i] - fixed.r[i]).abs()
                    <= 1e-9 * newton.r.iter().fold(0.0f64, |m, v| m.max(*v))
            );
        }
        assert!(newton.iterations <= 5, "{} iterations", newton.iterations);
        assert!(newton.r.contains(&0.0) && newton.r.iter().any(|r| *r > 0.0));
    }

    #[test]
    fn one_spring_pressed_by_an_interference_has_the_closed_form_force() {
        // A pad of stiffness k pressed by an interference δ: r = k δ, g = 0.
        let (k, delta) = (2.0e7, 1.0e-4);
        let a = Mat::from_fn(1, 1, |_, _| 1.0 / k);
        let q = [-delta];
        for solution in [
            semismooth_newton(&a, &q, &LcpSettings::default()).unwrap(),
            fixed_point(&a, &q, &LcpSettings::default()).unwrap(),
        ] {
            assert!((solution.r[0] - k * delta).abs() <= 1e-9 * k * delta);
            assert!(solution.g[0].abs() <= 1e-15);
        }
        let open = semismooth_newton(&a, &[delta], &LcpSettings::default()).unwrap();
        assert_eq!(open.r, [0.0]);
    }

    #[test]
    fn a_nonconverging_fixed_point_reports_its_residual_history() {
        // Over-relaxed Jacobi on a strongly coupled operator diverges.
        let a = Mat::from_fn(4, 4, |i, j| if i == j { 1.0 } else { 0.9 });
        let q = [-1.0; 4];
        let settings = LcpSettings {
            relaxation: 1.9,
            max_iterations: 50,
            ..LcpSettings::default()
        };
        let err = fixed_point(&a, &q, &settings).unwrap_err();
        let message = err.to_string();
        assert!(
            message.starts_with("fixed point did not converge in"),
            "{message}"
        );
        assert!(message.contains("last residuals:"), "{message}");
        assert!(semismooth_newton(&a, &q, &LcpSettings::default()).is_ok());
    }
}
