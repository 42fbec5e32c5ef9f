//! `equilibrium`: the static sliding equilibrium of the brake (`docs/science.md` §3).
//!
//! Find (u, r) with K u = F + Hᵀ r, every closed pair sliding (r_t = μ r_n, r_b = 0) and
//! Signorini's conditions on the normal gaps (conventions in [`crate::contact`]). With
//! G = H_n + μ H_t (one row per pair) the contact force is Gᵀ r_n.
//!
//! ## Load: interference (`load: interference`, the default)
//!
//! The clamped pad backs are pushed toward the disc by an interference δ. A rigid
//! translation of a pad stores no energy, so this is exactly an initial gap g₀ − δ on every
//! pair with the backs held in place (F = 0); the displacement reported excludes the
//! translation. K is factorised once (sparse LDLᵀ, nested-dissection ordering). With
//! Z = K⁻¹ Gᵀ (one solve per pair) the normal gaps are
//!
//! ```text
//! g = q + A r,   A = H_n Z,   q = g₀ − δ
//! ```
//!
//! a small dense linear complementarity problem ([`crate::contact::lcp`]), solved by the
//! paper's fixed point or by semi-smooth Newton (the default: a few iterations where the fixed
//! point needs hundreds). Then u = Z r_n. The load the pads then carry is the sum of the
//! support reactions at their backs, which [`back_reactions`] recovers from the element
//! stiffnesses as a balance check.
//!
//! ## Load: pressure (`load: pressure`)
//!
//! The backs are guided in-plane (`clamped: "hub, pad_backs:xy"`) and a pressure p acts on
//! the back faces (node set `pad_backs`), F its consistent nodal forces
//! ([`floating::pressure_load`]). Any node sets may be pressed instead, each by its own
//! pressure (`pressure_sets: [pistons_inner, "pistons_outer=1.2e6"]`: the pistons' faces of a
//! caliper), on faces of any element kind; F is the sum of their loads. Each pad puck is then a floating body: K is singular, its
//! kernel spanned by the columns of R, the rigid motions the clamps leave free
//! ([`floating::floating_bodies`]: for a puck, the normal translation and two tilts about
//! in-plane axes through its back). Pin k_b DOFs of each body (k_b its number of motions,
//! R on the pinned DOFs invertible): K_pin (K with the pinned rows and columns removed) is
//! positive definite, which the factorisation checks (no negative pivot). Write S for
//! "solve with K_pin, zero at the pinned DOFs". For any b with Rᵀ b = 0, the solutions of
//! K u = b are exactly u = S b + R a: the rows of K not pinned hold by construction, and the
//! pinned ones follow from Rᵀ K = 0 and Rᵀ b = 0 because R on the pinned DOFs is invertible.
//! So, with a the amplitudes of the rigid motions,
//!
//! ```text
//! u = S (F + Gᵀ r) + R a
//! g = q + A r + B a,   q = g₀ + H_n S F,   A = H_n S Gᵀ,   B = H_n R
//! Cᵀ r = d,            C = G R,           d = −Rᵀ F          (each body in balance)
//! ```
//!
//! with r ≥ 0, g ≥ 0, rᵀ g = 0: a mixed LCP, the amplitudes free and the balance an equality
//! (the pins carry no load). Newton solves the bordered system
//! [A_CC B_C; C_Cᵀ 0] on the closed set; the fixed point picks a at each sweep so that the
//! swept reactions balance the load ([`crate::contact::lcp`]). The displacement u includes
//! the rigid motions. The balance makes the total normal contact force on each pad equal
//! p × its back area, and the tilts make the contact pressure's moment balance the moment
//! of the friction drag about the guides (the contact pressure is then not uniform).
//!
//! Either way the summary states the load and the total normal contact force per side.
//! In a study, the pressure variant of `pipelines/quick.yaml` is two lines:
//!
//! ```yaml
//!   model:       { ..., params: { clamped: "hub, pad_backs:xy" } }
//!   equilibrium: { ..., params: { load: pressure, pressure: 1 MPa, mu: 0.38 } }
//! ```
//!
//! The summary's `pressure_Pa` is the largest of the pressures applied.

mod checks;
pub mod floating;
mod solve;
mod tables;
#[cfg(test)]
mod tests;

use crate::artifact::{Artifact, ArtifactType, Model};
use crate::contact::lcp::LcpSettings;
use crate::contact::pad_face;
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};

pub use checks::{SMALL_STRAIN, back_reactions, largest_strain};
pub use floating::{AppliedPressure, PRESSURE_SET, PressureOn};
pub use solve::{Load, Report, Solver, solve};
use tables::summary_table;
pub use tables::{contact_table, side_force};

crate::choice! {
    /// Which [`Load`] presses the pads, by the name a study gives it.
    pub enum LoadKind {
        Interference = "interference",
        Pressure = "pressure",
    }
}

crate::stage_params! {
    /// The parameters of `equilibrium`.
    pub struct EquilibriumParams {
        /// friction coefficient
        #[min = 0.0]
        mu: f64 = 0.38,
        /// disc speed (sets the sliding directions)
        #[unit = "rad/s"]
        omega: f64 = 4.0,
        /// clamped backs pushed by `interference`, or `pressure` on backs clamped pad_backs:xy
        load: LoadKind = LoadKind::Interference,
        /// load: interference — pad backs pushed toward the disc by this
        #[unit = "m"]
        #[min = 0.0]
        interference: f64 = 1e-4,
        /// load: pressure — pressure on the boundary faces of `pressure_sets`
        #[unit = "Pa"]
        #[min = 0.0]
        pressure: f64 = 1e6,
        /// load: pressure — node sets whose boundary faces it presses (the pad backs, the pistons' faces); `set=p` gives a set its own pressure (Pa)
        pressure_sets: Vec<String> = vec!["pad_backs".into()],
        /// semi-smooth Newton, or the paper's fixed point
        solver: Solver = Solver::SemismoothNewton,
        /// complementarity residual to reach
        #[min = 0.0]
        tolerance: f64 = LcpSettings::default().tolerance,
        /// iteration limit
        #[min = 1]
        max_iterations: usize = LcpSettings::default().max_iterations,
        /// fixed point: rho_i = relaxation / A_ii
        #[min = 0.0]
        relaxation: f64 = LcpSettings::default().relaxation,
    }
}

/// The `equilibrium` stage.
pub struct SlidingEquilibrium;

/// The pressure of each of `pressure_sets`: `set` takes `pressure`, `set=p` its own `p` (Pa).
fn pressures_on(params: &EquilibriumParams) -> Result<Vec<PressureOn>, StageError> {
    params
        .pressure_sets
        .iter()
        .map(|item| {
            let (set, pressure) = match item.split_once('=') {
                None => (item.trim(), params.pressure),
                Some((set, value)) => {
                    let pressure: f64 = value.trim().parse().map_err(|_| {
                        StageError::new(format!(
                            "pressure_sets: `{item}`: `{}` is not a pressure in Pa (write `set=1.5e6`)",
                            value.trim()
                        ))
                    })?;
                    (set.trim(), pressure)
                }
            };
            if !(pressure.is_finite() && pressure >= 0.0) {
                return Err(StageError::new(format!(
                    "pressure_sets: `{item}`: the pressure must be finite and not negative"
                )));
            }
            Ok(PressureOn {
                set: set.to_string(),
                pressure,
            })
        })
        .collect()
}

impl HasParams for SlidingEquilibrium {
    type Params = EquilibriumParams;
}

impl Stage for SlidingEquilibrium {
    fn kind(&self) -> &'static str {
        "equilibrium"
    }
    fn version(&self) -> u32 {
        // 4: the summary's max_strain_estimate (CHANGELOG.md, "equilibrium")
        4
    }
    fn doc(&self) -> &'static str {
        "Static sliding equilibrium: Signorini contact with Coulomb friction at constant mu, pads pressed by an interference or a back pressure"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "model",
            ArtifactType::Model,
            "the assembled brake, with contact pairs",
        )]
    }
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[("vtu", "fields")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "equilibrium",
                ArtifactType::Equilibrium,
                "u_e, r_e, the contact zone and frames",
            ),
            PortSpec::one(
                "contact",
                ArtifactType::Table,
                "one row per pair: position, reactions, pressure, gap, status",
            ),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "load, solver, iterations, residuals, total contact force per side, largest strain (max_strain_estimate)",
            ),
            PortSpec::one(
                "fields",
                ArtifactType::Document,
                "displacement, contact pressure and gap for ParaView",
            ),
            PortSpec::one(
                "pressure",
                ArtifactType::Figure,
                "contact pressure over the pad faces",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let model: &Model = inputs.get("model")?;
        let params: EquilibriumParams = params.read::<Self>()?;
        let settings = LcpSettings {
            tolerance: params.tolerance,
            max_iterations: params.max_iterations,
            relaxation: params.relaxation,
        };
        let load = match params.load {
            LoadKind::Interference => Load::Interference(params.interference),
            LoadKind::Pressure => Load::Pressure(pressures_on(&params)?),
        };
        let (equilibrium, report) = solve(
            model,
            params.mu,
            params.omega,
            load,
            params.solver,
            &settings,
        )?;
        let contact = contact_table(model, &equilibrium);
        let (strain, element) = largest_strain(model, &equilibrium.u);
        if strain > SMALL_STRAIN {
            let part = &model.mesh.parts[model.mesh.elements.part(element) as usize];
            tracing::warn!(
                "equilibrium: strains reach {:.2} % (element {element}, part `{part}`), beyond the small strains ({} %) the linear model assumes: lower the load",
                100.0 * strain,
                100.0 * SMALL_STRAIN
            );
        }
        let summary = summary_table(&equilibrium, &report, &model.mesh, strain);
        let pressure: Vec<f64> = equilibrium
            .r_n
            .iter()
            .zip(&model.mesh.contact_pairs)
            .map(|(r, pair)| r / pair.area)
            .collect();
        let peak = pressure.iter().copied().fold(0.0, f64::max);
        let pressure: Vec<Option<f64>> = pressure
            .into_iter()
            .map(|pressure| (pressure > 0.0).then_some(pressure))
            .collect();
        let pressure = pad_face::figure(&model.mesh, &pressure, peak, "pressure (Pa)")?;
        let vtu = Artifact::document(
            "vtu",
            crate::vtu_writer::equilibrium_vtu(model, &equilibrium)?,
        );
        Ok(Outputs::from([
            (
                "equilibrium".to_string(),
                Artifact::Equilibrium(Box::new(equilibrium)),
            ),
            ("contact".to_string(), Artifact::Table(contact)),
            ("summary".to_string(), Artifact::Table(summary)),
            ("fields".to_string(), vtu),
            ("pressure".to_string(), Artifact::Figure(pressure)),
        ]))
    }
}
