//! Verification of the ties: the tied patch test (uniaxial stress reproduced exactly across a
//! non-matching interface, either side the slave, 8- and 20-node hexahedra), a cantilever cut
//! in two differently meshed halves bending and vibrating as the whole beam, the model's
//! record of its tied nodes, contact pairs reading masters, and every refused case by its
//! message.

use std::collections::BTreeMap;
use std::sync::Arc;

use faer::linalg::solvers::Solve;
use faer::{Mat, Side as FaerSide};

use super::super::{Assemble, AssembleParams, TieMethod, assemble_model};
use crate::artifact::mesh::ContactPair;
use crate::artifact::{Artifact, ElementKind, Mesh, Model};
use crate::fem::element;
use crate::fem::faces::{Side, area_vectors};
use crate::mesh::interface::boundary_faces;
use crate::mesh::{convert, structured};
use crate::modes::Modes;
use crate::stage::{Input, Inputs, Params, Stage, StageError, Value};
use crate::table::ColumnData;

/// A block [x0, x0 + lx] × [0, ly] × [z0, z0 + lz] meshed `counts`, its node sets (the six
/// faces) prefixed `name_`, appended to `mesh` with nodes of its own, in part 0.
fn add_block(mesh: &mut Mesh, name: &str, origin: [f64; 3], lengths: [f64; 3], counts: [usize; 3]) {
    let block = structured::block(lengths, counts, "disc");
    let offset = mesh.nodes.len() as u32;
    mesh.nodes.extend(
        block
            .nodes
            .iter()
            .map(|x| std::array::from_fn(|axis| x[axis] + origin[axis])),
    );
    mesh.elements.extend_shifted(&block.elements, offset, 0);
    for (set, nodes) in &block.node_sets {
        mesh.node_sets.insert(
            format!("{name}_{set}"),
            nodes.iter().map(|node| node + offset).collect(),
        );
    }
    if mesh.parts.is_empty() {
        mesh.parts.push("disc".into());
    }
}

/// The node of `mesh` at `x` (to 1e-12 m).
fn node_at(mesh: &Mesh, x: [f64; 3]) -> u32 {
    mesh.nodes
        .iter()
        .position(|y| (0..3).all(|axis| (y[axis] - x[axis]).abs() < 1e-12))
        .unwrap_or_else(|| panic!("no node at {x:?}")) as u32
}

const WIDTH: [f64; 2] = [1.0, 0.8];
const HEIGHTS: [f64; 2] = [0.5, 0.6];

/// Two blocks stacked along z, `lower` and `upper`, meshed `lower_counts` and `upper_counts`
/// across (in x and y), two layers each, with nodes of their own at the interface z = 0.5; node
/// sets `lower_*`, `upper_*`, `origin` (the lower block's corner at 0) and `x_axis` (its corner
/// at x = 1). 20-node hexahedra if `kind` is `Hex20`.
fn stacked(lower_counts: [usize; 2], upper_counts: [usize; 2], kind: ElementKind) -> Mesh {
    let mut mesh = Mesh::default();
    let [a, b] = WIDTH;
    let [h_lower, h_upper] = HEIGHTS;
    let [nx, ny] = lower_counts;
    add_block(&mut mesh, "lower", [0.0; 3], [a, b, h_lower], [nx, ny, 2]);
    let [nx, ny] = upper_counts;
    add_block(
        &mut mesh,
        "upper",
        [0.0, 0.0, h_lower],
        [a, b, h_upper],
        [nx, ny, 2],
    );
    let origin = node_at(&mesh, [0.0; 3]);
    let x_axis = node_at(&mesh, [a, 0.0, 0.0]);
    mesh.node_sets.insert("origin".into(), vec![origin]);
    mesh.node_sets.insert("x_axis".into(), vec![x_axis]);
    convert::as_kind(&mesh, kind)
}

/// `assemble`'s parameters: the defaults with `clamped` and `ties` as given.
/// `assemble`'s parameters with `clamped` and `ties`, tied by collocation (the cases below
/// name the mortar method where they take it).
fn params(clamped: &str, ties: &str) -> AssembleParams {
    Params::defaults(
        &Assemble,
        &[
            ("clamped", Value::Str(clamped.into())),
            ("ties", Value::Str(ties.into())),
            ("tie_method", Value::Str("collocation".into())),
        ],
    )
    .read::<Assemble>()
    .unwrap()
}

/// [`params`] with the ties made by `method`.
fn params_by(clamped: &str, ties: &str, method: TieMethod) -> AssembleParams {
    AssembleParams {
        tie_method: method,
        ..params(clamped, ties)
    }
}

/// The model of `mesh` clamped and tied as given, by the stage as a study runs it (by
/// collocation unless `overrides` name the method).
fn run_stage(mesh: &Mesh, overrides: &[(&str, Value)]) -> Result<Model, StageError> {
    let mut overrides = overrides.to_vec();
    if !overrides.iter().any(|(name, _)| *name == "tie_method") {
        overrides.push(("tie_method", Value::Str("collocation".into())));
    }
    let params = Params::defaults(&Assemble, &overrides);
    let inputs = Inputs(BTreeMap::from([(
        "mesh".to_string(),
        Input::One(Arc::new(Artifact::Mesh(Box::new(mesh.clone())))),
    )]));
    let mut outputs = Assemble.run(&params, &inputs)?;
    match outputs.remove("model") {
        Some(Artifact::Model(model)) => Ok(*model),
        other => panic!("no model output: {other:?}"),
    }
}

/// The message of the error assembling `mesh` clamped and tied as given.
fn error(mesh: &Mesh, clamped: &str, ties: &str) -> String {
    error_within(mesh, clamped, ties, 1e-4)
}

fn error_within(mesh: &Mesh, clamped: &str, ties: &str, tie_distance: f64) -> String {
    run_stage(
        mesh,
        &[
            ("clamped", Value::Str(clamped.into())),
            ("ties", Value::Str(ties.into())),
            ("tie_distance", Value::Float(tie_distance)),
        ],
    )
    .map(|_| ())
    .unwrap_err()
    .message
}

/// The consistent nodal forces of a uniform traction `traction` (Pa, a vector) on the boundary
/// faces of the node set `set`, over the model's free DOFs.
fn traction_load(model: &Model, set: &str, traction: [f64; 3]) -> Vec<f64> {
    let mesh = &model.mesh;
    let mut forces = vec![0.0; model.n_dofs()];
    let side = Side::new(set, mesh.node_sets[set].iter().copied());
    for face in boundary_faces(mesh, &side) {
        let coords: Vec<[f64; 3]> = face
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let (nodal, area) = area_vectors(face.kind, &coords);
        let size = area.iter().map(|a| a * a).sum::<f64>().sqrt();
        for (&node, vector) in face.nodes.iter().zip(&nodal) {
            // ∫ N_a dA, whichever way the face's cycle turns.
            let integral: f64 = (0..3).map(|axis| vector[axis] * area[axis]).sum::<f64>() / size;
            // What falls on a clamped axis goes to its support: it does no work.
            model.add_nodal_force(node, traction.map(|t| t * integral), &mut forces);
        }
    }
    forces
}

/// K u = f, dense (the models here have a few thousand DOFs at most).
fn solve(model: &Model, forces: &[f64]) -> Vec<f64> {
    let K = model.K.to_dense();
    let rhs = Mat::from_fn(forces.len(), 1, |i, _| forces[i]);
    let solution = K
        .llt(FaerSide::Lower)
        .expect("K is positive definite")
        .solve(&rhs);
    (0..forces.len()).map(|i| solution[(i, 0)]).collect()
}

/// Young's modulus and Poisson's ratio of the short form's disc.
const E: f64 = 2.02e11;
const NU: f64 = 0.29;

/// The tied stack under a pressure p and a shear τ on its top, held at its base along z and
/// at two corners in-plane, its base sheared back by −τ and its x faces by ±τ along z (the
/// tractions σ n of the uniform stress σ_zz = −p, σ_xz = τ), against the exact field
/// u = (ν p x / E + τ z / G, ν p y / E, −p z / E): the largest error of the displacement of a
/// node (tied or not), relative to the largest displacement, and of the stress at an
/// element's centre, relative to p. With τ = 0 the stress is uniaxial; with τ ≠ 0 the
/// interface carries a uniform shear, as one in stick does.
fn uniform_stress_patch(mesh: &Mesh, ties: &str, method: TieMethod, tau: f64) -> (f64, f64) {
    let params = params_by("lower_z0:z, origin:xy, x_axis:y", ties, method);
    let (model, _) = assemble_model(mesh, &params).unwrap();
    model.check_dof_map().unwrap();
    let p = 1e6;
    let mut forces = traction_load(&model, "upper_z1", [tau, 0.0, -p]);
    if tau != 0.0 {
        for (set, traction) in [
            ("lower_z0", [-tau, 0.0, 0.0]),
            ("lower_x0", [0.0, 0.0, -tau]),
            ("upper_x0", [0.0, 0.0, -tau]),
            ("lower_x1", [0.0, 0.0, tau]),
            ("upper_x1", [0.0, 0.0, tau]),
        ] {
            for (total, force) in forces.iter_mut().zip(traction_load(&model, set, traction)) {
                *total += force;
            }
        }
    }
    let u = solve(&model, &forces);
    let shear_modulus = E / (2.0 * (1.0 + NU));
    let exact = |x: [f64; 3]| {
        [
            NU * p * x[0] / E + tau * x[2] / shear_modulus,
            NU * p * x[1] / E,
            -p * x[2] / E,
        ]
    };
    let scale = (p / E + tau / shear_modulus) * (HEIGHTS[0] + HEIGHTS[1]);
    let mut worst: f64 = 0.0;
    for node in 0..mesh.n_nodes() as u32 {
        let got = model.node_displacement(node, &u);
        let want = exact(mesh.nodes[node as usize]);
        for axis in 0..3 {
            worst = worst.max((got[axis] - want[axis]).abs() / scale);
        }
    }
    let D = params
        .material("disc")
        .unwrap()
        .elasticity_at([0.0; 3])
        .unwrap();
    let mut worst_stress: f64 = 0.0;
    for element in mesh.elements.iter() {
        let coords: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let nodal: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| model.node_displacement(node, &u))
            .collect();
        let g = element::centre_displacement_gradient(element.kind, &coords, &nodal).unwrap();
        let strain = element::engineering_strain(&g);
        let want = [0.0, 0.0, -p, 0.0, 0.0, tau];
        for i in 0..6 {
            let stress: f64 = (0..6).map(|j| D[i][j] * strain[j]).sum();
            worst_stress = worst_stress.max((stress - want[i]).abs() / p);
        }
    }
    (worst, worst_stress)
}

#[test]
fn a_mortar_tied_patch_reproduces_uniaxial_stress_exactly_either_side_the_slave() {
    // 3 × 3 against 4 × 5 across the interface: no node of one side on the other's, except
    // along the outline. Fine on coarse and coarse on fine, linear and quadratic hexahedra:
    // the uniaxial field and its stress to 1e-9.
    let mut worst: f64 = 0.0;
    for kind in [ElementKind::Hex8, ElementKind::Hex20] {
        for (lower, upper) in [([3, 3], [4, 5]), ([4, 5], [3, 3])] {
            let mesh = stacked(lower, upper, kind);
            for ties in ["upper_z0 -> lower_z1", "lower_z1 -> upper_z0"] {
                let (displacement, stress) =
                    uniform_stress_patch(&mesh, ties, TieMethod::Mortar, 0.0);
                let error = displacement.max(stress);
                assert!(
                    error <= 1e-9,
                    "{kind} {lower:?} | {upper:?} {ties}: error {error:e}"
                );
                worst = worst.max(error);
            }
        }
    }
    println!("mortar-tied patch test: largest error {worst:.2e} (relative)");
}

/// A contact pair in stick holds its pad point to its disc point in every direction, as a tie
/// does: the mortar-tied stack sheared along its interface (σ_xz = 0.3 p on top of the
/// pressure) carries the uniform shear exactly, either side the slave, to 1e-9.
#[test]
fn a_mortar_tied_patch_carries_a_uniform_shear_across_non_matching_meshes() {
    let mut worst: f64 = 0.0;
    for kind in [ElementKind::Hex8, ElementKind::Hex20] {
        let mesh = stacked([3, 3], [4, 5], kind);
        for ties in ["upper_z0 -> lower_z1", "lower_z1 -> upper_z0"] {
            let (displacement, stress) =
                uniform_stress_patch(&mesh, ties, TieMethod::Mortar, 0.3e6);
            let error = displacement.max(stress);
            assert!(error <= 1e-9, "{kind} {ties}: error {error:e}");
            worst = worst.max(error);
        }
    }
    println!("mortar-tied shear patch test: largest error {worst:.2e} (relative)");
}

#[test]
fn a_collocated_patch_is_exact_where_the_slave_refines_the_master_only() {
    // Collocation holds the slave nodes, not the faces between them: constant stress passes
    // where the slave trace can follow the master's exactly, coincident meshes and a slave
    // side refining the master's (6 × 6 on 3 × 3), to 1e-9.
    let mut worst: f64 = 0.0;
    for kind in [ElementKind::Hex8, ElementKind::Hex20] {
        for (upper, ties) in [
            ([3, 3], "upper_z0 -> lower_z1"),
            ([3, 3], "lower_z1 -> upper_z0"),
            ([6, 6], "upper_z0 -> lower_z1"),
        ] {
            let mesh = stacked([3, 3], upper, kind);
            let (displacement, stress) =
                uniform_stress_patch(&mesh, ties, TieMethod::Collocation, 0.0);
            let error = displacement.max(stress);
            assert!(error <= 1e-9, "{kind} {upper:?} {ties}: error {error:e}");
            worst = worst.max(error);
        }
    }
    println!("collocated patch test, matching or nested: largest error {worst:.2e}");
    // Elsewhere the slave faces part from the master's between the slave nodes, and the
    // constant traction across them is not carried consistently: errors of per cents in the
    // displacements, up to tens of per cents in the stress of the elements at the interface
    // (most for 3 × 3 slaves on a 6 × 6 master, whose nodes between the slave nodes carry
    // nothing).
    for kind in [ElementKind::Hex8, ElementKind::Hex20] {
        for (lower, upper, ties) in [
            ([3, 3], [4, 5], "upper_z0 -> lower_z1"),
            ([3, 3], [4, 5], "lower_z1 -> upper_z0"),
            ([3, 3], [6, 6], "lower_z1 -> upper_z0"),
        ] {
            let mesh = stacked(lower, upper, kind);
            let (displacement, stress) =
                uniform_stress_patch(&mesh, ties, TieMethod::Collocation, 0.0);
            println!(
                "collocated patch test {kind} {lower:?} | {upper:?} ({ties}): displacement \
                 error {displacement:.2e}, stress error {stress:.2e}"
            );
            assert!(
                displacement > 1e-6 && stress < 1.0,
                "{kind} {upper:?} {ties}"
            );
        }
    }
}

#[test]
fn a_tied_model_records_its_nodes_and_keeps_mass_and_symmetry_exact() {
    let mesh = stacked([3, 3], [4, 5], ElementKind::Hex8);
    let model = run_stage(
        &mesh,
        &[
            ("clamped", Value::Str(String::new())),
            ("ties", Value::Str("upper_z0 -> lower_z1".into())),
        ],
    )
    .unwrap();
    model.check_dof_map().unwrap();
    // Every node of the slave set tied, by increasing node, no DOF of its own.
    let slaves = &mesh.node_sets["upper_z0"];
    let tied: Vec<u32> = model.tied.iter().map(|tied| tied.node).collect();
    assert_eq!(&tied, slaves);
    for tied in &model.tied {
        assert_eq!(model.dof_of_node[tied.node as usize], [None; 3]);
        let sum: f64 = tied.masters.iter().map(|(_, weight)| weight).sum();
        assert!((sum - 1.0).abs() < 1e-14);
        // Held where it is: Σ w x_l is the node's own position on the flat interface.
        let x = mesh.nodes[tied.node as usize];
        for (axis, x) in x.iter().enumerate() {
            let at: f64 = tied
                .masters
                .iter()
                .map(|&(master, weight)| weight * mesh.nodes[master as usize][axis])
                .sum();
            assert!((at - x).abs() < 1e-14, "{tied:?}");
        }
    }
    assert_eq!(model.n_dofs(), 3 * (mesh.n_nodes() - slaves.len()));
    // The mass of a rigid translation is the whole mass: T keeps translations.
    let translation: Vec<f64> = (0..model.n_dofs())
        .map(|dof| if dof % 3 == 2 { 1.0 } else { 0.0 })
        .collect();
    let mass: f64 = translation
        .iter()
        .zip(model.M.mul_vec(&translation))
        .map(|(r, m)| r * m)
        .sum();
    let exact = 7850.0 * WIDTH[0] * WIDTH[1] * (HEIGHTS[0] + HEIGHTS[1]);
    assert!((mass - exact).abs() <= 1e-12 * exact, "{mass} vs {exact}");
    // A rigid translation strains nothing.
    let strain = model.K.mul_vec(&translation);
    let norm = model.K.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(strain.iter().all(|f| f.abs() <= 1e-9 * norm));
    // Exactly symmetric, one pattern for the three matrices.
    for A in [&model.K, &model.M, &model.C] {
        let dense = A.to_dense();
        for i in 0..A.n_rows {
            for j in 0..i {
                assert_eq!(dense[(i, j)].to_bits(), dense[(j, i)].to_bits());
            }
        }
    }
    assert_eq!(model.K.row_idx, model.M.row_idx);
    assert_eq!(model.K.col_ptr, model.C.col_ptr);
    // The same on any number of threads, and the model round-trips through its encoding.
    let on_threads = |threads: usize, method: TieMethod| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                assemble_model(&mesh, &params_by("", "upper_z0 -> lower_z1", method))
                    .unwrap()
                    .0
            })
    };
    let bytes = Artifact::Model(Box::new(model.clone())).encode();
    assert_eq!(
        bytes,
        Artifact::Model(Box::new(on_threads(1, TieMethod::Collocation))).encode()
    );
    assert_eq!(
        bytes,
        Artifact::Model(Box::new(on_threads(3, TieMethod::Collocation))).encode()
    );
    let mortar = Artifact::Model(Box::new(on_threads(1, TieMethod::Mortar))).encode();
    assert_eq!(
        mortar,
        Artifact::Model(Box::new(on_threads(3, TieMethod::Mortar))).encode()
    );
    assert_ne!(mortar, bytes);
    assert_eq!(
        Artifact::decode(&bytes).unwrap(),
        Artifact::Model(Box::new(model.clone()))
    );
    // A tied node's rows of a nodal table are its masters' values by their weights.
    let field: Vec<f64> = (0..model.n_dofs()).map(|dof| (dof as f64).sin()).collect();
    let table = model.nodal_table(vec![("u".into(), field.clone())]);
    let Some(ColumnData::F64(values)) = table.column("u") else {
        panic!("a column u")
    };
    let Some(ColumnData::I64(dofs)) = table.column("dof") else {
        panic!("a column dof")
    };
    for tied in &model.tied {
        let node = tied.node as usize;
        let want = model.node_displacement(tied.node, &field);
        assert_eq!(&values[3 * node..3 * node + 3], &want);
        assert_eq!(&dofs[3 * node..3 * node + 3], &[-1, -1, -1]);
        assert!(want.iter().all(|&u| u != 0.0));
    }
    assert_eq!(
        model.nodal_displacements(&field)[..],
        (0..mesh.n_nodes() as u32)
            .flat_map(|node| model.node_displacement(node, &field))
            .collect::<Vec<_>>()[..]
    );
}

#[test]
fn an_untied_model_is_the_model_before_ties_bit_for_bit() {
    // No ties: no tied node, and the model of the stage's defaults whatever `tie_distance`.
    let mesh = structured::stacked_blocks(0.02, 0.03, 0.01);
    let base = run_stage(&mesh, &[("clamped", Value::Str("base".into()))]).unwrap();
    assert!(base.tied.is_empty());
    assert_eq!(base.mesh, mesh);
    let other = run_stage(
        &mesh,
        &[
            ("clamped", Value::Str("base".into())),
            ("ties", Value::Str(" ".into())),
            ("tie_distance", Value::Float(0.5)),
        ],
    )
    .unwrap();
    assert_eq!(
        Artifact::Model(Box::new(base.clone())).encode(),
        Artifact::Model(Box::new(other)).encode()
    );
    // Its encoding is the one before ties plus one byte: an empty list of tied nodes.
    let mut without = base.clone();
    without.tied.push(crate::artifact::TiedNode::default());
    let (with_empty, with_one) = (
        Artifact::Model(Box::new(base)).encode(),
        Artifact::Model(Box::new(without)).encode(),
    );
    assert_eq!(with_empty.last(), Some(&0));
    assert_eq!(with_one.len(), with_empty.len() + 2);

    // The coarse brake's model (the quick study's) has the matrices it had before ties: the
    // digest of M, C, K recorded from the build before them.
    let (model, _) = crate::fixtures::assemble(&crate::fixtures::coarse_brake(), "hub, pad_backs");
    assert!(model.tied.is_empty());
    let fingerprint: String = model
        .fingerprint()
        .iter()
        .map(|byte| format!("{byte:02x}"))
        .collect();
    assert_eq!(
        fingerprint,
        "6f79ff6bc73a061fe20ef1fbf2ac92ec689bb600ea38a8a4e72b91d7628dfe41"
    );
}

/// A cantilever of length 1 m and square section 0.1 m along x, clamped at x = 0, as one block
/// meshed `counts` (conforming), or as two halves meshed `left` and `right` across (each
/// `n_half` elements along x), the right half's end face tied to the left half's.
fn beam(halves: Option<([usize; 2], [usize; 2])>, counts: [usize; 3]) -> (Mesh, String) {
    let mut mesh = Mesh::default();
    match halves {
        None => {
            add_block(&mut mesh, "left", [0.0; 3], [1.0, 0.1, 0.1], counts);
            mesh.node_sets
                .insert("tip".into(), mesh.node_sets["left_x1"].clone());
            (mesh, String::new())
        }
        Some((left, right)) => {
            let n_half = counts[0] / 2;
            add_block(
                &mut mesh,
                "left",
                [0.0; 3],
                [0.5, 0.1, 0.1],
                [n_half, left[0], left[1]],
            );
            add_block(
                &mut mesh,
                "right",
                [0.5, 0.0, 0.0],
                [0.5, 0.1, 0.1],
                [n_half, right[0], right[1]],
            );
            mesh.node_sets
                .insert("tip".into(), mesh.node_sets["right_x1"].clone());
            (mesh, "right_x0 -> left_x1".into())
        }
    }
}

/// The tip deflection (mean u_z over the end face) under a total shear load of 1 kN, and the
/// two lowest eigenfrequencies (Hz).
fn bend_and_vibrate(mesh: &Mesh, ties: &str, method: TieMethod) -> (f64, [f64; 2]) {
    let model = run_stage(
        mesh,
        &[
            ("clamped", Value::Str("left_x0".into())),
            ("ties", Value::Str(ties.into())),
            ("tie_method", Value::Str(method.name().into())),
        ],
    )
    .unwrap();
    let load = 1e3;
    let forces = traction_load(&model, "tip", [0.0, 0.0, -load / (0.1 * 0.1)]);
    let u = solve(&model, &forces);
    let tip = &mesh.node_sets["tip"];
    let deflection = -tip
        .iter()
        .map(|&node| model.node_displacement(node, &u)[2])
        .sum::<f64>()
        / tip.len() as f64;
    let modes = Modes
        .run(
            &Params::defaults(&Modes, &[("n_modes", Value::Int(2))]),
            &Inputs(BTreeMap::from([(
                "model".to_string(),
                Input::One(Arc::new(Artifact::Model(Box::new(model)))),
            )])),
        )
        .unwrap();
    let frequencies = modes["frequencies"]
        .as_table()
        .unwrap()
        .f64("freq_hz")
        .unwrap();
    (deflection, [frequencies[0], frequencies[1]])
}

#[test]
fn a_beam_tied_across_a_non_matching_cut_bends_and_vibrates_as_the_whole_beam() {
    // Left half 2 × 2 across, right half 3 × 3 (and the reverse), tied at x = 0.5 either side
    // the slave; the same beam meshed whole at either density (their deflections 0.05 %
    // apart). Against the mean of the two whole beams: the tip deflection within 0.5 %
    // (mortar) or 1.5 % (collocation, a coarse slave on a fine master is the worse), the two
    // first (bending) frequencies within 0.5 %.
    let n_length = 20;
    let whole: Vec<(f64, [f64; 2])> = [2, 3]
        .iter()
        .map(|&n| {
            let (mesh, ties) = beam(None, [n_length, n, n]);
            bend_and_vibrate(&mesh, &ties, TieMethod::Collocation)
        })
        .collect();
    let reference_deflection = 0.5 * (whole[0].0 + whole[1].0);
    let reference_frequency = 0.5 * (whole[0].1[0] + whole[1].1[0]);
    // Euler–Bernoulli for scale: P L³ / 3 E I.
    let bernoulli = 1e3 / (3.0 * E * 0.1f64.powi(4) / 12.0);
    println!(
        "whole beam: deflection {:.4e} m (2 × 2) and {:.4e} m (3 × 3), Euler–Bernoulli {bernoulli:.4e} m; \
         first frequencies {:.2} and {:.2} Hz",
        whole[0].0, whole[1].0, whole[0].1[0], whole[1].1[0]
    );
    for method in [TieMethod::Mortar, TieMethod::Collocation] {
        for (left, right) in [([2, 2], [3, 3]), ([3, 3], [2, 2])] {
            let (mesh, _) = beam(Some((left, right)), [n_length, 0, 0]);
            for ties in ["right_x0 -> left_x1", "left_x1 -> right_x0"] {
                let (deflection, frequencies) = bend_and_vibrate(&mesh, ties, method);
                let ratio = deflection / reference_deflection;
                println!(
                    "{method}-tied {left:?} | {right:?} ({ties}): deflection {deflection:.4e} m, \
                     ratio {ratio:.5}; frequencies {:.2}, {:.2} Hz, ratios {:.5}, {:.5}",
                    frequencies[0],
                    frequencies[1],
                    frequencies[0] / reference_frequency,
                    frequencies[1] / reference_frequency
                );
                let tolerance = match method {
                    TieMethod::Mortar => 0.005,
                    TieMethod::Collocation => 0.015,
                };
                assert!(
                    (ratio - 1.0).abs() < tolerance,
                    "{method} {ties}: deflection ratio {ratio}"
                );
                for frequency in frequencies {
                    let ratio = frequency / reference_frequency;
                    assert!(
                        (ratio - 1.0).abs() < 0.005,
                        "{method} {ties}: frequency ratio {ratio}"
                    );
                }
            }
        }
    }
}

#[test]
fn contact_pairs_read_the_masters_of_a_tied_node_and_refuse_a_tied_anchor() {
    let mut mesh = stacked([3, 3], [4, 5], ElementKind::Hex8);
    let slave = mesh.node_sets["upper_z0"][7];
    let free = mesh.node_sets["upper_z1"][0];
    let other = mesh.node_sets["upper_z1"][1];
    // A pair whose disc side is a tied node (and a free one), and an untied pair.
    mesh.contact_pairs = vec![
        ContactPair {
            pad: vec![(free, 1.0)],
            disc: vec![(slave, 0.25), (other, 0.75)],
            normal: [0.0, 0.0, 1.0],
            area: 1e-4,
        },
        ContactPair::node_to_node(other, free, [0.0, 0.0, 1.0], 1e-4),
    ];
    let model = run_stage(
        &mesh,
        &[
            ("clamped", Value::Str("lower_z0".into())),
            ("ties", Value::Str("upper_z0 -> lower_z1".into())),
        ],
    )
    .unwrap();
    let masters = model.masters(slave).unwrap().to_vec();
    let pair = &model.mesh.contact_pairs[0];
    assert_eq!(pair.pad, vec![(free, 1.0)]);
    // The tied node's masters where it stood, then the free node.
    let mut want: Vec<(u32, f64)> = masters
        .iter()
        .map(|&(master, weight)| (master, 0.25 * weight))
        .collect();
    want.push((other, 0.75));
    assert_eq!(pair.disc.len(), want.len());
    for ((node, weight), (want_node, want_weight)) in pair.disc.iter().zip(&want) {
        assert_eq!(node, want_node);
        assert!((weight - want_weight).abs() < 1e-15);
    }
    pair.check(mesh.n_nodes()).unwrap();
    assert_eq!(model.mesh.contact_pairs[1], mesh.contact_pairs[1]);
    assert!(
        model
            .mesh
            .contact_pairs
            .iter()
            .flat_map(|pair| pair.nodes())
            .all(|node| model.masters(node).is_none())
    );

    mesh.contact_pairs = vec![ContactPair::node_to_node(
        free,
        slave,
        [0.0, 0.0, 1.0],
        1e-4,
    )];
    assert_eq!(
        error(&mesh, "lower_z0", "upper_z0 -> lower_z1"),
        format!(
            "contact pair 0: its pad node {slave} (the pair's anchor, which carries its slave \
             DOF) is tied by `upper_z0 -> lower_z1`: contact needs nodes with DOFs of their own; \
             tie the other way round (`lower_z1 -> upper_z0`)"
        )
    );
}

#[test]
fn refused_ties_are_named_with_their_sets_and_the_figure_at_fault() {
    let mesh = stacked([3, 3], [4, 5], ElementKind::Hex8);
    // Not written `slave -> master`.
    assert_eq!(
        error(&mesh, "", "upper_z0 lower_z1"),
        "ties: `upper_z0 lower_z1` is not `slave_set -> master_set` (two node sets of the mesh)"
    );
    assert!(error(&mesh, "", "upper_z0 -> ").contains("`upper_z0 ->` is not"));
    // A set the mesh lacks, with those it has.
    let message = error(&mesh, "", "upper_z0 -> lining");
    assert!(
        message.starts_with(
            "tie `upper_z0 -> lining`: node set `lining` is not in the mesh (the mesh has: \
             lower_x0, lower_x1,"
        ),
        "{message}"
    );
    assert!(message.contains("upper_z1, x_axis)"), "{message}");
    // Overlapping sets: the block's side shares its bottom edge with the interface.
    let message = error(&mesh, "", "upper_x0 -> upper_z0");
    assert!(
        message.starts_with("tie `upper_x0 -> upper_z0`: node ")
            && message.ends_with(
                " is in both `upper_x0` and `upper_z0`: the slave and master sets must not \
                 overlap (a node cannot follow itself)"
            ),
        "{message}"
    );
    // A master set of one node holds no face.
    assert_eq!(
        error(&mesh, "", "upper_z0 -> origin"),
        "tie `upper_z0 -> origin`: master set `origin` holds no boundary face (all the nodes of \
         one element face), so `upper_z0` has no surface to follow"
    );
    // A node tied twice, and a chain (a slave that is another tie's master).
    let message = error(&mesh, "", "upper_z0 -> lower_z1, upper_z0 -> lower_z1");
    assert!(
        message.ends_with(
            "is tied twice, by `upper_z0 -> lower_z1` and by `upper_z0 -> lower_z1`: a node \
             follows one master surface"
        ),
        "{message}"
    );
    let message = error(&mesh, "", "upper_z0 -> lower_z1, lower_z1 -> upper_z0");
    assert!(
        message.contains(
            "is tied by `lower_z1 -> upper_z0` (a node of `lower_z1`) and is a master of \
             `upper_z0 -> lower_z1` (a node of `lower_z1`'s surface): chains of ties are refused"
        ),
        "{message}"
    );
    // A clamped slave node: the upper block's side holds the interface's edge.
    let message = error(&mesh, "upper_x0:z", "upper_z0 -> lower_z1");
    assert!(
        message.starts_with("tie `upper_z0 -> lower_z1`: node ")
            && message.contains(
                " of `upper_z0` is clamped (by `upper_x0`): a tied node has no DOF of its own \
                 and follows `lower_z1`"
            ),
        "{message}"
    );
    // A gap of 1 mm against a tie distance of 0.1 mm: the farthest node and its distance.
    let mut apart = mesh.clone();
    for &node in &mesh.node_sets["upper_z0"] {
        apart.nodes[node as usize][2] += 1e-3;
    }
    let message = error_within(&apart, "", "upper_z0 -> lower_z1", 1e-4);
    assert!(
        message.starts_with("tie `upper_z0 -> lower_z1`: node ")
            && message.ends_with(
                " of `upper_z0` is 1.000e-3 m from the surface of `lower_z1`, farther than \
                 tie_distance = 1.000e-4 m (30 of the 30 nodes of `upper_z0` are farther)"
            ),
        "{message}"
    );
    // Within 2 mm the same gap is tied.
    let model = assemble_model(
        &apart,
        &AssembleParams {
            tie_distance: 2e-3,
            ..params("", "upper_z0 -> lower_z1")
        },
    )
    .unwrap()
    .0;
    assert_eq!(model.tied.len(), 30);
    // A slave set far to the side of the master surface, where no face's closest point
    // converges: counted.
    let mut aside = mesh.clone();
    for &node in &mesh.node_sets["upper_z0"] {
        aside.nodes[node as usize][0] += 1e3;
    }
    let message = error_within(&aside, "", "upper_z0 -> lower_z1", 1e-4);
    assert!(
        message.starts_with(
            "tie `upper_z0 -> lower_z1`: 30 of the 30 nodes of `upper_z0` project nowhere on \
             the surface of `lower_z1`"
        ),
        "{message}"
    );
    // A tie distance that is no length.
    let message = error_within(&mesh, "", "upper_z0 -> lower_z1", f64::INFINITY);
    assert!(message.contains("tie_distance"), "{message}");

    // The mortar method: the same gap by the slave's weighted gaps; a slave set of no face;
    // a slave surface the master covers in part.
    let mortar = |mesh: &Mesh, ties: &str| {
        run_stage(
            mesh,
            &[
                ("clamped", Value::Str(String::new())),
                ("ties", Value::Str(ties.into())),
                ("tie_method", Value::Str("mortar".into())),
            ],
        )
        .map(|_| ())
        .unwrap_err()
        .message
    };
    let message = mortar(&apart, "upper_z0 -> lower_z1");
    assert!(
        message.starts_with("tie `upper_z0 -> lower_z1`: node ")
            && message.ends_with(
                " of `upper_z0` is 1.000e-3 m from the surface of `lower_z1`, farther than \
                 tie_distance = 1.000e-4 m (30 of the 30 nodes of `upper_z0` are farther)"
            ),
        "{message}"
    );
    assert_eq!(
        mortar(&mesh, "origin -> lower_z1"),
        "tie `origin -> lower_z1`: slave set `origin` holds no boundary face (all the nodes of \
         one element face), which the mortar method integrates over (collocation ties nodes \
         alone)"
    );
    let mut wider = mesh.clone();
    for &node in &mesh.node_sets["upper_z0"] {
        wider.nodes[node as usize][0] *= 1.5;
    }
    let message = mortar(&wider, "upper_z0 -> lower_z1");
    assert!(
        message.starts_with("tie `upper_z0 -> lower_z1`: ")
            && message.contains(
                " of the 30 nodes of `upper_z0` are not covered by the surface of `lower_z1` \
                 within tie_distance = 1.000e-4 m (the first node "
            ),
        "{message}"
    );
    let message = mortar(&aside, "upper_z0 -> lower_z1");
    assert!(
        message
            .starts_with("tie `upper_z0 -> lower_z1`: `upper_z0` projects nowhere on `lower_z1`"),
        "{message}"
    );
}
