//! `transient`: the time response of the friction-destabilised brake, from its sliding
//! equilibrium, with unilateral contact and Coulomb friction at every pair (non-smooth contact
//! dynamics, Jean 1999).
//!
//! # The scheme
//!
//! A first-order θ-method with step τ, the contact reactions entering as impulses over the
//! step (their mean force `r` over the step, applied at its end):
//!
//! ```text
//! M (V¹ − V⁰)/τ + C V^θ + K U^θ = F^θ + Hᵀ r,      U¹ = U⁰ + τ V^θ,   x^θ = θ x¹ + (1−θ) x⁰
//! ```
//!
//! Eliminating `U¹` (`U^θ = U⁰ + τθ V^θ`):
//!
//! ```text
//! J V¹ = F_MTD + Hᵀ r,     J = M/τ + θ (C + τθ K)
//! F_MTD = θ F¹ + (1−θ) F⁰ + (M/τ − (1−θ) C − τθ(1−θ) K) V⁰ − K U⁰
//! ```
//!
//! (the `V⁰` factor carries `−τθ(1−θ) K`, where the paper prints `+τθ K`: only this form
//! conserves energy exactly, which `undamped_scheme_without_contact_conserves_energy_exactly`
//! checks).
//! `J` is symmetric positive definite and constant: factorised once (sparse Cholesky,
//! [`squeal_linalg::cholesky`]). For θ = ½ the scheme is the trapezoidal rule: second order and
//! conserving `½VᵀMV + ½UᵀKU` exactly without damping and contact; for θ > ½ it is first order
//! and dissipates; it is unconditionally stable for θ ≥ ½.
//!
//! # Contact
//!
//! `H` maps the DOFs to the relative displacement of each pair (pad minus disc) in its frame
//! (n, t, b) ([`crate::contact`]); `w = H V` are the relative velocities. The disc turns: its
//! material slides past the pads at `v_g` along t, so the slip is `s = (w_t − v_g, w_b)` and a
//! pair in contact sticks (`s = 0`), slides, or opens. Per step, with `W = H J⁻¹ Hᵀ` formed
//! once (the Delassus operator), the relative velocities are `w = H J⁻¹ F_MTD + W r` and the
//! laws are solved on the pairs only ([`contact`]):
//!
//! ```text
//! 0 ≤ r_n ⊥ B̃ + τ w_n ≥ 0,    B̃ = g⁰ + τ(1−θ) w_n⁰         (the equivalent gap)
//! ‖r_T‖ ≤ μ r_n,   s ≠ 0 ⇒ r_T = −μ r_n s/‖s‖
//! ```
//!
//! The equivalent gap is the gap `g¹ = B̃ + τθ w_n¹` with the end-of-step velocity counted
//! fully. Complementarity makes the next step's `B̃` equal to `B̃ + τ w_n¹ ≥ 0`, so by
//! induction `B̃ ≥ 0` at every step and `g¹ = (1−θ) B̃ + θ (B̃ + τ w_n¹) ≥ 0`: no pair ever
//! penetrates (beyond the contact solver's tolerance). A pair that closes gets
//! `w_n¹ = −B̃/τ`, a final approach that ends exactly at contact, and `w_n = 0` the step after:
//! impacts are inelastic.
//!
//! # Initial condition
//!
//! The sliding equilibrium `(u_e, r_e)` is a fixed point of the scheme (`V = 0`, `r = r_e`,
//! every closed pair sliding). The run starts from it plus either a complex mode `φ` of the
//! stability stage (`initial: mode`), `U⁰ = u_e + Re φ`, `V⁰ = Re(λ φ)` with `φ` scaled so that
//! its largest component is real and equals `amplitude`, or a normal velocity `kick_velocity`
//! of every pad contact node (`initial: kick`). The imposed load is taken as the one that makes
//! the stored equilibrium exact, `F = K u_e − Hᵀ r_e` (the nominal load, up to the
//! equilibrium solver's residual).
//!
//! # Outputs
//!
//! What a person plots, never the state history: contact-zone averages and contact-state
//! fractions over time (`history`), the normal relative displacement and velocity of a few
//! pairs (`points`), displacement and velocity snapshots over the final window (`snapshots`,
//! `velocity_snapshots`: the input of `svd_projection`, with `mass`), the energy audit
//! (`energy`, see [`energy`]) and figures of both.

pub mod contact;
pub mod energy;
mod figure;
pub mod lumped;
pub(crate) mod products;
pub mod reduced;
pub mod scheme;
#[cfg(test)]
mod tests;

use faer::c64;

use crate::artifact::{Artifact, ArtifactType, Basis, ComplexModes, Equilibrium, Figure, Model};
use crate::contact::pad_face;
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Resources, RunContext, Stage, StageError,
};
use crate::table::Table;
use contact::{PairState, Solver};
use reduced::{FullStep, ReducedModel};
use scheme::{ContactState, Failure, Run, Settings, SolveBy, Structure};

/// Progress reports over a run.
const PROGRESS_REPORTS: usize = 500;

/// Most steps a run takes (a guard against a duration/step pair typed wrong).
pub const MAX_STEPS: usize = 10_000_000;

pub struct Transient;

crate::choice! {
    /// How a run starts from the sliding equilibrium.
    pub enum Initial {
        /// Plus a complex mode of the stability tables.
        Mode = "mode",
        /// Plus a normal velocity of the pads' contact nodes.
        Kick = "kick",
    }
}

crate::stage_params! {
    /// The parameters of the scheme, shared by `transient` and `transient.matrices`.
    pub struct SchemeParams {
        /// theta of the scheme, in [0.5, 1] (0.5: second order, conservative)
        theta: f64 = 0.5,
        /// time step
        #[unit = "s"]
        #[min = 0.0]
        tau: f64 = 1e-6,
        /// simulated time
        #[unit = "s"]
        #[min = 0.0]
        duration: f64 = 2e-3,
        /// contact solver: a chord Newton on the pairs' active set with a kept factorisation,
        /// falling back to projected Gauss-Seidel; projected Gauss-Seidel alone; or the Jacobi
        /// fixed point of the projection laws
        solver: Solver = Solver::ActiveSet,
        /// contact solver tolerance (natural residual over the force scale)
        #[min = 0.0]
        tolerance: f64 = 1e-10,
        /// contact solver iteration limit per step
        #[min = 1]
        max_iterations: usize = 2000,
        /// steps between rows of history, points and energy
        #[min = 1]
        output_every: usize = 1,
    }
}

impl SchemeParams {
    /// Refuses a step, a duration or a tolerance the scheme cannot run with.
    pub fn check(&self) -> Result<(), StageError> {
        let bad = |message: String| Err(StageError::new(message));
        if !(self.tau > 0.0) || !self.tau.is_finite() {
            return bad(format!(
                "tau = {} s: the time step must be positive",
                self.tau
            ));
        }
        if !(0.5..=1.0).contains(&self.theta) {
            return bad(format!(
                "theta = {}: the scheme is stable for theta in [0.5, 1]",
                self.theta
            ));
        }
        if !(self.duration >= self.tau) || !self.duration.is_finite() {
            return bad(format!(
                "duration = {} s is shorter than one step (tau = {} s)",
                self.duration, self.tau
            ));
        }
        if self.duration / self.tau > MAX_STEPS as f64 {
            return bad(format!(
                "duration / tau = {:.3e} steps: more than {MAX_STEPS}",
                self.duration / self.tau
            ));
        }
        if !(self.tolerance > 0.0) {
            return bad(format!(
                "tolerance = {}: the contact solver needs a positive tolerance",
                self.tolerance
            ));
        }
        Ok(())
    }

    pub fn n_steps(&self) -> usize {
        (self.duration / self.tau).round() as usize
    }

    /// The run's settings without records, snapshots or samples.
    pub fn settings(&self) -> Settings {
        Settings {
            theta: self.theta,
            tau: self.tau,
            n_steps: self.n_steps(),
            solver: self.solver,
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            output_every: self.output_every,
            record_pairs: Vec::new(),
            record_dofs: Vec::new(),
            record_contacts: false,
            snapshot_steps: Vec::new(),
            sample_steps: Vec::new(),
            solve_by: SolveBy::Choice,
        }
    }
}

crate::stage_params! {
    /// The parameters of `transient`.
    pub struct TransientParams {
        ..scheme: SchemeParams,
        /// start: equilibrium plus a complex mode, or plus a normal velocity of the pads' contact
        /// nodes
        initial: Initial = Initial::Mode,
        /// initial: mode, the mode number of the stability tables (0: the most unstable)
        #[min = 0]
        mode: i64 = 0,
        /// initial: mode, the largest displacement component of the mode
        #[unit = "m"]
        #[min = 0.0]
        amplitude: f64 = 1e-8,
        /// initial: kick, the normal velocity given to every pad contact node
        #[unit = "m/s"]
        kick_velocity: f64 = 1e-3,
        /// contact pairs recorded in points (empty: four spread over the pairs)
        record_pairs: Vec<usize> = Vec::new(),
        /// length of the final window kept as snapshots (0: the last fifth of the run)
        #[unit = "s"]
        #[min = 0.0]
        snapshot_window: f64 = 0.0,
        /// snapshots kept over the final window
        #[min = 1]
        n_snapshots: usize = 100,
        /// with a basis: steps, spread over the run, at which the full step equation is checked on
        /// the lifted reduced solution (the residual indicator); 0: no indicator (the full J is not
        /// factorised, the summary's residual_indicator is NaN)
        #[min = 0]
        indicator_samples: usize = 20,
    }
}

impl HasParams for Transient {
    type Params = TransientParams;
}

impl Stage for Transient {
    fn kind(&self) -> &'static str {
        "transient"
    }
    fn version(&self) -> u32 {
        // 19: the pairs' velocities from the step's own solution (CHANGELOG.md, "transient")
        19
    }
    fn doc(&self) -> &'static str {
        "Nonlinear transient from the sliding equilibrium: theta-method with contact impulses, Signorini-Coulomb at every pair, energy audit"
    }
    fn resources(&self) -> Resources {
        Resources::job(2, 2048)
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "model",
                ArtifactType::Model,
                "M, C, K and the contact pairs",
            ),
            PortSpec::one(
                "equilibrium",
                ArtifactType::Equilibrium,
                "the sliding equilibrium the run starts from",
            ),
            PortSpec::one(
                "complex_modes",
                ArtifactType::ComplexModes,
                "the stability stage's complex modes: `initial: mode` starts along one",
            ),
            PortSpec::one(
                "basis",
                ArtifactType::Basis,
                "a reduction basis (the basis stage): the run is made on the reduced model",
            )
            .optional(),
        ]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("figure", "history_figure")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "history",
                ArtifactType::Table,
                "t; contact-zone averages u_n, u_t, v_n, v_t; kinetic; open, stick, slide fractions",
            ),
            PortSpec::one(
                "points",
                ArtifactType::Table,
                "t; pair_P_un, pair_P_vn of the recorded pairs",
            ),
            PortSpec::one(
                "snapshots",
                ArtifactType::Table,
                "wide: one row per node and direction, displacement from the equilibrium at each kept step (step_NNNNNNNN)",
            ),
            PortSpec::one(
                "velocity_snapshots",
                ArtifactType::Table,
                "wide: as snapshots, the velocity",
            ),
            PortSpec::one(
                "mass",
                ArtifactType::Table,
                "M as COO row, col, value on the snapshot rows (for svd_projection)",
            ),
            energy_port(),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "steps, contact solver figures, peak penetration, energy balance",
            ),
            PortSpec::one(
                "history_figure",
                ArtifactType::Figure,
                "kinetic energy, contact averages and contact states against time",
            ),
            energy_figure_port(),
            PortSpec::one(
                "contact_states",
                ArtifactType::Table,
                "one row per pair: x, y, z (its disc point); shares of the steps it ended open, sticking, sliding",
            ),
            PortSpec::one(
                "contact_states_figure",
                ArtifactType::Figure,
                "the share of steps each pair stuck, on the pad faces",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        self.run_with(params, inputs, &RunContext::detached())
    }
    fn run_with(
        &self,
        params: &Params,
        inputs: &Inputs,
        context: &RunContext,
    ) -> Result<Outputs, StageError> {
        let model: &Model = inputs.get("model")?;
        let equilibrium: &Equilibrium = inputs.get("equilibrium")?;
        let modes: &ComplexModes = inputs.get("complex_modes")?;
        let params = params.read::<Self>()?;
        params.scheme.check()?;
        model.check_dof_map()?;
        let (structure, contact_state) = structure_of(model, equilibrium)?;
        let (u0, v0) = match params.initial {
            Initial::Kick => kick(model, equilibrium, params.kick_velocity),
            Initial::Mode => {
                let (lambda, shape) = chosen_mode(modes, params.mode, model.n_dofs())?;
                mode_start(lambda, &shape, params.amplitude)
            }
        };
        let basis = inputs.get_optional::<Basis>("basis")?;
        if let Some(basis) = basis {
            basis
                .check_built_on(model)
                .map_err(|err| StageError::new(format!("transient: {}", err.message)))?;
        }
        let samples = if basis.is_some() {
            params.indicator_samples
        } else {
            0
        };
        let settings = settings_of(&params, model.mesh.contact_pairs.len(), samples)?;
        let (run, indicator) = match basis {
            None => (
                integrate(&structure, &contact_state, &settings, (u0, v0), context)?,
                None,
            ),
            Some(basis) => {
                // The full J for the indicator is factorised on another core, when there is
                // one, while the reduced model integrates.
                let (full_step, run) = rayon::join(
                    || match samples {
                        0 => Ok(None),
                        _ => FullStep::new(&structure, settings.theta, settings.tau).map(Some),
                    },
                    || {
                        run_reduced(
                            model,
                            (&structure, &contact_state),
                            basis,
                            &settings,
                            (u0, v0),
                            context,
                        )
                    },
                );
                let run = run?;
                let indicator = full_step?.map(|full_step| {
                    full_step.indicator(basis, &structure, &contact_state, &run.samples)
                });
                (run, indicator)
            }
        };
        let residual_indicator = match (basis, indicator) {
            (None, _) => 0.0,
            (Some(_), Some(indicator)) => indicator.value,
            (Some(_), None) => f64::NAN,
        };
        outputs(model, &settings, &run, residual_indicator)
    }
}

/// A run on a reduction basis, its snapshots lifted to the full DOFs.
pub fn run_reduced(
    model: &Model,
    (structure, contact_state): (&Structure, &ContactState),
    basis: &Basis,
    settings: &Settings,
    (u0, v0): (Vec<f64>, Vec<f64>),
    context: &RunContext,
) -> Result<Run, StageError> {
    let reduced = ReducedModel::new(model, basis, structure)?;
    let restrict = |u: &[f64]| basis.restrict(&model.M, u);
    let start = (restrict(&u0), restrict(&v0));
    let mut run = integrate(
        &reduced.structure(),
        contact_state,
        settings,
        start,
        context,
    )?;
    reduced::lift_snapshots(basis, &mut run);
    Ok(run)
}

/// The start of a run from the sliding equilibrium plus the most unstable of the complex
/// modes at `amplitude` (see the module doc).
pub fn most_unstable_start(
    modes: &ComplexModes,
    n_dofs: usize,
    amplitude: f64,
) -> Result<(Vec<f64>, Vec<f64>), StageError> {
    let (lambda, shape) = chosen_mode(modes, 0, n_dofs)?;
    Ok(mode_start(lambda, &shape, amplitude))
}

/// `H`'s rows and the equilibrium's contact data.
pub fn structure_of<'a>(
    model: &'a Model,
    equilibrium: &Equilibrium,
) -> Result<(Structure<'a>, ContactState), StageError> {
    equilibrium.check_belongs_to(model)?;
    let n_pairs = model.mesh.contact_pairs.len();
    let frames = &equilibrium.frames;
    let mut r_e = Vec::with_capacity(3 * n_pairs);
    for (p, &r_n) in equilibrium.r_n.iter().enumerate() {
        let closed = equilibrium.closed[p];
        r_e.extend([r_n, if closed { equilibrium.mu * r_n } else { 0.0 }, 0.0]);
    }
    let structure = Structure {
        M: &model.M,
        C: &model.C,
        K: &model.K,
        dof_of_node: &model.dof_of_node,
        H_rows: crate::contact::h_columns(model, frames),
        load: scheme::Load::default(),
    };
    let body_of_node = model.bodies_of_nodes().0;
    let body_of_pair: Vec<usize> = model
        .mesh
        .contact_pairs
        .iter()
        .map(|pair| body_of_node[pair.pad_node() as usize])
        .collect();
    let contact_state = ContactState {
        gap: equilibrium.gap.clone(),
        sliding_speed: frames.sliding_speed.clone(),
        r_e,
        mu: vec![equilibrium.mu; n_pairs],
        mu_static: vec![equilibrium.mu; n_pairs],
        speed_scale: 0.0,
        blocks: contact::pad_blocks(&body_of_pair),
    };
    Ok((structure, contact_state))
}

/// The complex mode `mode` (1-based; 0 = the most unstable with a shape), over the free DOFs.
fn chosen_mode(
    modes: &ComplexModes,
    mode: i64,
    n_dofs: usize,
) -> Result<(c64, Vec<c64>), StageError> {
    let chosen = if mode == 0 {
        modes
            .with_shapes()
            .filter(|(mode, _)| mode.re > 0.0)
            .max_by(|(a, _), (b, _)| a.re.total_cmp(&b.re))
            .map(|(mode, _)| mode)
            .ok_or_else(|| {
                StageError::new(
                    "no unstable mode with a shape in the complex modes: choose `mode`, or `initial: kick`",
                )
            })?
    } else {
        modes.get(mode).ok_or_else(|| {
            StageError::new(format!(
                "mode {mode} is not among the complex modes (modes 1 to {})",
                modes.modes.len()
            ))
        })?
    };
    let number = chosen.number;
    let Some(shape) = &chosen.shape else {
        return Err(StageError::new(format!(
            "mode {number} has no shape (the stability stage keeps `shapes: unstable` only?)"
        )));
    };
    if shape.re.len() != n_dofs {
        return Err(StageError::new(format!(
            "mode {number} has {} DOFs, the model has {n_dofs}: it comes from another model's stability stage",
            shape.re.len()
        )));
    }
    let shape = shape
        .re
        .iter()
        .zip(&shape.im)
        .map(|(&re, &im)| c64::new(re, im))
        .collect();
    Ok((c64::new(chosen.re, chosen.im), shape))
}

/// The start on complex mode `(λ, φ)`: `u = Re φ`, `v = Re(λ φ)`, `φ` turned so its largest
/// component is real, of size `amplitude`.
pub fn mode_start(lambda: c64, shape: &[c64], amplitude: f64) -> (Vec<f64>, Vec<f64>) {
    let largest = shape
        .iter()
        .copied()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        .unwrap_or(c64::new(0.0, 0.0));
    let scale = if largest.norm() > 0.0 {
        largest.conj() * (amplitude / (largest.norm() * largest.norm()))
    } else {
        c64::new(0.0, 0.0)
    };
    let scaled: Vec<c64> = shape.iter().map(|value| value * scale).collect();
    (
        scaled.iter().map(|value| value.re).collect(),
        scaled.iter().map(|value| (lambda * value).re).collect(),
    )
}

/// No displacement; every pad contact node (each pair's anchor) moving at `speed` along its
/// pair's normal.
pub fn kick(model: &Model, equilibrium: &Equilibrium, speed: f64) -> (Vec<f64>, Vec<f64>) {
    let n = model.n_dofs();
    let mut v = vec![0.0; n];
    for (pair, normal) in model.mesh.contact_pairs.iter().zip(&equilibrium.frames.n) {
        for (axis, dof) in model.dof_of_node[pair.pad_node() as usize]
            .iter()
            .enumerate()
        {
            if let Some(dof) = dof {
                v[*dof as usize] = speed * normal[axis];
            }
        }
    }
    (vec![0.0; n], v)
}

/// The run's settings; `n_samples` steps kept whole for the residual indicator.
fn settings_of(
    params: &TransientParams,
    n_pairs: usize,
    n_samples: usize,
) -> Result<Settings, StageError> {
    let scheme = &params.scheme;
    let n_steps = scheme.n_steps();
    if let Some(pair) = params.record_pairs.iter().find(|&&pair| pair >= n_pairs) {
        return Err(StageError::new(format!(
            "record_pairs: `{pair}` is not a pair number (0 to {})",
            n_pairs.saturating_sub(1)
        )));
    }
    let record_pairs: Vec<usize> = if params.record_pairs.is_empty() {
        let count = n_pairs.min(4);
        (0..count).map(|k| k * n_pairs / count.max(1)).collect()
    } else {
        params.record_pairs.clone()
    };
    let window = if params.snapshot_window > 0.0 {
        params.snapshot_window
    } else {
        0.2 * scheme.duration
    };
    let window_steps = ((window / scheme.tau).round() as usize).clamp(1, n_steps);
    let n_snapshots = params.n_snapshots.min(window_steps);
    let stride = window_steps / n_snapshots;
    let snapshot_steps: Vec<usize> = (0..n_snapshots)
        .map(|k| n_steps - (n_snapshots - 1 - k) * stride)
        .collect();
    Ok(Settings {
        record_pairs,
        snapshot_steps,
        sample_steps: spread_steps(n_steps, n_samples),
        ..scheme.settings()
    })
}

/// `count` distinct steps spread evenly over `1..=n_steps`, the last one included.
pub fn spread_steps(n_steps: usize, count: usize) -> Vec<usize> {
    let mut steps: Vec<usize> = (1..=count.min(n_steps))
        .map(|k| (k * n_steps).div_ceil(count.min(n_steps)))
        .collect();
    steps.dedup();
    steps
}

fn integrate(
    structure: &Structure,
    contact_state: &ContactState,
    settings: &Settings,
    (u0, v0): (Vec<f64>, Vec<f64>),
    context: &RunContext,
) -> Result<Run, StageError> {
    let n_steps = settings.n_steps;
    let report_every = (n_steps / PROGRESS_REPORTS).max(1);
    let on_step = |step: usize| {
        if step.is_multiple_of(report_every) {
            context.progress.report(
                step as f64 / n_steps as f64,
                &format!(
                    "step {step} of {n_steps}, t = {:.4e} s",
                    step as f64 * settings.tau
                ),
            );
        }
    };
    let run = scheme::integrate(
        structure,
        contact_state,
        settings,
        u0,
        v0,
        context.checkpoints,
        on_step,
    )
    .map_err(|failure| {
        match failure {
            Failure::Linear(err) => StageError::new(format!("transient: J = M/tau + theta (C + tau theta K): {err}")),
            Failure::Contact {
                step,
                t,
                history,
                iterations,
            } => StageError::new(format!(
                "transient: the contact solver ({}) did not converge at step {step} (t = {t:.6e} s) in {iterations} iterations; last residuals {} (tolerance {:e}); raise max_iterations, loosen tolerance or shorten tau",
                settings.solver.name(),
                history
                    .iter()
                    .map(|residual| format!("{residual:.2e}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                settings.tolerance
            )),
            Failure::NotFinite { step, t } => StageError::new(format!(
                "transient: the velocity is not finite at step {step} (t = {t:.6e} s)"
            )),
        }
    })?;
    log_where_the_time_went(&run);
    Ok(run)
}

/// Where a run's time went, at `squeal run -v`: what a user weighing run time against error
/// (a basis, a time step) needs to see what limits a run. Never in an output: it is not
/// reproducible.
fn log_where_the_time_went(run: &Run) {
    let timings = &run.timings;
    // A step of the brake takes milliseconds, one of a lumped model a microsecond.
    let per_step = |seconds: f64| {
        let seconds = seconds / timings.steps_run.max(1) as f64;
        if seconds >= 1e-4 {
            format!("{:.2} ms", 1e3 * seconds)
        } else {
            format!("{:.2} us", 1e6 * seconds)
        }
    };
    tracing::info!(
        "transient: {} unknowns, J {} in {:.2} s ({} entries), the Delassus operator in {:.2} s; {} steps in {:.1} s, {} a step: solves {}, contact {} ({} factorisations of the active set, {} steps refined in double precision), the rest {}",
        run.unknowns,
        if run.by_inverse {
            "inverted by dense blocks"
        } else {
            "factorised"
        },
        timings.factor,
        run.factor_len,
        timings.delassus,
        timings.steps_run,
        timings.steps,
        per_step(timings.steps),
        per_step(timings.solve),
        per_step(timings.contact),
        run.contact_factorisations,
        run.contact_refinements,
        per_step(timings.steps - timings.solve - timings.contact),
    );
}

fn outputs(
    model: &Model,
    settings: &Settings,
    run: &Run,
    residual_indicator: f64,
) -> Result<Outputs, StageError> {
    let history = &run.history;
    let column =
        |f: &dyn Fn(&scheme::HistoryRow) -> f64| history.iter().map(f).collect::<Vec<f64>>();
    let history_table = Table::new()
        .with("t", column(&|row| row.t))
        .with("u_n", column(&|row| row.u_n))
        .with("u_t", column(&|row| row.u_t))
        .with("v_n", column(&|row| row.v_n))
        .with("v_t", column(&|row| row.v_t))
        .with("kinetic", column(&|row| row.kinetic))
        .with("open", column(&|row| row.open))
        .with("stick", column(&|row| row.stick))
        .with("slide", column(&|row| row.slide))
        .with(
            "contact_iterations",
            history
                .iter()
                .map(|row| row.contact_iterations as i64)
                .collect::<Vec<i64>>(),
        );
    let mut points = Table::new().with("t", column(&|row| row.t));
    for (k, pair) in settings.record_pairs.iter().enumerate() {
        points = points
            .with(format!("pair_{pair}_un"), column(&|row| row.points[k].0))
            .with(format!("pair_{pair}_vn"), column(&|row| row.points[k].1));
    }
    let energy = energy_table(history);
    let snapshot_name = |t: f64| format!("step_{:08}", (t / settings.tau).round() as u64);
    let snapshots = model.nodal_table(
        run.snapshots
            .iter()
            .map(|snapshot| (snapshot_name(snapshot.t), snapshot.u.clone()))
            .collect(),
    );
    let velocity_snapshots = model.nodal_table(
        run.snapshots
            .iter()
            .map(|snapshot| (snapshot_name(snapshot.t), snapshot.v.clone()))
            .collect(),
    );
    let summary = summary_table(settings, run, residual_indicator);
    let (contact_states, contact_states_figure) = contact_states(model, &run.pair_steps)?;
    let figure = figure::history(history, settings)?;
    let energy_figure = figure::energy(history)?;
    Ok(Outputs::from([
        ("history".to_string(), Artifact::Table(history_table)),
        ("points".to_string(), Artifact::Table(points)),
        ("snapshots".to_string(), Artifact::Table(snapshots)),
        (
            "velocity_snapshots".to_string(),
            Artifact::Table(velocity_snapshots),
        ),
        ("mass".to_string(), Artifact::Table(mass_table(model))),
        ("energy".to_string(), Artifact::Table(energy)),
        ("summary".to_string(), Artifact::Table(summary)),
        ("history_figure".to_string(), Artifact::Figure(figure)),
        ("energy_figure".to_string(), Artifact::Figure(energy_figure)),
        (
            "contact_states".to_string(),
            Artifact::Table(contact_states),
        ),
        (
            "contact_states_figure".to_string(),
            Artifact::Figure(contact_states_figure),
        ),
    ]))
}

/// The `energy` output both transients give.
pub(crate) fn energy_port() -> PortSpec {
    PortSpec::one(
        "energy",
        ArtifactType::Table,
        "t; kinetic, strain, viscous, scheme, drive, friction, normal, loads, balance_error (J)",
    )
}

/// The `energy_figure` output both transients give.
pub(crate) fn energy_figure_port() -> PortSpec {
    PortSpec::one(
        "energy_figure",
        ArtifactType::Figure,
        "the energy audit against time",
    )
}

/// The energy audit over time: one row per history row.
pub(crate) fn energy_table(history: &[scheme::HistoryRow]) -> Table {
    let column =
        |f: &dyn Fn(&scheme::HistoryRow) -> f64| history.iter().map(f).collect::<Vec<f64>>();
    Table::new()
        .with("t", column(&|row| row.t))
        .with("kinetic", column(&|row| row.energy.kinetic))
        .with("strain", column(&|row| row.energy.strain))
        .with("viscous", column(&|row| row.energy.viscous))
        .with("scheme", column(&|row| row.energy.scheme))
        .with("drive", column(&|row| row.energy.drive))
        .with("friction", column(&|row| row.energy.friction))
        .with("normal", column(&|row| row.energy.normal))
        .with("loads", column(&|row| row.energy.loads))
        .with("balance_error", column(&|row| row.energy.balance_error))
}

/// Per pair: where it is and the shares of the steps it ended open, sticking and sliding; and
/// the map of the share sticking on the pad faces (grey: open at every step).
fn contact_states(model: &Model, pair_steps: &[[u64; 3]]) -> Result<(Table, Figure), StageError> {
    let pairs = &model.mesh.contact_pairs;
    let position: Vec<[f64; 3]> = pairs
        .iter()
        .map(|pair| pair.disc_position(&model.mesh.nodes))
        .collect();
    let share = |state: PairState| -> Vec<f64> {
        pair_steps
            .iter()
            .map(|steps| steps[state as usize] as f64 / steps.iter().sum::<u64>().max(1) as f64)
            .collect()
    };
    let (open, stick) = (share(PairState::Open), share(PairState::Stick));
    let table = Table::new()
        .with("pair", (0..pairs.len() as i64).collect::<Vec<i64>>())
        .with("x", position.iter().map(|x| x[0]).collect::<Vec<f64>>())
        .with("y", position.iter().map(|x| x[1]).collect::<Vec<f64>>())
        .with("z", position.iter().map(|x| x[2]).collect::<Vec<f64>>())
        .with("open", open.clone())
        .with("stick", stick.clone())
        .with("slide", share(PairState::Slide));
    let sticking: Vec<Option<f64>> = open
        .iter()
        .zip(&stick)
        .map(|(&open, &stick)| (open < 1.0).then_some(stick))
        .collect();
    let figure = pad_face::figure(&model.mesh, &sticking, 1.0, "share of steps sticking")?;
    Ok((table, figure))
}

/// `M` on the rows of [`Model::nodal_table`] (node-major, three per node); the rows of clamped
/// and tied nodes have no entry (a tied node's mass is on its masters' rows).
fn mass_table(model: &Model) -> Table {
    let mut row_of_dof = vec![0i64; model.n_dofs()];
    if model.dof_of_node.is_empty() {
        for (dof, row) in row_of_dof.iter_mut().enumerate() {
            *row = dof as i64;
        }
    } else {
        for (node, dofs) in model.dof_of_node.iter().enumerate() {
            for (direction, dof) in dofs.iter().enumerate() {
                if let Some(dof) = dof {
                    row_of_dof[*dof as usize] = (3 * node + direction) as i64;
                }
            }
        }
    }
    let (mut rows, mut cols, mut values) = (Vec::new(), Vec::new(), Vec::new());
    for (row, col, value) in model.M.triplets() {
        rows.push(row_of_dof[row]);
        cols.push(row_of_dof[col]);
        values.push(value);
    }
    Table::new()
        .with("row", rows)
        .with("col", cols)
        .with("value", values)
}

/// The largest kinetic-plus-strain energy of the run, the scale of the balance error.
pub fn peak_energy(history: &[scheme::HistoryRow]) -> f64 {
    history
        .iter()
        .map(|row| row.energy.kinetic + row.energy.strain)
        .fold(0.0, f64::max)
}

/// The run's figures; `residual_indicator` is 0 for a run on the full model (which is its own
/// reference), NaN for a reduced run without the indicator.
fn summary_table(settings: &Settings, run: &Run, residual_indicator: f64) -> Table {
    let mut quantities = run_quantities(settings, run);
    quantities.push(("residual_indicator", residual_indicator));
    Table::quantities(&quantities)
}

/// What every run reports: its steps, its operator, its contact solves, its energy balance and
/// the final contact states.
pub(crate) fn run_quantities(settings: &Settings, run: &Run) -> Vec<(&'static str, f64)> {
    let last = run.history.last().cloned().unwrap_or_default();
    let peak = peak_energy(&run.history);
    let worst_balance = run
        .history
        .iter()
        .map(|row| row.energy.balance_error.abs())
        .fold(0.0, f64::max);
    let quantities: Vec<(&'static str, f64)> = vec![
        ("steps", settings.n_steps as f64),
        ("tau", settings.tau),
        ("theta", settings.theta),
        ("unknowns", run.unknowns as f64),
        ("factor_entries", run.factor_len as f64),
        ("interface_rows", run.interface_rows as f64),
        ("worst_contact_residual", run.worst_contact_residual),
        (
            "most_contact_iterations",
            run.most_contact_iterations as f64,
        ),
        ("peak_penetration", run.peak_penetration),
        ("peak_energy", peak),
        ("final_kinetic", last.energy.kinetic),
        ("worst_balance_error", worst_balance),
        (
            "relative_balance_error",
            if peak > 0.0 {
                worst_balance / peak
            } else {
                0.0
            },
        ),
        ("final_open", last.open),
        ("final_stick", last.stick),
        ("final_slide", last.slide),
    ];
    quantities
}
