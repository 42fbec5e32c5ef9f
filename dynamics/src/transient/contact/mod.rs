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
//! The solvers ([`Solver`], the transient's `solver` parameter) share the laws and the step's
//! problem (`laws.rs`) and the Delassus operator (`delassus.rs`):
//! - the iterative ones iterate the projection form of the laws, every pair at once or pair
//!   after pair, pad by pad (`iterative.rs`), Gauss–Seidel's sweeps accelerated by Anderson
//!   mixing (`anderson.rs`);
//! - the active-set solver (the default) runs a chord iteration on the factorised laws of the
//!   pairs' set (open, sticking or sliding) while the set holds from one step to the next,
//!   and falls back to Gauss–Seidel when it changes (`active_set.rs`).
//!
//! Every solver's step is accepted on the same natural residual.
//!
//! # Precision
//!
//! A step is bound by reading its operators (J's factor, `Y`, `W`, the products: on a reduced
//! brake more than the cache holds). So at tolerances of at least 1e-9
//! (`SINGLE_PRECISION_TOLERANCE`) the iterations' passes over `W` — Gauss–Seidel's updates
//! of the rest of `w` after a block, the chord's `w += W Δr` — read a single-precision copy,
//! half the bytes. Each pass then leaves an error of about `2⁻²⁴ |W Δr|` in `w`, small against
//! the step's change of velocity but not always against the tolerance. So a step solved this
//! way is accepted on its exact velocities: the scheme computes `w = H v¹` from the step's
//! own solution ([`ContactSolver::settle`]). A solution that misses the tolerance there is
//! refined by Gauss–Seidel in double precision from `w = H v¹` and the step solved again
//! ([`ContactSolver::refine`]), and the next steps are solved in double precision, for twice
//! as long after each refusal that follows fewer than `PAYBACK_STEPS` acceptances. Tighter
//! tolerances are solved in double precision throughout, and so is the fixed-point solver
//! (it rebuilds `w` from the whole of `r`).

mod active_set;
mod anderson;
mod delassus;
mod iterative;
mod laws;
#[cfg(test)]
mod tests;

use serde::{Deserialize, Serialize};

pub use active_set::Linearisation;
use active_set::{Factorisation, LastSolution, Pacing};
use delassus::velocities;
pub use delassus::{Delassus, Precision};
use iterative::iterate;
pub use iterative::pad_blocks;
pub use laws::{PairState, Problem, Solver, classify, pair};

/// The least tolerance tried with passes over `W` in single precision. Below it, their
/// rounding most often misses the tolerance, and every step would be solved twice before
/// the run settles in double.
const SINGLE_PRECISION_TOLERANCE: f64 = 1e-9;

/// How a solve went.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub iterations: usize,
    pub residual: f64,
    /// The passes' precision: after [`Precision::Single`] the residual is the iteration's,
    /// to be confirmed by [`ContactSolver::settle`].
    pub precision: Precision,
}

/// A solve that did not reach its tolerance: the iterations done and the last residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct NotConverged {
    pub iterations: usize,
    pub history: Vec<f64>,
}

/// The memory of a [`ContactSolver`] between steps: what a checkpoint keeps.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Memory {
    /// Where the active set's factorisation was built (it is rebuilt from this on restoring).
    factorised: Option<Linearisation>,
    /// The active set of the last step.
    previous: Option<Vec<PairState>>,
    last: Option<LastSolution>,
    /// When a factorisation is worth trying.
    pacing: Pacing,
    /// When passes in single precision are worth trying: after a refused solution the next
    /// steps are solved in double.
    single: Pacing,
}

/// A contact solver with what it keeps from step to step.
pub struct ContactSolver {
    solver: Solver,
    memory: Memory,
    /// The factorisation at `memory.factorised`.
    factorisation: Option<Factorisation>,
    /// Factorisations so far (for benchmarks; not part of any output).
    pub factorisations: usize,
    /// Solutions refined in double precision so far (likewise).
    pub refinements: usize,
    /// Vectors a step reuses rather than allocates.
    scratch: Scratch,
}

/// The active-set solver's warm start, kept while its chord iterates, and the chord's
/// corrections.
#[derive(Default)]
struct Scratch {
    r: Vec<f64>,
    w: Vec<f64>,
    F: Vec<f32>,
}

impl ContactSolver {
    pub fn new(solver: Solver) -> ContactSolver {
        ContactSolver {
            solver,
            memory: Memory::default(),
            factorisation: None,
            factorisations: 0,
            refinements: 0,
            scratch: Scratch::default(),
        }
    }

    /// What a checkpoint keeps.
    pub fn memory(&self) -> Memory {
        self.memory.clone()
    }

    /// Takes back a checkpoint's memory, for a problem of the same run.
    pub fn restore(&mut self, mut memory: Memory, problem: &Problem) {
        let factorised = memory.factorised.take();
        self.memory = memory;
        self.factorise_at(problem, factorised);
    }

    /// Solves the step's problem from the reactions `r` (the last solution, or any warm
    /// start; overwritten with the solution); `w` receives the matching velocities.
    pub fn solve(
        &mut self,
        problem: &Problem,
        tolerance: f64,
        max_iterations: usize,
        r: &mut [f64],
        w: &mut [f64],
    ) -> Result<Report, NotConverged> {
        match &self.memory.last {
            Some(LastSolution {
                r: r_0,
                W_r: W_r_0,
                before: Some((r_1, W_r_1)),
            }) if r_0 == r => {
                for k in 0..r.len() {
                    r[k] = 2.0 * r_0[k] - r_1[k];
                    w[k] = problem.w_free[k] + (2.0 * W_r_0[k] - W_r_1[k]);
                }
            }
            Some(last) if last.r == r => {
                for ((slot, w_free), W_r) in w.iter_mut().zip(problem.w_free).zip(&last.W_r) {
                    *slot = w_free + W_r;
                }
            }
            _ => velocities(problem.W, problem.w_free, r, w),
        }
        // Fixed-point iterations rebuild w from the whole of r: single precision would leave
        // an error of 2⁻²⁴ |W r| rather than of the change.
        let precision = if self.memory.single.next_step()
            && self.solver != Solver::FixedPoint
            && tolerance >= SINGLE_PRECISION_TOLERANCE
        {
            Precision::Single
        } else {
            Precision::Double
        };
        let report = match self.solver {
            Solver::GaussSeidel | Solver::FixedPoint => iterate(
                problem,
                self.solver == Solver::GaussSeidel,
                precision,
                tolerance,
                max_iterations,
                r,
                w,
            ),
            Solver::ActiveSet => {
                self.solve_active_set(problem, precision, tolerance, max_iterations, r, w)
            }
        }?;
        // The last solution becomes the one before, in the vectors of the one before that.
        let last = match self.memory.last.take() {
            Some(LastSolution {
                r: r_0,
                W_r: W_r_0,
                before,
            }) => {
                let (mut r_1, mut W_r_1) = before.unwrap_or_default();
                r_1.clear();
                r_1.extend_from_slice(r);
                W_r_1.clear();
                W_r_1.extend(reaction_velocities(problem, w));
                LastSolution {
                    r: r_1,
                    W_r: W_r_1,
                    before: Some((r_0, W_r_0)),
                }
            }
            None => LastSolution {
                r: r.to_vec(),
                W_r: reaction_velocities(problem, w).collect(),
                before: None,
            },
        };
        self.memory.last = Some(last);
        Ok(report)
    }

    /// Takes the exact velocities `w` of the reactions `r` just found in single precision
    /// (the step's own, `H v¹`, which the iteration's `w` approximates): `Ok` with their
    /// residual if it meets the tolerance, the solution then the next step's warm start;
    /// `Err` with it if not, and the next steps are solved in double precision for a while
    /// (twice as long after each failure that follows too few successes), the first by
    /// [`ContactSolver::refine`].
    pub fn settle(
        &mut self,
        problem: &Problem,
        tolerance: f64,
        r: &[f64],
        w: &[f64],
    ) -> Result<f64, f64> {
        let residual = problem.residual(r, w);
        self.adopt(problem, w);
        if residual <= tolerance {
            self.memory.single.served();
            Ok(residual)
        } else {
            self.memory.single.failed();
            Err(residual)
        }
    }

    /// Takes the exact velocities `w` of the last solution (the step's own, `H v¹`) in place
    /// of the iteration's: the next step's warm start builds on them.
    pub fn adopt(&mut self, problem: &Problem, w: &[f64]) {
        if let Some(last) = self.memory.last.as_mut() {
            last.W_r.clear();
            last.W_r.extend(reaction_velocities(problem, w));
        }
    }

    /// After [`ContactSolver::settle`] refused a solution: Gauss–Seidel in double precision
    /// from it, `r` and its exact velocities `w`; the result replaces it as the last solution.
    pub fn refine(
        &mut self,
        problem: &Problem,
        tolerance: f64,
        max_iterations: usize,
        r: &mut [f64],
        w: &mut [f64],
    ) -> Result<Report, NotConverged> {
        self.refinements += 1;
        let report = iterate(
            problem,
            true,
            Precision::Double,
            tolerance,
            max_iterations,
            r,
            w,
        )?;
        if let Some(last) = self.memory.last.as_mut() {
            last.r.copy_from_slice(r);
        }
        self.adopt(problem, w);
        Ok(report)
    }
}

/// `W r = w − w_free`.
fn reaction_velocities<'a>(problem: &'a Problem, w: &'a [f64]) -> impl Iterator<Item = f64> + 'a {
    w.iter().zip(problem.w_free).map(|(w, w_free)| w - w_free)
}
