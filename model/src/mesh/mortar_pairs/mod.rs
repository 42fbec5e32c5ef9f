//! `contact.mortar`: the contact pairs of a non-matching interface, the pad's contact faces
//! (slave) against the disc's (master), by the mortar operators of [`crate::fem::mortar`].
//!
//! Each slave node j that the disc covers gives one pair: its pad side the row's slave weights
//! S_jk with node j first (its anchor), its disc side the master weights P_jl, its normal the
//! row's reversed (the pair's normal points from the disc into the pad, as every pair's does),
//! its area the row's weight w_j = ∫ Φ_j dA over the covered part. A uniform pressure p then
//! loads both faces with their consistent nodal forces, and an affine displacement of a flat
//! interface leaves every weighted gap as it was: the contact patch test. On coincident meshes
//! of linear faces every row is one node against one node with weight 1, and the pairs are the
//! node-to-node ones of a conforming reader.
//!
//! Faces are taken where all their nodes are in a side's node set and one element owns them,
//! and turned so that their corner cycle's normal points out of their element, which the
//! mortar operators take as given. The stage replaces whatever pairs its input mesh has, and
//! reports in its `interface` table what a user checks first: the fraction of the pad side's
//! area that found the disc, the faces that found none, the largest initial gap and
//! penetration.

use crate::artifact::mesh::{ContactPair, Mesh, dot, sub};
use crate::artifact::{Artifact, ArtifactType};
use crate::fem::faces::{ElementFace, Side, area_vectors};
use crate::fem::mortar::{self, Settings, Surface};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

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
    /// The contact faces of each side.
    pub pad_faces: usize,
    pub disc_faces: usize,
    /// Pad faces the disc covers in part, and not at all.
    pub partial_faces: usize,
    pub uncovered_faces: usize,
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
        pad_faces: slave.faces.len(),
        disc_faces: master.faces.len(),
        partial_faces: interface.partial_faces,
        uncovered_faces: interface
            .face_coverage
            .iter()
            .filter(|fraction| **fraction == 0.0)
            .count(),
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

/// `contact.mortar`: mesh → the same mesh with mortar contact pairs, and its interface table.
pub struct ContactMortar;

crate::stage_params! {
    /// The parameters of `contact.mortar`.
    pub struct MortarParams {
        /// node set of the disc side of the interface (master): its boundary faces
        disc: String = "contact_disc".into(),
        /// node set of the pad side of the interface (slave): one pair per node the disc covers
        pad: String = "contact_pad".into(),
        /// how far apart a pad face and a disc face may be and still be paired
        #[unit = "m"]
        #[min = 0.0]
        search_distance: f64 = 1e-3,
        /// the smallest fraction of the pad side's area that must find the disc
        #[min = 0.0]
        min_coverage: f64 = 0.9,
    }
}

impl HasParams for ContactMortar {
    type Params = MortarParams;
}

impl Stage for ContactMortar {
    fn kind(&self) -> &'static str {
        "contact.mortar"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Mortar contact pairs between two independently meshed sides (tri3, tri6, quad4, quad8 faces): each pad node against the disc nodes its faces overlap, replacing the mesh's pairs"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "mesh",
            ArtifactType::Mesh,
            "a mesh with the two sides' node sets",
        )]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "mesh",
                ArtifactType::Mesh,
                "the mesh with mortar contact pairs",
            ),
            PortSpec::one(
                "interface",
                ArtifactType::Table,
                "faces, pairs, area covered, faces found by none, largest gap and penetration",
            ),
        ]
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let mesh: &Mesh = inputs.get("mesh")?;
        let params = params.read::<Self>()?;
        if params.min_coverage > 1.0 {
            return Err(StageError::new(format!(
                "min_coverage is a fraction of the pad side's area, at most 1, not {}",
                params.min_coverage
            )));
        }
        let disc = named_side(mesh, &params.disc, "disc")?;
        let pad = named_side(mesh, &params.pad, "pad")?;
        let (pairs, coverage) =
            mortar_pairs(mesh, &disc, &pad, params.search_distance).map_err(StageError::new)?;
        if coverage.covered < params.min_coverage {
            return Err(StageError::new(format!(
                "`{}` finds `{}` on {:.1} % of its area ({} of its {} faces on none) within {} m, \
                 below min_coverage = {} %: are the sides the right ones, and touching?",
                params.pad,
                params.disc,
                100.0 * coverage.covered,
                coverage.uncovered_faces,
                coverage.pad_faces,
                params.search_distance,
                100.0 * params.min_coverage
            )));
        }
        if coverage.uncovered_faces > 0 {
            tracing::warn!(
                "{} of the {} faces of `{}` find no face of `{}` within {} m: they carry no contact",
                coverage.uncovered_faces,
                coverage.pad_faces,
                params.pad,
                params.disc,
                params.search_distance
            );
        }
        if !mesh.contact_pairs.is_empty() {
            tracing::info!(
                "contact.mortar replaces the mesh's {} contact pairs by {}",
                mesh.contact_pairs.len(),
                pairs.len()
            );
        }
        let table = interface_table(&params, &coverage, pairs.len());
        let mut paired = mesh.clone();
        paired.contact_pairs = pairs;
        Ok(Outputs::from([
            ("mesh".to_string(), Artifact::Mesh(Box::new(paired))),
            ("interface".to_string(), Artifact::Table(table)),
        ]))
    }
}

/// The side of the node set `name`, the stage's parameter `param`.
fn named_side<'a>(mesh: &Mesh, name: &'a str, param: &str) -> Result<Side<'a>, StageError> {
    let nodes = mesh.node_sets.get(name).ok_or_else(|| {
        StageError::new(format!(
            "{param}: the mesh has no node set `{name}` (its node sets: {})",
            mesh.node_set_names()
        ))
    })?;
    Ok(Side::new(name, nodes.iter().copied()))
}

/// One row: the two sides, their faces, the pairs, and the coverage figures.
fn interface_table(params: &MortarParams, coverage: &Coverage, pairs: usize) -> Table {
    Table::new()
        .with("pad", vec![params.pad.clone()])
        .with("disc", vec![params.disc.clone()])
        .with("pad_faces", vec![coverage.pad_faces as i64])
        .with("disc_faces", vec![coverage.disc_faces as i64])
        .with("pairs", vec![pairs as i64])
        .with("pad_area_m2", vec![coverage.slave_area])
        .with("covered_fraction", vec![coverage.covered])
        .with("partial_faces", vec![coverage.partial_faces as i64])
        .with("uncovered_faces", vec![coverage.uncovered_faces as i64])
        .with("dropped_nodes", vec![coverage.dropped as i64])
        .with("largest_gap_m", vec![coverage.largest_gap])
        .with("largest_penetration_m", vec![coverage.largest_penetration])
}

#[cfg(test)]
mod tests;
