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
//! The iterative solvers iterate the projection form of the laws, for any ρ > 0,
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
//! - [`Solver::GaussSeidel`] (projected Gauss–Seidel): pair after pair, each using the
//!   reactions already updated in the sweep, projected once per sweep (iterating a pair's
//!   projection until its 3 × 3 block settles cost a third of the solve and saved no sweep),
//!   `w` kept current by rank-3 updates. It needs fewer sweeps and does not depend on
//!   diagonal dominance of `W` to converge, but it converges linearly, at a rate set by the
//!   coupling of neighbouring pairs through `W`. Neighbours on one pad couple through its
//!   compliance far more than through the disc, so a sweep goes pad by pad
//!   ([`pad_blocks`]): a pad's pairs are swept several times against the pad's own square of
//!   `W` (in cache), keeping only its rows of `w` current, before its change of reactions
//!   updates the rest of `w` in one pass over its columns. Every pair update is still an
//!   exact Gauss–Seidel update (no other pair moves meanwhile), and the passes over the
//!   whole of `W` drop severalfold. The sweeps are accelerated by Anderson mixing
//!   (`Anderson`).
//!
//! [`Solver::ActiveSet`] (the default) uses that from one step to the next the pairs mostly
//! keep their state. Once a step's solution has the same *active set* as the step before
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
//! which contracts by how far the set's linearisation has moved: two passes over `W` on
//! average where Gauss–Seidel needs fifteen. A step is accepted only on the same natural
//! residual as the iterative solvers. When the set changes the chord fails to meet it: the step
//! is solved by Gauss–Seidel from its warm start, and the factorisation is dropped until a set
//! holds for two steps again; a chord that needed more than three iterations
//! refactorises at its solution.
//!
//! Convergence is measured by the natural residual `max_p ‖r_p − proj(r_p)‖ / R`, `R` the
//! force scale (the largest equilibrium reaction, or the largest reaction found).
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

use std::ops::Range;

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};
use squeal_linalg::kernels::{axpy, axpy_single, dot};
use squeal_linalg::lu::PackedLu;

/// Chord iterations tried before a step falls back to Gauss–Seidel.
const CHORD_ITERATIONS: usize = 6;
/// A chord that needed more iterations than this refactorises for the next step (its
/// directions have drifted), if the factorisation has paid for itself.
const REFACTORISE_AFTER: usize = 3;
/// A chord converging slower than this ratio per iteration is given up: its set is stale.
const CHORD_CONTRACTION: f64 = 0.1;
/// Steps a factorisation must serve to have paid for itself (it costs about as much as this
/// many Gauss–Seidel solves); one that fails sooner doubles the wait before the next.
const PAYBACK_STEPS: usize = 16;
/// The longest wait (steps) between factorisations.
const LONGEST_WAIT: usize = 4096;
/// The least tolerance tried with passes over `W` in single precision. Below it, their
/// rounding most often misses the tolerance (on the default brake at 1e-10, in 895 steps of
/// 1,667), and every step would be solved twice before the run settles in double.
const SINGLE_PRECISION_TOLERANCE: f64 = 1e-9;
/// Residuals kept for an error message.
const HISTORY_KEPT: usize = 12;

crate::choice! {
    /// The contact solver, by the name the transient's `solver` parameter gives it.
    pub enum Solver {
        ActiveSet = "active_set",
        GaussSeidel = "gauss_seidel",
        FixedPoint = "fixed_point",
    }
}

/// Contact state of a pair at the end of a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PairState {
    Open,
    Stick,
    Slide,
}

/// Open (no reaction), sticking (no slip) or sliding, from the end-of-step reaction and
/// velocity; a slip below 1e-9 of the sliding speed counts as sticking.
pub fn classify(r: &[f64], w: &[f64], p: usize, sliding_speed: f64) -> PairState {
    if r[3 * p] <= 0.0 {
        return PairState::Open;
    }
    if slip(w, p, sliding_speed).0 <= 1e-9 * sliding_speed {
        PairState::Stick
    } else {
        PairState::Slide
    }
}

/// The slip speed `‖s‖` of pair `p` and the friction direction `d = −s/‖s‖` (zero without slip).
fn slip(w: &[f64], p: usize, sliding_speed: f64) -> (f64, [f64; 2]) {
    let s = [w[3 * p + 1] - sliding_speed, w[3 * p + 2]];
    let length = norm(s);
    if length > 0.0 {
        (length, [-s[0] / length, -s[1] / length])
    } else {
        (0.0, [0.0; 2])
    }
}

/// The Delassus operator, 3 rows and columns per pair in the order (n, t, b), fixed through a
/// run: in double precision, and copied to single precision for the iterations' passes over
/// it (half the bytes, see [`Precision`]); with the projections' step lengths from its
/// diagonal.
pub struct Delassus {
    double: Mat<f64>,
    single: Mat<f32>,
    step: Step,
}

impl Delassus {
    pub fn new(W: Mat<f64>) -> Delassus {
        let step = Step {
            rho_n: (0..W.nrows() / 3)
                .map(|p| 1.0 / W[(3 * p, 3 * p)])
                .collect(),
            rho_T: (0..W.nrows() / 3)
                .map(|p| 1.0 / W[(3 * p + 1, 3 * p + 1)].max(W[(3 * p + 2, 3 * p + 2)]))
                .collect(),
        };
        Delassus {
            single: Mat::from_fn(W.nrows(), W.ncols(), |i, j| W[(i, j)] as f32),
            double: W,
            step,
        }
    }

    /// `w += W e_k change`, from the copy in `precision`.
    fn add_column(&self, k: usize, change: f64, w: &mut [f64], precision: Precision) {
        match precision {
            Precision::Double => axpy(change, column(self.double.as_ref(), k), w),
            Precision::Single => {
                let column = self
                    .single
                    .col(k)
                    .try_as_col_major()
                    .expect("the Delassus operator is stored column-major")
                    .as_slice();
                axpy_single(change, column, w)
            }
        }
    }
}

/// Which copy of `W` an iteration's passes read. A pass in single precision leaves an error
/// of about `2⁻²⁴ |W Δr|` in `w`, `Δr` the pass's change of the reactions: far below a
/// step's change of velocity, but not always below the tolerance. A step solved so is
/// accepted on its end-of-step velocities, computed in double precision from the solution
/// ([`ContactSolver::settle`]), or refined in double precision.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    Single,
    Double,
}

/// The data of one step's problem.
pub struct Problem<'a> {
    /// The Delassus operator.
    pub W: &'a Delassus,
    /// End-of-step relative velocities without reaction.
    pub w_free: &'a [f64],
    /// Least normal relative velocity per pair, `−B̃/τ`.
    pub w_n_min: &'a [f64],
    /// Sliding speed `|v_g|` of the disc per pair.
    pub sliding_speed: &'a [f64],
    pub mu: f64,
    /// Force scale of the residual (N).
    pub force_scale: f64,
    /// The pairs in the order Gauss–Seidel sweeps them, in blocks of consecutive pairs
    /// (those of one pad: [`pad_blocks`]), each block's own problem swept a few times before
    /// the rest of `w` is brought up to date.
    pub blocks: &'a [Range<usize>],
}

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

struct Step {
    rho_n: Vec<f64>,
    rho_T: Vec<f64>,
}

impl Problem<'_> {
    fn n_pairs(&self) -> usize {
        self.w_n_min.len()
    }

    fn step_lengths(&self) -> &Step {
        &self.W.step
    }

    /// The projection of the laws for pair `p` at reaction `r` and velocities `w`.
    fn project(&self, p: usize, r: [f64; 3], w: [f64; 3]) -> [f64; 3] {
        let step = self.step_lengths();
        let r_n = (r[0] - step.rho_n[p] * (w[0] - self.w_n_min[p])).max(0.0);
        let slip = [w[1] - self.sliding_speed[p], w[2]];
        let trial = [
            r[1] - step.rho_T[p] * slip[0],
            r[2] - step.rho_T[p] * slip[1],
        ];
        let radius = self.mu * r_n;
        let length = norm(trial);
        let scale = if length > radius {
            radius / length
        } else {
            1.0
        };
        [r_n, trial[0] * scale, trial[1] * scale]
    }

    fn residual(&self, r: &[f64], w: &[f64]) -> f64 {
        let mut worst: f64 = 0.0;
        let mut largest: f64 = 0.0;
        for p in 0..self.n_pairs() {
            let r_p = pair(r, p);
            let projected = self.project(p, r_p, pair(w, p));
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

/// The length of a tangential vector. (`hypot`'s guard against overflow is a library call in
/// the innermost loop, and forces and velocities here are nowhere near 1e154.)
fn norm(x: [f64; 2]) -> f64 {
    (x[0] * x[0] + x[1] * x[1]).sqrt()
}

fn pair(values: &[f64], p: usize) -> [f64; 3] {
    [values[3 * p], values[3 * p + 1], values[3 * p + 2]]
}

/// Column `k` of `W` as a slice (`W` is stored column-major).
fn column<'a>(W: MatRef<'a, f64>, k: usize) -> &'a [f64] {
    W.col(k)
        .try_as_col_major()
        .expect("the Delassus operator is stored column-major")
        .as_slice()
}

squeal_linalg::widest_vectors! {
    /// `w = w_free + W r`, column by column (contiguous reads).
    fn velocities(problem: &Problem, r: &[f64], w: &mut [f64]) {
        w.copy_from_slice(problem.w_free);
        for (k, &r_k) in r.iter().enumerate() {
            if r_k != 0.0 {
                for (slot, W_ik) in w.iter_mut().zip(column(problem.W.double.as_ref(), k)) {
                    *slot += W_ik * r_k;
                }
            }
        }
    }
}

/// Past sweeps an Anderson step combines.
const ANDERSON_DEPTH: usize = 5;

/// Anderson acceleration of the Gauss–Seidel sweeps `g = G(x)` (type II): with `f = g − x`
/// each sweep's change, and `ΔF`, `ΔG` the differences of the last few sweeps' `f` and `g`,
/// the next sweep starts from
///
/// ```text
/// x⁺ = g_k − ΔG γ,    γ = argmin ‖f_k − ΔF γ‖
/// ```
///
/// the combination of the past sweeps that would have changed least, were `G` affine (it is,
/// while the pairs keep their states). `w` is affine in `r`, so `x⁺`'s velocities are the
/// same combination of the sweeps' (`w(g_k) − ΔW γ`): no pass over `W`.
struct Anderson {
    /// The sweep's input `x` (kept by [`Anderson::start`]).
    input: Vec<f64>,
    /// The last sweep's `f`, `g` and `w(g)`, once there is one.
    last: Option<[Vec<f64>; 3]>,
    /// The differences `ΔF`, `ΔG`, `ΔW` of the last [`ANDERSON_DEPTH`] sweeps, oldest first.
    differences: std::collections::VecDeque<[Vec<f64>; 3]>,
}

impl Anderson {
    fn new(n: usize) -> Anderson {
        Anderson {
            input: vec![0.0; n],
            last: None,
            differences: std::collections::VecDeque::with_capacity(ANDERSON_DEPTH),
        }
    }

    /// Keeps the input of the sweep about to run.
    fn start(&mut self, r: &[f64]) {
        self.input.copy_from_slice(r);
    }

    /// Takes the sweep's output `(r, w) = (g_k, w(g_k))` and replaces it with the next input.
    fn mix(&mut self, r: &mut [f64], w: &mut [f64]) {
        let f: Vec<f64> = r.iter().zip(&self.input).map(|(g, x)| g - x).collect();
        let Some(last) = self.last.replace([f, r.to_vec(), w.to_vec()]) else {
            return;
        };
        let current = self.last.as_ref().expect("just kept");
        if self.differences.len() == ANDERSON_DEPTH {
            self.differences.pop_front();
        }
        self.differences.push_back(std::array::from_fn(|which| {
            current[which]
                .iter()
                .zip(&last[which])
                .map(|(new, old)| new - old)
                .collect()
        }));
        // The normal equations of min ‖f_k − ΔF γ‖.
        let m = self.differences.len();
        let dF = |i: usize| &self.differences[i][0];
        let mut gram: Vec<f64> = (0..m * m)
            .map(|k| dot(dF((k / m).min(k % m)), dF((k / m).max(k % m))))
            .collect();
        let mut rhs: Vec<f64> = (0..m).map(|i| dot(dF(i), &current[0])).collect();
        let Some(gamma) = solve_small(&mut gram, &mut rhs, m) else {
            self.differences.clear();
            return;
        };
        for (g, difference) in gamma.iter().zip(&self.differences) {
            axpy(-g, &difference[1], r);
            axpy(-g, &difference[2], w);
        }
    }
}

/// `A γ = b` for a small symmetric positive semi-definite `A` (row-major `m × m`), by
/// Cholesky with a relative shift; `None` if it is singular to rounding.
fn solve_small(A: &mut [f64], b: &mut [f64], m: usize) -> Option<Vec<f64>> {
    let trace: f64 = (0..m).map(|i| A[i * m + i]).sum();
    if !(trace > 0.0) {
        return None;
    }
    for i in 0..m {
        A[i * m + i] += 1e-12 * trace;
    }
    for j in 0..m {
        let mut d = A[j * m + j];
        for k in 0..j {
            d -= A[j * m + k] * A[j * m + k];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        A[j * m + j] = d;
        for i in j + 1..m {
            let mut v = A[i * m + j];
            for k in 0..j {
                v -= A[i * m + k] * A[j * m + k];
            }
            A[i * m + j] = v / d;
        }
    }
    for i in 0..m {
        for k in 0..i {
            b[i] -= A[i * m + k] * b[k];
        }
        b[i] /= A[i * m + i];
    }
    for i in (0..m).rev() {
        for k in i + 1..m {
            b[i] -= A[k * m + i] * b[k];
        }
        b[i] /= A[i * m + i];
    }
    Some(b.to_vec())
}

/// Solves the step's problem with an iterative solver from the reactions `r` (a warm start,
/// overwritten with the solution), `w` its velocities on entry, the solution's on return.
fn iterate(
    problem: &Problem,
    gauss_seidel: bool,
    precision: Precision,
    tolerance: f64,
    max_iterations: usize,
    r: &mut [f64],
    w: &mut [f64],
) -> Result<Report, NotConverged> {
    let mut history = Vec::new();
    let mut next = vec![0.0; r.len()];
    let mut anderson = Anderson::new(r.len());
    for iteration in 1..=max_iterations {
        if gauss_seidel {
            anderson.start(r);
            gauss_seidel_sweep(problem, precision, r, w);
        } else {
            for p in 0..problem.n_pairs() {
                let projected = problem.project(p, pair(r, p), pair(w, p));
                next[3 * p..3 * p + 3].copy_from_slice(&projected);
            }
            r.copy_from_slice(&next);
            velocities(problem, r, w);
        }
        let residual = problem.residual(r, w);
        history.push(residual);
        if history.len() > HISTORY_KEPT {
            history.remove(0);
        }
        if residual <= tolerance {
            return Ok(Report {
                iterations: iteration,
                residual,
                precision,
            });
        }
        if !residual.is_finite() {
            break;
        }
        if gauss_seidel {
            anderson.mix(r, w);
        }
    }
    Err(NotConverged {
        iterations: max_iterations,
        history,
    })
}

/// The active set a factorisation is built for, with the sliding pairs' reactions and
/// velocities it linearises at: what a checkpoint keeps of the active-set solver (the
/// factorisation is rebuilt from it, to the same bits).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Basis {
    states: Vec<PairState>,
    r: Vec<f64>,
    w: Vec<f64>,
}

/// The memory of a [`ContactSolver`] between steps.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Memory {
    factorised: Option<Basis>,
    previous: Option<Vec<PairState>>,
    last: Option<LastSolution>,
    pacing: Pacing,
    single: Pacing,
}

/// When a device that can fail is worth trying: a factorisation of the active set (in a limit
/// cycle pairs open, stick and slide from step to step, a set rarely holds, and a
/// factorisation that serves a few steps costs more than Gauss–Seidel would have), or passes
/// in single precision (a refused solution costs a second solve of the step).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Pacing {
    /// Steps served since the last start or failure.
    uses: usize,
    /// Steps to wait before the next try, and the wait after the next failure.
    wait: usize,
    backoff: usize,
}

impl Pacing {
    /// A step begins: one less to wait; whether to try.
    fn next_step(&mut self) -> bool {
        self.wait = self.wait.saturating_sub(1);
        self.wait == 0
    }

    /// A step served: once it has paid for itself the wait after a failure starts again.
    fn served(&mut self) {
        self.uses += 1;
        if self.uses >= PAYBACK_STEPS {
            self.backoff = 1;
        }
    }

    /// A failure: wait before the next try, twice as long as before if too few steps were
    /// served since.
    fn failed(&mut self) {
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
/// their linear extrapolation `2 r⁰ − r⁻¹` (reactions vary smoothly while the set holds: the
/// chord then mostly needs one iteration instead of two), and since `w` is affine in `r`
/// its `w = w_free + 2 W r⁰ − W r⁻¹` costs no pass over `W`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct LastSolution {
    r: Vec<f64>,
    W_r: Vec<f64>,
    before: Option<(Vec<f64>, Vec<f64>)>,
}

/// The laws of one active set, linearised and factorised.
struct Factorisation {
    states: Vec<PairState>,
    /// First unknown of each pair (three per closed pair, none for an open one).
    offsets: Vec<usize>,
    /// In single precision: the chord needs only an approximate Jacobian (it already is one,
    /// from an earlier step), its residual is evaluated and the step accepted in double
    /// precision, and a solve, bound by reading the factors, takes half the time.
    lu: PackedLu,
}

impl Factorisation {
    fn new(problem: &Problem, basis: &Basis) -> Option<Factorisation> {
        let step = problem.step_lengths();
        let W = problem.W.double.as_ref();
        let states = &basis.states;
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
                }
                PairState::Slide => {
                    W_row(k, &mut row);
                    for (j, value) in row.iter().enumerate() {
                        A[(i, j)] = step.rho_n[p] * value;
                    }
                    // F_T = r_T − μ r_n d(s): ∂F_T = Δr_T − μ d Δr_n + κ (I − ŝŝᵀ) Δw_T,
                    // κ = μ r_n/‖s‖.
                    let (length, d) = slip(&basis.w, p, problem.sliding_speed[p]);
                    let kappa = problem.mu * basis.r[k] / length;
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
                        A[(i + 1 + e, i)] -= problem.mu * d[e];
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
                    step.rho_T[p] * w[k + 2],
                ],
                PairState::Slide => {
                    let d = slip(w, p, problem.sliding_speed[p]).1;
                    [
                        normal,
                        r[k + 1] - problem.mu * r[k] * d[0],
                        r[k + 2] - problem.mu * r[k] * d[1],
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
    fn chord(
        &self,
        problem: &Problem,
        precision: Precision,
        tolerance: f64,
        r: &mut [f64],
        w: &mut [f64],
    ) -> Option<Report> {
        let mut F = vec![0.0_f32; self.lu.n()];
        let mut last_residual = f64::INFINITY;
        for iteration in 1..=CHORD_ITERATIONS {
            self.laws(problem, r, w, &mut F);
            // F becomes the correction A⁻¹ F, and w follows r's change.
            self.lu.solve_in_place(&mut F);
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

/// A contact solver with what it keeps from step to step.
pub struct ContactSolver {
    solver: Solver,
    factorisation: Option<(Basis, Factorisation)>,
    previous: Option<Vec<PairState>>,
    last: Option<LastSolution>,
    pacing: Pacing,
    /// When passes in single precision are worth trying: after a refused solution the next
    /// steps are solved in double.
    single: Pacing,
    /// Factorisations so far (for benchmarks; not part of any output).
    pub factorisations: usize,
    /// Solutions refined in double precision so far (likewise).
    pub refinements: usize,
}

impl ContactSolver {
    pub fn new(solver: Solver) -> ContactSolver {
        ContactSolver {
            solver,
            factorisation: None,
            previous: None,
            last: None,
            pacing: Pacing::default(),
            single: Pacing::default(),
            factorisations: 0,
            refinements: 0,
        }
    }

    /// What a checkpoint keeps.
    pub fn memory(&self) -> Memory {
        Memory {
            factorised: self.factorisation.as_ref().map(|(basis, _)| basis.clone()),
            previous: self.previous.clone(),
            last: self.last.clone(),
            pacing: self.pacing.clone(),
            single: self.single.clone(),
        }
    }

    /// Takes back a checkpoint's memory, for a problem of the same run.
    pub fn restore(&mut self, memory: Memory, problem: &Problem) {
        self.factorisation = memory.factorised.and_then(|basis| {
            let factorisation = Factorisation::new(problem, &basis);
            factorisation.map(|f| (basis, f))
        });
        self.previous = memory.previous;
        self.last = memory.last;
        self.pacing = memory.pacing;
        self.single = memory.single;
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
        match &self.last {
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
            _ => velocities(problem, r, w),
        }
        // Fixed-point iterations rebuild w from the whole of r: single precision would leave
        // an error of 2⁻²⁴ |W r| rather than of the change.
        let precision = if self.single.next_step()
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
        let before = self.last.take().map(|last| (last.r, last.W_r));
        self.last = Some(LastSolution {
            before,
            r: r.to_vec(),
            W_r: reaction_velocities(problem, w),
        });
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
        if let Some(last) = self.last.as_mut() {
            last.W_r = reaction_velocities(problem, w);
        }
        if residual <= tolerance {
            self.single.served();
            Ok(residual)
        } else {
            self.single.failed();
            Err(residual)
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
        if let Some(last) = self.last.as_mut() {
            last.r.copy_from_slice(r);
            last.W_r = reaction_velocities(problem, w);
        }
        Ok(report)
    }

    fn solve_active_set(
        &mut self,
        problem: &Problem,
        precision: Precision,
        tolerance: f64,
        max_iterations: usize,
        r: &mut [f64],
        w: &mut [f64],
    ) -> Result<Report, NotConverged> {
        self.pacing.next_step();
        if let Some((_, factorisation)) = &self.factorisation {
            let warm_start = (r.to_vec(), w.to_vec());
            if let Some(report) = factorisation.chord(problem, precision, tolerance, r, w) {
                self.pacing.served();
                let basis = basis_of(problem, r, w);
                self.previous = Some(basis.states.clone());
                if report.iterations > REFACTORISE_AFTER && self.pacing.uses >= PAYBACK_STEPS {
                    self.factorise(problem, basis);
                }
                return Ok(report);
            }
            self.pacing.failed();
            self.factorisation = None;
            r.copy_from_slice(&warm_start.0);
            w.copy_from_slice(&warm_start.1);
        }
        let report = iterate(problem, true, precision, tolerance, max_iterations, r, w)?;
        let basis = basis_of(problem, r, w);
        if self.previous.as_ref() == Some(&basis.states) && self.pacing.wait == 0 {
            self.factorise(problem, basis);
        } else {
            self.previous = Some(basis.states);
        }
        Ok(report)
    }

    fn factorise(&mut self, problem: &Problem, basis: Basis) {
        self.factorisations += 1;
        self.pacing.uses = 0;
        self.factorisation =
            Factorisation::new(problem, &basis).map(|factorisation| (basis, factorisation));
    }
}

/// `W r = w − w_free`.
fn reaction_velocities(problem: &Problem, w: &[f64]) -> Vec<f64> {
    w.iter()
        .zip(problem.w_free)
        .map(|(w, w_free)| w - w_free)
        .collect()
}

/// The active set of a solution, with the reactions and velocities to linearise at.
fn basis_of(problem: &Problem, r: &[f64], w: &[f64]) -> Basis {
    Basis {
        states: (0..problem.n_pairs())
            .map(|p| classify(r, w, p, problem.sliding_speed[p]))
            .collect(),
        r: r.to_vec(),
        w: w.to_vec(),
    }
}

/// Sweeps over one block's own pairs before the rest of `w` is brought up to date.
const BLOCK_SWEEPS: usize = 8;
/// The most pairs in one Gauss–Seidel block: a block's own sweeps read its square of `W`, to
/// stay in cache.
const LARGEST_BLOCK: usize = 32;

/// Gauss–Seidel blocks for pairs pressing the bodies `body_of_pair` (any labels): runs of
/// consecutive pairs on one body, at most `LARGEST_BLOCK` pairs each.
pub fn pad_blocks(body_of_pair: &[usize]) -> Vec<Range<usize>> {
    let mut blocks: Vec<Range<usize>> = Vec::new();
    for (p, body) in body_of_pair.iter().enumerate() {
        match blocks.last_mut() {
            Some(block) if body_of_pair[block.start] == *body && block.len() < LARGEST_BLOCK => {
                block.end = p + 1
            }
            _ => blocks.push(p..p + 1),
        }
    }
    blocks
}

squeal_linalg::widest_vectors! {
    /// One Gauss–Seidel sweep over the pairs, block by block; `w` is kept equal to
    /// `w_free + W r`. Within a block, [`BLOCK_SWEEPS`] sweeps over its pairs keep only the
    /// block's own rows of `w` current (each pair's update is still exact: no other pair
    /// moves meanwhile); then the block's change of `r` updates every row.
    fn gauss_seidel_sweep(
        problem: &Problem,
        precision: Precision,
        r: &mut [f64],
        w: &mut [f64],
    ) {
        let W = problem.W.double.as_ref();
        for pairs in problem.blocks {
            let rows = 3 * pairs.start..3 * pairs.end;
            let (r_start, w_start) = (r[rows.clone()].to_vec(), w[rows.clone()].to_vec());
            let sweeps = if pairs.len() == 1 { 1 } else { BLOCK_SWEEPS };
            for _ in 0..sweeps {
                for p in pairs.clone() {
                    let k = 3 * p;
                    let start = pair(r, p);
                    let r_p = problem.project(p, start, pair(w, p));
                    let delta = [r_p[0] - start[0], r_p[1] - start[1], r_p[2] - start[2]];
                    if delta != [0.0; 3] {
                        let columns = [k, k + 1, k + 2].map(|k| &column(W, k)[rows.clone()]);
                        for (row, slot) in w[rows.clone()].iter_mut().enumerate() {
                            *slot += columns[0][row] * delta[0]
                                + columns[1][row] * delta[1]
                                + columns[2][row] * delta[2];
                        }
                        r[k..k + 3].copy_from_slice(&r_p);
                    }
                }
            }
            w[rows.clone()].copy_from_slice(&w_start);
            for (k, before) in rows.zip(r_start) {
                let change = r[k] - before;
                if change != 0.0 {
                    problem.W.add_column(k, change, w, precision);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A solve as the scheme makes it: a solution found in single precision is settled on
    /// its exact velocities `w_free + W r`, or refined in double precision.
    fn solve_settled(
        solver: &mut ContactSolver,
        problem: &Problem,
        tolerance: f64,
        max_iterations: usize,
        r: &mut [f64],
        w: &mut [f64],
    ) -> Result<Report, NotConverged> {
        let mut report = solver.solve(problem, tolerance, max_iterations, r, w)?;
        if report.precision == Precision::Single {
            velocities(problem, r, w);
            match solver.settle(problem, tolerance, r, w) {
                Ok(residual) => report.residual = residual,
                Err(_) => {
                    let refined = solver.refine(problem, tolerance, max_iterations, r, w)?;
                    report.iterations += refined.iterations;
                    report.residual = refined.residual;
                }
            }
        }
        Ok(report)
    }

    /// The six pairs of [`problem_data`] as two pads of three.
    fn two_pads() -> Vec<Range<usize>> {
        pad_blocks(&[7, 7, 7, 2, 2, 2])
    }

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
            W: &Delassus::new(W.clone()),
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            mu,
            force_scale: 0.0,
            blocks: &two_pads(),
        };
        let mut r = vec![0.0; 3 * n_pairs];
        let mut w = vec![0.0; 3 * n_pairs];
        let report = solve_settled(
            &mut ContactSolver::new(solver),
            &problem,
            1e-13,
            20_000,
            &mut r,
            &mut w,
        )
        .unwrap();
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

    /// Passes in single precision leave `w` off the exact `w_free + W r` by rounding: a
    /// loose tolerance is still met on the exact velocities; one below that error (1e-9
    /// here) is refused, refined in double precision to the tolerance, and the next step
    /// solved in double. Tolerances below the least tried are solved in double at once.
    #[test]
    fn single_precision_solutions_are_settled_on_exact_velocities_or_refined() {
        let n_pairs = 6;
        let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
        let W = Delassus::new(W);
        let blocks = two_pads();
        let problem = Problem {
            W: &W,
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            mu: 0.38,
            force_scale: 0.0,
            blocks: &blocks,
        };
        let m = 3 * n_pairs;
        let exact = |r: &[f64]| {
            let mut w = vec![0.0; m];
            velocities(&problem, r, &mut w);
            w
        };
        let distance = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        for (tolerance, met_in_single) in [(1e-6, true), (1e-9, false)] {
            let mut solver = ContactSolver::new(Solver::GaussSeidel);
            let (mut r, mut w) = (vec![0.0; m], vec![0.0; m]);
            let report = solver
                .solve(&problem, tolerance, 20_000, &mut r, &mut w)
                .unwrap();
            assert_eq!(report.precision, Precision::Single);
            let drift = distance(&w, &exact(&r));
            assert!(
                drift > 0.0 && drift < 1e-6,
                "single-precision drift {drift}"
            );
            let w_exact = exact(&r);
            match solver.settle(&problem, tolerance, &r, &w_exact) {
                Ok(residual) => {
                    assert!(
                        met_in_single,
                        "tolerance {tolerance}: settled at {residual}"
                    );
                    assert!(residual <= tolerance);
                }
                Err(residual) => {
                    assert!(
                        !met_in_single,
                        "tolerance {tolerance}: refused at {residual}"
                    );
                    assert!(
                        residual > tolerance && residual < 1e-6,
                        "refused at {residual}"
                    );
                    let mut w = w_exact;
                    let refined = solver
                        .refine(&problem, tolerance, 20_000, &mut r, &mut w)
                        .unwrap();
                    assert!(refined.residual <= tolerance);
                    assert_eq!(refined.precision, Precision::Double);
                    assert!(distance(&w, &exact(&r)) < 1e-14, "refined in double");
                    check_laws(&r, &w, 0.38, 1e-8);
                    let next = solver
                        .solve(&problem, tolerance, 20_000, &mut r, &mut w)
                        .unwrap();
                    assert_eq!(next.precision, Precision::Double);
                }
            }
        }
        let (mut r, mut w) = (vec![0.0; m], vec![0.0; m]);
        let tight = ContactSolver::new(Solver::GaussSeidel)
            .solve(&problem, 1e-12, 20_000, &mut r, &mut w)
            .unwrap();
        assert_eq!(tight.precision, Precision::Double);
    }

    #[test]
    fn the_active_set_solver_reuses_its_factorisation_and_agrees_with_gauss_seidel() {
        let n_pairs = 6;
        let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
        for mu in [0.0, 0.38, 1.2] {
            let (r_gs, _, _) = solve_with(Solver::GaussSeidel, mu);
            let mut solver = ContactSolver::new(Solver::ActiveSet);
            let mut r = vec![0.0; 3 * n_pairs];
            let mut w = vec![0.0; 3 * n_pairs];
            // A slowly drifting problem: the set holds, the sliding directions turn.
            for step in 0..6 {
                let drifted: Vec<f64> = w_free
                    .iter()
                    .enumerate()
                    .map(|(i, value)| value + 1e-5 * step as f64 * ((i % 5) as f64 - 2.0))
                    .collect();
                let problem = Problem {
                    W: &Delassus::new(W.clone()),
                    w_free: &drifted,
                    w_n_min: &w_n_min,
                    sliding_speed: &sliding,
                    mu,
                    force_scale: 0.0,
                    blocks: &two_pads(),
                };
                let report =
                    solve_settled(&mut solver, &problem, 1e-13, 20_000, &mut r, &mut w).unwrap();
                check_laws(&r, &w, mu, 1e-10);
                if step == 0 {
                    for (a, b) in r.iter().zip(&r_gs) {
                        assert!((a - b).abs() < 1e-9, "mu = {mu}: {a} vs {b}");
                    }
                }
                // Gauss–Seidel on the first two steps, then the chord on the factorisation.
                if step >= 2 {
                    assert!(
                        solver.factorisation.is_some() && report.iterations <= REFACTORISE_AFTER,
                        "mu = {mu}, step {step}: {} iterations",
                        report.iterations
                    );
                }
            }
            // A jump that changes the set: solved all the same, by the fallback.
            let reversed: Vec<f64> = w_free.iter().map(|value| -value).collect();
            let problem = Problem {
                W: &Delassus::new(W.clone()),
                w_free: &reversed,
                w_n_min: &w_n_min,
                sliding_speed: &sliding,
                mu,
                force_scale: 0.0,
                blocks: &two_pads(),
            };
            solve_settled(&mut solver, &problem, 1e-13, 20_000, &mut r, &mut w).unwrap();
            check_laws(&r, &w, mu, 1e-10);
            // The memory a checkpoint keeps rebuilds the same solver.
            let mut restored = ContactSolver::new(Solver::ActiveSet);
            restored.restore(solver.memory(), &problem);
            assert_eq!(restored.memory(), solver.memory());
        }
    }

    #[test]
    fn factorisations_that_do_not_pay_for_themselves_become_rare() {
        // Sets that hold two steps, then change: each factorisation fails on its first use,
        // and the waits between them double.
        let n_pairs = 6;
        let (W, w_free, w_n_min, sliding) = problem_data(n_pairs);
        let reversed: Vec<f64> = w_free.iter().map(|value| -value).collect();
        let mut solver = ContactSolver::new(Solver::ActiveSet);
        let (mut r, mut w) = (vec![0.0; 3 * n_pairs], vec![0.0; 3 * n_pairs]);
        let steps = 600;
        for step in 0..steps {
            let problem = Problem {
                W: &Delassus::new(W.clone()),
                w_free: if (step / 3) % 2 == 0 {
                    &w_free
                } else {
                    &reversed
                },
                w_n_min: &w_n_min,
                sliding_speed: &sliding,
                mu: 0.38,
                force_scale: 0.0,
                blocks: &two_pads(),
            };
            solve_settled(&mut solver, &problem, 1e-13, 20_000, &mut r, &mut w).unwrap();
            check_laws(&r, &w, 0.38, 1e-10);
        }
        // Unpaced, one factorisation every three steps (200); paced, the waits 2, 4, …, 256
        // leave about a dozen.
        assert!(
            solver.factorisations <= 12,
            "{} factorisations in {steps} steps",
            solver.factorisations
        );
    }

    #[test]
    fn a_pressed_single_pair_sticks_or_slides_as_coulomb_says() {
        // W = I: w = w_free + r. Pressed (w_free,n = −1) ⇒ r_n = 1. Free slip w_t − v_g =
        // −0.5: sticking needs r_t = 0.5, allowed when μ ≥ 0.5.
        let W = Mat::<f64>::identity(3, 3);
        for (mu, expected_r_t) in [(0.8, 0.5), (0.3, 0.3)] {
            let problem = Problem {
                W: &Delassus::new(W.clone()),
                w_free: &[-1.0, 0.5, 0.0],
                w_n_min: &[0.0],
                sliding_speed: &[1.0],
                mu,
                force_scale: 1.0,
                blocks: &pad_blocks(&[0]),
            };
            let (mut r, mut w) = (vec![0.0; 3], vec![0.0; 3]);
            solve_settled(
                &mut ContactSolver::new(Solver::GaussSeidel),
                &problem,
                1e-14,
                100,
                &mut r,
                &mut w,
            )
            .unwrap();
            assert!((r[0] - 1.0).abs() < 1e-14);
            assert!((r[1] - expected_r_t).abs() < 1e-14, "mu = {mu}: {r:?}");
            assert!(r[2].abs() < 1e-14);
        }
    }

    /// On an affine contraction `g = B x + c` (a sweep while the pairs keep their states),
    /// Anderson mixing reaches the fixed point in a fraction of the plain iterations, and the
    /// velocities it combines stay those of the combined reactions, `w = W_0 r + w_0`.
    #[test]
    fn anderson_mixing_accelerates_an_affine_iteration_and_keeps_the_velocities() {
        let n = 30;
        // Spectral radius 0.9: plain iteration needs about 260 iterations to gain 1e-12.
        let B = Mat::from_fn(n, n, |i, j| {
            let x = ((i * 5 + j * 3) % 7) as f64 / 7.0 - 0.5;
            if i == j { 0.9 } else { 0.004 * x }
        });
        let c: Vec<f64> = (0..n).map(|i| (i % 4) as f64 - 1.5).collect();
        let W_0 = Mat::from_fn(n, n, |i, j| 1.0 / (1.0 + (i as f64 - j as f64).abs()));
        let w_0: Vec<f64> = (0..n).map(|i| 0.1 * i as f64).collect();
        let apply = |A: &Mat<f64>, x: &[f64], shift: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|i| shift[i] + (0..n).map(|j| A[(i, j)] * x[j]).sum::<f64>())
                .collect()
        };
        let iterations = |accelerate: bool| {
            let mut anderson = Anderson::new(n);
            let mut r = vec![0.0; n];
            for iteration in 1..=1000 {
                anderson.start(&r);
                let g = apply(&B, &r, &c);
                let change = g
                    .iter()
                    .zip(&r)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                if change < 1e-12 {
                    return iteration;
                }
                r = g;
                let mut w = apply(&W_0, &r, &w_0);
                if accelerate {
                    anderson.mix(&mut r, &mut w);
                }
                let exact = apply(&W_0, &r, &w_0);
                for (mixed, exact) in w.iter().zip(&exact) {
                    assert!((mixed - exact).abs() < 1e-11, "{mixed} vs {exact}");
                }
            }
            panic!("no convergence");
        };
        let (plain, accelerated) = (iterations(false), iterations(true));
        assert!(plain > 200, "plain iteration: {plain}");
        assert!(
            5 * accelerated < plain,
            "{accelerated} against {plain} plain"
        );
    }

    /// Pairs on one pad couple through it far more than through the disc: sweeping each pad's
    /// pairs together reaches the same solution with a fraction of the sweeps over `W`.
    #[test]
    fn gauss_seidel_by_pads_agrees_with_pair_by_pair_in_fewer_sweeps() {
        let (n_pads, per_pad) = (4, 4);
        let (n_pairs, m) = (n_pads * per_pad, 3 * n_pads * per_pad);
        let pad = |i: usize| i / (3 * per_pad);
        let W = Mat::from_fn(m, m, |i, j| {
            let within = if i == j {
                1.0
            } else if pad(i) == pad(j) {
                0.3
            } else {
                0.0
            };
            // A weak coupling of every pair through the disc, positive semi-definite.
            let g = |k: usize| 1.0 + 0.5 * ((k * 7) % 5) as f64;
            within + 0.01 * g(i) * g(j)
        });
        let w_free: Vec<f64> = (0..m)
            .map(|i| match i % 3 {
                0 => -1.0 - 0.1 * (i % 4) as f64,
                1 => 0.1 * (i % 5) as f64 - 0.2,
                _ => 0.05,
            })
            .collect();
        let (w_n_min, sliding) = (vec![0.0; n_pairs], vec![1.0; n_pairs]);
        let solve = |body_of_pair: &[usize]| {
            let blocks = pad_blocks(body_of_pair);
            let problem = Problem {
                W: &Delassus::new(W.clone()),
                w_free: &w_free,
                w_n_min: &w_n_min,
                sliding_speed: &sliding,
                mu: 0.38,
                force_scale: 0.0,
                blocks: &blocks,
            };
            let (mut r, mut w) = (vec![0.0; m], vec![0.0; m]);
            let report = solve_settled(
                &mut ContactSolver::new(Solver::GaussSeidel),
                &problem,
                1e-13,
                20_000,
                &mut r,
                &mut w,
            )
            .unwrap();
            check_laws(&r, &w, 0.38, 1e-10);
            (r, report.iterations, blocks.len())
        };
        let by_pad: Vec<usize> = (0..n_pairs).map(|p| p / per_pad).collect();
        let by_pair: Vec<usize> = (0..n_pairs).collect();
        let ((r_pads, sweeps_pads, n_blocks), (r_pairs, sweeps_pairs, n_singletons)) =
            (solve(&by_pad), solve(&by_pair));
        assert_eq!((n_blocks, n_singletons), (n_pads, n_pairs));
        for (a, b) in r_pads.iter().zip(&r_pairs) {
            assert!((a - b).abs() < 1e-10, "{a} vs {b}");
        }
        assert!(
            2 * sweeps_pads <= sweeps_pairs,
            "{sweeps_pads} sweeps by pads, {sweeps_pairs} pair by pair"
        );
    }

    #[test]
    fn blocks_are_runs_of_one_body_and_no_longer_than_the_largest() {
        assert_eq!(pad_blocks(&[3, 3, 1, 1, 1, 3]), [0..2, 2..5, 5..6]);
        let long = pad_blocks(&[0; 2 * LARGEST_BLOCK + 1]);
        assert_eq!(
            long,
            [
                0..LARGEST_BLOCK,
                LARGEST_BLOCK..2 * LARGEST_BLOCK,
                2 * LARGEST_BLOCK..2 * LARGEST_BLOCK + 1
            ]
        );
    }

    #[test]
    fn a_solve_that_cannot_converge_reports_its_residuals() {
        let (W, w_free, w_n_min, sliding) = problem_data(6);
        let problem = Problem {
            W: &Delassus::new(W.clone()),
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &sliding,
            mu: 0.38,
            force_scale: 0.0,
            blocks: &two_pads(),
        };
        let (mut r, mut w) = (vec![0.0; 18], vec![0.0; 18]);
        let failure = solve_settled(
            &mut ContactSolver::new(Solver::FixedPoint),
            &problem,
            1e-15,
            2,
            &mut r,
            &mut w,
        )
        .unwrap_err();
        assert_eq!(failure.iterations, 2);
        assert_eq!(failure.history.len(), 2);
        assert!(failure.history.iter().all(|residual| *residual > 1e-15));
    }
}
