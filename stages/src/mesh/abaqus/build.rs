//! The flattened model into a [`Mesh`]: hexahedra in the parts named, node sets, contact
//! pairs.

use std::collections::BTreeMap;

use super::ReadOptions;
use super::assembly::Flat;
use super::deck::InpError;
use super::interpret::{Deck, Surface};
use crate::artifact::mesh::{ContactPair, Mesh};
use crate::fem::faces::{HEX_FACES, Side, faces_within};
use crate::fem::hex8::first_inverted_corner;
use crate::mesh::interface::{self, ContactSides};

/// The deck's mesh: hexahedra in the parts of `options`, node sets, contact pairs.
pub fn build_mesh(deck: &Deck, options: &ReadOptions) -> Result<Mesh, InpError> {
    let flat = deck.flatten()?;
    if flat.hexes.is_empty() {
        return Err(InpError::whole(
            "no hexahedra: the deck defines no *ELEMENT",
        ));
    }
    // Parts: element sets; every hexahedron in exactly one.
    let mut hex_part: Vec<Option<u32>> = vec![None; flat.hexes.len()];
    for (part_idx, part) in options.parts.iter().enumerate() {
        let members = flat.sets.elsets.get(part).ok_or_else(|| {
            InpError::whole(format!(
                "parts: no element set or instance named `{part}` (element sets: {})",
                names(flat.sets.elsets.keys())
            ))
        })?;
        for &element in members {
            if let Some(other) = hex_part[element].replace(part_idx as u32)
                && other != part_idx as u32
            {
                return Err(InpError::at(
                    &flat.hex_sources[element],
                    format!(
                        "element {} is in parts `{}` and `{part}`: each element is in one part",
                        flat.hex_names[element], options.parts[other as usize]
                    ),
                ));
            }
        }
    }
    // Only nodes of hexahedra carry stiffness: number them in flattened order.
    let mut used = vec![false; flat.nodes.len()];
    for hex in &flat.hexes {
        for node in hex {
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
    let mut hexes = Vec::with_capacity(flat.hexes.len());
    for (element, hex) in flat.hexes.iter().enumerate() {
        if hex_part[element].is_none() {
            return Err(InpError::at(
                &flat.hex_sources[element],
                format!(
                    "element {} is in none of the parts {}: add it to one of their element sets",
                    flat.hex_names[element],
                    options.parts.join(", ")
                ),
            ));
        }
        let hex = hex.map(|node| index_of[node].expect("nodes of hexahedra are kept"));
        let corners = hex.map(|node| nodes[node as usize]);
        if let Some(corner) = first_inverted_corner(&corners) {
            return Err(InpError::at(
                &flat.hex_sources[element],
                format!(
                    "element {} is inverted or degenerate (det J <= 0 at its node {}): check its node order",
                    flat.hex_names[element], flat.node_names[flat.hexes[element][corner]]
                ),
            ));
        }
        hexes.push(hex);
    }
    if let Some((first, second)) = crate::mesh::first_duplicate(&hexes) {
        return Err(InpError::at(
            &flat.hex_sources[second],
            format!(
                "element {} has the nodes of element {}: a duplicated element doubles its stiffness and mass",
                flat.hex_names[second], flat.hex_names[first]
            ),
        ));
    }
    let hex_part: Vec<u32> = hex_part
        .into_iter()
        .map(|part| part.expect("checked above"))
        .collect();
    let kept = |set: &str, members: &[usize]| -> Result<Vec<u32>, InpError> {
        let mut kept: Vec<u32> = members
            .iter()
            .map(|node| {
                index_of[*node].ok_or_else(|| {
                    InpError::whole(format!(
                        "set `{set}`: node {} belongs to no hexahedron",
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
        hexes,
        hex_part,
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

fn surface_nodes(flat: &Flat, surface: &Surface<usize>) -> Vec<usize> {
    match surface {
        Surface::Nodes(nodes) => nodes.clone(),
        Surface::Faces(faces) => faces
            .iter()
            .flat_map(|(element, face)| HEX_FACES[*face].map(|local| flat.hexes[*element][local]))
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
) -> Result<Vec<ContactPair>, InpError> {
    let find = |name: &str, param: &str| {
        if flat.sets.surfaces.contains_key(name) || flat.sets.nsets.contains_key(name) {
            Ok(())
        } else {
            Err(InpError::whole(format!(
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
    let disc_faces: Vec<[u32; 4]> = match flat.sets.surfaces.get(&contact.disc) {
        Some(Surface::Faces(faces)) => faces
            .iter()
            .map(|(element, face)| {
                let quad = HEX_FACES[*face].map(|local| mesh.hexes[*element][local]);
                interface::outward(mesh, *element, quad)
            })
            .collect(),
        _ => faces_within(mesh, &disc)
            .into_values()
            .filter_map(|owners| match owners[..] {
                [(hex_idx, quad)] => Some(interface::outward(mesh, hex_idx, quad)),
                _ => None,
            })
            .collect(),
    };
    if disc_faces.is_empty() {
        return Err(InpError::whole(format!(
            "contact_disc `{}` holds no face of a hexahedron on the boundary",
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
    .map_err(InpError::whole)
}
