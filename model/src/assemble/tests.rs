//! Verification of the assembly: exact mass, exact symmetry and reproducibility, the constant
//! strain patch test on a distorted mesh, Rayleigh damping per part, and clear errors.

use std::sync::Arc;

use super::Assemble;
use crate::artifact::material::{ElasticLaw, EngineeringConstants, Frame, Material};
use crate::artifact::{Artifact, ContactPair, Mesh, Model};
use crate::fixtures::{assemble, try_assemble};
use crate::mesh::structured;
use crate::stage::{Input, Inputs, Outputs, Stage, StageError};
use crate::stage::{Params, Value};
use crate::table::{ColumnData, Table};

/// `rᵀ M r` for the unit translation `r` along x: the total (free) mass.
fn translational_mass(model: &Model) -> f64 {
    let translation: Vec<f64> = (0..model.n_dofs())
        .map(|dof| if dof % 3 == 0 { 1.0 } else { 0.0 })
        .collect();
    let M_translation = model.M.mul_vec(&translation);
    translation
        .iter()
        .zip(&M_translation)
        .map(|(r, m)| r * m)
        .sum()
}

fn summary_total(summary: &Table, column: &str) -> f64 {
    match summary.column(column) {
        Some(ColumnData::F64(values)) => *values.last().unwrap(),
        other => panic!("summary column {column}: {other:?}"),
    }
}

#[test]
fn total_mass_is_exact_on_a_block() {
    let mesh = structured::block([0.2, 0.05, 0.03], [5, 3, 2], "disc");
    let (model, summary) = assemble(&mesh, "");
    let exact = 7850.0 * 0.2 * 0.05 * 0.03;
    let from_matrix = translational_mass(&model);
    assert!(
        (from_matrix - exact).abs() <= 1e-12 * exact,
        "{from_matrix} vs {exact}"
    );
    let from_table = summary_total(&summary, "mass_kg");
    assert!(
        (from_table - exact).abs() <= 1e-12 * exact,
        "{from_table} vs {exact}"
    );
    assert_eq!(model.n_dofs(), 3 * 6 * 4 * 3);
}

#[test]
fn total_mass_is_exact_on_an_annulus() {
    let (r_inner, r_outer, thickness, n_theta) = (0.1, 0.3, 0.02, 24);
    let mesh = structured::annulus(r_inner, r_outer, 0.0, thickness, [3, n_theta, 2], "pad");
    let (model, summary) = assemble(&mesh, "");
    // The mesh is the polygonal annulus between two regular 24-gons.
    let area = 0.5
        * n_theta as f64
        * (2.0 * std::f64::consts::PI / n_theta as f64).sin()
        * (r_outer * r_outer - r_inner * r_inner);
    let exact = 5102.0 * area * thickness;
    let from_matrix = translational_mass(&model);
    assert!(
        (from_matrix - exact).abs() <= 1e-12 * exact,
        "{from_matrix} vs {exact}"
    );
    let from_table = summary_total(&summary, "mass_kg");
    assert!(
        (from_table - exact).abs() <= 1e-12 * exact,
        "{from_table} vs {exact}"
    );
}

#[test]
fn matrices_are_exactly_symmetric_and_identical_on_any_thread_count() {
    let mut mesh = structured::annulus(0.05, 0.15, 0.0, 0.01, [3, 16, 2], "disc");
    mesh.nodes[40][2] += 0.001;
    let on_threads = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| assemble(&mesh, "inner").0)
    };
    let first = on_threads(1);
    for threads in [2, 3] {
        assert_eq!(
            Artifact::Model(Box::new(first.clone())).encode(),
            Artifact::Model(Box::new(on_threads(threads))).encode(),
            "{threads} threads"
        );
    }
    for A in [&first.K, &first.M, &first.C] {
        let dense = A.to_dense();
        for i in 0..A.n_rows {
            for j in 0..i {
                assert_eq!(dense[(i, j)].to_bits(), dense[(j, i)].to_bits());
            }
        }
    }
    // M, K and C share one pattern.
    assert_eq!(first.K.row_idx, first.M.row_idx);
    assert_eq!(first.K.col_ptr, first.C.col_ptr);
}

#[test]
fn clamped_node_sets_lose_their_dofs() {
    let mesh = structured::block([0.3, 0.1, 0.1], [3, 2, 2], "disc");
    let (model, summary) = assemble(&mesh, " x0 , y1 ");
    let clamped: std::collections::BTreeSet<u32> = mesh.node_sets["x0"]
        .iter()
        .chain(&mesh.node_sets["y1"])
        .copied()
        .collect();
    assert_eq!(model.n_dofs(), 3 * (mesh.n_nodes() - clamped.len()));
    for (node, dofs) in model.dof_of_node.iter().enumerate() {
        assert_eq!(dofs[0].is_none(), clamped.contains(&(node as u32)));
    }
    assert_eq!(
        summary.column("n_dofs"),
        Some(&ColumnData::I64(vec![model.n_dofs() as i64; 2]))
    );
}

#[test]
fn rayleigh_damping_is_taken_per_part() {
    // Two elements along x: element 0 is disc, element 1 is pad.
    let mut mesh = structured::block([2.0, 1.0, 1.0], [2, 1, 1], "disc");
    mesh.parts.push("pad".into());
    mesh.elements.set_part(1, 1);
    let (model, summary) = assemble(&mesh, "");
    let (disc_alpha, disc_beta, pad_alpha, pad_beta) = (3.75, 5e-8, 54.375, 72.5e-8);
    // Node 0 (x = 0) belongs to the disc element only, node 2 (x = 2) to the pad only.
    for (node, alpha, beta) in [(0usize, disc_alpha, disc_beta), (2, pad_alpha, pad_beta)] {
        let col = model.dof_of_node[node][0].unwrap() as usize;
        for entry in model.K.col_ptr[col]..model.K.col_ptr[col + 1] {
            let expected = alpha * model.M.values[entry] + beta * model.K.values[entry];
            let scale = expected.abs().max(1e-300);
            assert!((model.C.values[entry] - expected).abs() <= 1e-14 * scale.max(1.0));
        }
    }
    let masses = match summary.column("mass_kg") {
        Some(ColumnData::F64(values)) => values.clone(),
        other => panic!("{other:?}"),
    };
    assert!((masses[0] - 7850.0).abs() < 1e-9 && (masses[1] - 5102.0).abs() < 1e-9);
}

#[test]
fn inverted_element_is_named_with_its_det_j() {
    let mut mesh = structured::block([1.0, 1.0, 1.0], [3, 2, 2], "disc");
    // Mirror element 4 by swapping its bottom and top faces.
    let hex = mesh.elements.nodes(4).to_vec();
    mesh.elements.nodes_mut(4).copy_from_slice(&[
        hex[4], hex[5], hex[6], hex[7], hex[0], hex[1], hex[2], hex[3],
    ]);
    let err = try_assemble(&mesh, "").unwrap_err();
    assert!(
        err.message.contains("1 inverted or degenerate element"),
        "{err}"
    );
    assert!(err.message.contains("element 4 (det J = -"), "{err}");
}

/// A contact pair the stages could not read (a node out of range, weights that do not sum to
/// one, a normal that is no direction, no area) is refused before anything is assembled.
#[test]
fn a_broken_contact_pair_is_named_with_what_is_wrong() {
    let brake = crate::fixtures::small_brake();
    for (break_pair, expected) in [
        (
            (|pair: &mut ContactPair| pair.disc[0].0 = 1_000_000) as fn(&mut ContactPair),
            "contact pair 3: the disc side names node 1000000, but the mesh has",
        ),
        (
            |pair| pair.pad[0].1 = 0.5,
            "contact pair 3: the pad side's weights sum to 0.5, not 1",
        ),
        (
            |pair| pair.normal = [0.0, 0.0, 2.0],
            "contact pair 3: its normal [0.0, 0.0, 2.0] is not a unit vector (length 2)",
        ),
        (
            |pair| pair.area = f64::NAN,
            "contact pair 3: its area NaN m² is not positive",
        ),
    ] {
        let mut mesh = brake.clone();
        break_pair(&mut mesh.contact_pairs[3]);
        let err = try_assemble(&mesh, "hub, pad_backs").unwrap_err();
        assert!(err.message.contains(expected), "{err}");
    }
}

#[test]
fn unknown_part_and_missing_node_sets_are_errors() {
    let mesh = structured::block([1.0, 1.0, 1.0], [1, 1, 1], "caliper");
    let err = try_assemble(&mesh, "").unwrap_err();
    assert!(
        err.message.contains("part `caliper` has no material"),
        "{err}"
    );

    let mesh = structured::block([1.0, 1.0, 1.0], [1, 1, 1], "disc");
    let err = try_assemble(&mesh, "hub,pad_backs").unwrap_err();
    assert!(
        err.message
            .contains("clamped node sets not in the mesh: hub, pad_backs"),
        "{err}"
    );
}

#[test]
fn non_physical_material_is_an_error() {
    let mesh = structured::block([1.0, 1.0, 1.0], [1, 1, 1], "disc");
    let params = Params::defaults(
        &Assemble,
        &[
            ("clamped", Value::Str(String::new())),
            ("nu_disc", Value::Float(0.5)),
        ],
    )
    .read::<Assemble>()
    .unwrap();
    let err = super::assemble_model(&mesh, &params).unwrap_err();
    assert!(
        err.message.contains("nu = 0.5") && err.message.contains("`*_disc` parameters"),
        "{err}"
    );
}

fn isotropic(parts: &[&str], youngs_modulus: f64, density: f64) -> Material {
    Material {
        name: parts.join(", "),
        parts: parts.iter().map(|part| part.to_string()).collect(),
        law: ElasticLaw::Isotropic {
            youngs_modulus,
            poisson_ratio: 0.3,
        },
        density,
        alpha: 1.0,
        beta: 1e-7,
    }
}

/// `assemble` run as a study runs it, with `materials` connected and `params` set.
fn run_with_materials(
    mesh: &Mesh,
    materials: &[Material],
    params: &[(&str, Value)],
) -> Result<Outputs, StageError> {
    let mut values = vec![("clamped", Value::Str(String::new()))];
    values.extend(params.iter().cloned());
    let params = Params::defaults(&Assemble, &values);
    let listed = materials
        .iter()
        .map(|material| {
            let artifact = Artifact::Material(Box::new(material.clone()));
            (Default::default(), Arc::new(artifact))
        })
        .collect();
    let inputs = Inputs(
        [
            (
                "mesh".to_string(),
                Input::One(Arc::new(Artifact::Mesh(Box::new(mesh.clone())))),
            ),
            ("materials".to_string(), Input::Many(listed)),
        ]
        .into(),
    );
    Assemble.run(&params, &inputs)
}

/// Two blocks side by side, parts `ring` and `lining`.
fn two_parts() -> Mesh {
    let mut mesh = structured::block([0.1, 0.05, 0.02], [4, 2, 1], "ring");
    let lining = structured::block([0.1, 0.05, 0.01], [4, 2, 1], "lining");
    let offset = mesh.nodes.len() as u32;
    mesh.nodes
        .extend(lining.nodes.iter().map(|[x, y, z]| [*x, *y, z + 0.02]));
    mesh.elements.extend_shifted(&lining.elements, offset, 1);
    mesh.parts.push("lining".into());
    mesh
}

#[test]
fn materials_fill_the_parts_they_name_whatever_the_parts_are_called() {
    let mesh = two_parts();
    let outputs = run_with_materials(
        &mesh,
        &[
            isotropic(&["lining"], 3e8, 2000.0),
            isotropic(&["ring"], 2e11, 7000.0),
        ],
        &[],
    )
    .unwrap();
    let Artifact::Table(summary) = &outputs["summary"] else {
        panic!("a summary table")
    };
    let Some(ColumnData::F64(masses)) = summary.column("mass_kg") else {
        panic!("masses")
    };
    // Rounding only: volume × density of each block.
    let expected = [7000.0 * 0.1 * 0.05 * 0.02, 2000.0 * 0.1 * 0.05 * 0.01];
    for (mass, expected) in masses.iter().zip(expected) {
        assert!((mass - expected).abs() <= 1e-12 * expected, "{masses:?}");
    }
}

#[test]
fn materials_equal_to_the_short_form_give_the_same_model_bit_for_bit() {
    let mesh = structured::stacked_blocks(0.02, 0.03, 0.01);
    let short = Params::defaults(&Assemble, &[("clamped", Value::Str(String::new()))])
        .read::<Assemble>()
        .unwrap();
    let (short_model, _) = super::assemble_model(&mesh, &short).unwrap();
    let materials = [
        short.material("pad").unwrap(),
        short.material("disc").unwrap(),
    ];
    let outputs = run_with_materials(&mesh, &materials, &[]).unwrap();
    let Artifact::Model(model) = &outputs["model"] else {
        panic!("a model")
    };
    assert_eq!(**model, short_model);
}

#[test]
fn a_part_without_material_or_a_material_without_part_is_named_with_both() {
    let mesh = two_parts();
    let error = |materials: &[Material], params: &[(&str, Value)]| {
        run_with_materials(&mesh, materials, params)
            .unwrap_err()
            .message
    };
    let ring = isotropic(&["ring"], 2e11, 7000.0);
    assert_eq!(
        error(std::slice::from_ref(&ring), &[]),
        "part `lining` of the mesh has no material (the materials name `ring`)"
    );
    assert_eq!(
        error(&[ring.clone(), isotropic(&["linings"], 3e8, 2000.0)], &[]),
        "material `linings` names part `linings`, which the mesh does not have (its parts: ring, lining)"
    );
    assert_eq!(
        error(
            &[ring.clone(), isotropic(&["lining", "ring"], 3e8, 2000.0)],
            &[]
        ),
        "part `ring` is named by two materials, `ring` and `lining, ring`"
    );
    let both = [ring, isotropic(&["lining"], 3e8, 2000.0)];
    assert_eq!(
        error(&both, &[("E_pad", Value::Float(1e9))]),
        "`E_pad` is the short form for meshes of parts `disc` and `pad`: with `materials` \
         connected, give every constant in the materials"
    );
}

#[test]
fn a_cylindrical_frame_through_an_element_is_refused() {
    // The axis runs through the centre of the block's only element.
    let mesh = structured::block([0.02, 0.02, 0.02], [1, 1, 1], "disc");
    let material = Material {
        law: ElasticLaw::Orthotropic {
            constants: EngineeringConstants::isotropic(2e11, 0.3),
            frame: Frame::Cylindrical {
                origin: [0.01, 0.01, 0.0],
                axis: [0.0, 0.0, 1.0],
            },
        },
        ..isotropic(&["disc"], 2e11, 7850.0)
    };
    let message = run_with_materials(&mesh, &[material], &[])
        .unwrap_err()
        .message;
    assert!(
        message.starts_with("material `disc`: the cylindrical frame has no radial direction"),
        "{message}"
    );
}
