//! Node orders of the file formats squeal reads and writes, for every kind. Abaqus and VTK list
//! mid-edge nodes by squeal's edges ([`edges`]); the others' are written out here.
//!
//! A format numbers an element's corners and mid-edge nodes its own way. Each format's order
//! is given as data: its corners (squeal's corner for each of the file's) and, for quadratic
//! kinds, the corners of the edge of each of its mid-edge nodes (in the file's corner
//! numbering). [`file_to_squeal`] turns that into a permutation. The differences that matter:
//! Gmsh lists mid-edge nodes by edges sorted differently (and swaps the 10-node tetrahedron's
//! last two), Nastran puts the vertical edges of hexahedra and wedges before the top face's,
//! and VTK turns its wedges' first triangle the other way round.

use crate::artifact::ElementKind;

use super::topology::{edges, mid_edge_node};

/// A file format with its own node orders.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Gmsh,
    Abaqus,
    Nastran,
    Vtk,
}

const SAME_TET: [usize; 4] = [0, 1, 2, 3];
const SAME_WEDGE: [usize; 6] = [0, 1, 2, 3, 4, 5];
const VTK_WEDGE: [usize; 6] = [0, 2, 1, 3, 5, 4];
const SAME_HEX: [usize; 8] = [0, 1, 2, 3, 4, 5, 6, 7];

const GMSH_TET_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [2, 3], [1, 3]];

const GMSH_WEDGE_EDGES: [[usize; 2]; 9] = [
    [0, 1],
    [0, 2],
    [0, 3],
    [1, 2],
    [1, 4],
    [2, 5],
    [3, 4],
    [3, 5],
    [4, 5],
];
const NASTRAN_WEDGE_EDGES: [[usize; 2]; 9] = [
    [0, 1],
    [1, 2],
    [2, 0],
    [0, 3],
    [1, 4],
    [2, 5],
    [3, 4],
    [4, 5],
    [5, 3],
];

const GMSH_HEX_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [0, 3],
    [0, 4],
    [1, 2],
    [1, 5],
    [2, 3],
    [2, 6],
    [3, 7],
    [4, 5],
    [4, 7],
    [5, 6],
    [6, 7],
];
const NASTRAN_HEX_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
    [4, 5],
    [5, 6],
    [6, 7],
    [7, 4],
];

/// The format's corners (squeal's corner of each file corner) and mid-edge edges (file corners).
fn file_order(kind: ElementKind, format: Format) -> (&'static [usize], &'static [[usize; 2]]) {
    use ElementKind::*;
    use Format::*;
    match (kind, format) {
        (Tet4, _) => (&SAME_TET, &[]),
        (Tet10, Gmsh) => (&SAME_TET, &GMSH_TET_EDGES),
        (Tet10, _) => (&SAME_TET, edges(Tet10)),
        (Wedge6, Vtk) => (&VTK_WEDGE, &[]),
        (Wedge6, _) => (&SAME_WEDGE, &[]),
        (Wedge15, Gmsh) => (&SAME_WEDGE, &GMSH_WEDGE_EDGES),
        (Wedge15, Nastran) => (&SAME_WEDGE, &NASTRAN_WEDGE_EDGES),
        (Wedge15, Vtk) => (&VTK_WEDGE, edges(Wedge15)),
        (Wedge15, Abaqus) => (&SAME_WEDGE, edges(Wedge15)),
        (Hex8, _) => (&SAME_HEX, &[]),
        (Hex20, Gmsh) => (&SAME_HEX, &GMSH_HEX_EDGES),
        (Hex20, Nastran) => (&SAME_HEX, &NASTRAN_HEX_EDGES),
        (Hex20, _) => (&SAME_HEX, edges(Hex20)),
    }
}

/// `order[k]` is squeal's node for the file's node `k`: squeal's nodes are
/// `squeal[order[k]] = file[k]`.
pub fn file_to_squeal(kind: ElementKind, format: Format) -> Vec<usize> {
    let (corners, edges) = file_order(kind, format);
    let mut order = corners.to_vec();
    for &[a, b] in edges {
        order
            .push(mid_edge_node(kind, corners[a], corners[b]).expect("a format's edges are edges"));
    }
    order
}

/// An element's nodes as a file lists them, in squeal's order.
pub fn from_file<T: Copy + Default>(kind: ElementKind, format: Format, file: &[T]) -> Vec<T> {
    let mut squeal = vec![T::default(); file.len()];
    for (k, node) in file_to_squeal(kind, format).into_iter().enumerate() {
        squeal[node] = file[k];
    }
    squeal
}

/// An element's nodes (squeal's order) as a file lists them.
pub fn to_file<T: Copy>(kind: ElementKind, format: Format, squeal: &[T]) -> Vec<T> {
    file_to_squeal(kind, format)
        .into_iter()
        .map(|node| squeal[node])
        .collect()
}

/// The VTK cell type of each kind.
pub fn vtk_cell_type(kind: ElementKind) -> u8 {
    match kind {
        ElementKind::Tet4 => 10,
        ElementKind::Hex8 => 12,
        ElementKind::Wedge6 => 13,
        ElementKind::Tet10 => 24,
        ElementKind::Hex20 => 25,
        ElementKind::Wedge15 => 26,
    }
}
