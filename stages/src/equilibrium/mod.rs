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
//! ([`floating::pressure_load`]). Each pad puck is then a floating body: K is singular, its
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

mod figure;
pub mod floating;

use faer::Mat;

use crate::artifact::{Artifact, ArtifactType, Equilibrium};
use crate::artifact::{ContactFrames, CscMatrix, Model};
use crate::contact;
use crate::contact::lcp::{self, Balance, LcpSettings, LcpSolution};
use crate::fem::material::Material;
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;
use squeal_linalg::ldlt::{Factor, ShiftedPencil};

/// The node set the pressure acts on.
pub const PRESSURE_SET: &str = "pad_backs";

crate::choice! {
    /// The solver of the condensed contact problem.
    pub enum Solver {
        /// Semi-smooth Newton on the complementarity function.
        SemismoothNewton = "newton",
        /// The paper's projected fixed point.
        FixedPoint = "fixed_point",
    }
}

crate::choice! {
    /// Which [`Load`] presses the pads, by the name a study gives it.
    pub enum LoadKind {
        Interference = "interference",
        Pressure = "pressure",
    }
}

/// What presses the pads onto the disc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Load {
    /// Clamped backs pushed toward the disc by this much (m).
    Interference(f64),
    /// This pressure (Pa) on the back faces ([`PRESSURE_SET`]), backs free along the normal.
    Pressure(f64),
}

/// The pressure as applied: area and |z resultant| of the faces on the upper (index 0) and
/// lower (index 1) pads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AppliedPressure {
    pub area: [f64; 2],
    pub force: [f64; 2],
    pub floating_bodies: usize,
}

/// What the solve reports besides the equilibrium.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub solver: Solver,
    pub load: Load,
    /// With a pressure load: what it applies.
    pub applied: Option<AppliedPressure>,
    pub lcp: LcpSolution,
    /// ‖K u − F − Gᵀ r‖ / ‖F + Gᵀ r‖ of the returned state.
    pub equation_residual: f64,
    /// Wall time (s) of the factorisation of K, of the condensation (solves and A = H_n Z),
    /// and of the contact iterations. For benchmarks only: never part of an output.
    pub seconds: [f64; 3],
}

/// K with the `pinned` rows and columns replaced by their diagonal entry alone.
fn pin(K: &CscMatrix, pinned: &[usize]) -> CscMatrix {
    let mut is_pinned = vec![false; K.n_rows];
    for &dof in pinned {
        is_pinned[dof] = true;
    }
    let mut triplets = Vec::with_capacity(K.values.len());
    for col in 0..K.n_cols {
        for entry in K.col_ptr[col]..K.col_ptr[col + 1] {
            let row = K.row_idx[entry];
            if (is_pinned[row] || is_pinned[col]) && row != col {
                continue;
            }
            triplets.push((row, col, K.values[entry]));
        }
    }
    CscMatrix::from_triplets(K.n_rows, K.n_cols, triplets)
}

/// The pressure problem's pieces: F, R, the pins, and what the summary reports.
struct Floating {
    forces: Vec<f64>,
    R: Mat<f64>,
    pinned: Vec<usize>,
    applied: AppliedPressure,
    bodies: Vec<floating::FloatingBody>,
}

/// Checks that the pressure pushes floating bodies, every one of them, and nothing clamped.
fn floating_under_pressure(model: &Model, pressure: f64) -> Result<Floating, StageError> {
    let bodies = floating::floating_bodies(model)?;
    if bodies.bodies.is_empty() {
        return Err(StageError::new(format!(
            "load: pressure needs pads free along the disc normal, but every body is held by its clamps: clamp the pad backs in-plane only (`clamped: \"hub, {PRESSURE_SET}:xy\"`)"
        )));
    }
    let load = floating::pressure_load(model, pressure, PRESSURE_SET)?;
    let total = load.force[0] + load.force[1];
    if load.on_clamped > 1e-9 * total {
        return Err(StageError::new(format!(
            "{:.3e} N of the {total:.3e} N pressure resultant falls on clamped DOFs of `{PRESSURE_SET}`: clamp the pad backs in-plane only (`{PRESSURE_SET}:xy`) so that they are free along the normal",
            load.on_clamped
        )));
    }
    for body in &bodies.bodies {
        let pushed = body
            .nodes
            .iter()
            .flat_map(|&node| model.dof_of_node[node as usize].iter().flatten())
            .any(|&dof| load.forces[dof as usize] != 0.0);
        if !pushed {
            return Err(StageError::new(format!(
                "{body} is not held by its clamps and carries no pressure: clamp it"
            )));
        }
    }
    Ok(Floating {
        forces: load.forces,
        applied: AppliedPressure {
            area: load.area,
            force: load.force,
            floating_bodies: bodies.bodies.len(),
        },
        R: bodies.R,
        pinned: bodies.pinned,
        bodies: bodies.bodies,
    })
}

/// Solves the sliding equilibrium of `model`: K factorised (floating bodies pinned), the
/// problem condensed on the pairs, the LCP solved there, the displacement lifted back and the
/// equation `K u = F + Gᵀ r` checked.
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

    let clock = std::time::Instant::now();
    let (floating, interference) = match load {
        Load::Interference(delta) => (None, delta),
        Load::Pressure(pressure) => (Some(floating_under_pressure(model, pressure)?), 0.0),
    };
    let pinned_K = floating
        .as_ref()
        .map(|floating| pin(&model.K, &floating.pinned));
    let pencil = ShiftedPencil::new(
        pinned_K.as_ref().unwrap_or(&model.K),
        &model.M,
        &model.dof_of_node,
    )?;
    let factor = factor_stiffness(&pencil, floating.as_ref())?;
    let factor_seconds = clock.elapsed().as_secs_f64();

    let clock = std::time::Instant::now();
    let condensed = Condensed::new(
        model,
        &frames,
        &columns,
        mu,
        interference,
        floating.as_ref(),
        &factor,
    )?;
    let condense_seconds = clock.elapsed().as_secs_f64();

    let clock = std::time::Instant::now();
    let (A, q, balance) = (&condensed.A, &condensed.q, &condensed.balance);
    let lcp = match solver {
        Solver::FixedPoint => lcp::fixed_point_balanced(A, q, balance, settings),
        Solver::SemismoothNewton => lcp::semismooth_newton_balanced(A, q, balance, settings),
    }
    .map_err(|err| StageError::new(err.to_string()))?;
    let iterate_seconds = clock.elapsed().as_secs_f64();

    let u = condensed.displacement(&lcp, floating.as_ref());
    let equation_residual = equation_residual(model, &columns, mu, floating.as_ref(), &lcp, &u);
    let closed: Vec<bool> = lcp.r.iter().map(|r| *r > 0.0).collect();
    let equilibrium = Equilibrium {
        u,
        r_n: lcp.r.clone(),
        gap: lcp.g.clone(),
        closed,
        frames,
        mu,
        omega,
    };
    let seconds = [factor_seconds, condense_seconds, iterate_seconds];
    Ok((
        equilibrium,
        Report {
            solver,
            load,
            applied: floating.map(|floating| floating.applied),
            lcp,
            equation_residual,
            seconds,
        },
    ))
}

/// K (with the floating bodies pinned) factorised, or why it cannot be.
fn factor_stiffness<'p>(
    pencil: &'p ShiftedPencil,
    floating: Option<&Floating>,
) -> Result<Factor<'p>, StageError> {
    let factor = pencil
        .factor(0.0, squeal_linalg::par())
        .map_err(|err| match floating {
            None => StageError::from(err),
            Some(floating) => StageError::new(format!(
                "K with the floating bodies pinned cannot be factorised ({err}); floating: {}",
                body_list(&floating.bodies)
            )),
        })?;
    if factor.negative_pivots > 0 {
        return Err(StageError::new(match floating {
            None => format!(
                "K is not positive definite ({} negative pivots): a part is not supported — clamp the hub and the pad backs",
                factor.negative_pivots
            ),
            Some(floating) => format!(
                "K with the floating bodies pinned is not positive definite ({} negative pivots): a body has a mechanism other than its rigid motions, unsupported; floating: {}",
                factor.negative_pivots,
                body_list(&floating.bodies)
            ),
        }));
    }
    Ok(factor)
}

/// The problem condensed on the pairs: `A r + q = g ≥ 0 ⊥ r ≥ 0`, with the floating bodies'
/// balance, and `Z` to lift a solution back to the DOFs.
struct Condensed<'a> {
    columns: &'a [Vec<(usize, f64)>],
    /// `Z = S Gᵀ` (one column per pair), and `S F` in the last column under pressure; `S` is
    /// K⁻¹ without floating bodies, else the pinned solve (zero at the pinned DOFs).
    Z: Mat<f64>,
    A: Mat<f64>,
    q: Vec<f64>,
    balance: Balance,
}

impl<'a> Condensed<'a> {
    fn new(
        model: &Model,
        frames: &ContactFrames,
        columns: &'a [Vec<(usize, f64)>],
        mu: f64,
        interference: f64,
        floating: Option<&Floating>,
        factor: &Factor,
    ) -> Result<Condensed<'a>, StageError> {
        let mesh = &model.mesh;
        let (n, n_pairs) = (model.n_dofs(), mesh.contact_pairs.len());
        let normal = |pair: usize| &columns[3 * pair];
        let tangent = |pair: usize| &columns[3 * pair + 1];
        let mut Z = Mat::<f64>::zeros(n, n_pairs + usize::from(floating.is_some()));
        for pair in 0..n_pairs {
            for &(dof, value) in normal(pair) {
                Z[(dof, pair)] += value;
            }
            for &(dof, value) in tangent(pair) {
                Z[(dof, pair)] += mu * value;
            }
        }
        if let Some(floating) = floating {
            for (dof, force) in floating.forces.iter().enumerate() {
                Z[(dof, n_pairs)] = *force;
            }
            for &dof in &floating.pinned {
                Z.row_mut(dof).fill(0.0);
            }
        }
        factor.solve_in_place(Z.as_mut(), squeal_linalg::par());
        if let Some(floating) = floating {
            for &dof in &floating.pinned {
                Z.row_mut(dof).fill(0.0);
            }
        }
        let apply_normal = |pair: usize, vectors: &Mat<f64>, col: usize| {
            normal(pair)
                .iter()
                .map(|&(dof, value)| value * vectors[(dof, col)])
                .sum::<f64>()
        };
        let A = Mat::from_fn(n_pairs, n_pairs, |pair, col| apply_normal(pair, &Z, col));
        let q: Vec<f64> = (0..n_pairs)
            .map(|pair| {
                let contact_pair = &mesh.contact_pairs[pair];
                let (x_pad, x_disc) = (
                    mesh.nodes[contact_pair.pad_node as usize],
                    mesh.nodes[contact_pair.disc_node as usize],
                );
                let g0: f64 = (0..3)
                    .map(|axis| (x_pad[axis] - x_disc[axis]) * frames.n[pair][axis])
                    .sum();
                match floating {
                    None => g0 - interference,
                    Some(_) => g0 + apply_normal(pair, &Z, n_pairs),
                }
            })
            .collect();
        let balance = match floating {
            None => Balance::none(n_pairs),
            Some(floating) => {
                let R = &floating.R;
                let m = R.ncols();
                let apply_g = |pair: usize, mode: usize| {
                    apply_normal(pair, R, mode)
                        + mu * tangent(pair)
                            .iter()
                            .map(|&(dof, value)| value * R[(dof, mode)])
                            .sum::<f64>()
                };
                let balance = Balance {
                    B: Mat::from_fn(n_pairs, m, |pair, mode| apply_normal(pair, R, mode)),
                    C: Mat::from_fn(n_pairs, m, apply_g),
                    d: (0..m)
                        .map(|mode| {
                            -(0..n)
                                .map(|dof| R[(dof, mode)] * floating.forces[dof])
                                .sum::<f64>()
                        })
                        .collect(),
                };
                check_contact_holds(&balance.B, &floating.bodies)?;
                balance
            }
        };
        Ok(Condensed {
            columns,
            Z,
            A,
            q,
            balance,
        })
    }

    /// `u = Z r` (+ `S F` and the floating bodies' rigid motions `R a` under pressure).
    fn displacement(&self, lcp: &LcpSolution, floating: Option<&Floating>) -> Vec<f64> {
        let n_pairs = self.columns.len() / 3;
        let Z = &self.Z;
        (0..Z.nrows())
            .map(|dof| {
                let mut value = (0..n_pairs)
                    .map(|pair| Z[(dof, pair)] * lcp.r[pair])
                    .sum::<f64>();
                if let Some(floating) = floating {
                    value += Z[(dof, n_pairs)];
                    value += (0..lcp.a.len())
                        .map(|mode| floating.R[(dof, mode)] * lcp.a[mode])
                        .sum::<f64>();
                }
                value
            })
            .collect()
    }
}

/// `‖K u − F − Gᵀ r‖ / ‖F + Gᵀ r‖`, with K itself (not the pinned one).
fn equation_residual(
    model: &Model,
    columns: &[Vec<(usize, f64)>],
    mu: f64,
    floating: Option<&Floating>,
    lcp: &LcpSolution,
    u: &[f64],
) -> f64 {
    let mut rhs = match floating {
        None => vec![0.0; model.n_dofs()],
        Some(floating) => floating.forces.clone(),
    };
    for (pair, r) in lcp.r.iter().enumerate() {
        for &(dof, value) in &columns[3 * pair] {
            rhs[dof] += value * r;
        }
        for &(dof, value) in &columns[3 * pair + 1] {
            rhs[dof] += value * mu * r;
        }
    }
    let Ku = model.K.mul_vec(u);
    let norm = |v: &[f64]| v.iter().map(|value| value * value).sum::<f64>().sqrt();
    let difference: Vec<f64> = Ku.iter().zip(&rhs).map(|(a, b)| a - b).collect();
    norm(&difference) / norm(&rhs).max(f64::MIN_POSITIVE)
}

fn body_list(bodies: &[floating::FloatingBody]) -> String {
    bodies
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<String>>()
        .join("; ")
}

/// Each body's rigid motions must move its contact pairs along their normals (B_b of full
/// column rank): a motion the contact does not see (a pad spinning about the normal) is
/// held by nothing.
fn check_contact_holds(B: &Mat<f64>, bodies: &[floating::FloatingBody]) -> Result<(), StageError> {
    for body in bodies {
        let modes = body.modes.clone();
        let k = modes.len();
        let gram = Mat::from_fn(k, k, |i, j| {
            (0..B.nrows())
                .map(|pair| B[(pair, modes.start + i)] * B[(pair, modes.start + j)])
                .sum::<f64>()
        });
        let svd = gram.svd().map_err(|err| {
            StageError::new(format!("SVD of the contact motions of {body}: {err:?}"))
        })?;
        let largest = svd.S()[0];
        let smallest = svd.S()[k - 1];
        if !(smallest > 1e-10 * largest) {
            return Err(StageError::new(format!(
                "{body}: its contact pairs do not hold all its free rigid motions (a motion moves none of them along the normal): guide it in-plane (`{PRESSURE_SET}:xy`)"
            )));
        }
    }
    Ok(())
}

/// Support reactions at clamped nodes, summed per node set: the force the supports exert, from
/// the element stiffnesses (which still hold the clamped DOFs; `materials` by part index). With
/// the pads pressed by an interference, the z reactions at the pad backs balance the contact
/// forces.
pub fn back_reactions(
    model: &Model,
    materials: &[Material],
    u: &[f64],
    set: &str,
) -> Result<[f64; 3], StageError> {
    let mesh = &model.mesh;
    let nodes = mesh
        .node_sets
        .get(set)
        .ok_or_else(|| StageError::new(format!("no node set `{set}`")))?;
    let mut in_set = vec![false; mesh.n_nodes()];
    for &node in nodes {
        in_set[node as usize] = true;
    }
    let mut total = [0.0; 3];
    for (hex, part) in mesh.hexes.iter().zip(&mesh.hex_part) {
        if !hex.iter().any(|node| in_set[*node as usize]) {
            continue;
        }
        let material = materials.get(*part as usize).ok_or_else(|| {
            StageError::new(format!(
                "part {part} has no material: {} given",
                materials.len()
            ))
        })?;
        let coords = hex.map(|node| mesh.nodes[node as usize]);
        let element =
            crate::fem::hex8::element_matrices(&coords, &material.elasticity(), material.density)
                .map_err(|degenerate| {
                StageError::new(format!(
                    "degenerate element: det J = {:e}",
                    degenerate.det_j
                ))
            })?;
        let displacement = |dof: usize| {
            model.dof_of_node[hex[dof / 3] as usize][dof % 3].map_or(0.0, |free| u[free as usize])
        };
        for row in 0..24 {
            if !in_set[hex[row / 3] as usize] {
                continue;
            }
            // At a clamped DOF, K u = R + F with F = 0: the row of K times u is the support's
            // reaction R on the structure.
            let internal: f64 = (0..24)
                .map(|col| {
                    element.stiffness[crate::fem::hex8::packed_index(row, col)] * displacement(col)
                })
                .sum();
            total[row % 3] += internal;
        }
    }
    Ok(total)
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
        /// load: pressure — pressure on the pad back faces
        #[unit = "Pa"]
        #[min = 0.0]
        pressure: f64 = 1e6,
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
            LoadKind::Pressure => Load::Pressure(params.pressure),
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
            let part = &model.mesh.parts[model.mesh.hex_part[element] as usize];
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
        let pressure = figure::pressure_figure(&model.mesh, &pressure)?;
        let vtu = Artifact::document("vtu", crate::vtu::equilibrium_vtu(model, &equilibrium)?);
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

/// Strains above this break the small-strain assumption of the linear model.
pub const SMALL_STRAIN: f64 = 0.01;

/// The largest strain component at the element centres, and its element: the compatible part
/// of `u` (the incompatible modes refine it within an element, not its size).
pub fn largest_strain(model: &Model, u: &[f64]) -> (f64, usize) {
    let mesh = &model.mesh;
    let mut largest = (0.0, 0);
    for (element, hex) in mesh.hexes.iter().enumerate() {
        let coords = hex.map(|node| mesh.nodes[node as usize]);
        let displacement = hex.map(|node| {
            model.dof_of_node[node as usize].map(|dof| dof.map_or(0.0, |dof| u[dof as usize]))
        });
        let Some(gradient) = crate::fem::hex8::centre_displacement_gradient(&coords, &displacement)
        else {
            continue;
        };
        let strain = (0..9)
            .map(|ij| 0.5 * (gradient[ij / 3][ij % 3] + gradient[ij % 3][ij / 3]).abs())
            .fold(0.0, f64::max);
        if strain > largest.0 {
            largest = (strain, element);
        }
    }
    largest
}

/// One row per pair: where, how hard, open or closed.
pub fn contact_table(model: &Model, equilibrium: &Equilibrium) -> Table {
    let pairs = &model.mesh.contact_pairs;
    let position = |axis: usize| {
        pairs
            .iter()
            .map(|pair| model.mesh.nodes[pair.disc_node as usize][axis])
            .collect::<Vec<f64>>()
    };
    let r_n = equilibrium.r_n.clone();
    Table::new()
        .with("pair", (0..pairs.len() as i64).collect::<Vec<i64>>())
        .with("x", position(0))
        .with("y", position(1))
        .with("z", position(2))
        .with(
            "side",
            pairs
                .iter()
                .map(|pair| {
                    if pair.normal[2] >= 0.0 {
                        "upper"
                    } else {
                        "lower"
                    }
                    .to_string()
                })
                .collect::<Vec<String>>(),
        )
        .with("r_n", r_n.clone())
        .with(
            "r_t",
            r_n.iter().map(|r| equilibrium.mu * r).collect::<Vec<f64>>(),
        )
        .with("r_b", vec![0.0; pairs.len()])
        .with(
            "pressure",
            r_n.iter()
                .zip(pairs)
                .map(|(r, pair)| r / pair.area)
                .collect::<Vec<f64>>(),
        )
        .with("gap", equilibrium.gap.clone())
        .with("sliding_speed", equilibrium.frames.sliding_speed.clone())
        .with(
            "status",
            equilibrium
                .closed
                .iter()
                .map(|closed| if *closed { "closed" } else { "open" }.to_string())
                .collect::<Vec<String>>(),
        )
}

/// Total normal reaction on the upper (normal +z) or lower pad faces.
pub fn side_force(mesh: &crate::artifact::mesh::Mesh, r_n: &[f64], upper: bool) -> f64 {
    mesh.contact_pairs
        .iter()
        .zip(r_n)
        .filter(|(pair, _)| (pair.normal[2] >= 0.0) == upper)
        .map(|(_, r)| r)
        .sum()
}

/// The figures that say whether the solve is to be trusted, and the resultant forces.
fn summary_table(
    equilibrium: &Equilibrium,
    report: &Report,
    mesh: &crate::artifact::mesh::Mesh,
    max_strain: f64,
) -> Table {
    let total: f64 = equilibrium.r_n.iter().sum();
    let (load, mut quantities) = match (report.load, report.applied) {
        (Load::Pressure(pressure), Some(applied)) => (
            "pressure",
            vec![
                ("pressure_Pa", pressure),
                ("pressure_force_upper_N", applied.force[0]),
                ("pressure_force_lower_N", applied.force[1]),
                ("back_area_upper_m2", applied.area[0]),
                ("back_area_lower_m2", applied.area[1]),
                ("floating_bodies", applied.floating_bodies as f64),
            ],
        ),
        (Load::Pressure(pressure), None) => ("pressure", vec![("pressure_Pa", pressure)]),
        (Load::Interference(delta), _) => ("interference", vec![("interference_m", delta)]),
    };
    quantities.extend([
        ("iterations", report.lcp.iterations as f64),
        ("complementarity_residual", report.lcp.residual()),
        ("equation_residual", report.equation_residual),
        (
            "closed_pairs",
            equilibrium.closed.iter().filter(|closed| **closed).count() as f64,
        ),
        ("pairs", equilibrium.closed.len() as f64),
        (
            "normal_force_upper_N",
            side_force(mesh, &equilibrium.r_n, true),
        ),
        (
            "normal_force_lower_N",
            side_force(mesh, &equilibrium.r_n, false),
        ),
        ("normal_force_total_N", total),
        ("friction_force_total_N", equilibrium.mu * total),
        ("max_strain_estimate", max_strain),
    ]);
    Table::quantities(&quantities)
        .with(
            "solver",
            vec![report.solver.name().to_string(); quantities.len()],
        )
        .with("load", vec![load.to_string(); quantities.len()])
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::artifact::mesh::Mesh;
    use crate::mesh::brake::{BrakeGeometry, brake};
    use crate::mesh::structured::stacked_blocks;
    use crate::stage::Value;

    fn coarse_brake() -> Mesh {
        brake(&BrakeGeometry::coarse()).unwrap()
    }

    #[test]
    fn the_strain_estimate_is_exact_for_a_homogeneous_strain() {
        // A distorted block under u = (a x + b y, c z, 0): ε_xx = a, ε_xy = b/2, ε_yz = c/2.
        let mut mesh = crate::mesh::structured::block([1.0, 0.5, 0.3], [3, 2, 2], "disc");
        for node in &mut mesh.nodes {
            node[0] += 0.1 * node[1] * node[2];
        }
        let (model, _) = crate::assemble::test_model(&mesh, "", &[]);
        let (a, b, c) = (1e-3, -6e-3, 4e-3);
        let mut u = vec![0.0; model.n_dofs()];
        for (node, dofs) in model.dof_of_node.iter().enumerate() {
            let [x, y, z] = mesh.nodes[node];
            for (axis, value) in [a * x + b * y, c * z, 0.0].into_iter().enumerate() {
                u[dofs[axis].unwrap() as usize] = value;
            }
        }
        let (strain, _) = largest_strain(&model, &u);
        assert!((strain - 3e-3).abs() < 1e-15, "{strain}");
    }

    /// `assemble` with default materials (optionally overridden) and `clamped`.
    fn model(mesh: &Mesh, clamped: &str, overrides: &[(&str, f64)]) -> Model {
        crate::assemble::test_model(mesh, clamped, overrides).0
    }

    fn settings() -> LcpSettings {
        LcpSettings::default()
    }

    #[test]
    fn contact_forces_balance_the_support_reactions_of_each_pad() {
        let mesh = coarse_brake();
        let (model, params) = crate::assemble::test_model(&mesh, "hub, pad_backs", &[]);
        let materials: Vec<Material> = (model.mesh.parts.iter())
            .map(|part| params.material(part).unwrap())
            .collect();
        let (equilibrium, report) = solve(
            &model,
            0.38,
            4.0,
            Load::Interference(5e-5),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        let side = |upper: bool| side_force(&mesh, &equilibrium.r_n, upper);
        let upper_back =
            back_reactions(&model, &materials, &equilibrium.u, "pad_backs_upper").unwrap();
        let lower_back =
            back_reactions(&model, &materials, &equilibrium.u, "pad_backs_lower").unwrap();
        // Each pad: contact pushes it away from the disc, its back support pushes it back.
        assert!(
            (upper_back[2] + side(true)).abs() <= 1e-10 * side(true),
            "{upper_back:?} vs {}",
            side(true)
        );
        assert!(
            (lower_back[2] - side(false)).abs() <= 1e-10 * side(false),
            "{lower_back:?} vs {}",
            side(false)
        );
        // Friction μ Σr_n along the sliding directions is carried by the backs too.
        let friction: [f64; 3] = std::array::from_fn(|axis| {
            equilibrium
                .r_n
                .iter()
                .zip(&equilibrium.frames.t)
                .zip(&mesh.contact_pairs)
                .filter(|(_, pair)| pair.normal[2] > 0.0)
                .map(|((r, t), _)| 0.38 * r * t[axis])
                .sum()
        });
        for axis in 0..2 {
            assert!(
                (upper_back[axis] + friction[axis]).abs() <= 1e-9 * side(true),
                "axis {axis}: {upper_back:?} vs {friction:?}"
            );
        }
        assert!(
            report.equation_residual <= 1e-10,
            "{}",
            report.equation_residual
        );
        assert!(report.lcp.residual() <= 1e-10);
        for (r, g) in equilibrium.r_n.iter().zip(&equilibrium.gap) {
            assert!(*r >= 0.0);
            assert!(*g >= -1e-12 * 5e-5, "penetration {g}");
        }
        assert!(equilibrium.closed.iter().any(|closed| *closed));
    }

    #[test]
    fn without_friction_both_pads_carry_the_same_load() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs", &[]);
        let (equilibrium, _) = solve(
            &model,
            0.0,
            4.0,
            Load::Interference(5e-5),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        let side = |upper: bool| side_force(&mesh, &equilibrium.r_n, upper);
        let (upper, lower) = (side(true), side(false));
        assert!(upper > 0.0);
        assert!(
            (upper - lower).abs() <= 1e-8 * upper,
            "upper {upper} lower {lower}"
        );
        // With friction the symmetry breaks: the drag tilts the pads.
        let (with_friction, _) = solve(
            &model,
            0.38,
            4.0,
            Load::Interference(5e-5),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        assert_ne!(with_friction.r_n, equilibrium.r_n);
    }

    #[test]
    fn fixed_point_and_newton_agree() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs", &[]);
        let load = 5e-5;
        let (newton, newton_report) = solve(
            &model,
            0.38,
            4.0,
            Load::Interference(load),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        let relaxed = LcpSettings {
            relaxation: 0.5,
            max_iterations: 100_000,
            ..settings()
        };
        let (fixed, fixed_report) = solve(
            &model,
            0.38,
            4.0,
            Load::Interference(load),
            Solver::FixedPoint,
            &relaxed,
        )
        .unwrap();
        let largest = newton.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
        for (a, b) in newton.r_n.iter().zip(&fixed.r_n) {
            assert!((a - b).abs() <= 1e-8 * largest, "{a} vs {b}");
        }
        assert!(newton_report.lcp.iterations < fixed_report.lcp.iterations);
    }

    #[test]
    fn unsupported_pads_are_an_error() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub", &[]);
        let err = solve(
            &model,
            0.38,
            4.0,
            Load::Interference(5e-5),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap_err();
        assert!(
            err.message.contains("not positive definite") || err.message.contains("unstable"),
            "{}",
            err.message
        );
    }

    const PRESSURE: f64 = 1e6;

    /// The coarse brake guided in-plane at its backs, pressed by `PRESSURE`.
    fn pressed(
        model: &Model,
        mu: f64,
        solver: Solver,
        settings: &LcpSettings,
    ) -> (Equilibrium, Report) {
        solve(model, mu, 4.0, Load::Pressure(PRESSURE), solver, settings).unwrap()
    }

    /// Contact area per side from the mesh's tributary areas: a puck is a prism, so its back
    /// has the area of its friction face.
    fn pad_area(mesh: &Mesh, upper: bool) -> f64 {
        mesh.contact_pairs
            .iter()
            .filter(|pair| (pair.normal[2] >= 0.0) == upper)
            .map(|pair| pair.area)
            .sum()
    }

    #[test]
    fn under_a_pressure_each_pad_carries_the_pressure_times_its_back_area() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs:xy", &[]);
        let mu = 0.38;
        let (equilibrium, report) = pressed(&model, mu, Solver::SemismoothNewton, &settings());
        let applied = report.applied.unwrap();
        // 2 pucks per pad, each free to translate along z and tilt about x and y.
        assert_eq!(applied.floating_bodies, 4);
        assert_eq!(report.lcp.a.len(), 12);
        for (side, upper) in [(0, true), (1, false)] {
            let expected = PRESSURE * pad_area(&mesh, upper);
            let contact = side_force(&mesh, &equilibrium.r_n, upper);
            eprintln!(
                "side {side}: contact {contact:.12e} N, p A {expected:.12e} N, relative {:.2e}",
                (contact - expected).abs() / expected
            );
            assert!((contact - expected).abs() <= 1e-10 * expected);
            assert!((applied.force[side] - expected).abs() <= 1e-12 * expected);
            assert!((applied.area[side] - pad_area(&mesh, upper)).abs() <= 1e-14);
        }
        // The contact forces, read back from K u − F at the pad nodes: normal r_n, along the
        // sliding direction μ r_n, none across it.
        let load = floating::pressure_load(&model, PRESSURE, PRESSURE_SET).unwrap();
        let Ku = model.K.mul_vec(&equilibrium.u);
        let largest = equilibrium.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
        let mut worst_ratio = 0.0f64;
        for (pair_idx, pair) in mesh.contact_pairs.iter().enumerate() {
            let dofs = model.dof_of_node[pair.pad_node as usize];
            let force: [f64; 3] = std::array::from_fn(|axis| {
                dofs[axis].map_or(0.0, |dof| Ku[dof as usize] - load.forces[dof as usize])
            });
            let along = |direction: [f64; 3]| crate::artifact::mesh::dot(force, direction);
            let r_n = equilibrium.r_n[pair_idx];
            assert!((along(equilibrium.frames.n[pair_idx]) - r_n).abs() <= 1e-9 * largest);
            let coulomb = (along(equilibrium.frames.t[pair_idx]) - mu * r_n).abs() / largest;
            worst_ratio = worst_ratio.max(coulomb);
            assert!(along(equilibrium.frames.b[pair_idx]).abs() <= 1e-9 * largest);
        }
        eprintln!(
            "|r_t - mu r_n| / max r_n = {worst_ratio:.2e}, equation residual {:.2e}, complementarity {:.2e}, {} iterations",
            report.equation_residual,
            report.lcp.residual(),
            report.lcp.iterations
        );
        assert!(worst_ratio <= 1e-9);
        assert!(
            report.equation_residual <= 1e-10,
            "{}",
            report.equation_residual
        );
        assert!(report.lcp.residual() <= 1e-10);
        // Penetration within roundoff of the displacements.
        let displacement = equilibrium.u.iter().fold(0.0f64, |max, u| max.max(u.abs()));
        let deepest = equilibrium.gap.iter().fold(0.0f64, |min, g| min.min(*g));
        eprintln!("deepest penetration {deepest:.2e} m, largest displacement {displacement:.2e} m");
        assert!(deepest >= -1e-10 * displacement, "penetration {deepest}");
        assert!(equilibrium.r_n.iter().all(|r| *r >= 0.0));
        assert!(equilibrium.closed.iter().any(|closed| *closed));
    }

    #[test]
    fn without_friction_under_a_pressure_the_pads_are_mirror_images() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs:xy", &[]);
        let (equilibrium, _) = pressed(&model, 0.0, Solver::SemismoothNewton, &settings());
        let largest = equilibrium.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
        let position =
            |pair: &crate::artifact::mesh::ContactPair| mesh.nodes[pair.disc_node as usize];
        let mut worst = 0.0f64;
        for (upper_idx, upper) in mesh.contact_pairs.iter().enumerate() {
            if upper.normal[2] < 0.0 {
                continue;
            }
            let x = position(upper);
            let lower_idx = mesh
                .contact_pairs
                .iter()
                .position(|pair| {
                    pair.normal[2] < 0.0 && position(pair)[0] == x[0] && position(pair)[1] == x[1]
                })
                .expect("every upper pair has a mirror");
            worst = worst
                .max((equilibrium.r_n[upper_idx] - equilibrium.r_n[lower_idx]).abs() / largest);
        }
        eprintln!("mirror asymmetry of r_n: {worst:.2e} of the largest");
        assert!(worst <= 1e-8);
        assert!(
            (side_force(&mesh, &equilibrium.r_n, true)
                - side_force(&mesh, &equilibrium.r_n, false))
            .abs()
                <= 1e-10 * side_force(&mesh, &equilibrium.r_n, true)
        );
    }

    #[test]
    fn fixed_point_and_newton_agree_under_a_pressure() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs:xy", &[]);
        let (newton, newton_report) = pressed(&model, 0.38, Solver::SemismoothNewton, &settings());
        let relaxed = LcpSettings {
            relaxation: 0.5,
            max_iterations: 100_000,
            ..settings()
        };
        let (fixed, fixed_report) = pressed(&model, 0.38, Solver::FixedPoint, &relaxed);
        let largest = newton.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
        let worst = newton
            .r_n
            .iter()
            .zip(&fixed.r_n)
            .map(|(a, b)| (a - b).abs() / largest)
            .fold(0.0, f64::max);
        eprintln!(
            "newton {} iterations, fixed point {} iterations, |r_newton - r_fixed| / max r = {worst:.2e}",
            newton_report.lcp.iterations, fixed_report.lcp.iterations
        );
        assert!(worst <= 1e-8);
        assert!(newton_report.lcp.iterations < fixed_report.lcp.iterations);
    }

    /// Two blocks, the pad pressed by p on its back and guided in-plane, ν = 0: the stress is
    /// −p everywhere, so the contact pressure is p and each block shortens by p L / E.
    #[test]
    fn two_blocks_pressed_by_a_pressure_match_the_uniaxial_solution() {
        let (width, l_disc, l_pad) = (0.02, 0.03, 0.01);
        let mesh = stacked_blocks(width, l_disc, l_pad);
        let (e_disc, e_pad) = (2.0e11, 3.0e8);
        let model = model(
            &mesh,
            "base, pad_backs:xy",
            &[
                ("nu_disc", 0.0),
                ("nu_pad", 0.0),
                ("E_disc", e_disc),
                ("E_pad", e_pad),
            ],
        );
        let pressure = 2e6;
        // Jacobi on a pad whose pairs all move together needs the damped step; it converges
        // linearly, so a tighter residual for the 1e-9 check.
        let relaxed = LcpSettings {
            relaxation: 0.5,
            max_iterations: 100_000,
            tolerance: 1e-13,
        };
        for (solver, settings) in [
            (Solver::SemismoothNewton, settings()),
            (Solver::FixedPoint, relaxed),
        ] {
            let (equilibrium, report) = solve(
                &model,
                0.0,
                4.0,
                Load::Pressure(pressure),
                solver,
                &settings,
            )
            .unwrap();
            let mut worst_pressure = 0.0f64;
            for (r, pair) in equilibrium.r_n.iter().zip(&mesh.contact_pairs) {
                worst_pressure = worst_pressure.max((r / pair.area - pressure).abs() / pressure);
            }
            let u_z =
                |node: u32| equilibrium.u[model.dof_of_node[node as usize][2].unwrap() as usize];
            let disc_top = -pressure * l_disc / e_disc;
            let back = disc_top - pressure * l_pad / e_pad;
            let mut worst_displacement = 0.0f64;
            for pair in &mesh.contact_pairs {
                worst_displacement =
                    worst_displacement.max((u_z(pair.disc_node) - disc_top).abs() / disc_top.abs());
            }
            for &node in &mesh.node_sets[PRESSURE_SET] {
                worst_displacement = worst_displacement.max((u_z(node) - back).abs() / back.abs());
            }
            eprintln!(
                "{solver:?}: contact pressure error {worst_pressure:.2e}, displacement error {worst_displacement:.2e}, {} iterations",
                report.lcp.iterations
            );
            assert!(worst_pressure <= 1e-9);
            assert!(worst_displacement <= 1e-9);
        }
    }

    #[test]
    fn a_pressure_on_fully_clamped_backs_is_an_error() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs", &[]);
        let err = solve(
            &model,
            0.38,
            4.0,
            Load::Pressure(PRESSURE),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap_err();
        assert!(err.message.contains("pad_backs:xy"), "{}", err.message);
        // Backs held along z only where the pressure acts, but a puck left floating in-plane.
        let model = model_with_pucks_free_in_plane(&mesh);
        let err = solve(
            &model,
            0.38,
            4.0,
            Load::Pressure(PRESSURE),
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap_err();
        assert!(err.message.contains("pad_backs:xy"), "{}", err.message);
    }

    /// Backs clamped along z only: the pressure falls on the supports.
    fn model_with_pucks_free_in_plane(mesh: &Mesh) -> Model {
        model(mesh, "hub, pad_backs:z", &[])
    }

    #[test]
    fn a_nonconverging_solver_under_a_pressure_reports_its_residual_history() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs:xy", &[]);
        let few = LcpSettings {
            max_iterations: 3,
            relaxation: 0.5,
            ..settings()
        };
        let err = solve(
            &model,
            0.38,
            4.0,
            Load::Pressure(PRESSURE),
            Solver::FixedPoint,
            &few,
        )
        .unwrap_err();
        assert!(
            err.message
                .starts_with("fixed point did not converge in 3 iterations"),
            "{}",
            err.message
        );
        assert!(err.message.contains("last residuals:"), "{}", err.message);
    }

    /// The engine keys downstream stages by output bytes: the equilibrium must not depend on
    /// how many threads computed it, under either load.
    #[test]
    fn equilibrium_results_do_not_depend_on_the_thread_count() {
        use crate::stage::Input;
        use std::sync::Arc;
        squeal_linalg::fix_global_parallelism();
        let mesh = coarse_brake();
        for (clamped, load) in [
            ("hub, pad_backs", "interference"),
            ("hub, pad_backs:xy", "pressure"),
        ] {
            let model = model(&mesh, clamped, &[]);
            let params =
                Params::defaults(&SlidingEquilibrium, &[("load", Value::Str(load.into()))]);
            let inputs = Inputs(BTreeMap::from([(
                "model".to_string(),
                Input::One(Arc::new(Artifact::Model(Box::new(model)))),
            )]));
            crate::stage::assert_outputs_independent_of_threads(
                &SlidingEquilibrium,
                &params,
                &inputs,
                load,
            );
        }
    }

    /// The stage itself with `load: pressure` (the two lines a study adds: `clamped: "hub,
    /// pad_backs:xy"` on `assemble`, `load: pressure` on `equilibrium`).
    #[test]
    fn the_stage_runs_with_a_pressure_load() {
        use crate::stage::Input;
        use std::sync::Arc;
        let mesh = coarse_brake();
        let model = model(&mesh, "hub, pad_backs:xy", &[]);
        let params = Params::defaults(
            &SlidingEquilibrium,
            &[
                ("load", Value::Str("pressure".into())),
                ("pressure", Value::Float(2e6)),
            ],
        );
        let inputs = Inputs(BTreeMap::from([(
            "model".to_string(),
            Input::One(Arc::new(Artifact::Model(Box::new(model)))),
        )]));
        let outputs = SlidingEquilibrium.run(&params, &inputs).unwrap();
        let summary = outputs["summary"].as_table().unwrap();
        let Some(crate::table::ColumnData::Str(names)) = summary.column("quantity") else {
            panic!("no quantity column")
        };
        let Some(crate::table::ColumnData::F64(values)) = summary.column("value") else {
            panic!("no value column")
        };
        let value = |name: &str| values[names.iter().position(|n| n == name).unwrap()];
        assert_eq!(value("pressure_Pa"), 2e6);
        for side in ["upper", "lower"] {
            let applied = value(&format!("pressure_force_{side}_N"));
            let contact = value(&format!("normal_force_{side}_N"));
            assert!(
                (applied - contact).abs() <= 1e-10 * applied,
                "{side}: {applied} vs {contact}"
            );
            assert!(
                (applied - 2e6 * value(&format!("back_area_{side}_m2"))).abs() <= 1e-12 * applied
            );
        }
        assert_eq!(value("floating_bodies"), 4.0);
        let Some(crate::table::ColumnData::Str(load)) = summary.column("load") else {
            panic!("no load column")
        };
        assert!(load.iter().all(|load| load == "pressure"));
        assert!(matches!(outputs["equilibrium"], Artifact::Equilibrium(_)));
    }
}
