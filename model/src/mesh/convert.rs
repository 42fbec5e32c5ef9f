//! Other element kinds from a mesh of 8-node hexahedra, on the same nodes: each hexahedron
//! split into six tetrahedra or two wedges, and second-order elements by a node at the middle
//! of every edge. Verification cases and `mesh.brake` compare the kinds on one geometry.
//!
//! The splits are conforming when neighbouring hexahedra share their local orientation (as in
//! the structured meshes here): the tetrahedra are Kuhn's six around the diagonal from local
//! corner 0 to corner 6, the wedges the two halves on each side of the diagonal 0–2 of the
//! bottom face (and 4–6 of the top), so that two hexahedra split a shared face the same way.

use std::collections::BTreeMap;

use crate::artifact::{ElementKind, Elements, Mesh};
use crate::fem::element::topology;

/// Kuhn's six tetrahedra of a hexahedron, by local corner (all right-handed).
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 2, 6],
    [0, 2, 3, 6],
    [0, 3, 7, 6],
    [0, 7, 4, 6],
    [0, 4, 5, 6],
    [0, 5, 1, 6],
];

/// The two wedges of a hexahedron, by local corner: bottom triangle, then the top one above.
const WEDGES: [[usize; 6]; 2] = [[0, 1, 2, 4, 5, 6], [0, 2, 3, 4, 6, 7]];

/// The mesh with each 8-node hexahedron split into `kind` (`Tet4` or `Wedge6`); other
/// elements are kept. `None` for another `kind`.
pub fn split_hexahedra(mesh: &Mesh, kind: ElementKind) -> Option<Mesh> {
    let pieces: Vec<&[usize]> = match kind {
        ElementKind::Tet4 => KUHN.iter().map(|tet| &tet[..]).collect(),
        ElementKind::Wedge6 => WEDGES.iter().map(|wedge| &wedge[..]).collect(),
        _ => return None,
    };
    let mut elements = Elements::new();
    for element in mesh.elements.iter() {
        if element.kind != ElementKind::Hex8 {
            elements.push(element.kind, element.part, element.nodes);
            continue;
        }
        for piece in &pieces {
            let nodes: Vec<u32> = piece.iter().map(|&local| element.nodes[local]).collect();
            elements.push(kind, element.part, &nodes);
        }
    }
    Some(Mesh {
        elements,
        ..mesh.clone()
    })
}

/// A mesh of 8-node hexahedra as elements of `kind`, on the same nodes: split into
/// tetrahedra or wedges, then given mid-edge nodes for the second-order kinds.
pub fn as_kind(hexes: &Mesh, kind: ElementKind) -> Mesh {
    let linear = match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => split_hexahedra(hexes, ElementKind::Tet4),
        ElementKind::Wedge6 | ElementKind::Wedge15 => split_hexahedra(hexes, ElementKind::Wedge6),
        ElementKind::Hex8 | ElementKind::Hex20 => None,
    }
    .unwrap_or_else(|| hexes.clone());
    if kind.n_nodes() > kind.n_corners() {
        with_mid_edge_nodes(&linear)
    } else {
        linear
    }
}

/// The second-order kind of a first-order one.
pub fn second_order(kind: ElementKind) -> ElementKind {
    match kind {
        ElementKind::Tet4 => ElementKind::Tet10,
        ElementKind::Wedge6 => ElementKind::Wedge15,
        ElementKind::Hex8 => ElementKind::Hex20,
        quadratic => quadratic,
    }
}

/// The mesh with a node added at the middle of every edge of its first-order elements, which
/// become second-order (straight-edged); nodes shared by edges are shared. New nodes are
/// numbered after the old ones, in the order their edges are first met; a node set gains the
/// middle of every edge whose two ends it holds. Contact pairs are kept as they are.
pub fn with_mid_edge_nodes(mesh: &Mesh) -> Mesh {
    let mut nodes = mesh.nodes.clone();
    let mut middle_of: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    let mut elements = Elements::new();
    for element in mesh.elements.iter() {
        let kind = second_order(element.kind);
        if kind == element.kind {
            elements.push(element.kind, element.part, element.nodes);
            continue;
        }
        let mut element_nodes = element.nodes.to_vec();
        for &[a, b] in topology::edges(kind) {
            let (a, b) = (element.nodes[a], element.nodes[b]);
            let key = (a.min(b), a.max(b));
            let middle = *middle_of.entry(key).or_insert_with(|| {
                let (x, y) = (mesh.nodes[a as usize], mesh.nodes[b as usize]);
                nodes.push(std::array::from_fn(|axis| 0.5 * (x[axis] + y[axis])));
                (nodes.len() - 1) as u32
            });
            element_nodes.push(middle);
        }
        elements.push(kind, element.part, &element_nodes);
    }
    let node_sets = mesh
        .node_sets
        .iter()
        .map(|(name, set)| {
            let mut extended = set.clone();
            extended.extend(
                middle_of
                    .iter()
                    .filter(|((a, b), _)| {
                        set.binary_search(a).is_ok() && set.binary_search(b).is_ok()
                    })
                    .map(|(_, middle)| *middle),
            );
            extended.sort_unstable();
            (name.clone(), extended)
        })
        .collect();
    Mesh {
        nodes,
        elements,
        node_sets,
        ..mesh.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::element::first_inverted;
    use crate::mesh::structured::block;

    fn element_coords(mesh: &Mesh, element: usize) -> Vec<[f64; 3]> {
        mesh.elements
            .nodes(element)
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect()
    }

    fn every_element_is_right_handed(mesh: &Mesh) -> bool {
        (0..mesh.elements.len()).all(|element| {
            first_inverted(mesh.elements.kind(element), &element_coords(mesh, element)).is_none()
        })
    }

    /// Every face of the mesh is on the boundary (one element) or shared by exactly two.
    fn is_conforming(mesh: &Mesh) -> bool {
        let mut count: BTreeMap<Vec<u32>, usize> = BTreeMap::new();
        for element in mesh.elements.iter() {
            for face in 0..topology::n_faces(element.kind) {
                let mut key: Vec<u32> = topology::face_nodes(element.kind, face)
                    .into_iter()
                    .map(|local| element.nodes[local])
                    .collect();
                key.sort_unstable();
                *count.entry(key).or_default() += 1;
            }
        }
        count.values().all(|&n| n <= 2)
    }

    #[test]
    fn splits_and_mid_edge_nodes_keep_elements_right_handed_and_conforming() {
        let hexes = block([0.3, 0.2, 0.1], [3, 2, 2], "steel");
        for kind in [ElementKind::Tet4, ElementKind::Wedge6] {
            let split = split_hexahedra(&hexes, kind).unwrap();
            let per_hex = if kind == ElementKind::Tet4 { 6 } else { 2 };
            assert_eq!(split.elements.len(), per_hex * hexes.elements.len());
            assert!(every_element_is_right_handed(&split), "{kind}");
            assert!(is_conforming(&split), "{kind}");
            let quadratic = with_mid_edge_nodes(&split);
            assert!(every_element_is_right_handed(&quadratic), "{kind}");
            assert!(is_conforming(&quadratic), "{kind}");
        }
        let hex20 = with_mid_edge_nodes(&hexes);
        // 3×2×2 cells: x-, y- and z-edges.
        let n_edges = 3 * 3 * 3 + 4 * 2 * 3 + 4 * 3 * 2;
        assert_eq!(hex20.nodes.len(), hexes.nodes.len() + n_edges);
        assert!(every_element_is_right_handed(&hex20));
        assert!(is_conforming(&hex20));
        // The face x = 0 (3×3 corners) gains its 2·3 + 3·2 edge middles.
        assert_eq!(hex20.node_sets["x0"].len(), 9 + 12);
    }
}
