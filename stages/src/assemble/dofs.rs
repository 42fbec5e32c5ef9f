//! Degrees of freedom: three displacements per node, minus those of the clamped node sets,
//! numbered node by node (node-major), so that a node's free DOFs are consecutive and the
//! sparse matrices have one dense 3×3 block per pair of neighbouring nodes.

use crate::mesh::Mesh;
use crate::stage::StageError;

/// The node sets named in a comma-separated list (`"hub, pad_backs"`); empty names are skipped.
pub fn parse_set_names(list: &str) -> Vec<String> {
    list.split(',')
        .map(str::trim)
        .filter(|name| !name.is_empty())
        .map(str::to_string)
        .collect()
}

/// Free DOF index of each node's x, y, z displacement (`None` where clamped).
pub type DofOfNode = Vec<[Option<u32>; 3]>;

/// The DOF numbering (see [`DofOfNode`]) and the number of free DOFs.
pub fn number_dofs(mesh: &Mesh, clamped_sets: &[String]) -> Result<(DofOfNode, usize), StageError> {
    let missing: Vec<&str> = clamped_sets
        .iter()
        .filter(|name| !mesh.node_sets.contains_key(name.as_str()))
        .map(String::as_str)
        .collect();
    if !missing.is_empty() {
        let available: Vec<&str> = mesh.node_sets.keys().map(String::as_str).collect();
        return Err(StageError::new(format!(
            "clamped node sets not in the mesh: {} (the mesh has: {})",
            missing.join(", "),
            if available.is_empty() {
                "no node sets".to_string()
            } else {
                available.join(", ")
            }
        )));
    }
    let n_nodes = mesh.n_nodes();
    let mut clamped = vec![false; n_nodes];
    for name in clamped_sets {
        for &node in &mesh.node_sets[name.as_str()] {
            let slot = clamped.get_mut(node as usize).ok_or_else(|| {
                StageError::new(format!(
                    "node set `{name}` names node {node}, but the mesh has {n_nodes} nodes"
                ))
            })?;
            *slot = true;
        }
    }
    let mut in_element = vec![false; n_nodes];
    for hex in &mesh.hexes {
        for &node in hex {
            if let Some(slot) = in_element.get_mut(node as usize) {
                *slot = true;
            }
        }
    }
    // A free node outside every element has neither mass nor stiffness: M and K would be
    // singular. That is a broken mesh, not something to solve around.
    let orphans: Vec<usize> = (0..n_nodes)
        .filter(|&node| !in_element[node] && !clamped[node])
        .collect();
    if let Some(first) = orphans.first() {
        return Err(StageError::new(format!(
            "{} free node(s) belong to no element, the first is node {first}",
            orphans.len()
        )));
    }
    let mut next_dof: u32 = 0;
    let mut dof_of_node = Vec::with_capacity(n_nodes);
    for is_clamped in clamped {
        if is_clamped {
            dof_of_node.push([None; 3]);
        } else {
            dof_of_node.push([Some(next_dof), Some(next_dof + 1), Some(next_dof + 2)]);
            next_dof += 3;
        }
    }
    Ok((dof_of_node, next_dof as usize))
}
