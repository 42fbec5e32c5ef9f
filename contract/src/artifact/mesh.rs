//! Meshes of 8-node hexahedra, with parts (one material each), named node sets and the
//! node-to-node contact pairs of conforming pad/disc interfaces.
//!
//! Node order of a hexahedron (as VTK_HEXAHEDRON and Gmsh): nodes 0-1-2-3 are one face,
//! counter-clockwise seen from outside the opposite face 4-5-6-7, node `i + 4` above node `i`.
//! In the reference cube (ξ, η, ζ) ∈ [−1, 1]³ node 0 is (−1, −1, −1), 1 (1, −1, −1),
//! 2 (1, 1, −1), 3 (−1, 1, −1), 4..7 the same at ζ = 1. A positive Jacobian determinant
//! everywhere is required: an element with det J ≤ 0 is inverted or degenerate.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// A node of the disc face and the coincident (distinct) node of the pad face opposite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContactPair {
    pub disc_node: u32,
    pub pad_node: u32,
    /// Unit normal of the disc surface at the pair, pointing from the disc into the pad.
    pub normal: [f64; 3],
    /// Tributary area of the pair (m²), for pressures.
    pub area: f64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    /// Node coordinates (m).
    pub nodes: Vec<[f64; 3]>,
    /// Hexahedra, by node index.
    pub hexes: Vec<[u32; 8]>,
    /// Part of each hexahedron: an index into `parts`.
    pub hex_part: Vec<u32>,
    /// Part names; each names a material (`disc`, `pad`, ...).
    pub parts: Vec<String>,
    /// Named node sets, sorted: `hub` (clamped), `pad_backs`, ...
    pub node_sets: BTreeMap<String, Vec<u32>>,
    /// Node-to-node contact pairs between disc and pad faces.
    pub contact_pairs: Vec<ContactPair>,
}

/// a − b.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

impl Mesh {
    /// Connected components of the elements: the body of each node (`usize::MAX` for a node in
    /// no element), numbered by first element.
    pub fn bodies_of_nodes(&self) -> (Vec<usize>, usize) {
        let mut parent: Vec<usize> = (0..self.n_nodes()).collect();
        fn root(parent: &mut [usize], mut node: usize) -> usize {
            while parent[node] != node {
                parent[node] = parent[parent[node]];
                node = parent[node];
            }
            node
        }
        for hex in &self.hexes {
            let first = root(&mut parent, hex[0] as usize);
            for &node in &hex[1..] {
                let other = root(&mut parent, node as usize);
                if other != first {
                    parent[other] = first;
                }
            }
        }
        let mut body_of_root = vec![usize::MAX; self.n_nodes()];
        let mut n_bodies = 0;
        for hex in &self.hexes {
            let top = root(&mut parent, hex[0] as usize);
            if body_of_root[top] == usize::MAX {
                body_of_root[top] = n_bodies;
                n_bodies += 1;
            }
        }
        let mut in_element = vec![false; self.n_nodes()];
        for hex in &self.hexes {
            for &node in hex {
                in_element[node as usize] = true;
            }
        }
        let body = (0..self.n_nodes())
            .map(|node| {
                if in_element[node] {
                    body_of_root[root(&mut parent, node)]
                } else {
                    usize::MAX
                }
            })
            .collect();
        (body, n_bodies)
    }

    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    pub fn n_dofs(&self) -> usize {
        3 * self.nodes.len()
    }
}
