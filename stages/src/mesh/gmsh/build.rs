//! The records into a [`Mesh`]: renumbered nodes, hexahedra checked right-handed, parts,
//! node sets, and the contact pairs with the disc's normals and tributary areas.

use std::collections::{BTreeMap, HashMap};

use super::parse::{BoundaryGroup, Elements, GroupKey, Nodes, element_type_name};
use super::{ContactGroups, MshError, ReadOptions};
use crate::artifact::mesh::{ContactPair, Mesh, dot, norm, sub};
use crate::fem::hex8::{NODE_REFERENCE, det_j_at};
use crate::mesh::contact_faces::{FaceIntegrals, quad_tangents};

pub(super) fn build_mesh(
    nodes: &Nodes,
    elements: Elements,
    options: &ReadOptions,
) -> Result<Mesh, MshError> {
    // Only nodes of hexahedra carry stiffness; number them by increasing Gmsh tag.
    let mut used_tags: Vec<u64> = elements.hexes.iter().flat_map(|hex| hex.nodes).collect();
    used_tags.sort_unstable();
    used_tags.dedup();
    let index_of_tag: HashMap<u64, u32> = used_tags
        .iter()
        .enumerate()
        .map(|(idx, tag)| (*tag, idx as u32))
        .collect();
    let mesh_nodes: Vec<[f64; 3]> = used_tags.iter().map(|tag| nodes.coords[tag]).collect();

    // Parts in increasing physical tag; groups sharing a name share a part.
    let mut parts: Vec<String> = Vec::new();
    let mut part_of_group: HashMap<GroupKey, u32> = HashMap::new();
    for (key, name) in &elements.volume_names {
        let part = match parts.iter().position(|part| part == name) {
            Some(part) => part,
            None => {
                parts.push(name.clone());
                parts.len() - 1
            }
        };
        part_of_group.insert(*key, part as u32);
    }

    let mut hexes = Vec::with_capacity(elements.hexes.len());
    let mut hex_part = Vec::with_capacity(elements.hexes.len());
    for record in &elements.hexes {
        let hex = record.nodes.map(|tag| index_of_tag[&tag]);
        let corners = hex.map(|node| mesh_nodes[node as usize]);
        if let Some(corner) =
            (0..8).find(|&corner| det_j_at(&corners, NODE_REFERENCE[corner]) <= 0.0)
        {
            return Err(MshError::at(
                record.line,
                format!(
                    "hexahedron {} is inverted or degenerate (det J <= 0 at its node {}): check its node order",
                    record.tag, record.nodes[corner]
                ),
            ));
        }
        hexes.push(hex);
        hex_part.push(part_of_group[&record.group]);
    }

    let mut node_sets: BTreeMap<String, Vec<u32>> = BTreeMap::new();
    for (name, group) in elements.boundary_groups.values() {
        let set = node_sets.entry(name.clone()).or_default();
        for tag in &group.node_tags {
            let Some(&index) = index_of_tag.get(tag) else {
                return Err(MshError::whole_file(format!(
                    "physical group `{name}`: node {tag} belongs to no hexahedron"
                )));
            };
            set.push(index);
        }
    }
    for set in node_sets.values_mut() {
        set.sort_unstable();
        set.dedup();
    }

    let mut mesh = Mesh {
        nodes: mesh_nodes,
        hexes,
        hex_part,
        parts,
        node_sets,
        contact_pairs: Vec::new(),
    };
    if let Some(contact) = &options.contact {
        mesh.contact_pairs = pair_contact_nodes(&mesh, &elements, &index_of_tag, contact)?;
    }
    Ok(mesh)
}

/// The six faces of a hexahedron, by local node.
const HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// The surface groups named `name` (one per dimension at most is a surface).
fn contact_group<'e>(
    elements: &'e Elements,
    name: &str,
    param: &str,
) -> Result<&'e BoundaryGroup, MshError> {
    let mut surfaces = elements
        .boundary_groups
        .iter()
        .filter(|((dim, _), _)| *dim == 2);
    let found = surfaces
        .clone()
        .find(|(_, (group_name, _))| group_name == name);
    let Some((_, (_, group))) = found else {
        let mut available: Vec<&str> = surfaces
            .by_ref()
            .map(|(_, (group_name, _))| group_name.as_str())
            .collect();
        available.sort_unstable();
        available.dedup();
        let available = if available.is_empty() {
            "none".to_string()
        } else {
            available.join(", ")
        };
        return Err(MshError::whole_file(format!(
            "{param}: no physical surface named `{name}` (physical surfaces: {available}); set contact_disc and contact_pad to \"\" for a mesh without contact"
        )));
    };
    if let Some((element_type, element_tag, line)) = group.first_other {
        return Err(MshError::at(
            line,
            format!(
                "{param} `{name}`: element {element_tag} is a {}: contact faces must be quadrangles (faces of hexahedra)",
                element_type_name(element_type)
            ),
        ));
    }
    Ok(group)
}

/// The disc's and the pad's contact nodes (sorted indices), with the disc's group: both
/// surfaces must have quadrangles and share no node.
fn interface_nodes<'e>(
    elements: &'e Elements,
    index_of_tag: &HashMap<u64, u32>,
    tag_of_index: &HashMap<u32, u64>,
    contact: &ContactGroups,
) -> Result<(&'e BoundaryGroup, Vec<u32>, Vec<u32>), MshError> {
    let disc_group = contact_group(elements, &contact.disc, "contact_disc")?;
    let pad_group = contact_group(elements, &contact.pad, "contact_pad")?;
    let indices = |group: &BoundaryGroup| {
        let mut set: Vec<u32> = group
            .node_tags
            .iter()
            .map(|tag| index_of_tag[tag])
            .collect();
        set.sort_unstable();
        set.dedup();
        set
    };
    let disc_nodes = indices(disc_group);
    let pad_nodes = indices(pad_group);
    if disc_group.quads.is_empty() || pad_group.quads.is_empty() {
        let empty = if disc_group.quads.is_empty() {
            &contact.disc
        } else {
            &contact.pad
        };
        return Err(MshError::whole_file(format!(
            "contact surface `{empty}` has no quadrangles"
        )));
    }
    if let Some(shared) = disc_nodes
        .iter()
        .find(|node| pad_nodes.binary_search(node).is_ok())
    {
        return Err(MshError::whole_file(format!(
            "node {} is on both `{}` and `{}`: the contact interface needs duplicated nodes, one copy per side (mesh the parts without fragmenting them, or use Plugin(Crack))",
            tag_of_index[shared], contact.disc, contact.pad
        )));
    }
    Ok((disc_group, disc_nodes, pad_nodes))
}

/// Pairs the coincident nodes of the disc and pad contact surfaces, with the disc's outward
/// normal and tributary area at each pair.
pub(super) fn pair_contact_nodes(
    mesh: &Mesh,
    elements: &Elements,
    index_of_tag: &HashMap<u64, u32>,
    contact: &ContactGroups,
) -> Result<Vec<ContactPair>, MshError> {
    let tag_of_index: HashMap<u32, u64> =
        index_of_tag.iter().map(|(tag, idx)| (*idx, *tag)).collect();
    let (disc_group, disc_nodes, pad_nodes) =
        interface_nodes(elements, index_of_tag, &tag_of_index, contact)?;

    let (integrals, shortest_edge) =
        integrate_disc_faces(mesh, disc_group, &disc_nodes, index_of_tag, &contact.disc)?;

    let tolerance = contact.relative_tolerance * shortest_edge;
    let pad_grid = PointGrid::new(&mesh.nodes, &pad_nodes, shortest_edge.max(tolerance));
    let mut partner_of_pad: HashMap<u32, u32> = HashMap::new();
    let mut pairs = Vec::with_capacity(disc_nodes.len());
    for &disc_node in &disc_nodes {
        let position = mesh.nodes[disc_node as usize];
        let candidates = pad_grid.within(&mesh.nodes, position, tolerance);
        let pad_node = match candidates[..] {
            [pad_node] => pad_node,
            [] => {
                return Err(MshError::whole_file(format!(
                    "node {} of `{}` at ({}, {}, {}) has no node of `{}` within {tolerance:e} m: the interface must be conforming",
                    tag_of_index[&disc_node],
                    contact.disc,
                    position[0],
                    position[1],
                    position[2],
                    contact.pad
                )));
            }
            _ => {
                return Err(MshError::whole_file(format!(
                    "node {} of `{}` has {} nodes of `{}` within {tolerance:e} m: lower contact_tolerance",
                    tag_of_index[&disc_node],
                    contact.disc,
                    candidates.len(),
                    contact.pad
                )));
            }
        };
        if let Some(other) = partner_of_pad.insert(pad_node, disc_node) {
            return Err(MshError::whole_file(format!(
                "node {} of `{}` is within {tolerance:e} m of nodes {} and {} of `{}`: lower contact_tolerance",
                tag_of_index[&pad_node],
                contact.pad,
                tag_of_index[&other],
                tag_of_index[&disc_node],
                contact.disc
            )));
        }
        let Some((normal, area)) = integrals.normal_and_area(disc_node) else {
            let reason = if integrals.normal_sums.contains_key(&disc_node) {
                ": its faces' normals cancel out"
            } else {
                " is on none of its quadrangles"
            };
            return Err(MshError::whole_file(format!(
                "node {} of `{}`{reason}",
                tag_of_index[&disc_node], contact.disc
            )));
        };
        pairs.push(ContactPair {
            disc_node,
            pad_node,
            normal,
            area,
        });
    }
    if let Some(unmatched) = pad_nodes
        .iter()
        .find(|node| !partner_of_pad.contains_key(node))
    {
        let position = mesh.nodes[*unmatched as usize];
        return Err(MshError::whole_file(format!(
            "node {} of `{}` at ({}, {}, {}) has no node of `{}` within {tolerance:e} m: the interface must be conforming",
            tag_of_index[unmatched],
            contact.pad,
            position[0],
            position[1],
            position[2],
            contact.disc
        )));
    }
    Ok(pairs)
}

/// Integrates the disc's contact faces, each oriented out of the hexahedron it bounds; and
/// their shortest edge.
fn integrate_disc_faces(
    mesh: &Mesh,
    disc_group: &BoundaryGroup,
    disc_nodes: &[u32],
    index_of_tag: &HashMap<u64, u32>,
    disc_name: &str,
) -> Result<(FaceIntegrals, f64), MshError> {
    // Faces of hexahedra whose four nodes are all on the disc contact surface.
    let on_disc = |node: &u32| disc_nodes.binary_search(node).is_ok();
    let mut faces: HashMap<[u32; 4], Vec<usize>> = HashMap::new();
    for (hex_idx, hex) in mesh.hexes.iter().enumerate() {
        for face in HEX_FACES {
            let nodes = face.map(|local| hex[local]);
            if nodes.iter().all(on_disc) {
                let mut key = nodes;
                key.sort_unstable();
                faces.entry(key).or_default().push(hex_idx);
            }
        }
    }

    let mut integrals = FaceIntegrals::default();
    let mut shortest_edge = f64::INFINITY;
    for (quad_tags, element_tag, line) in &disc_group.quads {
        let mut quad = quad_tags.map(|tag| index_of_tag[&tag]);
        let mut key = quad;
        key.sort_unstable();
        let owners = faces.get(&key).map_or(&[][..], Vec::as_slice);
        let hex_idx = match owners {
            [hex_idx] => *hex_idx,
            [] => {
                return Err(MshError::at(
                    *line,
                    format!(
                        "contact_disc `{disc_name}`: element {element_tag} is not a face of any hexahedron"
                    ),
                ));
            }
            _ => {
                return Err(MshError::at(
                    *line,
                    format!(
                        "contact_disc `{disc_name}`: element {element_tag} is a face of {} hexahedra: it must lie on the disc's boundary",
                        owners.len()
                    ),
                ));
            }
        };
        let mut corners = quad.map(|node| mesh.nodes[node as usize]);
        // Orient the face outward from its hexahedron: Gmsh surface orientation is arbitrary.
        let hex_centre = centroid(mesh.hexes[hex_idx].iter().map(|n| mesh.nodes[*n as usize]));
        let face_centre = centroid(corners.iter().copied());
        let (_, centre_normal) = quad_tangents(&corners, 0.0, 0.0);
        if dot(centre_normal, sub(face_centre, hex_centre)) < 0.0 {
            quad.reverse();
            corners.reverse();
        }
        for edge in 0..4 {
            shortest_edge = shortest_edge.min(norm(sub(corners[(edge + 1) % 4], corners[edge])));
        }
        integrals.add(quad, &corners);
    }

    Ok((integrals, shortest_edge))
}

fn centroid(points: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
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
