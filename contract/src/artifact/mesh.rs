//! Meshes of solid elements of several kinds, with parts (one material each), named node sets
//! and the contact pairs between pad and disc faces (node to node on conforming interfaces,
//! weighted node sets in general: [`ContactPair`]).
//!
//! Node orders (0-based), those of Abaqus and VTK except for the wedges' first triangle, which
//! VTK writes the other way round. Corners first, counter-clockwise seen from the opposite
//! face or apex, so that the reference map has a positive Jacobian determinant:
//!
//! | kind | corners | mid-edge nodes, by the corners of their edge |
//! |---|---|---|
//! | `tet4` | 0 1 2 base, 3 apex | — |
//! | `tet10` | as `tet4` | 4 (0 1), 5 (1 2), 6 (2 0), 7 (0 3), 8 (1 3), 9 (2 3) |
//! | `wedge6` | 0 1 2 bottom, 3 4 5 above them | — |
//! | `wedge15` | as `wedge6` | 6 (0 1), 7 (1 2), 8 (2 0), 9 (3 4), 10 (4 5), 11 (5 3), 12 (0 3), 13 (1 4), 14 (2 5) |
//! | `hex8` | 0 1 2 3 bottom, 4..7 above them | — |
//! | `hex20` | as `hex8` | 8 (0 1), 9 (1 2), 10 (2 3), 11 (3 0), 12 (4 5), 13 (5 6), 14 (6 7), 15 (7 4), 16 (0 4), 17 (1 5), 18 (2 6), 19 (3 7) |
//!
//! A positive Jacobian determinant everywhere is required: an element with det J ≤ 0 is
//! inverted or degenerate. Shape functions, quadrature and faces of each kind are in the
//! stages' `fem::element` module.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// One contact constraint between the pad and the disc: a point of the pad's face, its
/// position a weighted sum of pad nodes, facing a point of the disc's face, a weighted sum of
/// disc nodes.
///
/// - `pad`: (node, weight) of the pad side. The **first entry is the pair's own pad node**, its
///   anchor: where the pair sits in tables and figures, the node whose DOF the stability's
///   elimination takes as the slave, and the body the pair belongs to.
/// - `disc`: (node, weight) of the disc side.
///
/// Each side's weights sum to 1 (to round-off). Node to node, the conforming interfaces of
/// today, is one entry of weight 1.0 per side. A mortar row (the stages' `fem::mortar`) has
/// slave weights S_jk over pad nodes (one node of weight 1 on linear faces; on quadratic faces
/// a mid-edge node's row reads 5/3 of itself and −1/3 of each corner of its edge, so weights
/// may be negative) and master weights P_jl over disc nodes. The relative displacement of the
/// pair is δ = Σ_k S_k u_k − Σ_l P_l u_l, and every stage reads it through these weights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContactPair {
    /// Pad nodes and weights, the anchor first.
    pub pad: Vec<(u32, f64)>,
    /// Disc nodes and weights.
    pub disc: Vec<(u32, f64)>,
    /// Unit normal of the disc surface at the pair, pointing from the disc into the pad (a
    /// mortar row's normal, from the pad to the disc, reversed).
    pub normal: [f64; 3],
    /// The pair's area (m²), for pressures: the tributary area of the disc node node to node,
    /// the row weight w_j of a mortar row.
    pub area: f64,
}

impl ContactPair {
    /// Node to node: `pad_node` facing `disc_node`, one entry of weight 1.0 per side.
    pub fn node_to_node(disc_node: u32, pad_node: u32, normal: [f64; 3], area: f64) -> Self {
        ContactPair {
            pad: vec![(pad_node, 1.0)],
            disc: vec![(disc_node, 1.0)],
            normal,
            area,
        }
    }

    /// The pair's own pad node (the first of the pad side): its anchor.
    pub fn pad_node(&self) -> u32 {
        self.pad[0].0
    }

    /// The disc node of a node-to-node pair (one disc node, of weight 1.0), `None` otherwise.
    pub fn single_disc_node(&self) -> Option<u32> {
        match self.disc[..] {
            [(node, 1.0)] => Some(node),
            _ => None,
        }
    }

    /// Whether each side is one node of weight 1.0.
    pub fn is_node_to_node(&self) -> bool {
        matches!((&self.pad[..], &self.disc[..]), ([(_, p)], [(_, d)]) if *p == 1.0 && *d == 1.0)
    }

    /// The point of the pad side, Σ_k S_k x_k.
    pub fn pad_position(&self, nodes: &[[f64; 3]]) -> [f64; 3] {
        weighted_position(&self.pad, nodes)
    }

    /// The point of the disc side, Σ_l P_l x_l: where the disc slides under the pair.
    pub fn disc_position(&self, nodes: &[[f64; 3]]) -> [f64; 3] {
        weighted_position(&self.disc, nodes)
    }

    /// Every node of either side, pad side first (a node on both sides, or twice on one, is
    /// given each time).
    pub fn nodes(&self) -> impl Iterator<Item = u32> + '_ {
        self.pad.iter().chain(&self.disc).map(|&(node, _)| node)
    }

    /// Every (node, signed weight) of δ = u_pad − u_disc: the pad side's weights, then the disc
    /// side's negated. With weight 1.0 the signed weights are exactly ±1.0.
    pub fn signed_weights(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.pad
            .iter()
            .copied()
            .chain(self.disc.iter().map(|&(node, weight)| (node, -weight)))
    }

    /// Checks that both sides are non-empty, their nodes below `n_nodes`, their weights finite
    /// and summing to 1 within `1e-9`, the normal a unit vector (within `1e-9`) and the area
    /// finite and positive.
    pub fn check(&self, n_nodes: usize) -> Result<(), String> {
        let length = norm(self.normal);
        if !((length - 1.0).abs() <= 1e-9) {
            return Err(format!(
                "its normal {:?} is not a unit vector (length {length})",
                self.normal
            ));
        }
        if !(self.area > 0.0 && self.area.is_finite()) {
            return Err(format!("its area {} m² is not positive", self.area));
        }
        for (side, entries) in [("pad", &self.pad), ("disc", &self.disc)] {
            if entries.is_empty() {
                return Err(format!("the {side} side has no node"));
            }
            if let Some((node, _)) = entries.iter().find(|(node, _)| *node as usize >= n_nodes) {
                return Err(format!(
                    "the {side} side names node {node}, but the mesh has {n_nodes} nodes"
                ));
            }
            let sum: f64 = entries.iter().map(|(_, weight)| weight).sum();
            if !sum.is_finite() || (sum - 1.0).abs() > 1e-9 {
                return Err(format!("the {side} side's weights sum to {sum}, not 1"));
            }
        }
        Ok(())
    }
}

/// Σ w_k x_k, the first term taken as it is, so that one entry of weight 1.0 gives its node's
/// position bit for bit (signed zeros included).
fn weighted_position(entries: &[(u32, f64)], nodes: &[[f64; 3]]) -> [f64; 3] {
    let mut entries = entries.iter();
    let Some(&(first, weight)) = entries.next() else {
        return [f64::NAN; 3];
    };
    let mut x = nodes[first as usize].map(|c| weight * c);
    for &(node, weight) in entries {
        let y = nodes[node as usize];
        for axis in 0..3 {
            x[axis] += weight * y[axis];
        }
    }
    x
}

/// The kind of a solid element (node orders in the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum ElementKind {
    /// 8-node hexahedron with incompatible modes.
    Hex8,
    /// 20-node serendipity hexahedron.
    Hex20,
    /// 4-node (constant-strain) tetrahedron.
    Tet4,
    /// 10-node tetrahedron.
    Tet10,
    /// 6-node wedge (triangular prism).
    Wedge6,
    /// 15-node wedge.
    Wedge15,
}

impl ElementKind {
    pub const ALL: [ElementKind; 6] = [
        ElementKind::Hex8,
        ElementKind::Hex20,
        ElementKind::Tet4,
        ElementKind::Tet10,
        ElementKind::Wedge6,
        ElementKind::Wedge15,
    ];

    pub fn n_nodes(self) -> usize {
        match self {
            ElementKind::Hex8 => 8,
            ElementKind::Hex20 => 20,
            ElementKind::Tet4 => 4,
            ElementKind::Tet10 => 10,
            ElementKind::Wedge6 => 6,
            ElementKind::Wedge15 => 15,
        }
    }

    /// The number of corner (vertex) nodes, which come first.
    pub fn n_corners(self) -> usize {
        match self {
            ElementKind::Hex8 | ElementKind::Hex20 => 8,
            ElementKind::Tet4 | ElementKind::Tet10 => 4,
            ElementKind::Wedge6 | ElementKind::Wedge15 => 6,
        }
    }

    /// The name in tables and messages: `hex8`, `tet10`, ...
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Hex8 => "hex8",
            ElementKind::Hex20 => "hex20",
            ElementKind::Tet4 => "tet4",
            ElementKind::Tet10 => "tet10",
            ElementKind::Wedge6 => "wedge6",
            ElementKind::Wedge15 => "wedge15",
        }
    }
}

impl std::fmt::Display for ElementKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One element: its kind, part and nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Element<'a> {
    pub kind: ElementKind,
    /// An index into the mesh's `parts`.
    pub part: u32,
    pub nodes: &'a [u32],
}

/// The elements of a mesh, their nodes stored one after the other.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Elements {
    kinds: Vec<ElementKind>,
    parts: Vec<u32>,
    /// Where each element's nodes start in `nodes`.
    starts: Vec<usize>,
    nodes: Vec<u32>,
}

impl Elements {
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends an element; `nodes` has `kind.n_nodes()` entries (a mismatch is a bug of the
    /// caller's, checked by [`Elements::check`]).
    pub fn push(&mut self, kind: ElementKind, part: u32, nodes: &[u32]) {
        debug_assert_eq!(nodes.len(), kind.n_nodes());
        self.kinds.push(kind);
        self.parts.push(part);
        self.starts.push(self.nodes.len());
        self.nodes.extend_from_slice(nodes);
    }

    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    pub fn get(&self, element: usize) -> Element<'_> {
        Element {
            kind: self.kinds[element],
            part: self.parts[element],
            nodes: self.nodes(element),
        }
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = Element<'_>> + Clone + '_ {
        (0..self.len()).map(|element| self.get(element))
    }

    pub fn kind(&self, element: usize) -> ElementKind {
        self.kinds[element]
    }

    pub fn part(&self, element: usize) -> u32 {
        self.parts[element]
    }

    /// The part of every element.
    pub fn parts(&self) -> &[u32] {
        &self.parts
    }

    pub fn set_part(&mut self, element: usize, part: u32) {
        self.parts[element] = part;
    }

    pub fn nodes(&self, element: usize) -> &[u32] {
        let start = self.starts[element];
        &self.nodes[start..start + self.kinds[element].n_nodes()]
    }

    pub fn nodes_mut(&mut self, element: usize) -> &mut [u32] {
        let start = self.starts[element];
        &mut self.nodes[start..start + self.kinds[element].n_nodes()]
    }

    /// Every element's nodes, one element after the other.
    pub fn all_nodes(&self) -> &[u32] {
        &self.nodes
    }

    /// Appends the elements of `other`, its node indices shifted by `node_offset` and its parts
    /// by `part_offset`.
    pub fn extend_shifted(&mut self, other: &Elements, node_offset: u32, part_offset: u32) {
        for element in other.iter() {
            let nodes: Vec<u32> = element
                .nodes
                .iter()
                .map(|node| node + node_offset)
                .collect();
            self.push(element.kind, element.part + part_offset, &nodes);
        }
    }

    /// How many elements of each kind, by kind.
    pub fn count_by_kind(&self) -> BTreeMap<ElementKind, usize> {
        let mut counts = BTreeMap::new();
        for kind in &self.kinds {
            *counts.entry(*kind).or_insert(0) += 1;
        }
        counts
    }

    /// Checks that the storage is consistent and that every element names existing nodes and
    /// parts: what indexing by element relies on.
    pub fn check(&self, n_nodes: usize, n_parts: usize) -> Result<(), String> {
        if self.parts.len() != self.kinds.len() || self.starts.len() != self.kinds.len() {
            return Err(format!(
                "the mesh has {} element kinds, {} element parts and {} element starts",
                self.kinds.len(),
                self.parts.len(),
                self.starts.len()
            ));
        }
        let mut next = 0;
        for (element, (kind, start)) in self.kinds.iter().zip(&self.starts).enumerate() {
            if *start != next || next + kind.n_nodes() > self.nodes.len() {
                return Err(format!(
                    "element {element}: its nodes are not stored in order"
                ));
            }
            next += kind.n_nodes();
        }
        if next != self.nodes.len() {
            return Err(format!(
                "the elements have {next} nodes in all but {} are stored",
                self.nodes.len()
            ));
        }
        if let Some((element, part)) = self
            .parts
            .iter()
            .enumerate()
            .find(|(_, part)| **part as usize >= n_parts)
        {
            return Err(format!(
                "element {element} is in part {part}, but the mesh has {n_parts} parts"
            ));
        }
        if let Some(element) = (0..self.len()).find(|&element| {
            self.nodes(element)
                .iter()
                .any(|&node| node as usize >= n_nodes)
        }) {
            return Err(format!(
                "element {element} names node {}, but the mesh has {n_nodes} nodes",
                self.nodes(element).iter().max().unwrap_or(&0)
            ));
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    /// Node coordinates (m).
    pub nodes: Vec<[f64; 3]>,
    /// The elements, each with its kind, part and nodes.
    pub elements: Elements,
    /// Part names; each names a material (`disc`, `pad`, ...).
    pub parts: Vec<String>,
    /// Named node sets, sorted: `hub` (clamped), `pad_backs`, ...
    pub node_sets: BTreeMap<String, Vec<u32>>,
    /// Contact pairs between disc and pad faces.
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
        self.bodies_of_linked_nodes(&[])
    }

    /// [`Mesh::bodies_of_nodes`] with the two nodes of each of `links` in one body as well (a
    /// tied node and its master): bodies joined by a link become one, numbered by its first
    /// element.
    pub fn bodies_of_linked_nodes(&self, links: &[(u32, u32)]) -> (Vec<usize>, usize) {
        let mut parent: Vec<usize> = (0..self.n_nodes()).collect();
        fn root(parent: &mut [usize], mut node: usize) -> usize {
            while parent[node] != node {
                parent[node] = parent[parent[node]];
                node = parent[node];
            }
            node
        }
        for element in self.elements.iter() {
            let first = root(&mut parent, element.nodes[0] as usize);
            for &node in &element.nodes[1..] {
                let other = root(&mut parent, node as usize);
                if other != first {
                    parent[other] = first;
                }
            }
        }
        for &(a, b) in links {
            let (a, b) = (root(&mut parent, a as usize), root(&mut parent, b as usize));
            if a != b {
                parent[b] = a;
            }
        }
        let mut body_of_root = vec![usize::MAX; self.n_nodes()];
        let mut n_bodies = 0;
        for element in self.elements.iter() {
            let top = root(&mut parent, element.nodes[0] as usize);
            if body_of_root[top] == usize::MAX {
                body_of_root[top] = n_bodies;
                n_bodies += 1;
            }
        }
        let mut in_element = vec![false; self.n_nodes()];
        for &node in self.elements.all_nodes() {
            in_element[node as usize] = true;
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

    /// The names of the node sets, comma-separated ("no node sets" if none), for the error
    /// that names a set the mesh lacks.
    pub fn node_set_names(&self) -> String {
        if self.node_sets.is_empty() {
            return "no node sets".to_string();
        }
        let names: Vec<&str> = self.node_sets.keys().map(String::as_str).collect();
        names.join(", ")
    }

    pub fn n_dofs(&self) -> usize {
        3 * self.nodes.len()
    }
}
