//! The active-set solver: a chord iteration on the factorised laws of the pairs' set.
//!
//! [`Solver::ActiveSet`](super::Solver::ActiveSet) (the default) uses that from one step to
//! the next the pairs mostly keep their state. Once a step's solution has the same *active set* as the step before
//! (each pair open, sticking or sliding), it linearises the laws of that set, with the
//! velocity rows scaled by `ρ` so that every row is a force,
//!
//! ```text
//! sliding pair:   ρ_n (w_n − w_n,min) = 0,          F_T = r_T − μ r_n d(s) = 0,  d = −s/‖s‖
//! sticking pair:  ρ_n (w_n − w_n,min) = 0,  ρ_T (w_t − v_g) = 0,  ρ_T w_b = 0
//! open pair:      r = 0
//! ```
//!
//! with `w = w_free + W r`. The friction direction turns with the binormal slip, and its
//! derivative must be kept (dropping it makes the iteration oscillate on `r_b`):
//! `∂F_T = Δr_T − μ d Δr_n + (μ r_n/‖s‖)(I − ŝŝᵀ) Δw_T`. The Jacobian `A` (three unknowns per
//! closed pair) is factorised (LU, in single precision: the residual and the acceptance stay
//! in double) at the solution it was built on, and later steps run the chord iteration
//!
//! ```text
//! r ← r − A⁻¹ F(r),   w = w_free + W r
//! ```
//!
//! which contracts by how far the set's linearisation has moved. A step is accepted only on
//! the same natural residual as the iterative solvers. When the set changes the chord fails to
//! meet it: the step is solved by Gauss–Seidel from its warm start, and the factorisation is
//! dropped until a set holds for two steps again; a chord that needed more than three
//! iterations refactorises at its solution.

use faer::Mat;
use serde::{Deserialize, Serialize};
use squeal_linalg::lu::PackedLu;

use super::delassus::Precision;
use super::iterative::iterate;
use super::laws::{PairState, Problem, classify, slip};
use super::{ContactSolver, NotConverged, Report};

/// Chord iterations tried before a step falls back to Gauss–Seidel.
const CHORD_ITERATIONS: usize = 6;
/// A chord that needed more iterations than this refactorises for the next step (its
/// directions have drifted), if the factorisation has paid for itself.
pub(super) const REFACTORISE_AFTER: usize = 3;
/// A chord converging slower than this ratio per iteration is given up: its set is stale.
const CHORD_CONTRACTION: f64 = 0.1;
/// Steps a factorisation must serve to have paid for itself (it costs about as much as this
/// many Gauss–Seidel solves); one that fails sooner doubles the wait before the next.
const PAYBACK_STEPS: usize = 16;
/// The longest wait (steps) between factorisations.
const LONGEST_WAIT: usize = 4096;

/// The active set a factorisation is built for, with the sliding pairs' reactions and
/// velocities it linearises at: what a checkpoint keeps of the active-set solver (the
/// factorisation is rebuilt from it, to the same bits).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Linearisation {
    states: Vec<PairState>,
    r: Vec<f64>,
    w: Vec<f64>,
}

/// When a device that can fail is worth trying: a factorisation of the active set (in a limit
/// cycle pairs open, stick and slide from step to step, a set rarely holds, and a
/// factorisation that serves a few steps costs more than Gauss–Seidel would have), or passes
/// in single precision (a refused solution costs a second solve of the step).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Pacing {
    /// Steps served since the last start or failure.
    uses: usize,
    /// Steps to wait before the next try, and the wait after the next failure.
    wait: usize,
    backoff: usize,
}

impl Pacing {
    /// A step begins: one less to wait; whether to try.
    pub(super) fn next_step(&mut self) -> bool {
        self.wait = self.wait.saturating_sub(1);
        self.wait == 0
    }

    /// A step served: once it has paid for itself the wait after a failure starts again.
    pub(super) fn served(&mut self) {
        self.uses += 1;
        if self.uses >= PAYBACK_STEPS {
            self.backoff = 1;
        }
    }

    /// A failure: wait before the next try, twice as long as before if too few steps were
    /// served since.
    pub(super) fn failed(&mut self) {
        if self.uses < PAYBACK_STEPS {
            self.backoff = (2 * self.backoff).min(LONGEST_WAIT);
        }
        self.wait = self.backoff;
        self.uses = 0;
    }
}

impl Default for Pacing {
    fn default() -> Pacing {
        Pacing {
            uses: 0,
            wait: 0,
            backoff: 1,
        }
    }
}

/// The last solution's reactions and `W r`, and the step's before. The next step starts from
/// their linear extrapolation `2 r⁰ − r⁻¹` (reactions vary smoothly while the set holds), and since `w` is affine in `r`
/// its `w = w_free + 2 W r⁰ − W r⁻¹` costs no pass over `W`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct LastSolution {
    pub(super) r: Vec<f64>,
    pub(super) W_r: Vec<f64>,
    pub(super) before: Option<(Vec<f64>, Vec<f64>)>,
}

/// The laws of one active set, linearised and factorised.
pub(super) struct Factorisation {
    states: Vec<PairState>,
    /// First unknown of each pair (three per closed pair, none for an open one).
    offsets: Vec<usize>,
    /// In single precision: the chord needs only an approximate Jacobian (it already is one,
    /// from an earlier step), its residual is evaluated and the step accepted in double
    /// precision, and a solve, bound by reading the factors, takes half the time.
    lu: PackedLu,
}

impl Factorisation {
    fn new(problem: &Problem, linearisation: &Linearisation) -> Option<Factorisation> {
        let step = problem.step_lengths();
        let W = problem.W.double.as_ref();
        let states = &linearisation.states;
        let mut offsets = Vec::with_capacity(states.len() + 1);
        let mut columns = Vec::new();
        for (p, state) in states.iter().enumerate() {
            offsets.push(columns.len());
            if *state != PairState::Open {
                columns.extend([3 * p, 3 * p + 1, 3 * p + 2]);
            }
        }
        offsets.push(columns.len());
        if columns.is_empty() {
            return None;
        }
        // Row i of W restricted to the unknowns (W is symmetric: its column).
        let W_row = |row: usize, out: &mut [f64]| {
            for (slot, &col) in out.iter_mut().zip(&columns) {
                *slot = W[(col, row)];
            }
        };
        let mut A = Mat::<f64>::zeros(columns.len(), columns.len());
        let mut row = vec![0.0; columns.len()];
        for (p, state) in states.iter().enumerate() {
            let (k, i) = (3 * p, offsets[p]);
            match state {
                PairState::Open => {}
                PairState::Stick => {
                    for (d, rho) in [step.rho_n[p], step.rho_T[p], step.rho_T[p]]
                        .into_iter()
                        .enumerate()
                    {
                        W_row(k + d, &mut row);
                        for (j, value) in row.iter().enumerate() {
                            A[(i + d, j)] = rho * value;
                        }
                    }
                    if W[(k + 2, k + 2)] == 0.0 {
                        // A pair without a binormal row (a lumped contact in a plane): its
                        // slip along b is zero whatever r_b, which stays zero instead.
                        A[(i + 2, i + 2)] = 1.0;
                    }
                }
                PairState::Slide => {
                    W_row(k, &mut row);
                    for (j, value) in row.iter().enumerate() {
                        A[(i, j)] = step.rho_n[p] * value;
                    }
                    // F_T = r_T − μ r_n d(s): ∂F_T = Δr_T − μ d Δr_n + κ (I − ŝŝᵀ) Δw_T,
                    // κ = μ r_n/‖s‖.
                    let (length, d) = slip(&linearisation.w, p, problem.sliding_speed[p]);
                    let kappa = problem.mu[p] * linearisation.r[k] / length;
                    let projector = [
                        [1.0 - d[0] * d[0], -d[0] * d[1]],
                        [-d[1] * d[0], 1.0 - d[1] * d[1]],
                    ];
                    let mut rows = [vec![0.0; columns.len()], vec![0.0; columns.len()]];
                    W_row(k + 1, &mut rows[0]);
                    W_row(k + 2, &mut rows[1]);
                    for e in 0..2 {
                        for j in 0..columns.len() {
                            A[(i + 1 + e, j)] = kappa
                                * (projector[e][0] * rows[0][j] + projector[e][1] * rows[1][j]);
                        }
                        A[(i + 1 + e, i + 1 + e)] += 1.0;
                        A[(i + 1 + e, i)] -= problem.mu[p] * d[e];
                    }
                }
            }
        }
        Some(Factorisation {
            states: states.clone(),
            offsets,
            lu: PackedLu::new(
                Mat::<f32>::from_fn(A.nrows(), A.ncols(), |i, j| A[(i, j)] as f32).as_ref(),
            ),
        })
    }

    /// The residual `F` of the set's laws at `r`, `w` (velocity rows scaled by ρ: forces),
    /// evaluated in double precision and rounded for the single-precision solve.
    fn laws(&self, problem: &Problem, r: &[f64], w: &[f64], F: &mut [f32]) {
        let step = problem.step_lengths();
        for (p, state) in self.states.iter().enumerate() {
            let (k, i) = (3 * p, self.offsets[p]);
            let normal = step.rho_n[p] * (w[k] - problem.w_n_min[p]);
            let values = match state {
                PairState::Open => continue,
                PairState::Stick => [
                    normal,
                    step.rho_T[p] * (w[k + 1] - problem.sliding_speed[p]),
                    if problem.W.double[(k + 2, k + 2)] == 0.0 {
                        r[k + 2]
                    } else {
                        step.rho_T[p] * w[k + 2]
                    },
                ],
                PairState::Slide => {
                    let d = slip(w, p, problem.sliding_speed[p]).1;
                    [
                        normal,
                        r[k + 1] - problem.mu[p] * r[k] * d[0],
                        r[k + 2] - problem.mu[p] * r[k] * d[1],
                    ]
                }
            };
            for (e, value) in values.into_iter().enumerate() {
                F[i + e] = value as f32;
            }
        }
    }

    /// The chord iteration `r ← r − A⁻¹ F(r)` from the reactions `r` and their velocities `w`;
    /// `None` when it does not reach the tolerance (`r` and `w` are then left anywhere).
    pub(super) fn chord(
        &self,
        problem: &Problem,
        (precision, tolerance): (Precision, f64),
        r: &mut [f64],
        w: &mut [f64],
        F: &mut Vec<f32>,
    ) -> Option<Report> {
        F.clear();
        F.resize(self.lu.n(), 0.0);
        let mut last_residual = f64::INFINITY;
        for iteration in 1..=CHORD_ITERATIONS {
            self.laws(problem, r, w, F);
            // F becomes the correction A⁻¹ F, and w follows r's change.
            self.lu.solve_in_place(F);
            for (p, state) in self.states.iter().enumerate() {
                let (k, i) = (3 * p, self.offsets[p]);
                for d in 0..3 {
                    let change = match state {
                        PairState::Open => -r[k + d],
                        _ => -f64::from(F[i + d]),
                    };
                    if change != 0.0 {
                        r[k + d] += change;
                        problem.W.add_column(k + d, change, w, precision);
                    }
                }
            }
            let residual = problem.residual(r, w);
            if residual <= tolerance {
                return Some(Report {
                    iterations: iteration,
                    residual,
                    precision,
                });
            }
            if !residual.is_finite() || residual > CHORD_CONTRACTION * last_residual {
                return None;
            }
            last_residual = residual;
        }
        None
    }
}

impl ContactSolver {
    pub(super) fn solve_active_set(
        &mut self,
        problem: &Problem,
        precision: Precision,
        tolerance: f64,
        max_iterations: usize,
        r: &mut [f64],
        w: &mut [f64],
    ) -> Result<Report, NotConverged> {
        self.memory.pacing.next_step();
        if let Some(factorisation) = &self.factorisation {
            let scratch = &mut self.scratch;
            scratch.r.clear();
            scratch.r.extend_from_slice(r);
            scratch.w.clear();
            scratch.w.extend_from_slice(w);
            let chord = factorisation.chord(problem, (precision, tolerance), r, w, &mut scratch.F);
            if let Some(report) = chord {
                self.memory.pacing.served();
                let states = self.memory.previous.get_or_insert_with(Vec::new);
                states.clear();
                states.extend(
                    (0..problem.n_pairs())
                        .map(|p| classify(r, w, p, problem.sliding_speed[p], problem.speed_scale)),
                );
                if report.iterations > REFACTORISE_AFTER && self.memory.pacing.uses >= PAYBACK_STEPS
                {
                    self.factorise(problem, linearisation_of(problem, r, w));
                }
                return Ok(report);
            }
            self.memory.pacing.failed();
            self.factorise_at(problem, None);
            r.copy_from_slice(&self.scratch.r);
            w.copy_from_slice(&self.scratch.w);
        }
        let report = iterate(problem, true, precision, tolerance, max_iterations, r, w)?;
        let linearisation = linearisation_of(problem, r, w);
        if self.memory.previous.as_ref() == Some(&linearisation.states)
            && self.memory.pacing.wait == 0
        {
            self.factorise(problem, linearisation);
        } else {
            self.memory.previous = Some(linearisation.states);
        }
        Ok(report)
    }

    fn factorise(&mut self, problem: &Problem, linearisation: Linearisation) {
        self.factorisations += 1;
        self.memory.pacing.uses = 0;
        self.factorise_at(problem, Some(linearisation));
    }

    /// Factorises the laws at `linearisation`, or drops the factorisation (`None`); the memory
    /// keeps the linearisation only if it could be factorised.
    pub(super) fn factorise_at(&mut self, problem: &Problem, linearisation: Option<Linearisation>) {
        self.factorisation = linearisation
            .as_ref()
            .and_then(|linearisation| Factorisation::new(problem, linearisation));
        self.memory.factorised = linearisation.filter(|_| self.factorisation.is_some());
    }
}

/// The active set of a solution, with the reactions and velocities to linearise at.
fn linearisation_of(problem: &Problem, r: &[f64], w: &[f64]) -> Linearisation {
    Linearisation {
        states: (0..problem.n_pairs())
            .map(|p| classify(r, w, p, problem.sliding_speed[p], problem.speed_scale))
            .collect(),
        r: r.to_vec(),
        w: w.to_vec(),
    }
}
