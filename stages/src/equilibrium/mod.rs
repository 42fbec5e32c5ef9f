//! `equilibrium`: the static sliding equilibrium of the brake (DESIGN §3.3).
//!
//! Find (u, r) with K u = F + Hᵀ r, every closed pair sliding (r_t = μ r_n, r_b = 0) and
//! Signorini's conditions on the normal gaps (conventions in [`crate::contact`]).
//! K is factorised once (sparse LDLᵀ, nested-dissection ordering). With
//! Z = K⁻¹ (H_n + μ H_t)ᵀ (one solve per pair) the normal gaps are
//!
//! ```text
//! g = q + A r_n,   A = H_n Z,   q = g₀ − δ
//! ```
//!
//! a small dense linear complementarity problem ([`crate::contact::lcp`]), solved by the
//! seed's fixed point or by semi-smooth Newton (the default: a few iterations where the fixed
//! point needs hundreds). Then u = K⁻¹ F + Z r_n.
//!
//! Load: the clamped pad backs are pushed toward the disc by an interference δ. A rigid
//! translation of a pad stores no energy, so this is exactly an initial gap g₀ − δ on every
//! pair with the backs held in place (F = 0); the displacement reported excludes the
//! translation. The load the pads then carry is the sum of the support reactions at their
//! backs, which [`back_reactions`] recovers from the element stiffnesses as a balance check.

mod figure;

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
    /// ‖K u − Hᵀ r‖ / ‖Hᵀ r‖ of the returned state.
    pub equation_residual: f64,
    /// Wall time (s) of the factorisation of K, of the condensation (solves and A = H_n Z),
    /// and of the contact iterations. For benchmarks only: never part of an output.
    pub seconds: [f64; 3],
}

/// Solves the sliding equilibrium of `model`.
pub fn solve(
    model: &Model,
    mu: f64,
    omega: f64,
    interference: f64,
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

    let clock = std::time::Instant::now();
    let pencil = ShiftedPencil::new(&model.K, &model.M, &model.dof_of_node)?;
    let factor = pencil.factor(0.0, Par::rayon(0))?;
    if factor.negative_pivots > 0 {
        return Err(StageError::new(format!(
            "K is not positive definite ({} negative pivots): a part is not supported — clamp the hub and the pad backs",
            factor.negative_pivots
        )));
    }
    let factor_seconds = clock.elapsed().as_secs_f64();
    let clock = std::time::Instant::now();
    let normal = |pair: usize| &columns[3 * pair];
    let tangent = |pair: usize| &columns[3 * pair + 1];

    // Z = K⁻¹ (H_n + μ H_t)ᵀ, one column per pair.
    let mut Z = Mat::<f64>::zeros(n, n_pairs);
    for pair in 0..n_pairs {
        for &(dof, value) in normal(pair) {
            Z[(dof, pair)] += value;
        }
        for &(dof, value) in tangent(pair) {
            Z[(dof, pair)] += mu * value;
        }
    }
    factor.solve_in_place(Z.as_mut(), Par::rayon(0));
    let apply_normal = |pair: usize, col: usize| {
        normal(pair)
            .iter()
            .map(|&(dof, value)| value * Z[(dof, col)])
            .sum::<f64>()
    };
    let A = Mat::from_fn(n_pairs, n_pairs, apply_normal);
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
            g0 - interference
        })
        .collect();

    let condense_seconds = clock.elapsed().as_secs_f64();
    let clock = std::time::Instant::now();
    let lcp = match solver {
        Solver::FixedPoint => lcp::fixed_point(&A, &q, settings),
        Solver::SemismoothNewton => lcp::semismooth_newton(&A, &q, settings),
    }
    .map_err(|err| StageError::new(err.to_string()))?;
    let iterate_seconds = clock.elapsed().as_secs_f64();

    let u: Vec<f64> = (0..n)
        .map(|dof| {
            (0..n_pairs)
                .map(|pair| Z[(dof, pair)] * lcp.r[pair])
                .sum::<f64>()
        })
        .collect();
    // Check the equation itself: K u = Hᵀ r.
    let mut rhs = vec![0.0; n];
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
            lcp,
            equation_residual,
            seconds,
        },
    ))
}

/// Support reactions at clamped nodes, summed per node set: the force the supports exert,
/// from the element stiffnesses (which still hold the clamped DOFs). With the pads pressed by
/// an interference, the z reactions at the pad backs balance the contact forces.
pub fn back_reactions(
    model: &Model,
    params: &Params,
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
        let material =
            crate::assemble::material::Material::from_params(params, &mesh.parts[*part as usize])?;
        let coords = hex.map(|node| mesh.nodes[node as usize]);
        let element = crate::assemble::hex8::element_matrices(
            &coords,
            &material.elasticity(),
            material.density,
        )
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
                    element.stiffness[crate::assemble::hex8::packed_index(row, col)]
                        * displacement(col)
                })
                .sum();
            total[row % 3] += internal;
        }
    }
    Ok(total)
}

/// The `equilibrium` stage.
pub struct SlidingEquilibrium;

impl Stage for SlidingEquilibrium {
    fn kind(&self) -> &'static str {
        "equilibrium"
    }
    fn version(&self) -> u32 {
        2
    }
    fn doc(&self) -> &'static str {
        "Static sliding equilibrium: Signorini contact with Coulomb friction at constant mu"
    }
    fn params(&self) -> Vec<ParamSpec> {
        let defaults = LcpSettings::default();
        vec![
            ParamSpec::float("mu", 0.38, "", "friction coefficient").at_least(0.0),
            ParamSpec::float(
                "omega",
                4.0,
                "rad/s",
                "disc speed (sets the sliding directions)",
            ),
            ParamSpec::float(
                "interference",
                1e-4,
                "m",
                "pad backs pushed toward the disc by this",
            )
            .at_least(0.0),
            ParamSpec::choice(
                "solver",
                &["newton", "fixed_point"],
                "newton",
                "semi-smooth Newton, or the seed's fixed point",
            ),
            ParamSpec::float(
                "tolerance",
                defaults.tolerance,
                "",
                "complementarity residual to reach",
            )
            .at_least(0.0),
            ParamSpec::int(
                "max_iterations",
                defaults.max_iterations as i64,
                "iteration limit",
            )
            .at_least(1.0),
            ParamSpec::float(
                "relaxation",
                defaults.relaxation,
                "",
                "fixed point: rho_i = relaxation / A_ii",
            )
            .at_least(0.0),
        ]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "model",
            ArtifactType::Model,
            "the assembled brake, with contact pairs",
        )]
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
                "solver, iterations, residuals, total forces",
            ),
            PortSpec::one(
                "vtu",
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
        let Artifact::Model(model) = inputs.one("model")? else {
            return Err(StageError::new("input `model` is not a model"));
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
        let (equilibrium, report) = solve(
            model,
            params.float("mu"),
            params.float("omega"),
            params.float("interference"),
            solver,
            &settings,
        )?;
        let contact = contact_table(model, &equilibrium);
        let summary = summary_table(&equilibrium, &report, &model.mesh);
        let pressure: Vec<f64> = equilibrium
            .r_n
            .iter()
            .zip(&model.mesh.contact_pairs)
            .map(|(r, pair)| r / pair.area)
            .collect();
        let pressure = figure::pressure_figure(&model.mesh, &pressure)?;
        let vtu = crate::export::document(
            "vtu",
            crate::export::vtu::equilibrium_vtu(model, &equilibrium)?,
        );
        Ok(Outputs::from([
            (
                "equilibrium".to_string(),
                Artifact::Equilibrium(Box::new(equilibrium)),
            ),
            ("contact".to_string(), Artifact::Table(contact)),
            ("summary".to_string(), Artifact::Table(summary)),
            ("vtu".to_string(), vtu),
            ("pressure".to_string(), Artifact::Figure(pressure)),
        ]))
    }
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
pub fn side_force(mesh: &crate::mesh::Mesh, r_n: &[f64], upper: bool) -> f64 {
    mesh.contact_pairs
        .iter()
        .zip(r_n)
        .filter(|(pair, _)| (pair.normal[2] >= 0.0) == upper)
        .map(|(_, r)| r)
        .sum()
}

/// The figures that say whether the solve is to be trusted, and the resultant forces.
fn summary_table(equilibrium: &Equilibrium, report: &Report, mesh: &crate::mesh::Mesh) -> Table {
    let total: f64 = equilibrium.r_n.iter().sum();
    let quantities = [
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
    ];
    let solver = match report.solver {
        Solver::FixedPoint => "fixed_point",
        Solver::SemismoothNewton => "newton",
    };
    Table::new()
        .with(
            "quantity",
            quantities
                .iter()
                .map(|(name, _)| name.to_string())
                .collect::<Vec<String>>(),
        )
        .with(
            "value",
            quantities
                .iter()
                .map(|(_, value)| *value)
                .collect::<Vec<f64>>(),
        )
        .with("solver", vec![solver.to_string(); quantities.len()])
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::assemble::assemble_model;
    use crate::mesh::brake::{BrakeGeometry, brake};
    use crate::mesh::structured::block;
    use crate::mesh::{ContactPair, Mesh};
    use crate::stage::Value;

    fn coarse_brake() -> Mesh {
        brake(&BrakeGeometry::coarse()).unwrap()
    }

    /// `assemble` with default materials (optionally overridden) and `clamped`.
    fn model(mesh: &Mesh, clamped: &str, overrides: &[(&str, f64)]) -> Model {
        model_and_params(mesh, clamped, overrides).0
    }

    fn model_and_params(mesh: &Mesh, clamped: &str, overrides: &[(&str, f64)]) -> (Model, Params) {
        let assemble = crate::assemble::Assemble;
        let mut values: BTreeMap<String, Value> = assemble
            .params()
            .into_iter()
            .map(|spec| {
                (
                    spec.name.to_string(),
                    spec.default.expect("assemble has defaults"),
                )
            })
            .collect();
        for (name, value) in overrides {
            values.insert(name.to_string(), Value::Float(*value));
        }
        let clamped: Vec<String> = clamped
            .split(',')
            .map(|name| name.trim().to_string())
            .filter(|name| !name.is_empty())
            .collect();
        let params = Params(values);
        (assemble_model(mesh, &params, &clamped).unwrap().0, params)
    }

    fn settings() -> LcpSettings {
        LcpSettings::default()
    }

    #[test]
    fn contact_forces_balance_the_support_reactions_of_each_pad() {
        let mesh = coarse_brake();
        let (model, params) = model_and_params(&mesh, "hub, pad_backs", &[]);
        let (equilibrium, report) = solve(
            &model,
            0.38,
            4.0,
            5e-5,
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        let side = |upper: bool| side_force(&mesh, &equilibrium.r_n, upper);
        let upper_back =
            back_reactions(&model, &params, &equilibrium.u, "pad_backs_upper").unwrap();
        let lower_back =
            back_reactions(&model, &params, &equilibrium.u, "pad_backs_lower").unwrap();
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
            5e-5,
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
            5e-5,
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
            load,
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        let relaxed = LcpSettings {
            relaxation: 0.5,
            max_iterations: 100_000,
            ..settings()
        };
        let (fixed, fixed_report) =
            solve(&model, 0.38, 4.0, load, Solver::FixedPoint, &relaxed).unwrap();
        let largest = newton.r_n.iter().fold(0.0f64, |max, r| max.max(*r));
        for (a, b) in newton.r_n.iter().zip(&fixed.r_n) {
            assert!((a - b).abs() <= 1e-8 * largest, "{a} vs {b}");
        }
        assert!(newton_report.lcp.iterations < fixed_report.lcp.iterations);
    }

    /// Two blocks in series, pressed by an interference, with ν = 0 so that the stress is
    /// uniaxial: F = δ / (L₁/(E₁A) + L₂/(E₂A)).
    #[test]
    fn two_bars_in_contact_match_the_series_spring_formula() {
        let (width, l_disc, l_pad) = (0.02, 0.03, 0.01);
        let mut disc = block([width, width, l_disc], [2, 2, 3], "disc");
        let pad = block([width, width, l_pad], [2, 2, 2], "pad");
        // Move the pair away from the rotation axis (for a sliding direction) and stack them.
        let offset = 1.0;
        for node in &mut disc.nodes {
            node[0] += offset;
        }
        let n_disc = disc.nodes.len() as u32;
        disc.nodes.extend(
            pad.nodes
                .iter()
                .map(|p| [p[0] + offset, p[1], p[2] + l_disc]),
        );
        disc.hexes
            .extend(pad.hexes.iter().map(|hex| hex.map(|node| node + n_disc)));
        disc.hex_part.extend(vec![1; pad.hexes.len()]);
        disc.parts.push("pad".into());
        let top = disc.node_sets["z1"].clone();
        let pad_bottom: Vec<u32> = pad.node_sets["z0"]
            .iter()
            .map(|node| node + n_disc)
            .collect();
        let cell = width / 2.0;
        for (&disc_node, &pad_node) in top.iter().zip(&pad_bottom) {
            let x = disc.nodes[disc_node as usize];
            let corners = |c: f64| {
                if (c - offset).abs() < 1e-12
                    || (c - offset - width).abs() < 1e-12
                    || c.abs() < 1e-12
                    || (c - width).abs() < 1e-12
                {
                    0.5
                } else {
                    1.0
                }
            };
            let area = cell * cell * corners(x[0]) * corners(x[1]);
            disc.contact_pairs.push(ContactPair {
                disc_node,
                pad_node,
                normal: [0.0, 0.0, 1.0],
                area,
            });
        }
        let pad_top: Vec<u32> = pad.node_sets["z1"]
            .iter()
            .map(|node| node + n_disc)
            .collect();
        let disc_bottom = disc.node_sets["z0"].clone();
        disc.node_sets = BTreeMap::from([
            ("base".to_string(), disc_bottom),
            ("pad_back".to_string(), pad_top),
        ]);
        let (e_disc, e_pad) = (2.0e11, 3.0e8);
        let model = model(
            &disc,
            "base, pad_back",
            &[
                ("nu_disc", 0.0),
                ("nu_pad", 0.0),
                ("E_disc", e_disc),
                ("E_pad", e_pad),
            ],
        );
        let delta = 1e-5;
        let (equilibrium, _) = solve(
            &model,
            0.0,
            4.0,
            delta,
            Solver::SemismoothNewton,
            &settings(),
        )
        .unwrap();
        let area = width * width;
        let expected = delta / (l_disc / (e_disc * area) + l_pad / (e_pad * area));
        let total: f64 = equilibrium.r_n.iter().sum();
        assert!(
            (total - expected).abs() <= 1e-9 * expected,
            "{total} vs {expected}"
        );
        // Uniform pressure: every pair carries its tributary share.
        for (r, pair) in equilibrium.r_n.iter().zip(&disc.contact_pairs) {
            assert!((r / pair.area - expected / area).abs() <= 1e-8 * expected / area);
        }
    }

    #[test]
    fn unsupported_pads_are_an_error() {
        let mesh = coarse_brake();
        let model = model(&mesh, "hub", &[]);
        let err = solve(
            &model,
            0.38,
            4.0,
            5e-5,
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
}
