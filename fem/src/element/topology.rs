//! The reference nodes, mid-edge nodes and faces of every kind (node orders of
//! [`crate::artifact::mesh`]).
//!
//! Reference elements: the tetrahedron with corners (0,0,0), (1,0,0), (0,1,0), (0,0,1); the
//! wedge with the triangle (0,0), (1,0), (0,1) at ζ = −1 and ζ = 1; the cube [−1, 1]³. A
//! mid-edge node sits at the middle of its edge.
//!
//! Faces are numbered as Abaqus numbers them (S1, S2, … in this order), each given by its
//! corners in a cycle; a quadratic face adds the mid-edge node of each edge of the cycle, in
//! order (tri6, quad8). The tetrahedra's and wedges' cycles turn counter-clockwise seen from
//! outside; the hexahedra's keep the historical cycles (S1 turns the other way): users that
//! need an orientation take it from the geometry (`squeal_model::mesh::interface::outward`).

use crate::artifact::ElementKind;

/// The shape of a face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaceKind {
    Tri3,
    Tri6,
    Quad4,
    Quad8,
}

impl FaceKind {
    pub fn n_nodes(self) -> usize {
        match self {
            FaceKind::Tri3 => 3,
            FaceKind::Tri6 => 6,
            FaceKind::Quad4 => 4,
            FaceKind::Quad8 => 8,
        }
    }

    pub fn n_corners(self) -> usize {
        match self {
            FaceKind::Tri3 | FaceKind::Tri6 => 3,
            FaceKind::Quad4 | FaceKind::Quad8 => 4,
        }
    }
}

impl std::fmt::Display for FaceKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FaceKind::Tri3 => "tri3",
            FaceKind::Tri6 => "tri6",
            FaceKind::Quad4 => "quad4",
            FaceKind::Quad8 => "quad8",
        })
    }
}

const TET_CORNERS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const WEDGE_CORNERS: [[f64; 3]; 6] = [
    [0.0, 0.0, -1.0],
    [1.0, 0.0, -1.0],
    [0.0, 1.0, -1.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
];
const HEX_CORNERS: [[f64; 3]; 8] = super::hex8::NODE_REFERENCE;

const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];
const WEDGE_EDGES: [[usize; 2]; 9] = [
    [0, 1],
    [1, 2],
    [2, 0],
    [3, 4],
    [4, 5],
    [5, 3],
    [0, 3],
    [1, 4],
    [2, 5],
];
const HEX_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [4, 5],
    [5, 6],
    [6, 7],
    [7, 4],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

const TET_FACES: [&[usize]; 4] = [&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[2, 0, 3]];
const WEDGE_FACES: [&[usize]; 5] = [
    &[0, 2, 1],
    &[3, 4, 5],
    &[0, 1, 4, 3],
    &[1, 2, 5, 4],
    &[2, 0, 3, 5],
];
const HEX_FACES: [&[usize]; 6] = [
    &[0, 1, 2, 3],
    &[4, 5, 6, 7],
    &[0, 1, 5, 4],
    &[1, 2, 6, 5],
    &[2, 3, 7, 6],
    &[3, 0, 4, 7],
];

fn corners(kind: ElementKind) -> &'static [[f64; 3]] {
    match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => &TET_CORNERS,
        ElementKind::Wedge6 | ElementKind::Wedge15 => &WEDGE_CORNERS,
        ElementKind::Hex8 | ElementKind::Hex20 => &HEX_CORNERS,
    }
}

/// The edges of the kind's shape, as corner pairs: for a quadratic kind, the edge of mid-edge
/// node `n_corners + k` is `edges(kind)[k]`.
pub fn edges(kind: ElementKind) -> &'static [[usize; 2]] {
    match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => &TET_EDGES,
        ElementKind::Wedge6 | ElementKind::Wedge15 => &WEDGE_EDGES,
        ElementKind::Hex8 | ElementKind::Hex20 => &HEX_EDGES,
    }
}

/// Whether the kind has a node in the middle of each edge.
pub fn is_quadratic(kind: ElementKind) -> bool {
    kind.n_nodes() > kind.n_corners()
}

/// Reference coordinates of node `node`.
pub fn reference_node(kind: ElementKind, node: usize) -> [f64; 3] {
    let corners = corners(kind);
    if node < corners.len() {
        return corners[node];
    }
    let [a, b] = edges(kind)[node - corners.len()];
    std::array::from_fn(|i| 0.5 * (corners[a][i] + corners[b][i]))
}

/// The reference point at the element's centroid.
pub fn reference_centre(kind: ElementKind) -> [f64; 3] {
    match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => [0.25; 3],
        ElementKind::Wedge6 | ElementKind::Wedge15 => [1.0 / 3.0, 1.0 / 3.0, 0.0],
        ElementKind::Hex8 | ElementKind::Hex20 => [0.0; 3],
    }
}

/// The number of faces of the kind.
pub fn n_faces(kind: ElementKind) -> usize {
    face_cycles(kind).len()
}

fn face_cycles(kind: ElementKind) -> &'static [&'static [usize]] {
    match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => &TET_FACES,
        ElementKind::Wedge6 | ElementKind::Wedge15 => &WEDGE_FACES,
        ElementKind::Hex8 | ElementKind::Hex20 => &HEX_FACES,
    }
}

/// The shape of face `face` (0-based: Abaqus's S1 is 0).
pub fn face_kind(kind: ElementKind, face: usize) -> FaceKind {
    match (face_cycles(kind)[face].len(), is_quadratic(kind)) {
        (3, false) => FaceKind::Tri3,
        (3, true) => FaceKind::Tri6,
        (_, false) => FaceKind::Quad4,
        (_, true) => FaceKind::Quad8,
    }
}

/// The local nodes of face `face`: its corners in a cycle, then (quadratic kinds) the mid-edge
/// node of each edge of the cycle.
pub fn face_nodes(kind: ElementKind, face: usize) -> Vec<usize> {
    let cycle = face_cycles(kind)[face];
    let mut nodes = cycle.to_vec();
    if is_quadratic(kind) {
        for (position, &a) in cycle.iter().enumerate() {
            let b = cycle[(position + 1) % cycle.len()];
            nodes.push(mid_edge_node(kind, a, b).expect("a face's sides are edges"));
        }
    }
    nodes
}

/// The mid-edge node between corners `a` and `b` of a quadratic kind.
pub fn mid_edge_node(kind: ElementKind, a: usize, b: usize) -> Option<usize> {
    edges(kind)
        .iter()
        .position(|edge| *edge == [a, b] || *edge == [b, a])
        .map(|k| kind.n_corners() + k)
}

/// The permutation from a file format's node order to squeal's: `order[k]` is squeal's node
/// for the file's node `k`, given the file's corners (in squeal's corner order, as every
/// format here shares it) and the corner pairs of the file's mid-edge nodes in its order.
/// `None` if the file's edges are not the kind's edges.
pub fn order_from_edges(kind: ElementKind, file_edges: &[[usize; 2]]) -> Option<Vec<usize>> {
    let mut order: Vec<usize> = (0..kind.n_corners()).collect();
    for &[a, b] in file_edges {
        order.push(mid_edge_node(kind, a, b)?);
    }
    let mut sorted = order.clone();
    sorted.sort_unstable();
    sorted.dedup();
    (sorted.len() == kind.n_nodes()).then_some(order)
}
