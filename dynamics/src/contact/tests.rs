//! The frames, H and g₀ of node-to-node and weighted pairs.

use super::*;
use crate::artifact::CscMatrix;
use crate::mesh::brake::{BrakeGeometry, brake};

#[test]
fn frames_follow_the_rotation_and_are_orthonormal() {
    let geometry = BrakeGeometry::coarse();
    let mesh = brake(&geometry).unwrap();
    let omega = 4.0;
    let frames = super::frames(&mesh, omega).unwrap();
    for (pair_idx, pair) in mesh.contact_pairs.iter().enumerate() {
        let x = pair.disc_position(&mesh.nodes);
        let radius = (x[0] * x[0] + x[1] * x[1]).sqrt();
        assert!((frames.sliding_speed[pair_idx] - omega * radius).abs() < 1e-12);
        let (n, t, b) = (frames.n[pair_idx], frames.t[pair_idx], frames.b[pair_idx]);
        for (u, v, expected) in [
            (n, n, 1.0),
            (t, t, 1.0),
            (b, b, 1.0),
            (n, t, 0.0),
            (n, b, 0.0),
            (t, b, 0.0),
        ] {
            assert!((dot(u, v) - expected).abs() < 1e-14);
        }
        // t is along e_z × x: counter-clockwise seen from +z for ω > 0.
        assert!((t[0] * -x[1] + t[1] * x[0]) / radius > 1.0 - 1e-14);
    }
    assert!(
        super::frames(&mesh, 0.0)
            .unwrap_err()
            .contains("has no sliding direction")
    );
}

/// A model of `nodes`, every DOF free, with `pairs` (no matrices: H and the frames read only the
/// mesh and the DOF map).
fn free_model(nodes: Vec<[f64; 3]>, pairs: Vec<ContactPair>) -> Model {
    let dof_of_node = (0..nodes.len() as u32)
        .map(|node| [Some(3 * node), Some(3 * node + 1), Some(3 * node + 2)])
        .collect();
    Model {
        mesh: Mesh {
            nodes,
            contact_pairs: pairs,
            ..Mesh::default()
        },
        dof_of_node,
        M: CscMatrix::default(),
        K: CscMatrix::default(),
        C: CscMatrix::default(),
        tied: Vec::new(),
    }
}

/// A column of Hᵀ as a dense vector over `n` DOFs.
fn dense(column: &[(usize, f64)], n: usize) -> Vec<f64> {
    let mut dense = vec![0.0; n];
    for &(dof, value) in column {
        dense[dof] += value;
    }
    dense
}

#[test]
fn a_pad_node_facing_the_midpoint_of_two_disc_nodes_is_the_average_of_the_two_node_to_node_pairs() {
    // Disc nodes 1 and 2 on a radius (so that both slide along the same t), the pad node 0
    // above their midpoint with a gap of 1 mm; a tilted normal, so that every axis counts.
    let nodes = vec![[0.25, 0.0, 1e-3], [0.2, 0.0, 0.0], [0.3, 0.0, 0.0]];
    let normal = {
        let n = [0.1, 0.0, 1.0];
        let length = dot(n, n).sqrt();
        n.map(|c| c / length)
    };
    let weighted = ContactPair {
        pad: vec![(0, 1.0)],
        disc: vec![(1, 0.5), (2, 0.5)],
        normal,
        area: 1e-4,
    };
    let single = [1, 2].map(|disc| ContactPair::node_to_node(disc, 0, normal, 1e-4));
    let model = free_model(
        nodes.clone(),
        vec![weighted.clone(), single[0].clone(), single[1].clone()],
    );
    let omega = 4.0;
    let frames = super::frames(&model.mesh, omega).unwrap();
    let columns = h_columns(&model, &frames);
    let n = 3 * nodes.len();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * (1.0 + a.abs().max(b.abs()));
    let close3 = |a: [f64; 3], b: [f64; 3]| (0..3).all(|axis| close(a[axis], b[axis]));
    let average3 = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|axis| 0.5 * (a[axis] + b[axis]));
    // Frames: the same n, t, b, and the average sliding speed (v_g is linear in x).
    assert!(close3(frames.n[0], average3(frames.n[1], frames.n[2])));
    assert!(close3(frames.t[0], average3(frames.t[1], frames.t[2])));
    assert!(close3(frames.b[0], average3(frames.b[1], frames.b[2])));
    assert!(close(
        frames.sliding_speed[0],
        0.5 * (frames.sliding_speed[1] + frames.sliding_speed[2])
    ));
    assert!(close(frames.sliding_speed[0], omega * 0.25));
    // H: each of the three columns the average of the node-to-node pairs'.
    for direction in 0..3 {
        let (w, a, b) = (
            dense(&columns[direction], n),
            dense(&columns[3 + direction], n),
            dense(&columns[6 + direction], n),
        );
        for dof in 0..n {
            assert!(
                close(w[dof], 0.5 * (a[dof] + b[dof])),
                "direction {direction}, DOF {dof}: {} vs {}",
                w[dof],
                0.5 * (a[dof] + b[dof])
            );
        }
    }
    // g₀: the average of the two pairs' gaps, here n_z · 1 mm.
    let gaps = model
        .mesh
        .contact_pairs
        .iter()
        .zip(&frames.n)
        .map(|(pair, n)| initial_gap(pair, &nodes, *n))
        .collect::<Vec<f64>>();
    assert!(close(gaps[0], 0.5 * (gaps[1] + gaps[2])));
    assert!(close(gaps[0], normal[2] * 1e-3));
}

#[test]
fn node_to_node_pairs_read_their_nodes_exactly() {
    // One entry of weight 1.0: positions, signed zeros included, and the column's entries as
    // they were (e_d on the pad node, −e_d on the disc node).
    let nodes = vec![[-0.0, 0.3, 0.0], [0.1, -0.0, 1e-3]];
    let pair = ContactPair::node_to_node(0, 1, [0.0, 0.0, 1.0], 1e-4);
    for (got, expected) in [
        (pair.disc_position(&nodes), nodes[0]),
        (pair.pad_position(&nodes), nodes[1]),
    ] {
        assert_eq!(got.map(f64::to_bits), expected.map(f64::to_bits));
    }
    let model = free_model(vec![[0.2, 0.0, 0.0], [0.2, 0.0, 0.0]], vec![pair]);
    let frames = super::frames(&model.mesh, 4.0).unwrap();
    let columns = h_columns(&model, &frames);
    for (direction, column) in columns.iter().enumerate() {
        let e = [frames.n[0], frames.t[0], frames.b[0]][direction];
        let expected: Vec<(usize, f64)> = (0..3)
            .filter(|&axis| e[axis] != 0.0)
            .map(|axis| (3 + axis, e[axis]))
            .chain(
                (0..3)
                    .filter(|&axis| e[axis] != 0.0)
                    .map(|axis| (axis, -e[axis])),
            )
            .collect();
        assert_eq!(*column, expected);
    }
}

#[test]
fn entries_of_one_dof_are_merged_in_a_column() {
    // A quadratic-face row: the mid-edge pad node 0 at 5/3, its corners 1 and 2 at −1/3, and a
    // disc side naming node 3 twice (½ + ½).
    let nodes = vec![
        [0.25, 0.0, 0.0],
        [0.2, 0.0, 0.0],
        [0.3, 0.0, 0.0],
        [0.25, 0.0, 0.0],
    ];
    let pair = ContactPair {
        pad: vec![(0, 5.0 / 3.0), (1, -1.0 / 3.0), (2, -1.0 / 3.0)],
        disc: vec![(3, 0.5), (3, 0.5)],
        normal: [0.0, 0.0, 1.0],
        area: 1e-4,
    };
    assert!(pair.check(nodes.len()).is_ok());
    let model = free_model(nodes, vec![pair]);
    let frames = super::frames(&model.mesh, 4.0).unwrap();
    let normal_column = &h_columns(&model, &frames)[0];
    let mut dofs: Vec<usize> = normal_column.iter().map(|&(dof, _)| dof).collect();
    dofs.dedup();
    assert_eq!(dofs, [2, 5, 8, 11]);
    assert_eq!(normal_column[3], (11, -1.0));
    assert_eq!(normal_column[0], (2, 5.0 / 3.0));
}
