//! The flattened model into a [`Mesh`]: elements in the parts named, node sets, contact
//! pairs.

use std::collections::BTreeMap;

use super::ReadOptions;
use super::assembly::Flat;
use super::deck::DeckError;
use super::interpret::{Deck, Surface};
use crate::artifact::mesh::{ContactPair, Elements, Mesh};
use crate::fem::element::topology;
use crate::fem::element::{Location, first_inverted};
use crate::fem::faces::{ElementFace, Side, element_face};
use crate::mesh::interface::{self, ContactSides};

/// The deck's mesh: elements in the parts of `options`, node sets, contact pairs.
pub fn build_mesh(deck: &Deck, options: &ReadOptions) -> Result<Mesh, DeckError> {
    let flat = deck.flatten()?;
    if flat.elements.is_empty() {
        return Err(DeckError::whole(
            "no elements: the deck defines no *ELEMENT",
        ));
    }
    check_surface_faces(&flat)?;
    // Parts: element sets; every element in exactly one.
    let mut element_part: Vec<Option<u32>> = vec![None; flat.elements.len()];
    for (part_idx, part) in options.parts.iter().enumerate() {
        let members = flat.sets.elsets.get(part).ok_or_else(|| {
            DeckError::whole(format!(
                "parts: no element set or instance named `{part}` (element sets: {})",
                names(flat.sets.elsets.keys())
            ))
        })?;
        for &element in members {
            if let Some(other) = element_part[element].replace(part_idx as u32)
                && other != part_idx as u32
            {
                return Err(DeckError::at(
                    &flat.element_sources[element],
                    format!(
                        "element {} is in parts `{}` and `{part}`: each element is in one part",
                        flat.element_names[element], options.parts[other as usize]
                    ),
                ));
            }
        }
    }
    // Only nodes of elements carry stiffness: number them in flattened order.
    let mut used = vec![false; flat.nodes.len()];
    for (_, nodes) in &flat.elements {
        for node in nodes {
            used[*node] = true;
        }
    }
    let mut index_of: Vec<Option<u32>> = vec![None; flat.nodes.len()];
    let mut nodes = Vec::new();
    for (node, x) in flat.nodes.iter().enumerate() {
        if used[node] {
            index_of[node] = Some(nodes.len() as u32);
            nodes.push(*x);
        }
    }
    let mut elements = Elements::new();
    for (element, (kind, element_nodes)) in flat.elements.iter().enumerate() {
        let Some(part) = element_part[element] else {
            return Err(DeckError::at(
                &flat.element_sources[element],
                format!(
                    "element {} is in none of the parts {}: add it to one of their element sets",
                    flat.element_names[element],
                    options.parts.join(", ")
                ),
            ));
        };
        let kept: Vec<u32> = element_nodes
            .iter()
            .map(|node| index_of[*node].expect("nodes of elements are kept"))
            .collect();
        let coords: Vec<[f64; 3]> = kept.iter().map(|&node| nodes[node as usize]).collect();
        if let Some(inverted) = first_inverted(*kind, &coords) {
            let place = match inverted.location {
                Location::Corner(node) | Location::Node(node) => {
                    format!("its node {}", flat.node_names[element_nodes[node]])
                }
                other => other.to_string(),
            };
            return Err(DeckError::at(
                &flat.element_sources[element],
                format!(
                    "element {} is inverted or degenerate (det J <= 0 at {place}): check its node order",
                    flat.element_names[element]
                ),
            ));
        }
        elements.push(*kind, part, &kept);
    }
    if let Some((first, second)) = crate::mesh::first_duplicate(&elements) {
        return Err(DeckError::at(
            &flat.element_sources[second],
            format!(
                "element {} has the nodes of element {}: a duplicated element doubles its stiffness and mass",
                flat.element_names[second], flat.element_names[first]
            ),
        ));
    }
    let kept = |set: &str, members: &[usize]| -> Result<Vec<u32>, DeckError> {
        let mut kept: Vec<u32> = members
            .iter()
            .map(|node| {
                index_of[*node].ok_or_else(|| {
                    DeckError::whole(format!(
                        "set `{set}`: node {} belongs to no element",
                        flat.node_names[*node]
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
        kept.sort_unstable();
        kept.dedup();
        Ok(kept)
    };
    let mut node_sets: BTreeMap<String, Vec<u32>> = BTreeMap::new();
    for (name, members) in &flat.sets.nsets {
        node_sets.insert(name.clone(), kept(name, members)?);
    }
    for (name, surface) in &flat.sets.surfaces {
        let members = surface_nodes(&flat, surface);
        let set = node_sets.entry(name.clone()).or_default();
        set.extend(kept(name, &members)?);
        set.sort_unstable();
        set.dedup();
    }
    let mut mesh = Mesh {
        nodes,
        elements,
        parts: options.parts.clone(),
        node_sets,
        contact_pairs: Vec::new(),
    };
    if let Some(contact) = &options.contact {
        mesh.contact_pairs = contact_pairs(&mesh, &flat, &index_of, contact)?;
    }
    Ok(mesh)
}

fn names<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let names: Vec<&str> = names.map(String::as_str).collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// Every element face a surface names exists on its element's kind (a tetrahedron has S1..S4,
/// a wedge S1..S5, a hexahedron S1..S6).
fn check_surface_faces(flat: &Flat) -> Result<(), DeckError> {
    for (name, surface) in &flat.sets.surfaces {
        let Surface::Faces(faces) = surface else {
            continue;
        };
        for &(element, face) in faces {
            let (kind, _) = &flat.elements[element];
            let n_faces = topology::n_faces(*kind);
            if face >= n_faces {
                return Err(DeckError::at(
                    &flat.element_sources[element],
                    format!(
                        "surface `{name}`: element {} ({kind}) has faces S1 to S{n_faces}, not S{}",
                        flat.element_names[element],
                        face + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn surface_nodes(flat: &Flat, surface: &Surface<usize>) -> Vec<usize> {
    match surface {
        Surface::Nodes(nodes) => nodes.clone(),
        Surface::Faces(faces) => faces
            .iter()
            .flat_map(|(element, face)| {
                let (kind, nodes) = &flat.elements[*element];
                topology::face_nodes(*kind, *face)
                    .into_iter()
                    .map(|local| nodes[local])
            })
            .collect(),
    }
}

/// The kept nodes of the surface or node set `name`.
fn side<'a>(flat: &Flat, index_of: &[Option<u32>], name: &'a str) -> Side<'a> {
    let nodes = match flat.sets.surfaces.get(name) {
        Some(surface) => surface_nodes(flat, surface),
        None => flat.sets.nsets[name].clone(),
    };
    Side::new(name, nodes.into_iter().filter_map(|node| index_of[node]))
}

/// The contact pairs between the surfaces or node sets `contact` names.
fn contact_pairs(
    mesh: &Mesh,
    flat: &Flat,
    index_of: &[Option<u32>],
    contact: &ContactSides,
) -> Result<Vec<ContactPair>, DeckError> {
    let find = |name: &str, param: &str| {
        if flat.sets.surfaces.contains_key(name) || flat.sets.nsets.contains_key(name) {
            Ok(())
        } else {
            Err(DeckError::whole(format!(
                "{param}: no surface or node set named `{name}` (surfaces: {}; node sets: {}); set contact_disc and contact_pad to \"\" for a mesh without contact",
                names(flat.sets.surfaces.keys()),
                names(flat.sets.nsets.keys())
            )))
        }
    };
    find(&contact.disc, "contact_disc")?;
    find(&contact.pad, "contact_pad")?;
    let disc = side(flat, index_of, &contact.disc);
    let pad = side(flat, index_of, &contact.pad);
    // The disc's faces: a surface's own, or every boundary face of a node set.
    let faces: Vec<ElementFace> = match flat.sets.surfaces.get(&contact.disc) {
        Some(Surface::Faces(faces)) => faces
            .iter()
            .map(|(element, face)| element_face(mesh, *element, *face))
            .collect(),
        _ => interface::boundary_faces(mesh, &disc),
    };
    let disc_faces = interface::contact_quads(mesh, faces).map_err(|face| {
        DeckError::at(
            &flat.element_sources[face.element],
            format!(
                "contact_disc `{}`: face S{} of element {} is a {}: node-to-node contact faces must be 4-node quadrangles (quad4)",
                contact.disc,
                face.face + 1,
                flat.element_names[face.element],
                face.kind
            ),
        )
    })?;
    if disc_faces.is_empty() {
        return Err(DeckError::whole(format!(
            "contact_disc `{}` holds no element face on the boundary",
            contact.disc
        )));
    }
    let node_name = |node: u32| {
        let flat_idx = index_of
            .iter()
            .position(|idx| *idx == Some(node))
            .expect("a kept node");
        flat.node_names[flat_idx].clone()
    };
    interface::pair_nodes(
        mesh,
        &disc,
        &pad,
        &disc_faces,
        contact.relative_tolerance,
        &node_name,
    )
    .map_err(DeckError::whole)
}
