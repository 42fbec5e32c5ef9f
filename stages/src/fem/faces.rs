//! The faces of hexahedra, and the faces a set of nodes covers: what surfaces, loads and
//! contact interfaces are made of.

use std::collections::BTreeMap;

use crate::artifact::mesh::Mesh;

/// The six faces of a hexahedron, each as a cycle of local nodes: Abaqus's faces S1..S6 in
/// this order (a user orients them: [`outward`](crate::mesh::interface::outward), or the pressure load's sign).
pub const HEX_FACES: [[usize; 4]; 6] = [
    [0, 1, 2, 3],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// One side of the interface: its name (for messages) and its nodes, sorted.
pub struct Side<'a> {
    pub name: &'a str,
    pub nodes: Vec<u32>,
}

impl<'a> Side<'a> {
    pub fn new(name: &'a str, nodes: impl IntoIterator<Item = u32>) -> Self {
        let mut nodes: Vec<u32> = nodes.into_iter().collect();
        nodes.sort_unstable();
        nodes.dedup();
        Side { name, nodes }
    }

    pub fn contains(&self, node: u32) -> bool {
        self.nodes.binary_search(&node).is_ok()
    }
}

/// The faces of hexahedra whose four nodes are all in `side`, keyed by their sorted nodes,
/// with the hexahedra that have them and the face in each one's node order (one hexahedron
/// for a face on the boundary).
pub fn faces_within(mesh: &Mesh, side: &Side) -> BTreeMap<[u32; 4], Vec<(usize, [u32; 4])>> {
    let mut faces: BTreeMap<[u32; 4], Vec<(usize, [u32; 4])>> = BTreeMap::new();
    for (hex_idx, hex) in mesh.hexes.iter().enumerate() {
        for face in HEX_FACES {
            let nodes = face.map(|local| hex[local]);
            if nodes.iter().all(|node| side.contains(*node)) {
                let mut key = nodes;
                key.sort_unstable();
                faces.entry(key).or_default().push((hex_idx, nodes));
            }
        }
    }
    faces
}
