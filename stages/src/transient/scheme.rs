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
//! pairs with `W = H J⁻¹ Hᵀ`, one backward sweep. `C v` and `K v` come from one pass over
//! their union pattern; `M v` from the step's own equation,
//!
//! ```text
//! M v¹ = τ (J v¹ − θ C v¹ − τθ² K v¹),   J v¹ = F_MTD + Hᵀ r  (the right-hand side just solved)
//! ```
//!
//! and `K u` by its recursion `K u¹ = K u⁰ + τ K v^θ`, so a step costs one solve and one
//! product with two matrices. (The solve's backward error, ε‖J‖‖v‖ per step, is all that
//! separates the derived `M v` from the product.)

use faer::{MatMut, Par};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use squeal_linalg::CscMatrix;
use squeal_linalg::cholesky::{Cholesky, InterfaceSolve};

use super::contact::{self, ContactSolver, PairState, Solver, classify};
use super::energy::{Audit, StepWork};
use crate::stage::Checkpoints;

/// Rows of each fixed chunk of the fused products (independent of the thread count).
const PRODUCT_CHUNK: usize = 4096;

/// The structure the scheme integrates.
pub struct Structure<'a> {
    pub M: &'a CscMatrix,
    pub C: &'a CscMatrix,
    pub K: &'a CscMatrix,
    /// DOFs grouped by node, for the fill-reducing ordering (may be empty).
    pub dof_of_node: &'a [[Option<u32>; 3]],
    /// Rows of `H`, three per pair (n, t, b): `(H v)_{3p+d}` is the relative velocity.
    pub H_rows: Vec<Vec<(usize, f64)>>,
}

/// The contact pairs' data at the sliding equilibrium.
pub struct ContactState {
    /// Gap per pair at the equilibrium (m).
    pub gap: Vec<f64>,
    /// Sliding speed `|v_g|` per pair (m/s).
    pub sliding_speed: Vec<f64>,
    /// Equilibrium reactions, three per pair (n, t, b) (N).
    pub r_e: Vec<f64>,
    pub mu: f64,
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
    /// Steps at which a snapshot of `u`, `v` is kept (ascending).
    pub snapshot_steps: Vec<usize>,
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
    pub energy: super::energy::Totals,
    pub contact_iterations: usize,
}

/// A kept snapshot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pub t: f64,
    pub u: Vec<f64>,
    pub v: Vec<f64>,
}

/// What a run gives.
pub struct Run {
    pub history: Vec<HistoryRow>,
    pub snapshots: Vec<Snapshot>,
    pub factor_len: usize,
    /// Rows of `Y = L⁻¹ Pᵀ Hᵀ` that are not zero.
    pub interface_rows: usize,
    pub worst_contact_residual: f64,
    pub most_contact_iterations: usize,
    pub peak_penetration: f64,
    /// Factorisations of the active-set contact solver (for benchmarks, like the timings).
    pub contact_factorisations: usize,
    /// Where the time went (for benchmarks; never in an output: it is not reproducible).
    pub timings: Timings,
}

/// Wall time of a run's parts (s).
#[derive(Debug, Clone, Default)]
pub struct Timings {
    /// Cholesky of J (ordering, symbolic and numeric).
    pub factor: f64,
    /// `Y = L⁻¹ Pᵀ Hᵀ` and `W = Yᵀ Y`.
    pub delassus: f64,
    /// The steps: their forward and backward sweeps, their contact solves, all of them.
    pub sweeps: f64,
    pub contact: f64,
    pub steps: f64,
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

/// Everything a step changes: what a checkpoint holds. `C v`, `K v` are recomputed from `v`
/// (the same bytes: the fused product is deterministic); `M v` and `K u` are carried by
/// recursions, so they are kept.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    step: usize,
    u: Vec<f64>,
    v: Vec<f64>,
    K_u: Vec<f64>,
    M_v: Vec<f64>,
    delta: Vec<f64>,
    w: Vec<f64>,
    r: Vec<f64>,
    contact: contact::Memory,
    audit: Audit,
    history: Vec<HistoryRow>,
    snapshots: Vec<Snapshot>,
    worst_contact_residual: f64,
    most_contact_iterations: usize,
    peak_penetration: f64,
}

/// `C x` and `K x` in one pass over the union of their patterns.
struct FusedProducts {
    col_ptr: Vec<usize>,
    /// `u32` halves the index traffic: the product is bound by memory bandwidth.
    row_idx: Vec<u32>,
    values: Vec<[f64; 2]>,
}

impl FusedProducts {
    fn new(matrices: [&CscMatrix; 2]) -> FusedProducts {
        let n = matrices[0].n_cols;
        assert!(n <= u32::MAX as usize, "more unknowns than u32 indices");
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        let mut values: Vec<[f64; 2]> = Vec::new();
        let mut column: Vec<(usize, usize, f64)> = Vec::new();
        for col in 0..n {
            column.clear();
            for (which, A) in matrices.iter().enumerate() {
                for entry in A.col_ptr[col]..A.col_ptr[col + 1] {
                    column.push((A.row_idx[entry], which, A.values[entry]));
                }
            }
            column.sort_by_key(|&(row, which, _)| (row, which));
            let mut last = usize::MAX;
            for &(row, which, value) in &column {
                if row != last {
                    row_idx.push(row as u32);
                    values.push([0.0; 2]);
                    last = row;
                }
                values.last_mut().expect("an entry was pushed")[which] += value;
            }
            col_ptr.push(row_idx.len());
        }
        FusedProducts {
            col_ptr,
            row_idx,
            values,
        }
    }

    /// `C x` and `K x` into the last two slots of `out`, laid out `(M x, C x, K x)` per row:
    /// the matrices are symmetric, so row `i` is read as column `i`; each output entry is
    /// summed by one task in a fixed order.
    fn apply(&self, x: &[f64], out: &mut [[f64; 3]]) {
        out.par_chunks_mut(PRODUCT_CHUNK)
            .enumerate()
            .for_each(|(chunk, slots)| {
                for (offset, slot) in slots.iter_mut().enumerate() {
                    let i = chunk * PRODUCT_CHUNK + offset;
                    let mut sum = [0.0; 2];
                    for entry in self.col_ptr[i]..self.col_ptr[i + 1] {
                        let value = self.values[entry];
                        let x_j = x[self.row_idx[entry] as usize];
                        sum[0] += value[0] * x_j;
                        sum[1] += value[1] * x_j;
                    }
                    slot[1] = sum[0];
                    slot[2] = sum[1];
                }
            });
    }
}

fn h_times(H_rows: &[Vec<(usize, f64)>], x: &[f64]) -> Vec<f64> {
    H_rows
        .iter()
        .map(|row| row.iter().map(|&(dof, value)| value * x[dof]).sum())
        .collect()
}

/// Integrates from the departure `(u, v)` (from the equilibrium), or from the latest of
/// `checkpoints` if it holds one of this run; `on_step(step)` is called after each step
/// (progress).
pub fn integrate(
    structure: &Structure,
    contact_state: &ContactState,
    settings: &Settings,
    mut u: Vec<f64>,
    mut v: Vec<f64>,
    checkpoints: &dyn Checkpoints,
    mut on_step: impl FnMut(usize),
) -> Result<Run, Failure> {
    let Settings { theta, tau, .. } = *settings;
    let n = structure.K.n_rows;
    let n_pairs = contact_state.gap.len();
    let m = 3 * n_pairs;
    let mut timings = Timings::default();
    let clock = std::time::Instant::now();
    let interface: Vec<usize> = {
        let mut dofs: Vec<usize> = structure
            .H_rows
            .iter()
            .flat_map(|row| row.iter().map(|&(dof, _)| dof))
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        dofs
    };
    let cholesky = Cholesky::new(
        &[
            (1.0 / tau, structure.M),
            (theta, structure.C),
            (tau * theta * theta, structure.K),
        ],
        structure.dof_of_node,
        &interface,
        Par::Seq,
    )
    .map_err(Failure::Linear)?;
    timings.factor = clock.elapsed().as_secs_f64();
    let clock = std::time::Instant::now();
    let interface_solve = InterfaceSolve::new(&cholesky, &structure.H_rows);
    timings.delassus = clock.elapsed().as_secs_f64();
    let products = FusedProducts::new([structure.C, structure.K]);

    // Hᵀ r_e, the equilibrium's contact force.
    let mut equilibrium_force = vec![0.0; n];
    for (row, entries) in structure.H_rows.iter().enumerate() {
        for &(dof, value) in entries {
            equilibrium_force[dof] += value * contact_state.r_e[row];
        }
    }
    let force_scale = contact_state
        .r_e
        .iter()
        .fold(0.0_f64, |largest, r| largest.max(r.abs()));

    let mut MCK_v = vec![[0.0; 3]; n];
    products.apply(&v, &mut MCK_v);
    for (slot, M_v) in MCK_v.iter_mut().zip(structure.M.mul_vec(&v)) {
        slot[0] = M_v;
    }
    let mut K_u = structure.K.mul_vec(&u);
    // Relative displacement (from the equilibrium) and velocity of the pairs.
    let mut delta = h_times(&structure.H_rows, &u);
    let mut w = h_times(&structure.H_rows, &v);
    let mut r = contact_state.r_e.clone();
    let mut audit = Audit::new(&u, &v, &MCK_v, &K_u);

    let mut rhs = vec![0.0; n];
    // The step's vector in elimination order, through both sweeps.
    let mut y = vec![0.0; n];
    let mut u_old = vec![0.0; n];
    let mut K_u_old = vec![0.0; n];
    let mut w_free = vec![0.0; m];
    let mut w_new = vec![0.0; m];
    let mut w_n_min = vec![0.0; n_pairs];
    let mut v_new = vec![0.0; n];
    let mut MCK_v_new = vec![[0.0; 3]; n];
    let mut states = vec![PairState::Open; n_pairs];
    let mut contact_solver = ContactSolver::new(settings.solver);
    let mut history = Vec::new();
    let mut snapshots = Vec::new();
    let mut worst_contact_residual: f64 = 0.0;
    let mut most_contact_iterations = 0;
    let mut peak_penetration: f64 = 0.0;
    let mut next_snapshot = 0;
    let record = |step: usize,
                  states: &[PairState],
                  delta: &[f64],
                  w: &[f64],
                  audit: &Audit,
                  iterations: usize|
     -> HistoryRow {
        let mean = |values: &[f64], d: usize| {
            if n_pairs == 0 {
                0.0
            } else {
                (0..n_pairs).map(|p| values[3 * p + d]).sum::<f64>() / n_pairs as f64
            }
        };
        let fraction = |state: PairState| {
            if n_pairs == 0 {
                0.0
            } else {
                states.iter().filter(|s| **s == state).count() as f64 / n_pairs as f64
            }
        };
        HistoryRow {
            t: step as f64 * tau,
            u_n: mean(delta, 0),
            u_t: mean(delta, 1),
            v_n: mean(w, 0),
            v_t: mean(w, 1),
            kinetic: audit.totals.kinetic,
            open: fraction(PairState::Open),
            stick: fraction(PairState::Stick),
            slide: fraction(PairState::Slide),
            points: settings
                .record_pairs
                .iter()
                .map(|&p| (delta[3 * p], w[3 * p]))
                .collect(),
            energy: audit.totals.clone(),
            contact_iterations: iterations,
        }
    };
    for (p, state) in states.iter_mut().enumerate() {
        *state = classify(&r, &w, p, contact_state.sliding_speed[p]);
    }
    history.push(record(0, &states, &delta, &w, &audit, 0));
    if settings.snapshot_steps.first() == Some(&0) {
        snapshots.push(Snapshot {
            t: 0.0,
            u: u.clone(),
            v: v.clone(),
        });
        next_snapshot = 1;
    }
    let mut first_step = 1;
    if let Some(saved) = checkpoints
        .load()
        .and_then(|bytes| postcard::from_bytes::<Checkpoint>(&bytes).ok())
        .filter(|saved| {
            saved.step <= settings.n_steps
                && saved.u.len() == n
                && saved.v.len() == n
                && saved.K_u.len() == n
                && saved.M_v.len() == n
                && saved.r.len() == m
        })
    {
        first_step = saved.step + 1;
        (u, v, K_u, delta, w, r) = (saved.u, saved.v, saved.K_u, saved.delta, saved.w, saved.r);
        contact_solver.restore(
            saved.contact,
            &contact::Problem {
                W: interface_solve.W.as_ref(),
                w_free: &w_free,
                w_n_min: &w_n_min,
                sliding_speed: &contact_state.sliding_speed,
                mu: contact_state.mu,
                force_scale,
            },
        );
        (audit, history, snapshots) = (saved.audit, saved.history, saved.snapshots);
        worst_contact_residual = saved.worst_contact_residual;
        most_contact_iterations = saved.most_contact_iterations;
        peak_penetration = saved.peak_penetration;
        next_snapshot = settings
            .snapshot_steps
            .partition_point(|&kept| kept <= saved.step);
        products.apply(&v, &mut MCK_v);
        for (slot, M_v) in MCK_v.iter_mut().zip(&saved.M_v) {
            slot[0] = *M_v;
        }
    }

    let steps_clock = std::time::Instant::now();
    for step in first_step..=settings.n_steps {
        let t = step as f64 * tau;
        // F_MTD for the departure, in elimination order.
        let a = 1.0 / tau;
        let b = -(1.0 - theta);
        let c = -tau * theta * (1.0 - theta);
        for i in 0..n {
            let [Mv, Cv, Kv] = MCK_v[i];
            rhs[i] = a * Mv + b * Cv + c * Kv - K_u[i] - equilibrium_force[i];
        }
        cholesky.permute(&rhs, &mut y);
        let clock = std::time::Instant::now();
        cholesky.forward_in_place(MatMut::from_column_major_slice_mut(&mut y, n, 1), Par::Seq);
        timings.sweeps += clock.elapsed().as_secs_f64();
        interface_solve.project(&y, &mut w_free);
        // The equivalent gap B̃ = g + τ(1−θ) w_n (Signorini on the end-of-step velocity).
        for p in 0..n_pairs {
            let gap = contact_state.gap[p] + delta[3 * p];
            let equivalent_gap = gap + tau * (1.0 - theta) * w[3 * p];
            w_n_min[p] = -equivalent_gap / tau;
        }
        let problem = contact::Problem {
            W: interface_solve.W.as_ref(),
            w_free: &w_free,
            w_n_min: &w_n_min,
            sliding_speed: &contact_state.sliding_speed,
            mu: contact_state.mu,
            force_scale,
        };
        let clock = std::time::Instant::now();
        let report = if n_pairs == 0 {
            contact::Report {
                iterations: 0,
                residual: 0.0,
            }
        } else {
            contact_solver
                .solve(
                    &problem,
                    settings.tolerance,
                    settings.max_iterations,
                    &mut r,
                    &mut w_new,
                )
                .map_err(|failure| Failure::Contact {
                    step,
                    t,
                    history: failure.history,
                    iterations: failure.iterations,
                })?
        };
        timings.contact += clock.elapsed().as_secs_f64();
        worst_contact_residual = worst_contact_residual.max(report.residual);
        most_contact_iterations = most_contact_iterations.max(report.iterations);
        if n_pairs > 0 {
            interface_solve.lift(&r, &mut y);
        }
        let clock = std::time::Instant::now();
        cholesky.backward_in_place(MatMut::from_column_major_slice_mut(&mut y, n, 1), Par::Seq);
        timings.sweeps += clock.elapsed().as_secs_f64();
        cholesky.unpermute(&y, &mut v_new);
        if v_new.iter().any(|value| !value.is_finite()) {
            return Err(Failure::NotFinite { step, t });
        }
        products.apply(&v_new, &mut MCK_v_new);
        // M v¹ = τ (F_MTD + Hᵀ r − θ C v¹ − τθ² K v¹).
        for (row, entries) in structure.H_rows.iter().enumerate() {
            for &(dof, value) in entries {
                rhs[dof] += value * r[row];
            }
        }
        for (slot, J_v) in MCK_v_new.iter_mut().zip(&rhs) {
            slot[0] = tau * (J_v - theta * slot[1] - tau * theta * theta * slot[2]);
        }
        // u¹ = u⁰ + τ v^θ, K u¹ = K u⁰ + τ K v^θ, δ¹ = δ⁰ + τ w^θ.
        u_old.copy_from_slice(&u);
        K_u_old.copy_from_slice(&K_u);
        for i in 0..n {
            u[i] += tau * (theta * v_new[i] + (1.0 - theta) * v[i]);
            K_u[i] += tau * (theta * MCK_v_new[i][2] + (1.0 - theta) * MCK_v[i][2]);
        }
        for (k, slot) in delta.iter_mut().enumerate() {
            *slot += tau * (theta * w_new[k] + (1.0 - theta) * w[k]);
        }
        audit.step(StepWork {
            tau,
            theta,
            u_old: &u_old,
            u_new: &u,
            v_old: &v,
            v_new: &v_new,
            MCK_v_old: &MCK_v,
            MCK_v_new: &MCK_v_new,
            K_u_old: &K_u_old,
            K_u_new: &K_u,
            r: &r,
            r_e: &contact_state.r_e,
            w_old: &w,
            w_new: &w_new,
            sliding_speed: &contact_state.sliding_speed,
        });
        std::mem::swap(&mut v, &mut v_new);
        std::mem::swap(&mut MCK_v, &mut MCK_v_new);
        std::mem::swap(&mut w, &mut w_new);
        for p in 0..n_pairs {
            states[p] = classify(&r, &w, p, contact_state.sliding_speed[p]);
            peak_penetration = peak_penetration.max(-(contact_state.gap[p] + delta[3 * p]));
        }
        if step.is_multiple_of(settings.output_every) || step == settings.n_steps {
            history.push(record(step, &states, &delta, &w, &audit, report.iterations));
        }
        if settings.snapshot_steps.get(next_snapshot) == Some(&step) {
            snapshots.push(Snapshot {
                t,
                u: u.clone(),
                v: v.clone(),
            });
            next_snapshot += 1;
        }
        if step < settings.n_steps && checkpoints.due() {
            let checkpoint = Checkpoint {
                step,
                u: u.clone(),
                v: v.clone(),
                K_u: K_u.clone(),
                M_v: MCK_v.iter().map(|p| p[0]).collect(),
                delta: delta.clone(),
                w: w.clone(),
                r: r.clone(),
                contact: contact_solver.memory(),
                audit: audit.clone(),
                history: history.clone(),
                snapshots: snapshots.clone(),
                worst_contact_residual,
                most_contact_iterations,
                peak_penetration,
            };
            if let Ok(bytes) = postcard::to_stdvec(&checkpoint) {
                checkpoints.save(&bytes);
            }
        }
        on_step(step);
    }
    timings.steps = steps_clock.elapsed().as_secs_f64();
    Ok(Run {
        timings,
        history,
        snapshots,
        factor_len: cholesky.factor_len(),
        interface_rows: interface_solve.rows.len(),
        worst_contact_residual,
        most_contact_iterations,
        peak_penetration,
        contact_factorisations: contact_solver.factorisations,
    })
}
