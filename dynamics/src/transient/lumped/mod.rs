//! `transient.matrices`: the transient of a lumped model given by its matrices and contact
//! rows — Hoffmann's model on a belt, the stick–slip oscillator, a pin on a disc, a chain of
//! masses on a belt — by the brake's scheme ([`super::scheme`]), with its contact laws, energy
//! audit, progress and checkpoints.
//!
//! The model ([`model`]): `M`, `K` and optionally `C` from Matrix Market files (symmetric:
//! friction acts through the contacts, never through `K`), a constant load, contacts from a
//! YAML file (each a normal row, one or two tangential rows over the DOFs and a gap), the
//! surface moving at `surface_speed` along a contact's tangent row, Coulomb friction with a
//! kinetic and a static coefficient (each contact may give its own speed and coefficients),
//! and DOFs driven at a prescribed velocity.
//!
//! Static friction: a contact that stuck at the end of a step is held, through the next step's
//! contact problem, by `μ_s`; if it slips anyway, the step is solved again with `μ` for it (it
//! slides under the kinetic law). Impacts are inelastic, as in the brake's scheme (the
//! equivalent gap makes a closing contact end its step exactly at contact).
//!
//! The run starts from rest at `q = 0`, from given `q` and `q̇`, or from the sliding equilibrium
//! plus its most unstable linearised mode at `amplitude` ([`sliding`]), as the brake's
//! transient does from the stability stage's mode.

pub mod model;
mod outputs;
pub mod sliding;
#[cfg(test)]
mod tests;

use std::path::PathBuf;

use faer::c64;

use super::scheme::{self, ContactState, Load, Structure};
use super::{SchemeParams, contact, mode_start};
use crate::artifact::CscMatrix;
use crate::artifact::complex_modes::is_unstable;
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Resources, RunContext, Stage, StageError,
};
use model::{LumpedModel, read_contacts, read_matrix};
use sliding::Sliding;

pub struct TransientMatrices;

crate::choice! {
    /// How a lumped run starts.
    pub enum LumpedInitial {
        /// At rest, every DOF at zero.
        Zero = "zero",
        /// From `u0` and `v0`.
        Given = "given",
        /// The sliding equilibrium plus its most unstable linearised mode.
        Mode = "mode",
    }
}

crate::stage_params! {
    /// The parameters of `transient.matrices`.
    pub struct LumpedParams {
        ..scheme: SchemeParams,
        /// mass matrix, Matrix Market (symmetric positive definite)
        m_path: PathBuf,
        /// stiffness matrix, Matrix Market (symmetric: friction acts through the contacts)
        k_path: PathBuf,
        /// damping matrix, Matrix Market (symmetric); none: undamped
        c_path: Option<PathBuf> = None,
        /// contacts, a YAML list: each a normal row, a tangent row, optionally a binormal row (over
        /// the DOFs) and a gap (m); none: no contact
        contacts_path: Option<PathBuf> = None,
        /// constant load, one entry per DOF (empty: none)
        #[unit = "N"]
        load: Vec<f64> = Vec::new(),
        /// kinetic friction coefficient of the contacts that do not give their own
        #[min = 0.0]
        mu: f64 = 0.0,
        /// static friction coefficient, holding a contact that sticks; 0: equal to mu (a contact
        /// may give its own)
        #[min = 0.0]
        mu_static: f64 = 0.0,
        /// speed of the surface (a belt, a disc) along the tangent row of the contacts that do
        /// not give their own
        #[unit = "m/s"]
        surface_speed: f64 = 0.0,
        /// DOFs driven at a prescribed velocity
        prescribed_dofs: Vec<usize> = Vec::new(),
        /// the velocity of each DOF of prescribed_dofs
        #[unit = "m/s"]
        prescribed_velocities: Vec<f64> = Vec::new(),
        /// start: at rest at zero, from u0 and v0, or the sliding equilibrium plus its most unstable
        /// linearised mode
        initial: LumpedInitial = LumpedInitial::Zero,
        /// initial: given, the displacement of every DOF (empty: zero)
        #[unit = "m"]
        u0: Vec<f64> = Vec::new(),
        /// initial: given, the velocity of every DOF (empty: zero; a driven DOF's is its prescribed
        /// velocity)
        #[unit = "m/s"]
        v0: Vec<f64> = Vec::new(),
        /// initial: mode, the largest displacement component of the mode
        #[unit = "m"]
        #[min = 0.0]
        amplitude: f64 = 1e-6,
        /// DOFs recorded in the history (empty: every DOF)
        record_dofs: Vec<usize> = Vec::new(),
        /// the DOF whose phase portrait (velocity against displacement) is drawn
        phase_dof: usize = 0,
    }
}

impl HasParams for TransientMatrices {
    type Params = LumpedParams;
}

impl Stage for TransientMatrices {
    fn kind(&self) -> &'static str {
        "transient.matrices"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Nonlinear transient of a lumped model from Matrix Market M, C, K and contact rows: the brake's scheme, contact laws and energy audit"
    }
    fn resources(&self) -> Resources {
        Resources::job(1, 1024)
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        outputs::ports()
    }
    fn pure(&self) -> bool {
        // It reads files: it reruns every time, and the stages below it still cut off early.
        false
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        self.run_with(params, inputs, &RunContext::detached())
    }
    fn run_with(
        &self,
        params: &Params,
        _inputs: &Inputs,
        context: &RunContext,
    ) -> Result<Outputs, StageError> {
        let params = params.read::<Self>()?;
        params.scheme.check()?;
        let model = read_model(&params)?;
        let lumped = LumpedRun::new(&model, &params)?;
        let settings = scheme::Settings {
            record_dofs: lumped.free_records(),
            record_contacts: true,
            ..params.scheme.settings()
        };
        let structure = lumped.structure();
        let run = super::integrate(
            &structure,
            &lumped.contact_state,
            &settings,
            (lumped.u0.clone(), lumped.v0.clone()),
            context,
        )?;
        outputs::outputs(&lumped, &params, &settings, &run)
    }
}

/// The model the parameters name, read and checked.
pub fn read_model(params: &LumpedParams) -> Result<LumpedModel, StageError> {
    let M = read_matrix(&params.m_path)?;
    let K = read_matrix(&params.k_path)?;
    let n = M.n_rows;
    let C = match &params.c_path {
        Some(path) => read_matrix(path)?,
        None => CscMatrix::from_triplets(n, n, Vec::new()),
    };
    let contacts = match &params.contacts_path {
        Some(path) => read_contacts(path)?,
        None => Vec::new(),
    };
    if params.prescribed_dofs.len() != params.prescribed_velocities.len() {
        return Err(StageError::new(format!(
            "prescribed_dofs has {} DOFs, prescribed_velocities {} velocities: give one velocity per DOF",
            params.prescribed_dofs.len(),
            params.prescribed_velocities.len()
        )));
    }
    let mut driven: Vec<(usize, f64)> = params
        .prescribed_dofs
        .iter()
        .copied()
        .zip(params.prescribed_velocities.iter().copied())
        .collect();
    driven.sort_by_key(|(dof, _)| *dof);
    if let Some((dof, velocity)) = driven.iter().find(|(_, velocity)| !velocity.is_finite()) {
        return Err(StageError::new(format!(
            "prescribed_velocities: DOF {dof} at {velocity} m/s is not finite"
        )));
    }
    let load = if params.load.is_empty() {
        vec![0.0; n]
    } else {
        params.load.clone()
    };
    let model = LumpedModel {
        M,
        C,
        K,
        load,
        contacts,
        driven,
    };
    model.check()?;
    Ok(model)
}

/// A lumped model made ready for the scheme: its free DOFs, the reference state the scheme's
/// departure is measured from, the contacts' data and the start.
pub struct LumpedRun<'m> {
    pub model: &'m LumpedModel,
    pub free: Vec<usize>,
    M: CscMatrix,
    C: CscMatrix,
    K: CscMatrix,
    H_rows: Vec<Vec<(usize, f64)>>,
    load: Load,
    pub contact_state: ContactState,
    /// The free DOFs' reference (zero, or the sliding equilibrium).
    pub q_ref: Vec<f64>,
    /// The driven DOFs' initial displacement, in `model.driven` order.
    pub q_driven: Vec<f64>,
    /// The start, as a departure from `q_ref`.
    pub u0: Vec<f64>,
    pub v0: Vec<f64>,
    /// The DOFs recorded, over all the model's DOFs, and the one of the phase portrait.
    pub record_dofs: Vec<usize>,
    pub phase_dof: usize,
    /// With `initial: mode`: the mode started from, and the equilibrium's residual.
    pub start_mode: Option<(c64, f64)>,
}

impl<'m> LumpedRun<'m> {
    pub fn new(model: &'m LumpedModel, params: &LumpedParams) -> Result<LumpedRun<'m>, StageError> {
        let n = model.n_dofs();
        let free = model.free_dofs();
        let n_contacts = model.contacts.len();
        let friction: Vec<(f64, f64)> = (0..n_contacts)
            .map(|c| model.friction(c, (params.mu, params.mu_static)))
            .collect::<Result<_, _>>()?;
        let mu: Vec<f64> = friction.iter().map(|friction| friction.0).collect();
        let mu_static: Vec<f64> = friction.iter().map(|friction| friction.1).collect();
        if !params.surface_speed.is_finite() {
            return Err(StageError::new(format!(
                "surface_speed = {} is not finite",
                params.surface_speed
            )));
        }
        let record_dofs = if params.record_dofs.is_empty() {
            (0..n).collect()
        } else {
            params.record_dofs.clone()
        };
        for (name, dof) in record_dofs
            .iter()
            .map(|dof| ("record_dofs", *dof))
            .chain([("phase_dof", params.phase_dof)])
        {
            if dof >= n {
                return Err(StageError::new(format!(
                    "{name}: DOF {dof} is not among the model's {n} DOFs (0 to {})",
                    n - 1
                )));
            }
        }
        let speeds: Vec<f64> = (0..n_contacts)
            .map(|c| model.sliding_speed(c, params.surface_speed))
            .collect();
        let full_vector = |name: &str, values: &[f64]| -> Result<Vec<f64>, StageError> {
            match values.len() {
                0 => Ok(vec![0.0; n]),
                len if len == n => Ok(values.to_vec()),
                len => Err(StageError::new(format!(
                    "{name} has {len} entries, the model {n} DOFs"
                ))),
            }
        };
        let (u_given, v_given) = match params.initial {
            LumpedInitial::Given => (
                full_vector("u0", &params.u0)?,
                full_vector("v0", &params.v0)?,
            ),
            _ => (vec![0.0; n], vec![0.0; n]),
        };
        if let Some((dof, velocity)) = model
            .driven
            .iter()
            .find(|(dof, velocity)| !params.v0.is_empty() && v_given[*dof] != *velocity)
        {
            return Err(StageError::new(format!(
                "v0 gives DOF {dof} a velocity of {} m/s, but it is driven at {velocity} m/s",
                v_given[*dof]
            )));
        }
        let q_driven: Vec<f64> = model.driven.iter().map(|(dof, _)| u_given[*dof]).collect();
        let (driven_constant, rate) = model.driven_load(&free, &q_driven);
        let f: Vec<f64> = free
            .iter()
            .zip(&driven_constant)
            .map(|(&dof, driven)| model.load[dof] + driven)
            .collect();
        let M = model.M.principal_submatrix(&free);
        let C = model.C.principal_submatrix(&free);
        let K = model.K.principal_submatrix(&free);
        let H_rows = model.h_rows(&free);
        let (q_ref, r_e, u0, v0, start_mode) = match params.initial {
            LumpedInitial::Zero | LumpedInitial::Given => {
                let pick = |values: &[f64]| free.iter().map(|&dof| values[dof]).collect();
                (
                    vec![0.0; free.len()],
                    vec![0.0; 3 * n_contacts],
                    pick(&u_given),
                    pick(&v_given),
                    None,
                )
            }
            LumpedInitial::Mode => {
                if rate.iter().any(|&value| value != 0.0) {
                    return Err(StageError::new(
                        "initial: mode needs a steady sliding state, and a DOF driven at a prescribed velocity through a spring loads the others more every instant: start from `zero` or `given`",
                    ));
                }
                let sliding = Sliding {
                    model,
                    free: &free,
                    speeds: &speeds,
                    mu: &mu,
                };
                let equilibrium = sliding.equilibrium(&f)?;
                let modes = sliding.modes(&equilibrium)?;
                let Some((lambda, shape)) =
                    modes.first().filter(|(lambda, _)| is_unstable(*lambda))
                else {
                    return Err(StageError::new(format!(
                        "the sliding state is stable (largest Re lambda = {:.4e}): no unstable mode to start from; use `initial: zero` or `given`",
                        modes.first().map_or(f64::NAN, |(lambda, _)| lambda.re)
                    )));
                };
                let (u0, v0) = mode_start(*lambda, shape, params.amplitude);
                let mut r_e = vec![0.0; 3 * n_contacts];
                for c in 0..n_contacts {
                    let r_n = equilibrium.r_n[c];
                    r_e[3 * c] = r_n;
                    r_e[3 * c + 1] = if r_n > 0.0 {
                        mu[c] * speeds[c].signum() * r_n
                    } else {
                        0.0
                    };
                }
                (
                    equilibrium.q.clone(),
                    r_e,
                    u0,
                    v0,
                    Some((*lambda, equilibrium.residual)),
                )
            }
        };
        // The departure's load: f − K q_ref + Hᵀ r_e (the scheme subtracts Hᵀ r_e), and the
        // driven DOFs' rate.
        let K_q = K.mul_vec(&q_ref);
        let mut constant: Vec<f64> = f.iter().zip(&K_q).map(|(f, Kq)| f - Kq).collect();
        for (row, entries) in H_rows.iter().enumerate() {
            for &(dof, value) in entries {
                constant[dof] += value * r_e[row];
            }
        }
        let none = |values: &[f64]| values.iter().all(|&value| value == 0.0);
        let load = Load {
            constant: if none(&constant) {
                Vec::new()
            } else {
                constant
            },
            rate: if none(&rate) { Vec::new() } else { rate },
        };
        let gap: Vec<f64> = model
            .contacts
            .iter()
            .map(|contact| {
                contact.gap
                    + free
                        .iter()
                        .zip(&q_ref)
                        .map(|(&dof, q)| contact.normal[dof] * q)
                        .sum::<f64>()
            })
            .collect();
        let speed_scale = speeds
            .iter()
            .map(|speed| speed.abs())
            .chain(model.driven.iter().map(|(_, velocity)| velocity.abs()))
            .fold(0.0, f64::max);
        let contact_state = ContactState {
            gap,
            sliding_speed: speeds,
            r_e,
            mu,
            mu_static,
            speed_scale,
            blocks: contact::pad_blocks(&vec![0; n_contacts]),
        };
        Ok(LumpedRun {
            model,
            free,
            M,
            C,
            K,
            H_rows,
            load,
            contact_state,
            q_ref,
            q_driven,
            u0,
            v0,
            record_dofs,
            phase_dof: params.phase_dof,
            start_mode,
        })
    }

    /// What the scheme integrates.
    pub fn structure(&self) -> Structure<'_> {
        Structure {
            M: &self.M,
            C: &self.C,
            K: &self.K,
            dof_of_node: &[],
            H_rows: self.H_rows.clone(),
            load: self.load.clone(),
        }
    }

    /// The DOFs the history and the phase portrait read that the scheme integrates, as its
    /// unknowns (ascending, deduplicated).
    pub fn free_records(&self) -> Vec<usize> {
        let mut records: Vec<usize> = self
            .record_dofs
            .iter()
            .chain([&self.phase_dof])
            .filter_map(|dof| self.free.binary_search(dof).ok())
            .collect();
        records.sort_unstable();
        records.dedup();
        records
    }
}
