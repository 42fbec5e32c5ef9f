//! The θ-method with contact impulses, step by step (the equations are in the module doc of
//! [`super`]).
//!
//! Everything is written for the departure from the sliding equilibrium, `u = U − u_e`, with the
//! imposed load taken as the one that makes the stored equilibrium exact,
//! `F = K u_e − Hᵀ r_e`. Then
//!
//! ```text
//! J v¹ = (M/τ − (1−θ) C − τθ(1−θ) K) v⁰ − K u⁰ − Hᵀ r_e + Hᵀ r
//! ```
//!
//! solved as in [`squeal_linalg::cholesky`]: one forward sweep, the contact problem on the
//! pairs with `W = H J⁻¹ Hᵀ`, one backward sweep (the independent subtrees of J's elimination
//! tree in parallel, [`squeal_linalg::sweeps`]); or, for a reduced model of dense blocks, by
//! their inverses (`StepSolve`). `M v` comes from the step's own equation
//! (and `C v` too when the damping is Rayleigh's row by row, `products/`), `K u` by its
//! recursion `K u¹ = K u⁰ + τ K v^θ`, so a step costs one solve and one pass over `K` (with `C`
//! for other damping). (The solve's backward error, ε‖J‖‖v‖ per step by the factor, up to
//! `κ₁(Â) ε ‖b‖` by the inverse's blocks, is all that separates the derived products from
//! computed ones.) A contact problem solved with `W` in single
//! precision is accepted on the step's own relative velocities `H v¹`, or refined and the
//! step solved again ([`super::contact`]: precision).

use faer::Mat;
use faer::Par;
use serde::{Deserialize, Serialize};
use squeal_linalg::CscMatrix;
use squeal_linalg::block_inverse::{BlockInterfaceSolve, BlockInverse, Components};
use squeal_linalg::cholesky::{self, Cholesky, InterfaceSolve};

use super::contact::{self, ContactSolver, Delassus, PairState, Precision, Solver, classify};
use super::energy::{Audit, StepWork};
use super::products::Products;
use crate::stage::Checkpoints;

/// The structure the scheme integrates.
pub struct Structure<'a> {
    pub M: &'a CscMatrix,
    pub C: &'a CscMatrix,
    pub K: &'a CscMatrix,
    /// DOFs grouped by node, for the fill-reducing ordering (may be empty).
    pub dof_of_node: &'a [[Option<u32>; 3]],
    /// Rows of `H`, three per pair (n, t, b): `(H v)_{3p+d}` is the relative velocity.
    pub H_rows: Vec<Vec<(usize, f64)>>,
    /// Loads beyond the equilibrium's (none for the brake, whose load the equilibrium holds).
    pub load: Load,
}

/// A load `f(t) = constant + t rate` on the departure's equation (empty vectors: none): what a
/// lumped model's own load, and the DOFs it drives at a prescribed velocity, add.
#[derive(Debug, Clone, Default)]
pub struct Load {
    pub constant: Vec<f64>,
    pub rate: Vec<f64>,
}

impl Load {
    fn is_none(&self) -> bool {
        self.constant.is_empty() && self.rate.is_empty()
    }

    /// `f(t)`'s entry `i`.
    fn at(&self, i: usize, t: f64) -> f64 {
        self.constant.get(i).copied().unwrap_or(0.0) + t * self.rate.get(i).copied().unwrap_or(0.0)
    }
}

/// The contact pairs' data at the sliding equilibrium.
pub struct ContactState {
    /// Gap per pair at the equilibrium (m).
    pub gap: Vec<f64>,
    /// Sliding speed `|v_g|` per pair (m/s).
    pub sliding_speed: Vec<f64>,
    /// Equilibrium reactions, three per pair (n, t, b) (N).
    pub r_e: Vec<f64>,
    /// Per pair, the kinetic friction coefficient, and the static one that holds it when it
    /// stuck at a step's start (equal for the brake).
    pub mu: Vec<f64>,
    pub mu_static: Vec<f64>,
    /// The run's speed scale, below whose 1e-9 a slip on a surface at rest counts as none (0:
    /// every pair slides on a moving surface).
    pub speed_scale: f64,
    /// The pairs' Gauss–Seidel blocks ([`contact::pad_blocks`]): consecutive ranges covering
    /// every pair, in order.
    pub blocks: Vec<std::ops::Range<usize>>,
}

#[derive(Debug, Clone)]
pub struct Settings {
    pub theta: f64,
    pub tau: f64,
    pub n_steps: usize,
    pub solver: Solver,
    pub tolerance: f64,
    pub max_iterations: usize,
    /// Every how many steps a row of the history is written.
    pub output_every: usize,
    /// Pairs whose normal relative displacement and velocity are recorded.
    pub record_pairs: Vec<usize>,
    /// DOFs whose displacement and velocity are recorded in each history row.
    pub record_dofs: Vec<usize>,
    /// Whether each history row holds every pair's [`PairRecord`].
    pub record_contacts: bool,
    /// Steps at which a snapshot of `u`, `v` is kept (ascending).
    pub snapshot_steps: Vec<usize>,
    /// Steps kept whole, as [`StepSample`]s (ascending).
    pub sample_steps: Vec<usize>,
    /// `J`'s factor or its inverse's blocks ([`SolveBy::Choice`] but in tests).
    pub solve_by: SolveBy,
}

/// What the steps solve by (`StepSolve`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolveBy {
    /// `J`'s inverse by dense blocks where it pays and its residual stays small, `J`'s
    /// factor otherwise.
    Choice,
    Factor,
    /// `J`'s inverse by dense blocks whatever the model's size and condition (for tests).
    Inverse,
}

/// One row of the history, at time `t`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct HistoryRow {
    pub t: f64,
    /// Contact-zone averages of the relative displacement (from the equilibrium) and velocity.
    pub u_n: f64,
    pub u_t: f64,
    pub v_n: f64,
    pub v_t: f64,
    pub kinetic: f64,
    pub open: f64,
    pub stick: f64,
    pub slide: f64,
    /// The recorded pairs' normal relative displacement and velocity.
    pub points: Vec<(f64, f64)>,
    /// The recorded DOFs' displacement (from the equilibrium) and velocity.
    pub dofs: Vec<(f64, f64)>,
    /// Every pair, when the settings record them.
    pub contacts: Vec<PairRecord>,
    pub energy: super::energy::Totals,
    pub contact_iterations: usize,
}

/// A pair at the end of a step: its gap, relative velocities (n, t, b), mean reaction over the
/// step (n, t, b) and state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairRecord {
    pub gap: f64,
    pub w: [f64; 3],
    pub r: [f64; 3],
    pub state: PairState,
}

/// A kept snapshot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pub t: f64,
    pub u: Vec<f64>,
    pub v: Vec<f64>,
}

/// One step kept whole, for an a-posteriori check of the step equation: the state before,
/// the velocity after and the reactions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepSample {
    pub step: usize,
    pub u_old: Vec<f64>,
    pub v_old: Vec<f64>,
    pub v_new: Vec<f64>,
    pub r: Vec<f64>,
}

/// What a run gives.
pub struct Run {
    pub history: Vec<HistoryRow>,
    pub snapshots: Vec<Snapshot>,
    pub samples: Vec<StepSample>,
    /// Unknowns of the structure (DOFs, or reduced coordinates).
    pub unknowns: usize,
    /// Entries of `J`'s factor, or of its inverse's blocks when `by_inverse`.
    pub factor_len: usize,
    /// Rows of `Y = L⁻¹ Pᵀ Hᵀ` that are not zero; by the inverse, the unknowns of the blocks
    /// that `H` reaches.
    pub interface_rows: usize,
    /// Whether the steps solved by `J`'s inverse, by dense blocks, rather than its factor.
    pub by_inverse: bool,
    pub worst_contact_residual: f64,
    pub most_contact_iterations: usize,
    pub peak_penetration: f64,
    /// Per pair, the steps it ended open, sticking and sliding ([`PairState`] order).
    pub pair_steps: Vec<[u64; 3]>,
    /// Factorisations of the active-set contact solver (for benchmarks, like the timings).
    pub contact_factorisations: usize,
    /// Steps whose single-precision contact solution was refined in double precision.
    pub contact_refinements: usize,
    /// Where the time went (for benchmarks; never in an output: it is not reproducible).
    pub timings: Timings,
}

/// Wall time of a run's parts (s).
#[derive(Debug, Clone, Default)]
pub struct Timings {
    /// Cholesky of J (ordering, symbolic and numeric).
    pub factor: f64,
    /// `Y = L⁻¹ Pᵀ Hᵀ`, `W = Yᵀ Y` and the response `J⁻¹ Hᵀ` if kept.
    pub delassus: f64,
    /// The steps' solves but their contact problems: the sweeps and the interface products.
    pub solve: f64,
    /// The steps' contact problems.
    pub contact: f64,
    /// The steps, all of them.
    pub steps: f64,
    /// Steps run in this process: fewer than the run's after a resume from a checkpoint.
    pub steps_run: usize,
}

/// Why a run stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    Linear(squeal_linalg::Error),
    Contact {
        step: usize,
        t: f64,
        history: Vec<f64>,
        iterations: usize,
    },
    NotFinite {
        step: usize,
        t: f64,
    },
}

/// `out = H x`.
fn h_times_into(H_rows: &[Vec<(usize, f64)>], x: &[f64], out: &mut [f64]) {
    for (slot, row) in out.iter_mut().zip(H_rows) {
        *slot = row.iter().map(|&(dof, value)| value * x[dof]).sum();
    }
}

fn h_times(H_rows: &[Vec<(usize, f64)>], x: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; H_rows.len()];
    h_times_into(H_rows, x, &mut out);
    out
}

/// `J = M/τ + θ C + τθ² K` combined, ordered and analysed, the contact DOFs ordered last.
fn analyse_J(
    structure: &Structure,
    theta: f64,
    tau: f64,
) -> Result<cholesky::Analysis, squeal_linalg::Error> {
    let mut interface: Vec<usize> = structure
        .H_rows
        .iter()
        .flat_map(|row| row.iter().map(|&(dof, _)| dof))
        .collect();
    interface.sort_unstable();
    interface.dedup();
    // Eliminated last, a small interface keeps `Y = L⁻¹ Pᵀ Hᵀ` short. A reduced model's
    // interface is most of its unknowns, its bodies' blocks coupled only through the modal
    // coordinates: nested dissection alone puts those last and keeps the blocks apart, where
    // the interface last would fill it whole.
    let last = if 2 * interface.len() > structure.K.n_rows {
        &[][..]
    } else {
        &interface[..]
    };
    Cholesky::analyse(
        &[
            (1.0 / tau, structure.M),
            (theta, structure.C),
            (tau * theta * theta, structure.K),
        ],
        structure.dof_of_node,
        last,
    )
}

/// `J` factorised, the contact DOFs ordered last.
pub fn factorise_J(
    structure: &Structure,
    theta: f64,
    tau: f64,
) -> Result<Cholesky, squeal_linalg::Error> {
    analyse_J(structure, theta, tau)?.factorise(Par::Seq)
}

/// Below these many entries, `J`'s factor and `Y` stay in cache: the inverse would gain
/// nothing.
const LEAST_INVERSE_ENTRIES: usize = 1 << 16;
/// The largest condition `κ₁(Â)` of an inverse's scaled blocks that a step solves by: a
/// product by the inverse leaves a residual `κ₁(Â)` times a solve's at worst, and the step's
/// derived products (`products/`) and its energy audit read the step's equation as exact.
const MOST_INVERSE_CONDITION: f64 = 1e4;

/// How a step solves `J v¹ = F + Hᵀ r`: by `J`'s sparse factor split around the contact
/// DOFs, or by the dense inverses of `J`'s connected components
/// ([`squeal_linalg::block_inverse`]) where these hold no more entries than the factor would
/// (a reduced model with its bodies kept whole: each body's block is dense, and so is its
/// factor), unless the model is small enough to solve in cache or a block's condition makes
/// the inverse's residual too large.
enum StepSolve {
    Factor(Box<Cholesky>, InterfaceSolve),
    Inverse(BlockInverse, BlockInterfaceSolve),
}

impl StepSolve {
    /// The solve, with the time its operator and its Delassus operator took into `timings`.
    fn new(
        structure: &Structure,
        (theta, tau, solve_by): (f64, f64, SolveBy),
        timings: &mut Timings,
    ) -> Result<StepSolve, squeal_linalg::Error> {
        let clock = std::time::Instant::now();
        let analysis = analyse_J(structure, theta, tau)?;
        let components = Components::of(&[structure.M, structure.C, structure.K]);
        let entries = components.dense_len();
        let worth_trying = match solve_by {
            SolveBy::Choice => (LEAST_INVERSE_ENTRIES..=analysis.factor_len()).contains(&entries),
            SolveBy::Factor => false,
            SolveBy::Inverse => true,
        };
        if worth_trying {
            let inverse = BlockInverse::new(&analysis, &components)?;
            if solve_by == SolveBy::Inverse || inverse.condition() <= MOST_INVERSE_CONDITION {
                timings.factor = clock.elapsed().as_secs_f64();
                let clock = std::time::Instant::now();
                let split = BlockInterfaceSolve::new(&inverse, &structure.H_rows);
                timings.delassus = clock.elapsed().as_secs_f64();
                return Ok(StepSolve::Inverse(inverse, split));
            }
        }
        let cholesky = analysis.factorise(Par::Seq)?;
        timings.factor = clock.elapsed().as_secs_f64();
        let clock = std::time::Instant::now();
        let split = InterfaceSolve::new(&cholesky, &structure.H_rows);
        timings.delassus = clock.elapsed().as_secs_f64();
        Ok(StepSolve::Factor(Box::new(cholesky), split))
    }

    /// The Delassus operator `W = H J⁻¹ Hᵀ`.
    fn W(&self) -> &Mat<f64> {
        match self {
            StepSolve::Factor(_, split) => &split.W,
            StepSolve::Inverse(_, split) => &split.W,
        }
    }

    /// `x = J⁻¹ (b + Hᵀ r)`, `r` chosen by `react` from `H J⁻¹ b` (written to `w_free`).
    fn solve<'r, E>(
        &self,
        b: &[f64],
        work: (&mut [f64], &mut [f64], &mut [f64]),
        react: impl FnOnce(&[f64]) -> Result<&'r [f64], E>,
    ) -> Result<(), E> {
        match self {
            StepSolve::Factor(cholesky, split) => split.solve(cholesky, b, work, react),
            StepSolve::Inverse(inverse, split) => split.solve(inverse, b, work, react),
        }
    }

    /// What the run reports of its operator: its entries, the rows the contact reaches, and
    /// whether it is `J`'s inverse.
    fn size(&self) -> (usize, usize, bool) {
        match self {
            StepSolve::Factor(cholesky, split) => (cholesky.factor_len(), split.rows.len(), false),
            StepSolve::Inverse(inverse, split) => {
                (inverse.entries(), split.contact_rows(inverse), true)
            }
        }
    }
}

/// What stays fixed through a run: J's factorisation, the Delassus operator, the products.
struct Operators<'s> {
    structure: &'s Structure<'s>,
    contact_state: &'s ContactState,
    settings: &'s Settings,
    step_solve: StepSolve,
    delassus: Delassus,
    products: Products,
    /// `Hᵀ r_e`, the equilibrium's contact force.
    equilibrium_force: Vec<f64>,
    /// The largest equilibrium reaction, the contact residual's force scale.
    force_scale: f64,
}

impl<'s> Operators<'s> {
    fn new(
        structure: &'s Structure<'s>,
        contact_state: &'s ContactState,
        settings: &'s Settings,
        timings: &mut Timings,
    ) -> Result<Operators<'s>, Failure> {
        let Settings { theta, tau, .. } = *settings;
        debug_assert!(
            (contact_state.blocks.iter().cloned().flatten()).eq(0..contact_state.gap.len()),
            "the Gauss–Seidel blocks cover every pair, in order"
        );
        let step_solve = StepSolve::new(structure, (theta, tau, settings.solve_by), timings)
            .map_err(Failure::Linear)?;
        let clock = std::time::Instant::now();
        let delassus = Delassus::new(step_solve.W().clone());
        timings.delassus += clock.elapsed().as_secs_f64();
        let mut equilibrium_force = vec![0.0; structure.K.n_rows];
        add_h_transpose_times(
            &structure.H_rows,
            &contact_state.r_e,
            &mut equilibrium_force,
        );
        Ok(Operators {
            structure,
            contact_state,
            settings,
            step_solve,
            delassus,
            products: Products::new(structure.M, structure.C, structure.K),
            equilibrium_force,
            force_scale: contact_state
                .r_e
                .iter()
                .fold(0.0_f64, |largest, r| largest.max(r.abs())),
        })
    }

    fn n_pairs(&self) -> usize {
        self.contact_state.gap.len()
    }

    /// The contact problem of a step with these free velocities, least normal velocities and
    /// friction coefficients.
    fn contact_problem<'a>(
        &'a self,
        w_free: &'a [f64],
        w_n_min: &'a [f64],
        mu: &'a [f64],
    ) -> contact::Problem<'a> {
        contact::Problem {
            W: &self.delassus,
            w_free,
            w_n_min,
            sliding_speed: &self.contact_state.sliding_speed,
            speed_scale: self.contact_state.speed_scale,
            mu,
            force_scale: self.force_scale,
            blocks: &self.contact_state.blocks,
        }
    }

    /// The state at step 0, the departure `(u, v)`, with its history row and snapshot.
    fn initial_state(&self, u: Vec<f64>, v: Vec<f64>) -> State {
        let H_rows = &self.structure.H_rows;
        let mut MCK_v: Vec<[f64; 3]> = self
            .structure
            .M
            .mul_vec(&v)
            .into_iter()
            .map(|M_v| [M_v, 0.0, 0.0])
            .collect();
        self.products.with_mass(&v, &mut MCK_v);
        let K_u = self.structure.K.mul_vec(&u);
        let audit = Audit::new(&u, &v, &MCK_v, &K_u);
        let mut state = State {
            step: 0,
            delta: h_times(H_rows, &u),
            w: h_times(H_rows, &v),
            r: self.contact_state.r_e.clone(),
            u,
            v,
            MCK_v,
            K_u,
            contact: contact::Memory::default(),
            audit,
            history: Vec::new(),
            snapshots: Vec::new(),
            samples: Vec::new(),
            worst_contact_residual: 0.0,
            most_contact_iterations: 0,
            peak_penetration: 0.0,
            pair_steps: vec![[0; 3]; self.n_pairs()],
            sticking: vec![false; self.n_pairs()],
        };
        self.record(&mut state, 0);
        state
    }

    /// A checkpoint of this run, if `bytes` hold one.
    fn resume(&self, bytes: &[u8]) -> Option<State> {
        let n = self.structure.K.n_rows;
        postcard::from_bytes::<State>(bytes).ok().filter(|saved| {
            saved.step <= self.settings.n_steps
                && saved.u.len() == n
                && saved.v.len() == n
                && saved.MCK_v.len() == n
                && saved.K_u.len() == n
                && saved.r.len() == 3 * self.n_pairs()
                && saved.sticking.len() == self.n_pairs()
        })
    }

    /// `v¹` into `work.v_new` from `work.rhs`, with the reactions `r` that `contact` finds
    /// from the step's contact problem (their velocities into `work.w_new`; `None` without
    /// pairs), the time it took added to `contact_time`.
    fn solve_step(
        &self,
        work: &mut Work,
        r: &mut [f64],
        contact_time: &mut f64,
        contact: impl FnOnce(
            &contact::Problem,
            &mut [f64],
            &mut [f64],
        ) -> Result<contact::Report, contact::NotConverged>,
    ) -> Result<Option<contact::Report>, contact::NotConverged> {
        let mut report = None;
        let (w_new, w_n_min) = (&mut work.w_new, &work.w_n_min);
        let work_mu = &work.mu;
        self.step_solve.solve(
            &work.rhs,
            (&mut work.w_free, &mut work.y, &mut work.v_new),
            |w_free| {
                if self.n_pairs() > 0 {
                    let clock = std::time::Instant::now();
                    let problem = self.contact_problem(w_free, w_n_min, work_mu);
                    report = Some(contact(&problem, r, w_new)?);
                    *contact_time += clock.elapsed().as_secs_f64();
                }
                Ok(&r[..])
            },
        )?;
        Ok(report)
    }

    /// The step's velocity and reactions (into `work.v_new`, `state.r`, their pair velocities
    /// into `work.w_new`) at the friction coefficients `work.mu`.
    fn solve_contact(
        &self,
        state: &mut State,
        contact_solver: &mut ContactSolver,
        work: &mut Work,
        contact_time: &mut f64,
    ) -> Result<contact::Report, contact::NotConverged> {
        let (tolerance, max_iterations) = (self.settings.tolerance, self.settings.max_iterations);
        let mut report = self
            .solve_step(work, &mut state.r, contact_time, |problem, r, w| {
                contact_solver.solve(problem, tolerance, max_iterations, r, w)
            })?
            .unwrap_or(contact::Report {
                iterations: 0,
                residual: 0.0,
                precision: Precision::Double,
            });
        let finite = work.v_new.iter().all(|value| value.is_finite());
        if !finite || self.n_pairs() == 0 {
            return Ok(report);
        }
        // The pairs' velocities from the step's own solution: the solver's `w_free + W r`,
        // carried from step to step by its warm start, drifts from them by round-off (1e-11 of
        // the velocity over 10⁴ steps), and the gaps, the slips and the energy audit read them.
        h_times_into(&self.structure.H_rows, &work.v_new, &mut work.w_new);
        let problem = self.contact_problem(&work.w_free, &work.w_n_min, &work.mu);
        if report.precision == Precision::Single {
            // Reactions found with W in single precision: the step is accepted on its own
            // end-of-step velocities, or its contact problem is refined in double precision
            // from there and the step solved again.
            match contact_solver.settle(&problem, tolerance, &state.r, &work.w_new) {
                Ok(residual) => report.residual = residual,
                Err(_) => {
                    let refine = |problem: &contact::Problem, r: &mut [f64], w: &mut [f64]| {
                        contact_solver.refine(problem, tolerance, max_iterations, r, w)
                    };
                    if let Some(refined) =
                        self.solve_step(work, &mut state.r, contact_time, refine)?
                    {
                        report.iterations += refined.iterations;
                        report.residual = refined.residual;
                    }
                }
            }
        } else {
            contact_solver.adopt(&problem, &work.w_new);
        }
        Ok(report)
    }

    fn sliding_speed(&self, p: usize) -> f64 {
        self.contact_state.sliding_speed[p]
    }

    fn speed_scale(&self) -> f64 {
        self.contact_state.speed_scale
    }

    /// One step of the scheme, from `state` at step `state.step`.
    fn advance(
        &self,
        state: &mut State,
        contact_solver: &mut ContactSolver,
        work: &mut Work,
        timings: &mut Timings,
    ) -> Result<(), Failure> {
        let Settings { theta, tau, .. } = *self.settings;
        let step = state.step + 1;
        let t = step as f64 * tau;
        let n_pairs = self.n_pairs();
        // F_MTD for the departure, in elimination order.
        let (a, b, c) = (1.0 / tau, -(1.0 - theta), -tau * theta * (1.0 - theta));
        for (i, slot) in work.rhs.iter_mut().enumerate() {
            let [Mv, Cv, Kv] = state.MCK_v[i];
            *slot = a * Mv + b * Cv + c * Kv - state.K_u[i] - self.equilibrium_force[i];
        }
        // A load beyond the equilibrium's at t^θ (θ F¹ + (1−θ) F⁰, F affine in t).
        let load = &self.structure.load;
        let t_theta = (state.step as f64 + theta) * tau;
        if !load.is_none() {
            for (i, slot) in work.rhs.iter_mut().enumerate() {
                *slot += load.at(i, t_theta);
            }
        }
        // The equivalent gap B̃ = g + τ(1−θ) w_n (Signorini on the end-of-step velocity).
        for p in 0..n_pairs {
            let gap = self.contact_state.gap[p] + state.delta[3 * p];
            let equivalent_gap = gap + tau * (1.0 - theta) * state.w[3 * p];
            work.w_n_min[p] = -equivalent_gap / tau;
        }
        let clock = std::time::Instant::now();
        let mut contact_time = 0.0;
        let failed = |failure: contact::NotConverged| Failure::Contact {
            step,
            t,
            history: failure.history,
            iterations: failure.iterations,
        };
        let (mu, mu_static) = (&self.contact_state.mu, &self.contact_state.mu_static);
        let static_friction = mu_static != mu;
        if static_friction {
            for p in 0..n_pairs {
                work.mu[p] = if state.sticking[p] {
                    mu_static[p]
                } else {
                    mu[p]
                };
            }
        }
        let mut report = self
            .solve_contact(state, contact_solver, work, &mut contact_time)
            .map_err(failed)?;
        // A pair held by static friction that slips anyway slides under the kinetic law: its
        // step is solved again with μ (each pass releases at least one pair).
        let mut released = static_friction;
        while released {
            released = false;
            for (p, slot) in work.mu.iter_mut().enumerate() {
                let slides = classify(
                    &state.r,
                    &work.w_new,
                    p,
                    self.sliding_speed(p),
                    self.speed_scale(),
                ) == PairState::Slide;
                if *slot != mu[p] && slides {
                    *slot = mu[p];
                    released = true;
                }
            }
            if released {
                let again = self
                    .solve_contact(state, contact_solver, work, &mut contact_time)
                    .map_err(failed)?;
                report.iterations += again.iterations;
                report.residual = again.residual;
            }
        }
        timings.contact += contact_time;
        timings.solve += clock.elapsed().as_secs_f64() - contact_time;
        state.worst_contact_residual = state.worst_contact_residual.max(report.residual);
        state.most_contact_iterations = state.most_contact_iterations.max(report.iterations);
        if work.v_new.iter().any(|value| !value.is_finite()) {
            return Err(Failure::NotFinite { step, t });
        }
        // J v¹ = F_MTD + Hᵀ r gives M v¹ (and C v¹ for Rayleigh damping) without a product.
        add_h_transpose_times(&self.structure.H_rows, &state.r, &mut work.rhs);
        self.products
            .of_solution(&work.v_new, &work.rhs, tau, theta, &mut work.MCK_v_new);
        // u¹ = u⁰ + τ v^θ, K u¹ = K u⁰ + τ K v^θ, δ¹ = δ⁰ + τ w^θ.
        work.u_old.copy_from_slice(&state.u);
        work.K_u_old.copy_from_slice(&state.K_u);
        for i in 0..state.u.len() {
            state.u[i] += tau * (theta * work.v_new[i] + (1.0 - theta) * state.v[i]);
            state.K_u[i] +=
                tau * (theta * work.MCK_v_new[i][2] + (1.0 - theta) * state.MCK_v[i][2]);
        }
        for (k, slot) in state.delta.iter_mut().enumerate() {
            *slot += tau * (theta * work.w_new[k] + (1.0 - theta) * state.w[k]);
        }
        let load_work = (!load.is_none()).then(|| {
            (0..state.u.len())
                .map(|i| {
                    let v_theta = theta * work.v_new[i] + (1.0 - theta) * state.v[i];
                    tau * load.at(i, t_theta) * v_theta
                })
                .sum::<f64>()
        });
        state.audit.step(StepWork {
            tau,
            theta,
            load_work,
            u_old: &work.u_old,
            u_new: &state.u,
            v_old: &state.v,
            v_new: &work.v_new,
            MCK_v_old: &state.MCK_v,
            MCK_v_new: &work.MCK_v_new,
            K_u_old: &work.K_u_old,
            K_u_new: &state.K_u,
            r: &state.r,
            r_e: &self.contact_state.r_e,
            w_old: &state.w,
            w_new: &work.w_new,
            sliding_speed: &self.contact_state.sliding_speed,
        });
        if self.settings.sample_steps.binary_search(&step).is_ok() {
            state.samples.push(StepSample {
                step,
                u_old: work.u_old.clone(),
                v_old: state.v.clone(),
                v_new: work.v_new.clone(),
                r: state.r.clone(),
            });
        }
        std::mem::swap(&mut state.v, &mut work.v_new);
        std::mem::swap(&mut state.MCK_v, &mut work.MCK_v_new);
        std::mem::swap(&mut state.w, &mut work.w_new);
        for p in 0..n_pairs {
            let penetration = -(self.contact_state.gap[p] + state.delta[3 * p]);
            state.peak_penetration = state.peak_penetration.max(penetration);
            let pair_state = classify(
                &state.r,
                &state.w,
                p,
                self.sliding_speed(p),
                self.speed_scale(),
            );
            state.pair_steps[p][pair_state as usize] += 1;
            state.sticking[p] = pair_state == PairState::Stick;
        }
        state.step = step;
        self.record(state, report.iterations);
        Ok(())
    }

    /// The history row and snapshot of `state.step`, when they are due.
    fn record(&self, state: &mut State, contact_iterations: usize) {
        let settings = self.settings;
        let step = state.step;
        if step.is_multiple_of(settings.output_every) || step == settings.n_steps {
            state
                .history
                .push(self.history_row(state, contact_iterations));
        }
        if settings.snapshot_steps.binary_search(&step).is_ok() {
            state.snapshots.push(Snapshot {
                t: step as f64 * settings.tau,
                u: state.u.clone(),
                v: state.v.clone(),
            });
        }
    }

    fn history_row(&self, state: &State, contact_iterations: usize) -> HistoryRow {
        let n_pairs = self.n_pairs();
        let (delta, w) = (&state.delta, &state.w);
        let mean = |values: &[f64], d: usize| {
            if n_pairs == 0 {
                0.0
            } else {
                (0..n_pairs).map(|p| values[3 * p + d]).sum::<f64>() / n_pairs as f64
            }
        };
        let mut counts = [0usize; 3];
        for p in 0..n_pairs {
            let pair_state = classify(&state.r, w, p, self.sliding_speed(p), self.speed_scale());
            counts[pair_state as usize] += 1;
        }
        let fraction = |state: PairState| {
            if n_pairs == 0 {
                0.0
            } else {
                counts[state as usize] as f64 / n_pairs as f64
            }
        };
        HistoryRow {
            t: state.step as f64 * self.settings.tau,
            u_n: mean(delta, 0),
            u_t: mean(delta, 1),
            v_n: mean(w, 0),
            v_t: mean(w, 1),
            kinetic: state.audit.totals.kinetic,
            open: fraction(PairState::Open),
            stick: fraction(PairState::Stick),
            slide: fraction(PairState::Slide),
            points: self
                .settings
                .record_pairs
                .iter()
                .map(|&p| (delta[3 * p], w[3 * p]))
                .collect(),
            dofs: self
                .settings
                .record_dofs
                .iter()
                .map(|&dof| (state.u[dof], state.v[dof]))
                .collect(),
            contacts: match self.settings.record_contacts {
                false => Vec::new(),
                true => (0..n_pairs)
                    .map(|p| PairRecord {
                        gap: self.contact_state.gap[p] + delta[3 * p],
                        w: contact::pair(w, p),
                        r: contact::pair(&state.r, p),
                        state: classify(&state.r, w, p, self.sliding_speed(p), self.speed_scale()),
                    })
                    .collect(),
            },
            energy: state.audit.totals.clone(),
            contact_iterations,
        }
    }
}

/// `out += Hᵀ r`.
fn add_h_transpose_times(H_rows: &[Vec<(usize, f64)>], r: &[f64], out: &mut [f64]) {
    for (row, entries) in H_rows.iter().enumerate() {
        for &(dof, value) in entries {
            out[dof] += value * r[row];
        }
    }
}

/// Everything a step changes: what a checkpoint holds. `M v` and `K u` are carried by
/// recursions, so the products are kept with the vectors.
#[derive(Serialize, Deserialize)]
struct State {
    step: usize,
    u: Vec<f64>,
    v: Vec<f64>,
    /// `(M v, C v, K v)` per DOF.
    MCK_v: Vec<[f64; 3]>,
    K_u: Vec<f64>,
    /// Relative displacement (from the equilibrium) and velocity of the pairs, and their
    /// reactions.
    delta: Vec<f64>,
    w: Vec<f64>,
    r: Vec<f64>,
    /// The contact solver's memory, written with each checkpoint.
    contact: contact::Memory,
    audit: Audit,
    history: Vec<HistoryRow>,
    snapshots: Vec<Snapshot>,
    samples: Vec<StepSample>,
    worst_contact_residual: f64,
    most_contact_iterations: usize,
    peak_penetration: f64,
    /// Per pair, the steps it ended open, sticking and sliding ([`PairState`] order).
    pair_steps: Vec<[u64; 3]>,
    /// Per pair, whether it ended the last step sticking (static friction holds it).
    sticking: Vec<bool>,
}

/// A step's scratch vectors.
struct Work {
    rhs: Vec<f64>,
    /// The step's vector in elimination order, through both sweeps.
    y: Vec<f64>,
    u_old: Vec<f64>,
    K_u_old: Vec<f64>,
    v_new: Vec<f64>,
    MCK_v_new: Vec<[f64; 3]>,
    w_free: Vec<f64>,
    w_new: Vec<f64>,
    w_n_min: Vec<f64>,
    /// The step's friction coefficient per pair.
    mu: Vec<f64>,
}

impl Work {
    fn new(n: usize, mu: &[f64]) -> Work {
        let n_pairs = mu.len();
        Work {
            rhs: vec![0.0; n],
            y: vec![0.0; n],
            u_old: vec![0.0; n],
            K_u_old: vec![0.0; n],
            v_new: vec![0.0; n],
            MCK_v_new: vec![[0.0; 3]; n],
            w_free: vec![0.0; 3 * n_pairs],
            w_new: vec![0.0; 3 * n_pairs],
            w_n_min: vec![0.0; n_pairs],
            mu: mu.to_vec(),
        }
    }
}

/// Integrates from the departure `(u, v)` (from the equilibrium), or from the latest of
/// `checkpoints` if it holds one of this run; `on_step(step)` is called after each step
/// (progress).
pub fn integrate(
    structure: &Structure,
    contact_state: &ContactState,
    settings: &Settings,
    u: Vec<f64>,
    v: Vec<f64>,
    checkpoints: &dyn Checkpoints,
    mut on_step: impl FnMut(usize),
) -> Result<Run, Failure> {
    let mut timings = Timings::default();
    let operators = Operators::new(structure, contact_state, settings, &mut timings)?;
    let mut state = match checkpoints
        .load()
        .and_then(|bytes| operators.resume(&bytes))
    {
        Some(saved) => saved,
        None => operators.initial_state(u, v),
    };
    let mut contact_solver = ContactSolver::new(settings.solver);
    let mut work = Work::new(structure.K.n_rows, &contact_state.mu);
    contact_solver.restore(
        state.contact.clone(),
        &operators.contact_problem(&work.w_free, &work.w_n_min, &work.mu),
    );
    let steps_clock = std::time::Instant::now();
    timings.steps_run = settings.n_steps.saturating_sub(state.step);
    while state.step < settings.n_steps {
        operators.advance(&mut state, &mut contact_solver, &mut work, &mut timings)?;
        if state.step < settings.n_steps && checkpoints.due() {
            state.contact = contact_solver.memory();
            if let Ok(bytes) = postcard::to_stdvec(&state) {
                checkpoints.save(&bytes);
            }
        }
        on_step(state.step);
    }
    timings.steps = steps_clock.elapsed().as_secs_f64();
    let (factor_len, interface_rows, by_inverse) = operators.step_solve.size();
    Ok(Run {
        timings,
        unknowns: structure.K.n_rows,
        factor_len,
        interface_rows,
        by_inverse,
        history: state.history,
        snapshots: state.snapshots,
        samples: state.samples,
        worst_contact_residual: state.worst_contact_residual,
        most_contact_iterations: state.most_contact_iterations,
        peak_penetration: state.peak_penetration,
        pair_steps: state.pair_steps,
        contact_factorisations: contact_solver.factorisations,
        contact_refinements: contact_solver.refinements,
    })
}
