//! `equilibrium`: the static sliding equilibrium of the brake (DESIGN §3.3).
//!
//! Find (u, r) with K u = F + Hᵀ r, every closed pair sliding (r_t = μ r_n, r_b = 0) and
//! Signorini's conditions on the normal gaps (conventions in [`crate::contact`]).
//! K is factorised once (sparse LDLᵀ, nested-dissection ordering). With
//! Z = K⁻¹ (H_n + μ H_t)ᵀ (one solve per pair) the normal gaps are
//!
//!     g = q + A r_n,   A = H_n Z,   q = g₀ − δ + H_n K⁻¹ F,
//!
//! a small dense linear complementarity problem ([`crate::contact::lcp`]), solved by the
//! seed's fixed point or by semi-smooth Newton (the default: a few iterations where the fixed
//! point needs hundreds). Then u = K⁻¹ F + Z r_n.
//!
//! Loads:
//! - `interference`: the clamped pad backs are pushed toward the disc by δ. A rigid
//!   translation of a pad stores no energy, so this is exactly an initial gap g₀ − δ on every
//!   pair with the backs held in place; the displacement reported adds the translation back.
//! - `force`: a normal force F (N) pushes each pad's back toward the disc, spread evenly over
//!   its back nodes (sets `pad_backs_upper` and `pad_backs_lower`), which must be free along
//!   the normal (clamp them in-plane only: `clamped: "hub, pad_backs:xy"` in `assemble`).
//!   The normal reactions on each pad then add up to F.

use faer::{Mat, Par};
use serde::{Deserialize, Serialize};

use crate::artifact::{Artifact, ArtifactType};
use crate::contact::lcp::{self, LcpSettings, LcpSolution};
use crate::contact::{self, ContactFrames};
use crate::model::Model;
use crate::modes::factor::ShiftedPencil;
use crate::stage::{Inputs, Outputs, ParamSpec, Params, PortSpec, Stage, StageError};
use crate::table::Table;

/// The sliding equilibrium, as the stability analysis needs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Equilibrium {
    /// Displacement over the model's free DOFs (m), rigid pad approach excluded.
    pub u: Vec<f64>,
    /// Normal reaction per pair (N, ≥ 0); r_t = μ r_n on closed pairs, r_b = 0.
    pub r_n: Vec<f64>,
    /// Normal gap per pair (m).
    pub gap: Vec<f64>,
    /// Effective contact zone: pairs in contact.
    pub closed: Vec<bool>,
    pub frames: ContactFrames,
    pub mu: f64,
    pub omega: f64,
}

/// How the pads are loaded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Load {
    /// Pad backs pushed toward the disc by this distance (m).
    Interference(f64),
    /// Each pad pushed toward the disc with this normal force (N).
    Force(f64),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solver {
    FixedPoint,
    SemismoothNewton,
}

/// What the solve reports besides the equilibrium.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub solver: Solver,
    pub lcp: LcpSolution,
    /// ‖K u − F − Hᵀ r‖ / ‖F + Hᵀ r‖ of the returned state.
    pub equation_residual: f64,
}

/// Solves the sliding equilibrium of `model`.
pub fn solve(
    model: &Model,
    mu: f64,
    omega: f64,
    load: Load,
    solver: Solver,
    settings: &LcpSettings,
) -> Result<(Equilibrium, Report), StageError> {
    let mesh = &model.mesh;
    if mesh.contact_pairs.is_empty() {
        return Err(StageError::new("the mesh has no contact pairs"));
    }
    let frames = contact::frames(mesh, omega).map_err(StageError::new)?;
    let columns = contact::h_columns(model, &frames);
    let n = model.n_dofs();
    let n_pairs = mesh.contact_pairs.len();

    let pencil = ShiftedPencil::new(&model.K, &model.M, &model.dof_of_node)?;
    let factor = pencil.factor(0.0, Par::rayon(0))?;
    if factor.negative_pivots > 0 {
        return Err(StageError::new(format!(
            "K is not positive definite ({} negative pivots): a part is not supported — clamp the hub and the pad backs",
            factor.negative_pivots
        )));
    }
    let normal = |pair: usize| &columns[3 * pair];
    let tangent = |pair: usize| &columns[3 * pair + 1];

    // Z = K⁻¹ (H_n + μ H_t)ᵀ, one column per pair, plus K⁻¹ F in the last column.
    let force = external_force(model, load)?;
    let mut Z = Mat::<f64>::zeros(n, n_pairs + 1);
    for pair in 0..n_pairs {
        for &(dof, value) in normal(pair) {
            Z[(dof, pair)] += value;
        }
        for &(dof, value) in tangent(pair) {
            Z[(dof, pair)] += mu * value;
        }
    }
    for (dof, value) in force.iter().enumerate() {
        Z[(dof, n_pairs)] = *value;
    }
    factor.solve_in_place(Z.as_mut(), Par::rayon(0));
    let apply_normal = |pair: usize, col: usize| normal(pair).iter().map(|&(dof, value)| value * Z[(dof, col)]).sum::<f64>();
    let A = Mat::from_fn(n_pairs, n_pairs, |row, col| apply_normal(row, col));
    let interference = match load {
        Load::Interference(delta) => delta,
        Load::Force(_) => 0.0,
    };
    let q: Vec<f64> = (0..n_pairs)
        .map(|pair| {
            let contact_pair = &mesh.contact_pairs[pair];
            let (x_pad, x_disc) = (mesh.nodes[contact_pair.pad_node as usize], mesh.nodes[contact_pair.disc_node as usize]);
            let g0: f64 = (0..3).map(|axis| (x_pad[axis] - x_disc[axis]) * frames.n[pair][axis]).sum();
            g0 - interference + apply_normal(pair, n_pairs)
        })
        .collect();

    let lcp = match solver {
        Solver::FixedPoint => lcp::fixed_point(&A, &q, settings),
        Solver::SemismoothNewton => lcp::semismooth_newton(&A, &q, settings),
    }
    .map_err(|err| StageError::new(err.to_string()))?;

    let u: Vec<f64> = (0..n).map(|dof| Z[(dof, n_pairs)] + (0..n_pairs).map(|pair| Z[(dof, pair)] * lcp.r[pair]).sum::<f64>()).collect();
    // Check the equation itself: K u = F + Hᵀ r.
    let mut rhs = force.clone();
    for pair in 0..n_pairs {
        for &(dof, value) in normal(pair) {
            rhs[dof] += value * lcp.r[pair];
        }
        for &(dof, value) in tangent(pair) {
            rhs[dof] += value * mu * lcp.r[pair];
        }
    }
    let Ku = model.K.mul_vec(&u);
    let norm = |v: &[f64]| v.iter().map(|value| value * value).sum::<f64>().sqrt();
    let difference: Vec<f64> = Ku.iter().zip(&rhs).map(|(a, b)| a - b).collect();
    let equation_residual = norm(&difference) / norm(&rhs).max(f64::MIN_POSITIVE);

    let closed: Vec<bool> = lcp.r.iter().map(|r| *r > 0.0).collect();
    let equilibrium = Equilibrium { u, r_n: lcp.r.clone(), gap: lcp.g.clone(), closed, frames, mu, omega };
    Ok((equilibrium, Report { solver, lcp, equation_residual }))
}

/// F: under `Force`, F/N_back on each back node of each pad, along ∓z toward the disc.
fn external_force(model: &Model, load: Load) -> Result<Vec<f64>, StageError> {
    let mut force = vec![0.0; model.n_dofs()];
    let Load::Force(total) = load else {
        return Ok(force);
    };
    let mesh = &model.mesh;
    for (set, toward_disc) in [("pad_backs_upper", -1.0), ("pad_backs_lower", 1.0)] {
        let nodes = mesh.node_sets.get(set).ok_or_else(|| {
            StageError::new(format!("force loading needs the node set `{set}`, which the mesh does not have"))
        })?;
        for &node in nodes {
            let dof = model.dof_of_node[node as usize][2].ok_or_else(|| {
                StageError::new(format!(
                    "force loading needs the pad backs free along the normal, but node {node} of `{set}` is clamped in z: clamp them in-plane only (clamped: \"hub, pad_backs:xy\")"
                ))
            })?;
            force[dof as usize] += toward_disc * total / nodes.len() as f64;
        }
    }
    Ok(force)
}

/// The `equilibrium` stage.
pub struct SlidingEquilibrium;

impl Stage for SlidingEquilibrium {
    fn kind(&self) -> &'static str {
        "equilibrium"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Static sliding equilibrium: Signorini contact with Coulomb friction at constant mu"
    }
    fn params(&self) -> Vec<ParamSpec> {
        let defaults = LcpSettings::default();
        vec![
            ParamSpec::float("mu", 0.38, "", "friction coefficient").at_least(0.0),
            ParamSpec::float("omega", 4.0, "rad/s", "disc speed (sets the sliding directions)"),
            ParamSpec::choice("load", &["interference", "force"], "interference", "how the pads are pushed"),
            ParamSpec::float("interference", 1e-4, "m", "load = interference: pad backs pushed toward the disc by this").at_least(0.0),
            ParamSpec::float("force", 1e4, "N", "load = force: normal force on each pad").at_least(0.0),
            ParamSpec::choice("solver", &["newton", "fixed_point"], "newton", "semi-smooth Newton, or the seed's fixed point"),
            ParamSpec::float("tolerance", defaults.tolerance, "", "complementarity residual to reach").at_least(0.0),
            ParamSpec::int("max_iterations", defaults.max_iterations as i64, "iteration limit").at_least(1.0),
            ParamSpec::float("relaxation", defaults.relaxation, "", "fixed point: rho_i = relaxation / A_ii").at_least(0.0),
        ]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one("model", ArtifactType::Model, "the assembled brake, with contact pairs")]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one("equilibrium", ArtifactType::Equilibrium, "u_e, r_e, the contact zone and frames"),
            PortSpec::one("contact", ArtifactType::Table, "one row per pair: position, reactions, pressure, gap, status"),
            PortSpec::one("summary", ArtifactType::Table, "solver, iterations, residuals, total forces"),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let Artifact::Model(model) = inputs.one("model")? else {
            return Err(StageError::new("input `model` is not a model"));
        };
        let load = match params.str("load") {
            "force" => Load::Force(params.float("force")),
            _ => Load::Interference(params.float("interference")),
        };
        let solver = match params.str("solver") {
            "fixed_point" => Solver::FixedPoint,
            _ => Solver::SemismoothNewton,
        };
        let settings = LcpSettings {
            tolerance: params.float("tolerance"),
            max_iterations: params.int("max_iterations") as usize,
            relaxation: params.float("relaxation"),
        };
        let (equilibrium, report) = solve(model, params.float("mu"), params.float("omega"), load, solver, &settings)?;
        let contact = contact_table(model, &equilibrium);
        let summary = summary_table(&equilibrium, &report, &model.mesh);
        Ok(Outputs::from([
            ("equilibrium".to_string(), Artifact::Equilibrium(Box::new(equilibrium))),
            ("contact".to_string(), Artifact::Table(contact)),
            ("summary".to_string(), Artifact::Table(summary)),
        ]))
    }
}

/// One row per pair: where, how hard, open or closed.
pub fn contact_table(model: &Model, equilibrium: &Equilibrium) -> Table {
    let pairs = &model.mesh.contact_pairs;
    let position = |axis: usize| pairs.iter().map(|pair| model.mesh.nodes[pair.disc_node as usize][axis]).collect::<Vec<f64>>();
    let r_n = equilibrium.r_n.clone();
    Table::new()
        .with("pair", (0..pairs.len() as i64).collect::<Vec<i64>>())
        .with("x", position(0))
        .with("y", position(1))
        .with("z", position(2))
        .with("side", pairs.iter().map(|pair| if pair.normal[2] >= 0.0 { "upper" } else { "lower" }.to_string()).collect::<Vec<String>>())
        .with("r_n", r_n.clone())
        .with("r_t", r_n.iter().map(|r| equilibrium.mu * r).collect::<Vec<f64>>())
        .with("r_b", vec![0.0; pairs.len()])
        .with("pressure", r_n.iter().zip(pairs).map(|(r, pair)| r / pair.area).collect::<Vec<f64>>())
        .with("gap", equilibrium.gap.clone())
        .with("sliding_speed", equilibrium.frames.sliding_speed.clone())
        .with("status", equilibrium.closed.iter().map(|closed| if *closed { "closed" } else { "open" }.to_string()).collect::<Vec<String>>())
}

/// The figures that say whether the solve is to be trusted, and the resultant forces.
fn summary_table(equilibrium: &Equilibrium, report: &Report, mesh: &crate::mesh::Mesh) -> Table {
    let side_total = |upper: bool| {
        mesh.contact_pairs.iter().zip(&equilibrium.r_n).filter(|(pair, _)| (pair.normal[2] >= 0.0) == upper).map(|(_, r)| r).sum::<f64>()
    };
    let total: f64 = equilibrium.r_n.iter().sum();
    let quantities = [
        ("iterations", report.lcp.iterations as f64),
        ("complementarity_residual", report.lcp.residual()),
        ("equation_residual", report.equation_residual),
        ("closed_pairs", equilibrium.closed.iter().filter(|closed| **closed).count() as f64),
        ("pairs", equilibrium.closed.len() as f64),
        ("normal_force_upper_N", side_total(true)),
        ("normal_force_lower_N", side_total(false)),
        ("normal_force_total_N", total),
        ("friction_force_total_N", equilibrium.mu * total),
    ];
    let solver = match report.solver {
        Solver::FixedPoint => "fixed_point",
        Solver::SemismoothNewton => "newton",
    };
    Table::new()
        .with("quantity", quantities.iter().map(|(name, _)| name.to_string()).collect::<Vec<String>>())
        .with("value", quantities.iter().map(|(_, value)| *value).collect::<Vec<f64>>())
        .with("solver", vec![solver.to_string(); quantities.len()])
}
