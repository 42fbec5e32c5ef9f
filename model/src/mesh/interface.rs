//! The contact interface of an imported mesh (`mesh.gmsh`, `mesh.abaqus`): the nodes of the
//! disc's contact surface paired one to one with the coincident nodes of the pad's, each pair
//! with the disc's outward unit normal and tributary area ([`super::contact_faces`]).
//!
//! The interface must be conforming with its nodes duplicated, one copy per side: every node
//! on either side finds exactly one partner within `relative_tolerance` × the shortest edge of
//! the disc's contact faces, and no node is on both sides.

use std::collections::HashMap;

use crate::fem::faces::{ElementFace, Side, faces_within};

use super::contact_faces::{FaceIntegrals, quad_tangents};
use crate::artifact::mesh::{ContactPair, Mesh, dot, norm, sub};
use crate::value::StageError;

/// The two sides of the contact interface, by name (Gmsh physical surfaces; Abaqus surfaces or
/// node sets), and how far apart paired nodes may be.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactSides {
    pub disc: String,
    pub pad: String,
    /// Largest distance between paired nodes, relative to the shortest contact face edge.
    pub relative_tolerance: f64,
}

/// The two sides as given: both named, or both empty (no contact).
pub fn contact_sides(disc: &str, pad: &str, what: &str) -> Result<Option<[String; 2]>, StageError> {
    match (disc.trim(), pad.trim()) {
        ("", "") => Ok(None),
        ("", _) | (_, "") => Err(StageError::new(format!(
            "contact_disc and contact_pad must both name {what}, or both be empty"
        ))),
        (disc, pad) => Ok(Some([disc.to_string(), pad.to_string()])),
    }
}

/// `quad` ordered so that its normal points out of element `element`.
pub fn outward(mesh: &Mesh, element: usize, mut quad: [u32; 4]) -> [u32; 4] {
    let corners = quad.map(|node| mesh.nodes[node as usize]);
    let hex_centre = centroid(
        mesh.elements
            .nodes(element)
            .iter()
            .map(|n| mesh.nodes[*n as usize]),
    );
    let (_, centre_normal) = quad_tangents(&corners, 0.0, 0.0);
    if dot(
        centre_normal,
        sub(centroid(corners.into_iter()), hex_centre),
    ) < 0.0
    {
        quad.reverse();
    }
    quad
}

/// The boundary faces (of one element) whose nodes are all in `side`.
pub fn boundary_faces(mesh: &Mesh, side: &Side) -> Vec<ElementFace> {
    faces_within(mesh, side)
        .into_values()
        .filter_map(|mut owners| (owners.len() == 1).then(|| owners.remove(0)))
        .collect()
}

/// `faces` as the disc's contact quadrangles, each oriented out of its element; node-to-node
/// contact takes 4-node quadrangles only: the first face of another shape is the error.
pub fn contact_quads(mesh: &Mesh, faces: Vec<ElementFace>) -> Result<Vec<[u32; 4]>, ElementFace> {
    faces
        .into_iter()
        .map(|face| match <[u32; 4]>::try_from(face.nodes.as_slice()) {
            Ok(quad) => Ok(outward(mesh, face.element, quad)),
            Err(_) => Err(face),
        })
        .collect()
}

/// Pairs the nodes of `disc` and `pad`; `disc_faces` are the disc's contact faces, oriented
/// outward ([`outward`]); `label` names a node as the file does. Errors are one line.
pub fn pair_nodes(
    mesh: &Mesh,
    disc: &Side,
    pad: &Side,
    disc_faces: &[[u32; 4]],
    relative_tolerance: f64,
    label: &dyn Fn(u32) -> String,
) -> Result<Vec<ContactPair>, String> {
    if let Some(shared) = disc.nodes.iter().find(|node| pad.contains(**node)) {
        return Err(format!(
            "node {} is on both `{}` and `{}`: the contact interface needs duplicated nodes, one copy per side",
            label(*shared),
            disc.name,
            pad.name
        ));
    }
    let mut integrals = FaceIntegrals::default();
    let mut shortest_edge = f64::INFINITY;
    for quad in disc_faces {
        let corners = quad.map(|node| mesh.nodes[node as usize]);
        for edge in 0..4 {
            shortest_edge = shortest_edge.min(norm(sub(corners[(edge + 1) % 4], corners[edge])));
        }
        integrals.add(*quad, &corners);
    }
    let tolerance = relative_tolerance * shortest_edge;
    let pad_grid = PointGrid::new(&mesh.nodes, &pad.nodes, shortest_edge.max(tolerance));
    let mut partner_of_pad: HashMap<u32, u32> = HashMap::new();
    let mut pairs = Vec::with_capacity(disc.nodes.len());
    for &disc_node in &disc.nodes {
        let position = mesh.nodes[disc_node as usize];
        let candidates = pad_grid.within(&mesh.nodes, position, tolerance);
        let pad_node = match candidates[..] {
            [pad_node] => pad_node,
            [] => {
                return Err(format!(
                    "node {} of `{}` at ({}, {}, {}) has no node of `{}` within {tolerance:e} m: the interface must be conforming (pair independently meshed sides with a `contact.mortar` stage)",
                    label(disc_node),
                    disc.name,
                    position[0],
                    position[1],
                    position[2],
                    pad.name
                ));
            }
            _ => {
                return Err(format!(
                    "node {} of `{}` has {} nodes of `{}` within {tolerance:e} m: lower contact_tolerance",
                    label(disc_node),
                    disc.name,
                    candidates.len(),
                    pad.name
                ));
            }
        };
        if let Some(other) = partner_of_pad.insert(pad_node, disc_node) {
            return Err(format!(
                "node {} of `{}` is within {tolerance:e} m of nodes {} and {} of `{}`: lower contact_tolerance",
                label(pad_node),
                pad.name,
                label(other),
                label(disc_node),
                disc.name
            ));
        }
        let Some((normal, area)) = integrals.normal_and_area(disc_node) else {
            let reason = if integrals.normal_sums.contains_key(&disc_node) {
                ": its faces' normals cancel out"
            } else {
                " is on none of its faces"
            };
            return Err(format!(
                "node {} of `{}`{reason}",
                label(disc_node),
                disc.name
            ));
        };
        pairs.push(ContactPair::node_to_node(disc_node, pad_node, normal, area));
    }
    if let Some(unmatched) = pad
        .nodes
        .iter()
        .find(|node| !partner_of_pad.contains_key(node))
    {
        let position = mesh.nodes[*unmatched as usize];
        return Err(format!(
            "node {} of `{}` at ({}, {}, {}) has no node of `{}` within {tolerance:e} m: the interface must be conforming (pair independently meshed sides with a `contact.mortar` stage)",
            label(*unmatched),
            pad.name,
            position[0],
            position[1],
            position[2],
            disc.name
        ));
    }
    Ok(pairs)
}

/// The mean of `points`.
pub(super) fn centroid(points: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    let mut sum = [0.0; 3];
    let mut count = 0.0;
    for point in points {
        for axis in 0..3 {
            sum[axis] += point[axis];
        }
        count += 1.0;
    }
    sum.map(|component| component / count)
}

/// Points bucketed in cubes of side `cell`, to find near neighbours without a quadratic search.
struct PointGrid {
    cell: f64,
    buckets: HashMap<[i64; 3], Vec<u32>>,
}

impl PointGrid {
    fn new(positions: &[[f64; 3]], members: &[u32], cell: f64) -> Self {
        let mut grid = PointGrid {
            cell,
            buckets: HashMap::new(),
        };
        for &node in members {
            let key = grid.key(positions[node as usize]);
            grid.buckets.entry(key).or_default().push(node);
        }
        grid
    }

    fn key(&self, position: [f64; 3]) -> [i64; 3] {
        position.map(|coordinate| (coordinate / self.cell).floor() as i64)
    }

    /// Members within `radius` (≤ the cell size) of `position`, in increasing index.
    fn within(&self, positions: &[[f64; 3]], position: [f64; 3], radius: f64) -> Vec<u32> {
        let [i, j, k] = self.key(position);
        let mut found = Vec::new();
        for di in -1..=1 {
            for dj in -1..=1 {
                for dk in -1..=1 {
                    let Some(bucket) = self.buckets.get(&[i + di, j + dj, k + dk]) else {
                        continue;
                    };
                    found.extend(
                        bucket.iter().copied().filter(|node| {
                            norm(sub(positions[*node as usize], position)) <= radius
                        }),
                    );
                }
            }
        }
        found.sort_unstable();
        found
    }
}
