//! The contact pairs of a non-matching interface: the pad's contact faces (slave) against the
//! disc's (master), by the mortar operators of [`crate::fem::mortar`].
//!
//! Each slave node j that the disc covers gives one pair: its pad side the row's slave weights
//! S_jk with node j first (its anchor), its disc side the master weights P_jl, its normal the
//! row's reversed (the pair's normal points from the disc into the pad, as every pair's does),
//! its area the row's weight w_j = ∫ Φ_j dA over the covered part. A uniform pressure p then
//! loads both faces with their consistent nodal forces, and an affine displacement of a flat
//! interface leaves every weighted gap as it was: the contact patch test.
//!
//! Faces are taken where all their nodes are in a side's node set and one element owns them,
//! and turned so that their corner cycle's normal points out of their element, which the
//! mortar operators take as given.

use crate::artifact::mesh::{ContactPair, Mesh, dot, sub};
use crate::fem::faces::{ElementFace, Side, area_vectors};
use crate::fem::mortar::{self, Settings, Surface};

use super::interface::{boundary_faces, centroid};

/// What a user checks first about a non-matching interface.
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage {
    /// The fraction of the pad's contact area that found the disc.
    pub covered: f64,
    /// The pad's contact area (m²).
    pub slave_area: f64,
    /// The largest weighted gap (m) and the largest penetration (m, ≥ 0) at rest.
    pub largest_gap: f64,
    pub largest_penetration: f64,
    /// Pad nodes that carry no pair: the disc covers too little of their faces.
    pub dropped: usize,
}

/// The pairs of the pad side `pad` against the disc side `disc`, master faces searched within
/// `search_distance` (m) of each pad face. Errors are one line naming the sides.
pub fn mortar_pairs(
    mesh: &Mesh,
    disc: &Side,
    pad: &Side,
    search_distance: f64,
) -> Result<(Vec<ContactPair>, Coverage), String> {
    if let Some(shared) = disc.nodes.iter().find(|node| pad.contains(**node)) {
        return Err(format!(
            "node {shared} is on both `{}` and `{}`: the contact interface needs a node set per side",
            disc.name, pad.name
        ));
    }
    let slave = surface(mesh, pad);
    let master = surface(mesh, disc);
    let settings = Settings {
        search_distance,
        ..Settings::default()
    };
    let interface = mortar::interface(&mesh.nodes, &slave, &master, &settings)
        .map_err(|err| err.to_string())?;
    let pairs = interface
        .rows
        .iter()
        .map(|row| {
            let mut pad_side = row.slave.clone();
            if let Some(own) = pad_side.iter().position(|&(node, _)| node == row.node) {
                pad_side[..=own].rotate_right(1);
            }
            ContactPair {
                pad: pad_side,
                disc: row.master.clone(),
                normal: row.normal.map(|component| -component),
                area: row.weight,
            }
        })
        .collect();
    let coverage = Coverage {
        covered: interface.coverage,
        slave_area: interface.slave_area,
        largest_gap: interface.largest_gap,
        largest_penetration: interface.largest_penetration,
        dropped: interface.dropped.len(),
    };
    Ok((pairs, coverage))
}

/// The boundary faces of `side`, each turned to face out of its element (also the master
/// surface of a tie, [`crate::assemble::ties`]).
pub(crate) fn surface<'a>(mesh: &Mesh, side: &Side<'a>) -> Surface<'a> {
    Surface {
        name: side.name,
        faces: boundary_faces(mesh, side)
            .into_iter()
            .map(|face| (face.kind, outward_face(mesh, &face)))
            .collect(),
    }
}

/// The nodes of `face` in an order whose corner cycle turns counter-clockwise seen from
/// outside its element: reversed when the face's area vector points from its corners' centroid
/// at the element's. Reversing a cycle reverses its mid-edge nodes too, the edge after corner 0
/// being the one to the last corner.
fn outward_face(mesh: &Mesh, face: &ElementFace) -> Vec<u32> {
    let position = |node: &u32| mesh.nodes[*node as usize];
    let coords: Vec<[f64; 3]> = face.nodes.iter().map(position).collect();
    let (_, area) = area_vectors(face.kind, &coords);
    let corners = face.kind.n_corners();
    let face_centre = centroid(face.nodes[..corners].iter().map(position));
    let element = mesh.elements.nodes(face.element);
    let n_corners = mesh.elements.kind(face.element).n_corners();
    let element_centre = centroid(element[..n_corners].iter().map(position));
    if dot(area, sub(face_centre, element_centre)) >= 0.0 {
        return face.nodes.clone();
    }
    let corners = face.kind.n_corners();
    let mut turned = Vec::with_capacity(face.nodes.len());
    turned.push(face.nodes[0]);
    turned.extend(face.nodes[1..corners].iter().rev());
    turned.extend(face.nodes[corners..].iter().rev());
    turned
}

#[cfg(test)]
mod tests;
