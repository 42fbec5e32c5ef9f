//! The records into a [`Mesh`]: renumbered nodes, elements checked right-handed, parts,
//! node sets, and the contact pairs with the disc's normals and tributary areas.

use std::collections::{BTreeMap, HashMap};

use super::parse::{BoundaryGroup, Elements, GroupKey, Nodes, element_type_name};
use super::{MshError, ReadOptions};
use crate::artifact::mesh::{ContactPair, Elements as MeshElements, Mesh};
use crate::fem::element::{Location, first_inverted};
use crate::fem::faces::{Side, faces_within};
use crate::mesh::interface::{self, ContactSides};

pub(super) fn build_mesh(
    nodes: &Nodes,
    elements: Elements,
    options: &ReadOptions,
) -> Result<Mesh, MshError> {
    // Only nodes of solid elements carry stiffness; number them by increasing Gmsh tag.
    let mut used_tags: Vec<u64> = elements
        .solids
        .iter()
        .flat_map(|solid| solid.nodes.iter().copied())
        .collect();
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

    let mut mesh_elements = MeshElements::new();
    for record in &elements.solids {
        let nodes: Vec<u32> = record.nodes.iter().map(|tag| index_of_tag[tag]).collect();
        let coords: Vec<[f64; 3]> = nodes
            .iter()
            .map(|&node| mesh_nodes[node as usize])
            .collect();
        if let Some(inverted) = first_inverted(record.kind, &coords) {
            let place = match inverted.location {
                Location::Corner(node) | Location::Node(node) => {
                    format!("its node {}", record.nodes[node])
                }
                other => other.to_string(),
            };
            return Err(MshError::at(
                record.line,
                format!(
                    "{} {} is inverted or degenerate (det J <= 0 at {place}): check its node order",
                    element_noun(record.element_type),
                    record.tag
                ),
            ));
        }
        mesh_elements.push(record.kind, part_of_group[&record.group], &nodes);
    }
    if let Some((first, second)) = crate::mesh::first_duplicate(&mesh_elements) {
        let (first, second) = (&elements.solids[first], &elements.solids[second]);
        return Err(MshError::at(
            second.line,
            format!(
                "{} {} has the nodes of {} {}: a duplicated element doubles its stiffness and mass",
                element_noun(second.element_type),
                second.tag,
                element_noun(first.element_type),
                first.tag
            ),
        ));
    }

    let mut node_sets: BTreeMap<String, Vec<u32>> = BTreeMap::new();
    for (name, group) in elements.boundary_groups.values() {
        let set = node_sets.entry(name.clone()).or_default();
        for tag in &group.node_tags {
            let Some(&index) = index_of_tag.get(tag) else {
                return Err(MshError::whole_file(format!(
                    "physical group `{name}`: node {tag} belongs to no solid element"
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
        elements: mesh_elements,
        parts,
        node_sets,
        contact_pairs: Vec::new(),
    };
    if let Some(contact) = &options.contact {
        mesh.contact_pairs = pair_contact_nodes(&mesh, &elements, &index_of_tag, contact)?;
    }
    Ok(mesh)
}

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
                "{param} `{name}`: element {element_tag} is a {}: node-to-node contact faces must be 4-node quadrangles",
                element_type_name(element_type)
            ),
        ));
    }
    Ok(group)
}

/// Pairs the coincident nodes of the disc and pad contact surfaces, with the disc's outward
/// normal and tributary area at each pair.
pub(super) fn pair_contact_nodes(
    mesh: &Mesh,
    elements: &Elements,
    index_of_tag: &HashMap<u64, u32>,
    contact: &ContactSides,
) -> Result<Vec<ContactPair>, MshError> {
    let disc_group = contact_group(elements, &contact.disc, "contact_disc")?;
    let pad_group = contact_group(elements, &contact.pad, "contact_pad")?;
    for (group, name) in [(disc_group, &contact.disc), (pad_group, &contact.pad)] {
        if group.quads.is_empty() {
            return Err(MshError::whole_file(format!(
                "contact surface `{name}` has no quadrangles"
            )));
        }
    }
    let side = |group: &BoundaryGroup, name| {
        Side::new(name, group.node_tags.iter().map(|tag| index_of_tag[tag]))
    };
    let disc = side(disc_group, &contact.disc);
    let pad = side(pad_group, &contact.pad);
    let disc_faces = disc_faces(mesh, disc_group, &disc, index_of_tag)?;
    let tag_of_index: HashMap<u32, u64> =
        index_of_tag.iter().map(|(tag, idx)| (*idx, *tag)).collect();
    let label = |node: u32| tag_of_index[&node].to_string();
    interface::pair_nodes(
        mesh,
        &disc,
        &pad,
        &disc_faces,
        contact.relative_tolerance,
        &label,
    )
    .map_err(|message| {
        let hint = if message.contains("is on both") {
            " (mesh the parts without fragmenting them, or use Plugin(Crack))"
        } else {
            ""
        };
        MshError::whole_file(format!("{message}{hint}"))
    })
}

/// The disc's contact quadrangles, each oriented out of the element it bounds.
fn disc_faces(
    mesh: &Mesh,
    disc_group: &BoundaryGroup,
    disc: &Side,
    index_of_tag: &HashMap<u64, u32>,
) -> Result<Vec<[u32; 4]>, MshError> {
    let faces = faces_within(mesh, disc);
    disc_group
        .quads
        .iter()
        .map(|(quad_tags, element_tag, line)| {
            let quad = quad_tags.map(|tag| index_of_tag[&tag]);
            let mut key = quad;
            key.sort_unstable();
            match faces.get(&key[..]).map_or(&[][..], Vec::as_slice) {
                [face] => Ok(interface::outward(mesh, face.element, quad)),
                [] => Err(MshError::at(
                    *line,
                    format!(
                        "contact_disc `{}`: element {element_tag} is not a face of any solid element",
                        disc.name
                    ),
                )),
                owners => Err(MshError::at(
                    *line,
                    format!(
                        "contact_disc `{}`: element {element_tag} is a face of {} elements: it must lie on the disc's boundary",
                        disc.name,
                        owners.len()
                    ),
                )),
            }
        })
        .collect()
}

/// How a message names a solid element of a Gmsh type ("hexahedron" for 8-node hexahedra, as
/// always).
fn element_noun(element_type: u32) -> &'static str {
    match element_type {
        4 => "4-node tetrahedron",
        5 => "hexahedron",
        6 => "6-node prism",
        11 => "10-node tetrahedron",
        17 => "20-node hexahedron",
        18 => "15-node prism",
        _ => "element",
    }
}
