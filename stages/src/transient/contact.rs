//! The contact problem of one time step, on the contact pairs only.
//!
//! Unknowns: the reaction `r_p = (r_n, r_t, r_b)` of every pair `p` (the force the disc
//! exerts on the pad, `r_n ≥ 0` compression, as everywhere in squeal). The end-of-step relative
//! velocities are affine in them, `w = w_free + W r`, with the Delassus operator `W`. The laws
//! (Signorini with the equivalent gap, Coulomb with the disc's sliding velocity `v_g` along t):
//!
//! ```text
//! 0 ≤ r_n  ⊥  w_n − w_n,min ≥ 0                    (w_n,min = −B̃/τ)
//! s = (w_t − v_g, w_b),   ‖r_T‖ ≤ μ r_n,   s ≠ 0 ⇒ r_T = −μ r_n s/‖s‖
//! ```
//!
//! Both solvers iterate the projection form of the laws, for any ρ > 0,
//!
//! ```text
//! r_n ← max(0, r_n − ρ_n (w_n − w_n,min)),    r_T ← proj_{‖·‖ ≤ μ r_n}(r_T − ρ_T s)
//! ```
//!
//! with `ρ` from the diagonal of `W` (`ρ_n = 1/W_nn`, `ρ_T = 1/max(W_tt, W_bb)` per pair: one
//! length for both tangential directions keeps the disk projection isotropic), whose
//! fixed points are exactly the solutions:
//! - [`Solver::FixedPoint`], the classic algorithm of the method: every pair at once from the
//!   previous iterate (a Jacobi sweep), `w = w_free + W r` once per iteration;
//! - [`Solver::GaussSeidel`] (projected Gauss–Seidel, the default): pair after pair, each using
//!   the reactions already updated in the sweep, iterated locally until its 3 × 3 block settles,
//!   `w` kept current by rank-3 updates. It needs fewer sweeps and does not depend on
//!   diagonal dominance of `W` to converge.
//!
//! Convergence is measured by the natural residual `max_p ‖r_p − proj(r_p)‖ / R`, `R` the
//! force scale (the largest equilibrium reaction, or the largest reaction found).

use faer::MatRef;

/// Sweeps of the local projection on one pair within a Gauss–Seidel sweep.
const LOCAL_ITERATIONS: usize = 16;
/// Residuals kept for an error message.
const HISTORY_KEPT: usize = 12;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solver {
    GaussSeidel,
    FixedPoint,
}

/// The data of one step's problem.
pub struct Problem<'a> {
    /// The Delassus operator, 3 rows and columns per pair in the order (n, t, b).
    pub W: MatRef<'a, f64>,
    /// End-of-step relative velocities without reaction.
    pub w_free: &'a [f64],
    /// Least normal relative velocity per pair, `−B̃/τ`.
    pub w_n_min: &'a [f64],
    /// Sliding speed `|v_g|` of the disc per pair.
    pub sliding_speed: &'a [f64],
    pub mu: f64,
    /// Force scale of the residual (N).
    pub force_scale: f64,
}

/// How a solve went.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub iterations: usize,
    pub residual: f64,
}

/// A solve that did not reach its tolerance: the iterations done and the last residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct NotConverged {
    pub iterations: usize,
    pub history: Vec<f64>,
}

struct Step {
    rho_n: Vec<f64>,
    rho_T: Vec<f64>,
}

impl Problem<'_> {
    fn n_pairs(&self) -> usize {
        self.w_n_min.len()
    }

    fn step_lengths(&self) -> Step {
        let W = self.W;
        let (mut rho_n, mut rho_T) = (Vec::new(), Vec::new());
        for p in 0..self.n_pairs() {
            let k = 3 * p;
            rho_n.push(1.0 / W[(k, k)]);
            rho_T.push(1.0 / W[(k + 1, k + 1)].max(W[(k + 2, k + 2)]));
        }
        Step { rho_n, rho_T }
    }

    /// The projection of the laws for pair `p` at reaction `r` and velocities `w`.
    fn project(&self, p: usize, step: &Step, r: [f64; 3], w: [f64; 3]) -> [f64; 3] {
        let r_n = (r[0] - step.rho_n[p] * (w[0] - self.w_n_min[p])).max(0.0);
        let slip = [w[1] - self.sliding_speed[p], w[2]];
        let trial = [
            r[1] - step.rho_T[p] * slip[0],
            r[2] - step.rho_T[p] * slip[1],
        ];
        let radius = self.mu * r_n;
        let length = trial[0].hypot(trial[1]);
        let scale = if length > radius {
            radius / length
        } else {
            1.0
        };
        [r_n, trial[0] * scale, trial[1] * scale]
    }

    fn residual(&self, step: &Step, r: &[f64], w: &[f64]) -> f64 {
        let mut worst: f64 = 0.0;
        let mut largest: f64 = 0.0;
        for p in 0..self.n_pairs() {
            let r_p = pair(r, p);
            let projected = self.project(p, step, r_p, pair(w, p));
            let change = (0..3)
                .map(|d| (projected[d] - r_p[d]).abs())
                .fold(0.0, f64::max);
            worst = worst.max(change);
            largest = largest
                .max(r_p[0].abs())
                .max(r_p[1].abs())
                .max(r_p[2].abs());
        }
        let scale = self.force_scale.max(largest);
        if scale > 0.0 { worst / scale } else { 0.0 }
    }
}

fn pair(values: &[f64], p: usize) -> [f64; 3] {
    [values[3 * p], values[3 * p + 1], values[3 * p + 2]]
}

/// `w = w_free + W r`.
fn velocities(problem: &Problem, r: &[f64], w: &mut [f64]) {
    let W = problem.W;
    for (row, slot) in w.iter_mut().enumerate() {
        let mut sum = problem.w_free[row];
        for (col, value) in r.iter().enumerate() {
            sum += W[(row, col)] * value;
        }
        *slot = sum;
    }
}

/// Solves the step's problem from the reactions `r` (a warm start, overwritten with the
/// solution); `w` receives the matching velocities.
pub fn solve(
    problem: &Problem,
    solver: Solver,
    tolerance: f64,
    max_iterations: usize,
    r: &mut [f64],
    w: &mut [f64],
) -> Result<Report, NotConverged> {
    let step = problem.step_lengths();
    velocities(problem, r, w);
    let mut history = Vec::new();
    let mut next = vec![0.0; r.len()];
    for iteration in 1..=max_iterations {
        match solver {
            Solver::FixedPoint => {
                for p in 0..problem.n_pairs() {
                    let projected = problem.project(p, &step, pair(r, p), pair(w, p));
                    next[3 * p..3 * p + 3].copy_from_slice(&projected);
                }
                r.copy_from_slice(&next);
                velocities(problem, r, w);
            }
            Solver::GaussSeidel => gauss_seidel_sweep(problem, &step, r, w),
        }
        let residual = problem.residual(&step, r, w);
        history.push(residual);
        if history.len() > HISTORY_KEPT {
            history.remove(0);
        }
        if residual <= tolerance {
            return Ok(Report {
                iterations: iteration,
                residual,
            });
        }
        if !residual.is_finite() {
            break;
        }
    }
    Err(NotConverged {
        iterations: max_iterations,
        history,
    })
}

/// One Gauss–Seidel sweep over the pairs; `w` is kept equal to `w_free + W r`.
fn gauss_seidel_sweep(problem: &Problem, step: &Step, r: &mut [f64], w: &mut [f64]) {
    let W = problem.W;
    for p in 0..problem.n_pairs() {
        let k = 3 * p;
        let start = pair(r, p);
        let mut r_p = start;
        let mut w_p = pair(w, p);
        for _ in 0..LOCAL_ITERATIONS {
            let projected = problem.project(p, step, r_p, w_p);
            let delta = [
                projected[0] - r_p[0],
                projected[1] - r_p[1],
                projected[2] - r_p[2],
            ];
            if delta == [0.0; 3] {
                break;
            }
            for (i, slot) in w_p.iter_mut().enumerate() {
                *slot += (0..3).map(|j| W[(k + i, k + j)] * delta[j]).sum::<f64>();
            }
            r_p = projected;
        }
        let delta = [r_p[0] - start[0], r_p[1] - start[1], r_p[2] - start[2]];
        if delta != [0.0; 3] {
            for (row, slot) in w.iter_mut().enumerate() {
                *slot += W[(row, k)] * delta[0]
                    + W[(row, k + 1)] * delta[1]
                    + W[(row, k + 2)] * delta[2];
            }
            r[k..k + 3].copy_from_slice(&r_p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A small coupled problem: pairs sharing compliance through off-diagonal terms.
    fn problem_data(n_pairs: usize) -> (Mat<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let m = 3 * n_pairs;
        let B = Mat::from_fn(m, m, |i, j| {
            let x = ((i * 7 + j * 13) % 11) as f64 / 11.0 - 0.5;
            if i == j { 2.0 + x } else { 0.3 * x }
        });
        let W = B.transpose() * &B;
        // Some pairs pressed (negative free normal velocity), some leaving.
        let w_free: Vec<f64> = (0..m)
            .map(|i| match i % 3 {
                0 => {
                    if (i / 3) % 3 == 2 {
                        0.5
                    } else {
                        -1.0
                    }
                }
                1 => 0.2 * ((i / 3) as f64 - 1.0),
                _ => 0.1,
            })
            .collect();
        let w_n_min = vec![0.0; n_pairs];
        let sliding = vec![1.0; n_pairs];
        (W, w_free, w_n_min, sliding)
    }

    fn solve_with(solver: Solver, mu: f64) -> (Vec<f64>, Vec<f64>, Report) {
        let n_pairs = 6;
        let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
        let problem = Problem {
            W: W.as_ref(),
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            mu,
            force_scale: 0.0,
        };
        let mut r = vec![0.0; 3 * n_pairs];
        let mut w = vec![0.0; 3 * n_pairs];
        let report = solve(&problem, solver, 1e-13, 20_000, &mut r, &mut w).unwrap();
        (r, w, report)
    }

    /// Checks every law on the solution, to `tolerance` in forces and velocities.
    fn check_laws(r: &[f64], w: &[f64], mu: f64, tolerance: f64) {
        for p in 0..r.len() / 3 {
            let (r_p, w_p) = (pair(r, p), pair(w, p));
            assert!(
                r_p[0] >= 0.0 && w_p[0] >= -tolerance,
                "pair {p}: {r_p:?} {w_p:?}"
            );
            assert!(
                (r_p[0] * w_p[0]).abs() < tolerance,
                "complementarity at pair {p}"
            );
            let r_T = r_p[1].hypot(r_p[2]);
            assert!(r_T <= mu * r_p[0] * (1.0 + 1e-12) + tolerance);
            let slip = [w_p[1] - 1.0, w_p[2]];
            let slip_speed = slip[0].hypot(slip[1]);
            if slip_speed > tolerance {
                // Sliding: on the cone's edge, against the slip.
                assert!((r_T - mu * r_p[0]).abs() < tolerance * 10.0, "pair {p}");
                let alignment = (r_p[1] * slip[0] + r_p[2] * slip[1]) / (r_T * slip_speed);
                assert!(
                    r_T == 0.0 || alignment < -1.0 + 1e-8,
                    "pair {p}: {alignment}"
                );
            }
        }
    }

    #[test]
    fn both_solvers_satisfy_the_laws_and_agree() {
        for mu in [0.0, 0.38, 1.2] {
            let (r_gs, w_gs, report_gs) = solve_with(Solver::GaussSeidel, mu);
            let (r_fp, w_fp, report_fp) = solve_with(Solver::FixedPoint, mu);
            check_laws(&r_gs, &w_gs, mu, 1e-10);
            check_laws(&r_fp, &w_fp, mu, 1e-10);
            for (a, b) in r_gs.iter().zip(&r_fp) {
                assert!((a - b).abs() < 1e-9, "mu = {mu}: {a} vs {b}");
            }
            assert!(
                report_gs.iterations <= report_fp.iterations,
                "mu = {mu}: Gauss-Seidel {} sweeps, fixed point {}",
                report_gs.iterations,
                report_fp.iterations
            );
        }
    }

    #[test]
    fn a_pressed_single_pair_sticks_or_slides_as_coulomb_says() {
        // W = I: w = w_free + r. Pressed (w_free,n = −1) ⇒ r_n = 1. Free slip w_t − v_g =
        // −0.5: sticking needs r_t = 0.5, allowed when μ ≥ 0.5.
        let W = Mat::<f64>::identity(3, 3);
        for (mu, expected_r_t) in [(0.8, 0.5), (0.3, 0.3)] {
            let problem = Problem {
                W: W.as_ref(),
                w_free: &[-1.0, 0.5, 0.0],
                w_n_min: &[0.0],
                sliding_speed: &[1.0],
                mu,
                force_scale: 1.0,
            };
            let (mut r, mut w) = (vec![0.0; 3], vec![0.0; 3]);
            solve(&problem, Solver::GaussSeidel, 1e-14, 100, &mut r, &mut w).unwrap();
            assert!((r[0] - 1.0).abs() < 1e-14);
            assert!((r[1] - expected_r_t).abs() < 1e-14, "mu = {mu}: {r:?}");
            assert!(r[2].abs() < 1e-14);
        }
    }

    #[test]
    fn a_solve_that_cannot_converge_reports_its_residuals() {
        let (W, w_free, w_n_min, sliding) = problem_data(6);
        let problem = Problem {
            W: W.as_ref(),
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            mu: 0.38,
            force_scale: 0.0,
        };
        let (mut r, mut w) = (vec![0.0; 18], vec![0.0; 18]);
        let failure = solve(&problem, Solver::FixedPoint, 1e-15, 2, &mut r, &mut w).unwrap_err();
        assert_eq!(failure.iterations, 2);
        assert_eq!(failure.history.len(), 2);
        assert!(failure.history.iter().all(|residual| *residual > 1e-15));
    }
}
