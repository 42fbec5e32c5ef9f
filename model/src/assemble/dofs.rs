//! Degrees of freedom: three displacements per node, minus those of the clamped node sets
//! (all three, or only the axes written after a colon: `pad_backs:xy` guides the pad backs
//! in-plane and leaves them free along z) and those of the tied nodes (which follow their
//! masters, [`super::ties`]),
//! numbered node by node (node-major), so that a node's free DOFs are consecutive and the
//! sparse matrices have one dense 3×3 block per pair of neighbouring nodes.

use crate::artifact::mesh::Mesh;
use crate::stage::StageError;

/// Free DOF index of each node's x, y, z displacement (`None` where clamped or tied).
pub type DofOfNode = Vec<[Option<u32>; 3]>;

/// The DOF numbering (see [`DofOfNode`]) and the number of free DOFs.
pub fn number_dofs(mesh: &Mesh, clamped_sets: &[String]) -> Result<(DofOfNode, usize), StageError> {
    let clamped = clamped_axes(mesh, clamped_sets)?;
    number_free(mesh, &clamped, &vec![false; mesh.n_nodes()])
}

/// The clamped axes of each node: those of every entry of `clamped_sets` (`set` or
/// `set:axes`) whose set holds it.
pub fn clamped_axes(mesh: &Mesh, clamped_sets: &[String]) -> Result<Vec<[bool; 3]>, StageError> {
    let mut entries = Vec::with_capacity(clamped_sets.len());
    for entry in clamped_sets {
        let (name, axes) = match entry.split_once(':') {
            Some((name, axes)) => (name.trim(), axes.trim()),
            None => (entry.as_str(), "xyz"),
        };
        let mut mask = [false; 3];
        for axis in axes.chars() {
            let idx = "xyz".find(axis).ok_or_else(|| {
                StageError::new(format!(
                    "clamped `{entry}`: axes must be letters among x, y, z, found `{axis}`"
                ))
            })?;
            mask[idx] = true;
        }
        if mask == [false; 3] {
            return Err(StageError::new(format!(
                "clamped `{entry}`: no axis after the colon"
            )));
        }
        entries.push((name, mask));
    }
    let missing: Vec<&str> = entries
        .iter()
        .map(|(name, _)| *name)
        .filter(|name| !mesh.node_sets.contains_key(*name))
        .collect();
    if !missing.is_empty() {
        return Err(StageError::new(format!(
            "clamped node sets not in the mesh: {} (the mesh has: {})",
            missing.join(", "),
            mesh.node_set_names()
        )));
    }
    let n_nodes = mesh.n_nodes();
    let mut clamped = vec![[false; 3]; n_nodes];
    for (name, mask) in &entries {
        for &node in &mesh.node_sets[*name] {
            let slot = clamped.get_mut(node as usize).ok_or_else(|| {
                StageError::new(format!(
                    "node set `{name}` names node {node}, but the mesh has {n_nodes} nodes"
                ))
            })?;
            for axis in 0..3 {
                slot[axis] |= mask[axis];
            }
        }
    }
    Ok(clamped)
}

/// The DOF numbering of the nodes neither `clamped` (per axis) nor `tied`, node by node, and
/// the number of free DOFs.
pub fn number_free(
    mesh: &Mesh,
    clamped: &[[bool; 3]],
    tied: &[bool],
) -> Result<(DofOfNode, usize), StageError> {
    let n_nodes = mesh.n_nodes();
    let mut in_element = vec![false; n_nodes];
    for &node in mesh.elements.all_nodes() {
        if let Some(slot) = in_element.get_mut(node as usize) {
            *slot = true;
        }
    }
    // A free node outside every element has neither mass nor stiffness: M and K would be
    // singular. That is a broken mesh, not something to solve around.
    let orphans: Vec<usize> = (0..n_nodes)
        .filter(|&node| !in_element[node] && clamped[node] != [true; 3] && !tied[node])
        .collect();
    if let Some(first) = orphans.first() {
        return Err(StageError::new(format!(
            "{} free node(s) belong to no element, the first is node {first}",
            orphans.len()
        )));
    }
    let mut next_dof: u32 = 0;
    let mut dof_of_node = Vec::with_capacity(n_nodes);
    for (axes_clamped, &tied) in clamped.iter().zip(tied) {
        let mut dofs = [None; 3];
        for axis in 0..3 {
            if !axes_clamped[axis] && !tied {
                dofs[axis] = Some(next_dof);
                next_dof += 1;
            }
        }
        dof_of_node.push(dofs);
    }
    Ok((dof_of_node, next_dof as usize))
}
