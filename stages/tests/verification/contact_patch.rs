//! The contact patch test of non-matching (mortar) contact: two blocks pressed together
//! through an interface meshed independently on each side must carry a uniform pressure and a
//! uniform stress to round-off, whatever the element kinds and whichever side is finer.
//!
//! # The problem
//!
//! A `disc` block [X₀, X₀ + W] × [0, W] × [0, H_d] under a `pad` block of the same footprint on
//! [H_d, H_d + H_p], each with its own nodes at the interface, their faces non-matching
//! (hexahedra of 3 × 3 cells against 4 × 4, 10-node tetrahedra against hexahedra, 20-node
//! hexahedra against 10-node tetrahedra, each both ways round). The pairs are
//! [`mortar_pairs`] of the pad's bottom against the disc's top. X₀ = 1 m puts the blocks off
//! the z axis so that the disc's rotation gives every pair a sliding direction.
//!
//! Frictionless (μ = 0), a pressure p on the pad's top ([`Load::Pressure`]), the disc's bottom
//! on rollers (u_z = 0), and each body held in-plane by the least that removes its in-plane
//! rigid motions: the corner at (X₀, 0) of the disc's bottom and of the pad's top pinned in x
//! and y, the corner at (X₀ + W, 0) in y. The pad's normal translation and tilts are left to
//! the pressure load, which balances them by the contact.
//!
//! # The exact solution
//!
//! Both bodies free to expand laterally and no friction between them: the uniaxial stress
//! σ_zz = −p, every other component zero, in both bodies, whatever their moduli and Poisson
//! ratios (lateral strains differ across the interface, which slides freely). With (E, ν) of
//! each body and z_b its base (0 for the disc, H_d for the pad):
//!
//! ```text
//! u_x = ν p (x − X₀) / E     u_y = ν p y / E     u_z = u_b − p (z − z_b) / E
//! u_b = 0 (disc),  −p H_d / E_disc (pad)
//! ```
//!
//! The field is affine in each body, which every element kind reproduces exactly (the element
//! patch test, `patch_test.rs`); the mortar pairs load both faces of the interface with the
//! consistent nodal forces of a uniform pressure (`fem::mortar`, "Rows"), so that the discrete
//! solution is the exact one to round-off: every pair's pressure r_n / area is p, every node
//! sits on the field, the stress at every integration point is −p e_z ⊗ e_z, the pad's total
//! normal force is p W². A pairing that is not consistent (each pad node to its nearest disc
//! node) fails the same measures by orders of magnitude.
//!
//! # Friction
//!
//! The sliding equilibrium sets every closed pair sliding, r_t = μ r_n along the disc's motion
//! e_z × x at the pair; it does not model a tangential load below μ p with sticking, so there
//! is no frictional patch test of a uniform state to run. The drag D = μ Σ r_n t (≈ μ p W²)
//! acts at the interface and is held at the pad's back (guided in-plane), H_p above: its moment
//! tilts the pad, and the contact pressure is far from uniform (0.16 p to 1.45 p at μ = 0.2; the
//! direction of sliding, which turns by W / X₀ across the block, matters much less). Statics
//! about the centre c of the back, where neither the pressure nor the guides have a moment
//! about in-plane axes, fix the pressure's first moments instead:
//!
//! ```text
//! Σ r_n = p W²        Σ r_n (x_p − c) = −H_p D   (in-plane components)
//! ```
//!
//! Checked to round-off, with these: every pair closed and sliding along e_z × x, the forces
//! the elements exert (K u − F, from the stiffness alone) those of the pairs, r_n (n + μ t)
//! spread by their weights, and each body's supports holding the forces the other exerts
//! through the non-matching interface (the disc's base (D, p W²), the pad's guides −D).

use std::collections::BTreeMap;

use faer::Mat;
use faer::linalg::solvers::Solve;
use serde::Deserialize;
use squeal_stages::artifact::mesh::ContactPair;
use squeal_stages::artifact::{ElementKind, Equilibrium, Mesh, Model};
use squeal_stages::assemble::{AssembleParams, with_default_materials};
use squeal_stages::contact::lcp::LcpSettings;
use squeal_stages::equilibrium::floating::pressure_load;
use squeal_stages::equilibrium::{Load, PressureOn, Solver, back_reactions, solve};
use squeal_stages::fem::element::{self, hex8, quadrature, shapes};
use squeal_stages::fem::faces::Side;
use squeal_stages::mesh::convert::as_kind;
use squeal_stages::mesh::mortar_pairs::{Coverage, mortar_pairs};
use squeal_stages::mesh::structured::block;

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactPatch {
    /// W, H_d, H_p (m): the footprint's side, the disc's and the pad's heights.
    width_m: f64,
    disc_height_m: f64,
    pad_height_m: f64,
    /// Element layers through each block's height.
    layers: usize,
    /// X₀ (m): the blocks' distance from the rotation axis.
    offset_m: f64,
    pressure_pa: f64,
    omega_rad_s: f64,
    /// Pairs of interface meshes, each tried both ways round.
    meshes: Vec<[Block; 2]>,
    materials: Vec<Materials>,
    /// |r_n / area − p| / p of the worst pair.
    pressure_tolerance: f64,
    /// |Σ r_n − p W²| / (p W²).
    force_tolerance: f64,
    /// |u − u_exact| of the worst node, relative to its body's largest displacement.
    displacement_tolerance: f64,
    /// |σ − σ_exact| of the worst integration point and component, relative to p.
    stress_tolerance: f64,
    /// |coverage − 1|, and the largest weighted gap or penetration at rest relative to W.
    coverage_tolerance: f64,
    /// The displacement and stress measures must exceed this (and the pressure measure its
    /// tolerance) with each pad node paired to its nearest disc node, weight 1 (node to node),
    /// on the non-matching meshes.
    wrong_pairing_least_error: f64,
    friction: Friction,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Block {
    kind: ElementKind,
    cells: [usize; 2],
}

impl std::fmt::Display for Block {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [nx, ny] = self.cells;
        write!(f, "{} {nx}×{ny}", self.kind.name())
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Materials {
    name: String,
    /// (E (Pa), ν) of each body.
    disc: [f64; 2],
    pad: [f64; 2],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Friction {
    mu: f64,
    materials: Materials,
    /// Forces (nodal, resultants, reactions, moments / W) against p W², directions against 1.
    tolerance: f64,
}

/// The two blocks as one mesh with its mortar pairs; disc nodes come first.
struct Stack {
    mesh: Mesh,
    n_disc_nodes: usize,
    coverage: Coverage,
}

fn stack(case: &ContactPatch, disc: &Block, pad: &Block) -> Stack {
    let (w, h_disc) = (case.width_m, case.disc_height_m);
    let cells = |block: &Block| [block.cells[0], block.cells[1], case.layers];
    let lower = as_kind(&block([w, w, h_disc], cells(disc), "disc"), disc.kind);
    let upper = as_kind(
        &block([w, w, case.pad_height_m], cells(pad), "pad"),
        pad.kind,
    );
    let mut mesh = lower.clone();
    let n_disc_nodes = mesh.nodes.len();
    mesh.nodes
        .extend(upper.nodes.iter().map(|x| [x[0], x[1], x[2] + h_disc]));
    mesh.elements
        .extend_shifted(&upper.elements, n_disc_nodes as u32, 1);
    mesh.parts.push("pad".into());
    for x in &mut mesh.nodes {
        x[0] += case.offset_m;
    }
    let upper_set = |name: &str| -> Vec<u32> {
        upper.node_sets[name]
            .iter()
            .map(|node| node + n_disc_nodes as u32)
            .collect()
    };
    let (disc_bottom, pad_top) = (lower.node_sets["z0"].clone(), upper_set("z1"));
    let corner = |set: &[u32], x: f64| -> Vec<u32> {
        let node = set.iter().copied().find(|&node| {
            let y = mesh.nodes[node as usize];
            (y[0] - case.offset_m - x).abs() < 1e-12 * w && y[1].abs() < 1e-12 * w
        });
        vec![node.expect("a corner of the set")]
    };
    let pins = [
        ("disc_pin_xy", corner(&disc_bottom, 0.0)),
        ("disc_pin_y", corner(&disc_bottom, w)),
        ("pad_pin_xy", corner(&pad_top, 0.0)),
        ("pad_pin_y", corner(&pad_top, w)),
    ];
    mesh.node_sets = BTreeMap::from([
        ("disc_bottom".to_string(), disc_bottom),
        ("disc_top".to_string(), lower.node_sets["z1"].clone()),
        ("pad_bottom".to_string(), upper_set("z0")),
        ("pad_top".to_string(), pad_top),
    ]);
    mesh.node_sets
        .extend(pins.map(|(name, node)| (name.to_string(), node)));
    let (pairs, coverage) = mortar_pairs(
        &mesh,
        &Side::new("disc_top", mesh.node_sets["disc_top"].clone()),
        &Side::new("pad_bottom", mesh.node_sets["pad_bottom"].clone()),
        0.1 * w,
    )
    .expect("mortar pairs");
    mesh.contact_pairs = pairs;
    Stack {
        mesh,
        n_disc_nodes,
        coverage,
    }
}

/// The model of `stack` with `clamped` and the bodies' `materials`.
fn assemble(stack: &Stack, clamped: &str, materials: &Materials) -> (Model, AssembleParams) {
    let [[e_disc, nu_disc], [e_pad, nu_pad]] = [materials.disc, materials.pad];
    with_default_materials(
        &stack.mesh,
        clamped,
        &[
            ("E_disc", e_disc),
            ("nu_disc", nu_disc),
            ("E_pad", e_pad),
            ("nu_pad", nu_pad),
        ],
    )
    .expect("assembly")
}

/// `model` pressed by p on the pad's top, at friction `mu`.
fn press(case: &ContactPatch, model: &Model, mu: f64) -> Equilibrium {
    let load = Load::Pressure(vec![PressureOn {
        set: "pad_top".into(),
        pressure: case.pressure_pa,
    }]);
    solve(
        model,
        mu,
        case.omega_rad_s,
        load,
        Solver::SemismoothNewton,
        &LcpSettings::default(),
    )
    .expect("sliding equilibrium")
    .0
}

/// The displacement of every node, zero where clamped.
fn nodal(model: &Model, u: &[f64]) -> Vec<[f64; 3]> {
    model
        .dof_of_node
        .iter()
        .map(|dofs| dofs.map(|dof| dof.map_or(0.0, |dof| u[dof as usize])))
        .collect()
}

/// The largest |u − u_exact| of each body (disc, pad) relative to its largest |u_exact|.
fn displacement_errors(
    case: &ContactPatch,
    stack: &Stack,
    materials: &Materials,
    u: &[[f64; 3]],
) -> [f64; 2] {
    let p = case.pressure_pa;
    let [e_disc, _] = materials.disc;
    let exact = |node: usize| -> [f64; 3] {
        let x = stack.mesh.nodes[node];
        let ([e, nu], base, u_base) = if node < stack.n_disc_nodes {
            (materials.disc, 0.0, 0.0)
        } else {
            (
                materials.pad,
                case.disc_height_m,
                -p * case.disc_height_m / e_disc,
            )
        };
        [
            nu * p * (x[0] - case.offset_m) / e,
            nu * p * x[1] / e,
            u_base - p * (x[2] - base) / e,
        ]
    };
    let mut worst = [[0.0f64; 2]; 2];
    for (node, u) in u.iter().enumerate() {
        let body = usize::from(node >= stack.n_disc_nodes);
        let want = exact(node);
        for axis in 0..3 {
            worst[body][0] = worst[body][0].max((u[axis] - want[axis]).abs());
            worst[body][1] = worst[body][1].max(want[axis].abs());
        }
    }
    worst.map(|[error, scale]| error / scale)
}

/// The displacement gradient ∂u_i/∂x_j at the reference point `xi` of an element.
fn gradient_at(
    kind: ElementKind,
    coords: &[[f64; 3]],
    u: &[[f64; 3]],
    xi: [f64; 3],
) -> [[f64; 3]; 3] {
    let n = kind.n_nodes();
    let (mut values, mut gradients) = (vec![0.0; n], vec![[0.0; 3]; n]);
    shapes::evaluate(kind, xi, &mut values, &mut gradients);
    // J = ∂x/∂ξ and ∂u/∂ξ = ∇u J, hence Jᵀ ∇uᵀ = (∂u/∂ξ)ᵀ.
    let by_reference = |field: &[[f64; 3]]| {
        Mat::from_fn(3, 3, |j, i| {
            (0..n).map(|a| field[a][i] * gradients[a][j]).sum::<f64>()
        })
    };
    let transposed = by_reference(coords).partial_piv_lu().solve(by_reference(u));
    std::array::from_fn(|i| std::array::from_fn(|j| transposed[(j, i)]))
}

/// The largest |σ − σ_exact| over every integration point and component, relative to p: the
/// Gauss points of the incompatible-mode hexahedra (internal modes recovered), the stiffness
/// rule's points of the other kinds.
fn stress_error(case: &ContactPatch, mesh: &Mesh, params: &AssembleParams, u: &[[f64; 3]]) -> f64 {
    let p = case.pressure_pa;
    let exact = [0.0, 0.0, -p, 0.0, 0.0, 0.0];
    let mut worst = 0.0f64;
    for element in mesh.elements.iter() {
        let part = &mesh.parts[element.part as usize];
        let D = params
            .material(part)
            .and_then(|material| material.elasticity_at([0.0; 3]))
            .expect("an isotropic material");
        let coords: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let displacement: Vec<[f64; 3]> =
            element.nodes.iter().map(|&node| u[node as usize]).collect();
        let strains: Vec<[f64; 6]> = if element.kind == ElementKind::Hex8 {
            let element_displacement: [f64; 24] =
                std::array::from_fn(|dof| displacement[dof / 3][dof % 3]);
            hex8::gauss_point_strains(
                &coords.clone().try_into().expect("8 nodes"),
                &D,
                &element_displacement,
            )
            .expect("no element is inverted")
            .to_vec()
        } else {
            quadrature::rule(element.kind)
                .iter()
                .map(|point| {
                    let g = gradient_at(element.kind, &coords, &displacement, point.xi);
                    element::engineering_strain(&g)
                })
                .collect()
        };
        for strain in strains {
            for (row, want) in D.iter().zip(exact) {
                let stress: f64 = row.iter().zip(strain).map(|(d, e)| d * e).sum();
                worst = worst.max((stress - want).abs() / p);
            }
        }
    }
    worst
}

/// The frictionless case's measures.
#[derive(Debug)]
struct Measured {
    pressure: f64,
    force: f64,
    displacement: [f64; 2],
    stress: f64,
}

fn frictionless(case: &ContactPatch, stack: &Stack, materials: &Materials) -> Measured {
    let (model, params) = assemble(
        stack,
        "disc_bottom:z, disc_pin_xy:xy, disc_pin_y:y, pad_pin_xy:xy, pad_pin_y:y",
        materials,
    );
    let equilibrium = press(case, &model, 0.0);
    let p = case.pressure_pa;
    let pairs = &model.mesh.contact_pairs;
    let pressure = equilibrium
        .r_n
        .iter()
        .zip(pairs)
        .map(|(r, pair)| (r / pair.area - p).abs() / p)
        .fold(0.0, f64::max);
    let total: f64 = equilibrium.r_n.iter().sum();
    let area = case.width_m * case.width_m;
    let u = nodal(&model, &equilibrium.u);
    Measured {
        pressure,
        force: (total - p * area).abs() / (p * area),
        displacement: displacement_errors(case, stack, materials, &u),
        stress: stress_error(case, &model.mesh, &params, &u),
    }
}

/// Every interface mesh both ways round, with each set of materials: the exact solution to
/// round-off.
#[test]
fn contact_patch_non_matching_blocks_carry_a_uniform_pressure_and_stress() {
    let case: ContactPatch = reference::load("contact_patch");
    for [first, second] in &case.meshes {
        for (disc, pad) in [(first, second), (second, first)] {
            let stack = stack(&case, disc, pad);
            let what = format!("disc {disc}, pad {pad}");
            let coverage = &stack.coverage;
            assert!(
                (coverage.covered - 1.0).abs() <= case.coverage_tolerance
                    && coverage.dropped == 0
                    && coverage.largest_gap.abs() <= case.coverage_tolerance * case.width_m
                    && coverage.largest_penetration <= case.coverage_tolerance * case.width_m,
                "{what}: {coverage:?}"
            );
            for materials in &case.materials {
                let measured = frictionless(&case, &stack, materials);
                eprintln!("{what}, {}: {measured:?}", materials.name);
                assert!(
                    measured.pressure <= case.pressure_tolerance
                        && measured.force <= case.force_tolerance
                        && measured.displacement[0] <= case.displacement_tolerance
                        && measured.displacement[1] <= case.displacement_tolerance
                        && measured.stress <= case.stress_tolerance,
                    "{what}, {}: {measured:?}",
                    materials.name
                );
            }
        }
    }
}

/// The measure is not vacuous: the same meshes with each pad node paired, weight 1, to its
/// nearest disc node (node to node, as a one-pass pairing of non-matching meshes would) carry
/// neither the uniform pressure nor the exact field.
#[test]
fn contact_patch_fails_with_node_to_node_pairs_on_non_matching_meshes() {
    let case: ContactPatch = reference::load("contact_patch");
    let [first, second] = &case.meshes[0];
    for (disc, pad) in [(first, second), (second, first)] {
        let mut stack = stack(&case, disc, pad);
        let disc_top = &stack.mesh.node_sets["disc_top"];
        let nodes = &stack.mesh.nodes;
        let distance = |a: u32, b: u32| {
            let (x, y) = (nodes[a as usize], nodes[b as usize]);
            (0..3).map(|i| (x[i] - y[i]).powi(2)).sum::<f64>()
        };
        let wrong: Vec<ContactPair> = stack
            .mesh
            .contact_pairs
            .iter()
            .map(|pair| {
                let anchor = pair.pad_node();
                let nearest = disc_top
                    .iter()
                    .copied()
                    .min_by(|a, b| distance(anchor, *a).total_cmp(&distance(anchor, *b)))
                    .expect("disc nodes");
                ContactPair::node_to_node(nearest, anchor, pair.normal, pair.area)
            })
            .collect();
        stack.mesh.contact_pairs = wrong;
        for materials in &case.materials {
            let measured = frictionless(&case, &stack, materials);
            eprintln!(
                "node to node, disc {disc}, pad {pad}, {}: {measured:?}",
                materials.name
            );
            let error = measured.displacement[0].max(measured.displacement[1]);
            assert!(
                error >= case.wrong_pairing_least_error
                    && measured.stress >= case.wrong_pairing_least_error
                    && measured.pressure > case.pressure_tolerance,
                "{measured:?}"
            );
        }
    }
}

/// Sliding friction through the non-matching interface: every pair closed and sliding along
/// the disc's motion, the forces the elements exert at the interface those of the pairs, the
/// pressure's resultant and first moments those of statics, each body's supports holding the
/// other body's forces.
#[test]
fn contact_patch_with_sliding_friction_balances_each_block() {
    let case: ContactPatch = reference::load("contact_patch");
    let Friction {
        mu,
        ref materials,
        tolerance,
    } = case.friction;
    let (p, w) = (case.pressure_pa, case.width_m);
    let force_scale = p * w * w;
    for [first, second] in &case.meshes {
        for (disc, pad) in [(first, second), (second, first)] {
            let stack = stack(&case, disc, pad);
            let what = format!("disc {disc}, pad {pad}");
            let (model, params) = assemble(&stack, "disc_bottom, pad_top:xy", materials);
            let equilibrium = press(&case, &model, mu);
            let mesh = &model.mesh;
            let frames = &equilibrium.frames;
            assert!(equilibrium.closed.iter().all(|closed| *closed), "{what}");
            // The sliding direction: the disc's velocity e_z × x at the pair, in-plane.
            let mut direction_error = 0.0f64;
            for (pair, t) in mesh.contact_pairs.iter().zip(&frames.t) {
                let x = pair.disc_position(&mesh.nodes);
                let speed = x[0].hypot(x[1]);
                let want = [-x[1] / speed, x[0] / speed, 0.0];
                for axis in 0..3 {
                    direction_error = direction_error.max((t[axis] - want[axis]).abs());
                }
            }
            // The pairs' forces r_n (n + μ t), spread over their nodes by their weights, are
            // the forces the elements exert, K u − F, at every DOF.
            let mut contact = vec![0.0; model.n_dofs()];
            let forces: Vec<[f64; 3]> = (equilibrium.r_n.iter().zip(&frames.n).zip(&frames.t))
                .map(|((r, n), t)| std::array::from_fn(|axis| r * (n[axis] + mu * t[axis])))
                .collect();
            for (pair, force) in mesh.contact_pairs.iter().zip(&forces) {
                for (node, weight) in pair.signed_weights() {
                    for (axis, dof) in model.dof_of_node[node as usize].iter().enumerate() {
                        if let Some(dof) = dof {
                            contact[*dof as usize] += weight * force[axis];
                        }
                    }
                }
            }
            let load = pressure_load(&model, p, "pad_top").expect("pressure load");
            let internal = model.K.mul_vec(&equilibrium.u);
            let nodal_error = (0..model.n_dofs())
                .map(|dof| (internal[dof] - load.forces[dof] - contact[dof]).abs())
                .fold(0.0, f64::max)
                / force_scale;
            // Statics of the pad: the resultant p W², and about the centre c of its back (where
            // the pressure and the guides' reactions have no moment about in-plane axes) the
            // first moments Σ r_n (x − c) = −μ H_p Σ r_n t.
            let total: f64 = equilibrium.r_n.iter().sum();
            let drag: [f64; 2] =
                std::array::from_fn(|axis| forces.iter().map(|force| force[axis]).sum::<f64>());
            let centre = [case.offset_m + 0.5 * w, 0.5 * w];
            let mut moment_error = 0.0f64;
            for axis in 0..2 {
                let moment: f64 = mesh
                    .contact_pairs
                    .iter()
                    .zip(&equilibrium.r_n)
                    .map(|(pair, r)| r * (pair.pad_position(&mesh.nodes)[axis] - centre[axis]))
                    .sum();
                moment_error = moment_error.max((moment + case.pad_height_m * drag[axis]).abs());
            }
            // The supports: the disc's base holds (drag, p W²), the pad's guides −drag.
            let by_part = [params.material("disc"), params.material("pad")]
                .map(|material| material.expect("material"));
            let reactions = |set: &str| {
                back_reactions(&model, &by_part, &equilibrium.u, set).expect("reactions")
            };
            let (base, guides) = (reactions("disc_bottom"), reactions("pad_top"));
            let reaction_error = [
                base[0] - drag[0],
                base[1] - drag[1],
                base[2] - total,
                guides[0] + drag[0],
                guides[1] + drag[1],
            ]
            .iter()
            .fold(0.0f64, |worst, e| worst.max(e.abs()))
                / force_scale;
            let pressures: Vec<f64> = equilibrium
                .r_n
                .iter()
                .zip(&mesh.contact_pairs)
                .map(|(r, pair)| r / pair.area / p)
                .collect();
            let (low, high) = pressures
                .iter()
                .fold((f64::MAX, f64::MIN), |(l, h), q| (l.min(*q), h.max(*q)));
            eprintln!(
                "{what}: direction {direction_error:.1e}, nodal forces {nodal_error:.1e}, resultant {:.1e}, moments {:.1e}, reactions {reaction_error:.1e}, drag/(p W²) {:.4} {:.4}, pressure / p in [{low:.3}, {high:.3}]",
                (total - force_scale).abs() / force_scale,
                moment_error / (force_scale * w),
                drag[0] / force_scale,
                drag[1] / force_scale,
            );
            assert!(
                direction_error <= tolerance
                    && nodal_error <= tolerance
                    && (total - force_scale).abs() <= tolerance * force_scale
                    && moment_error <= tolerance * force_scale * w
                    && reaction_error <= tolerance,
                "{what}"
            );
        }
    }
}
