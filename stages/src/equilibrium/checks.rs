//! Checks of a solution: the support reactions the pads carry, and the largest strain.

use crate::artifact::Model;
use crate::fem::material::Material;
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
    for (hex, part) in mesh.hexes.iter().zip(&mesh.hex_part) {
        if !hex.iter().any(|node| in_set[*node as usize]) {
            continue;
        }
        let material = materials.get(*part as usize).ok_or_else(|| {
            StageError::new(format!(
                "part {part} has no material: {} given",
                materials.len()
            ))
        })?;
        let coords = hex.map(|node| mesh.nodes[node as usize]);
        let element =
            crate::fem::hex8::element_matrices(&coords, &material.elasticity(), material.density)
                .map_err(|degenerate| {
                StageError::new(format!(
                    "degenerate element: det J = {:e}",
                    degenerate.det_j
                ))
            })?;
        let displacement = |dof: usize| {
            model.dof_of_node[hex[dof / 3] as usize][dof % 3].map_or(0.0, |free| u[free as usize])
        };
        for row in 0..24 {
            if !in_set[hex[row / 3] as usize] {
                continue;
            }
            // At a clamped DOF, K u = R + F with F = 0: the row of K times u is the support's
            // reaction R on the structure.
            let internal: f64 = (0..24)
                .map(|col| {
                    element.stiffness[crate::fem::hex8::packed_index(row, col)] * displacement(col)
                })
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
    for (element, hex) in mesh.hexes.iter().enumerate() {
        let coords = hex.map(|node| mesh.nodes[node as usize]);
        let displacement = hex.map(|node| {
            model.dof_of_node[node as usize].map(|dof| dof.map_or(0.0, |dof| u[dof as usize]))
        });
        let Some(gradient) = crate::fem::hex8::centre_displacement_gradient(&coords, &displacement)
        else {
            continue;
        };
        let strain = (0..9)
            .map(|ij| 0.5 * (gradient[ij / 3][ij % 3] + gradient[ij % 3][ij / 3]).abs())
            .fold(0.0, f64::max);
        if strain > largest.0 {
            largest = (strain, element);
        }
    }
    largest
}
