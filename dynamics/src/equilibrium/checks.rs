//! Checks of a solution: the support reactions the pads carry, and the largest strain.

use crate::artifact::Material;
use crate::artifact::Model;
use crate::fem::element::{self, element_elasticity, packed_index};
use crate::stage::StageError;

/// Support reactions at clamped nodes, summed per node set: the force the supports exert, from
/// the element stiffnesses (which still hold the clamped DOFs; `materials` by part index). With
/// the pads pressed by an interference, the z reactions at the pad backs balance the contact
/// forces.
pub fn back_reactions(
    model: &Model,
    materials: &[Material],
    u: &[f64],
    set: &str,
) -> Result<[f64; 3], StageError> {
    let mesh = &model.mesh;
    let nodes = mesh
        .node_sets
        .get(set)
        .ok_or_else(|| StageError::new(format!("no node set `{set}`")))?;
    let mut in_set = vec![false; mesh.n_nodes()];
    for &node in nodes {
        in_set[node as usize] = true;
    }
    let mut total = [0.0; 3];
    for (index, element) in mesh.elements.iter().enumerate() {
        if !element.nodes.iter().any(|node| in_set[*node as usize]) {
            continue;
        }
        let part = element.part;
        let material = materials.get(part as usize).ok_or_else(|| {
            StageError::new(format!(
                "part {part} has no material: {} given",
                materials.len()
            ))
        })?;
        let coords: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let D = element_elasticity(material, element.kind, &coords)?;
        let matrices = element::element_matrices(element.kind, &coords, &D, material.density)
            .map_err(|degenerate| {
                StageError::new(format!(
                    "element {index} is degenerate: det J = {:e} at {}",
                    degenerate.det_j, degenerate.location
                ))
            })?;
        // A tied node moves with its masters.
        let nodal: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| model.node_displacement(node, u))
            .collect();
        let displacement = |dof: usize| nodal[dof / 3][dof % 3];
        let n_dofs = 3 * element.nodes.len();
        for row in 0..n_dofs {
            if !in_set[element.nodes[row / 3] as usize] {
                continue;
            }
            // At a clamped DOF, K u = R + F with F = 0: the row of K times u is the support's
            // reaction R on the structure.
            let internal: f64 = (0..n_dofs)
                .map(|col| matrices.stiffness[packed_index(row, col)] * displacement(col))
                .sum();
            total[row % 3] += internal;
        }
    }
    Ok(total)
}

/// Strains above this break the small-strain assumption of the linear model.
pub const SMALL_STRAIN: f64 = 0.01;

/// The largest strain component at the element centres, and its element: the compatible part
/// of `u` (the incompatible modes refine it within an element, not its size).
pub fn largest_strain(model: &Model, u: &[f64]) -> (f64, usize) {
    let mesh = &model.mesh;
    let mut largest = (0.0, 0);
    for (index, element) in mesh.elements.iter().enumerate() {
        let coords: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let displacement: Vec<[f64; 3]> = element
            .nodes
            .iter()
            .map(|&node| model.node_displacement(node, u))
            .collect();
        let Some(gradient) =
            element::centre_displacement_gradient(element.kind, &coords, &displacement)
        else {
            continue;
        };
        let strain = (0..9)
            .map(|ij| 0.5 * (gradient[ij / 3][ij % 3] + gradient[ij % 3][ij / 3]).abs())
            .fold(0.0, f64::max);
        if strain > largest.0 {
            largest = (strain, index);
        }
    }
    largest
}
