use std::collections::BTreeMap;

use super::*;
use crate::artifact::ElementKind;
use crate::mesh::convert::as_kind;
use crate::mesh::structured::block;

const WIDTH: f64 = 0.06;

/// A disc block of `disc` (x, y) cells under a pad block of `pad` cells, both `WIDTH` square,
/// touching at z = 0.02, each of element `kind`; with the disc's top and the pad's bottom
/// node sets.
fn stack(disc: [usize; 2], pad: [usize; 2], kind: ElementKind) -> (Mesh, Vec<u32>, Vec<u32>) {
    let lower = as_kind(
        &block([WIDTH, WIDTH, 0.02], [disc[0], disc[1], 2], "disc"),
        kind,
    );
    let upper = as_kind(
        &block([WIDTH, WIDTH, 0.01], [pad[0], pad[1], 1], "pad"),
        kind,
    );
    let mut mesh = lower.clone();
    let offset = mesh.nodes.len() as u32;
    mesh.nodes
        .extend(upper.nodes.iter().map(|x| [x[0], x[1], x[2] + 0.02]));
    mesh.elements.extend_shifted(&upper.elements, offset, 1);
    mesh.parts.push("pad".into());
    mesh.node_sets = BTreeMap::new();
    let top = lower.node_sets["z1"].clone();
    let bottom = upper.node_sets["z0"].iter().map(|n| n + offset).collect();
    (mesh, top, bottom)
}

fn pairs_of(disc: [usize; 2], pad: [usize; 2], kind: ElementKind) -> (Mesh, Vec<ContactPair>) {
    let (mesh, top, bottom) = stack(disc, pad, kind);
    let (pairs, coverage) = mortar_pairs(
        &mesh,
        &Side::new("disc_top", top),
        &Side::new("pad_bottom", bottom),
        1e-3,
    )
    .unwrap();
    assert!((coverage.covered - 1.0).abs() < 1e-12, "{coverage:?}");
    assert!(coverage.largest_gap.abs() < 1e-15 && coverage.largest_penetration < 1e-15);
    (mesh, pairs)
}

/// The consistent nodal areas ∫ N dA of a uniform grid of `cells` on the `WIDTH` square.
fn grid_area(x: [f64; 3], cells: [usize; 2]) -> f64 {
    let share = |coordinate: f64, n: usize| {
        let edge = coordinate.abs() < 1e-12 || (coordinate - WIDTH).abs() < 1e-12;
        WIDTH / n as f64 * if edge { 0.5 } else { 1.0 }
    };
    share(x[0], cells[0]) * share(x[1], cells[1])
}

#[test]
fn coincident_faces_pair_each_pad_node_with_its_disc_node_by_weight_one() {
    let (mesh, pairs) = pairs_of([3, 2], [3, 2], ElementKind::Hex8);
    assert_eq!(pairs.len(), 12);
    for pair in &pairs {
        let ([(pad, s)], [(disc, p)]) = (&pair.pad[..], &pair.disc[..]) else {
            panic!("not node to node: {pair:?}");
        };
        assert!(
            (s - 1.0).abs() < 1e-12 && (p - 1.0).abs() < 1e-12,
            "{pair:?}"
        );
        let (x, y) = (mesh.nodes[*pad as usize], mesh.nodes[*disc as usize]);
        assert!(x.iter().zip(y).all(|(a, b)| (a - b).abs() < 1e-15));
        assert!((pair.normal[2] - 1.0).abs() < 1e-15, "{:?}", pair.normal);
        assert!((pair.area - grid_area(x, [3, 2])).abs() < 1e-15 * WIDTH * WIDTH);
    }
}

/// Both ways round, of linear and quadratic faces: the pairs cover the square, each pad node
/// sits where its disc weights put it (an affine field reproduced, the gap zero), and a uniform
/// pressure loads every disc node with its consistent area.
#[test]
fn non_matching_faces_transmit_a_uniform_pressure_as_the_consistent_loads_of_both_sides() {
    for (disc, pad, kind) in [
        ([3, 3], [4, 4], ElementKind::Hex8),
        ([4, 4], [3, 3], ElementKind::Hex8),
        ([2, 3], [3, 2], ElementKind::Hex20),
        ([3, 2], [2, 2], ElementKind::Tet10),
    ] {
        let what = format!("{kind:?}, disc {disc:?}, pad {pad:?}");
        let (mesh, pairs) = pairs_of(disc, pad, kind);
        let total: f64 = pairs.iter().map(|pair| pair.area).sum();
        assert!(
            (total - WIDTH * WIDTH).abs() < 1e-12 * WIDTH * WIDTH,
            "{what}"
        );
        let mut disc_load: BTreeMap<u32, f64> = BTreeMap::new();
        for pair in &pairs {
            let (x_pad, x_disc) = (
                pair.pad_position(&mesh.nodes),
                pair.disc_position(&mesh.nodes),
            );
            for axis in 0..3 {
                assert!(
                    (x_pad[axis] - x_disc[axis]).abs() < 1e-14,
                    "{what}: {pair:?}"
                );
            }
            for &(node, weight) in &pair.disc {
                *disc_load.entry(node).or_default() += pair.area * weight;
            }
        }
        if kind == ElementKind::Hex8 {
            for (node, load) in disc_load {
                let expected = grid_area(mesh.nodes[node as usize], disc);
                assert!(
                    (load - expected).abs() < 1e-12 * WIDTH * WIDTH,
                    "{what}: node {node}"
                );
            }
        }
    }
}

#[test]
fn a_pad_away_from_the_disc_and_a_node_on_both_sides_are_refused_with_the_sides_named() {
    let (mut mesh, top, bottom) = stack([2, 2], [2, 2], ElementKind::Hex8);
    let err = mortar_pairs(
        &mesh,
        &Side::new("disc_top", top.clone()),
        &Side::new("pad_bottom", top.clone()),
        1e-3,
    )
    .unwrap_err();
    assert!(
        err.contains("is on both `disc_top` and `pad_bottom`"),
        "{err}"
    );
    for &node in &bottom {
        mesh.nodes[node as usize][2] += 0.5;
    }
    let err = mortar_pairs(
        &mesh,
        &Side::new("disc_top", top),
        &Side::new("pad_bottom", bottom),
        1e-3,
    )
    .unwrap_err();
    assert!(
        err.contains("pad_bottom") && err.contains("disc_top"),
        "{err}"
    );
}

fn covered_fraction(table: &Table) -> f64 {
    match table.column("covered_fraction") {
        Some(crate::table::ColumnData::F64(values)) => values[0],
        other => panic!("covered_fraction: {other:?}"),
    }
}

fn run_stage(mesh: &Mesh, values: &[(&str, &str)]) -> Result<(Mesh, Table), StageError> {
    use crate::stage::{Input, Value};
    let values: Vec<(&str, Value)> = values
        .iter()
        .map(|&(name, value)| {
            let value = match value.parse::<f64>() {
                Ok(number) => Value::Float(number),
                Err(_) => Value::Str(value.to_string()),
            };
            (name, value)
        })
        .collect();
    let params = Params::defaults(&ContactMortar, &values);
    let inputs = Inputs(BTreeMap::from([(
        "mesh".to_string(),
        Input::One(std::sync::Arc::new(Artifact::Mesh(Box::new(mesh.clone())))),
    )]));
    let mut outputs = ContactMortar.run(&params, &inputs)?;
    let (Some(Artifact::Mesh(mesh)), Some(Artifact::Table(table))) =
        (outputs.remove("mesh"), outputs.remove("interface"))
    else {
        panic!("contact.mortar gives a mesh and a table");
    };
    Ok((*mesh, table))
}

/// The coincident interface of the parametric brake: the stage's pairs are the brake's own
/// node-to-node pairs (the same nodes, normals and areas, in another order).
#[test]
fn the_stage_gives_the_brakes_node_to_node_pairs_on_its_coincident_interface() {
    let brake = crate::fixtures::coarse_brake();
    let (paired, table) = run_stage(&brake, &[]).unwrap();
    assert_eq!(paired.contact_pairs.len(), brake.contact_pairs.len());
    let key = |pair: &ContactPair| pair.pad[0].0;
    let mut expected = brake.contact_pairs.clone();
    expected.sort_by_key(key);
    let mut found = paired.contact_pairs.clone();
    found.sort_by_key(key);
    for (mortar, conforming) in found.iter().zip(&expected) {
        assert_eq!(mortar.pad.len(), 1, "{mortar:?}");
        assert_eq!(mortar.disc.len(), 1, "{mortar:?}");
        assert_eq!(mortar.pad[0].0, conforming.pad[0].0);
        assert_eq!(mortar.disc[0].0, conforming.disc[0].0);
        assert!((mortar.pad[0].1 - 1.0).abs() < 1e-12 && (mortar.disc[0].1 - 1.0).abs() < 1e-12);
        for axis in 0..3 {
            assert!((mortar.normal[axis] - conforming.normal[axis]).abs() < 1e-12);
        }
        assert!(
            (mortar.area - conforming.area).abs() < 1e-12 * conforming.area,
            "{} against {}",
            mortar.area,
            conforming.area
        );
    }
    assert_eq!(table.n_rows(), 1);
    let covered = covered_fraction(&table);
    assert!((covered - 1.0).abs() < 1e-12, "{covered}");
}

#[test]
fn the_stage_refuses_a_missing_set_a_side_too_far_and_a_fraction_above_one() {
    let (mut mesh, top, bottom) = stack([2, 2], [3, 3], ElementKind::Hex8);
    mesh.node_sets.insert("disc_top".into(), top);
    mesh.node_sets.insert("pad_bottom".into(), bottom.clone());
    let sides = [("disc", "disc_top"), ("pad", "pad_bottom")];
    let (paired, _) = run_stage(&mesh, &sides).unwrap();
    assert_eq!(paired.contact_pairs.len(), 16);

    let err = run_stage(&mesh, &[("disc", "disc_top"), ("pad", "lining")]).unwrap_err();
    assert!(
        err.to_string().contains(
            "pad: the mesh has no node set `lining` (its node sets: disc_top, pad_bottom)"
        ),
        "{err}"
    );
    let err = run_stage(&mesh, &[sides[0], sides[1], ("min_coverage", "1.5")]).unwrap_err();
    assert!(err.to_string().contains("at most 1, not 1.5"), "{err}");

    // Half the pad hangs off the disc: 50 % found, below the 90 % asked.
    for &node in &bottom {
        mesh.nodes[node as usize][0] += WIDTH / 2.0;
    }
    let err = run_stage(&mesh, &sides).unwrap_err();
    assert!(
        err.to_string()
            .contains("`pad_bottom` finds `disc_top` on 50.0 % of its area"),
        "{err}"
    );
    let (_, table) = run_stage(&mesh, &[sides[0], sides[1], ("min_coverage", "0.4")]).unwrap();
    assert!((covered_fraction(&table) - 0.5).abs() < 1e-12);
}
