//! The cards into a [`Mesh`]: coordinate systems resolved, grid points placed in the basic
//! frame, solid elements in squeal's node order (mirrored when a deck turns them the other
//! way), parts by property, node sets, contact pairs.

use std::collections::{BTreeMap, HashMap};

use super::ReadOptions;
use super::cards::Card;
use crate::artifact::ElementKind;
use crate::artifact::mesh::{ContactPair, Elements, Mesh, cross, norm, sub};
use crate::fem::element::first_inverted;
use crate::fem::element::formats::{self, Format};
use crate::fem::element::topology::mid_edge_node;
use crate::fem::faces::Side;
use crate::mesh::deck_error::{DeckError, Source};
use crate::mesh::interface::{self, ContactSides};

/// Cards that carry no mesh (materials, loads, constraints other than SPC1, solution
/// parameters: the stages set those), skipped.
pub const SKIPPED: [&str; 16] = [
    "PARAM", "EIGRL", "EIGR", "MAT1", "MAT2", "MAT8", "MAT9", "MAT10", "SPC", "SPCADD", "SPCD",
    "LOAD", "FORCE", "PLOAD4", "GRAV", "TEMPD",
];

/// Cards refused with why: skipping them would change the model.
const REFUSED: [(&str, &str); 12] = [
    (
        "RBE2",
        "rigid elements tie nodes squeal cannot tie: mesh the parts they join, or remove them",
    ),
    (
        "RBE3",
        "interpolation elements tie nodes squeal cannot tie: remove them",
    ),
    (
        "RBAR",
        "rigid bars tie nodes squeal cannot tie: remove them",
    ),
    (
        "MPC",
        "multipoint constraints are not supported: remove them",
    ),
    (
        "CONM2",
        "concentrated masses are not supported: model the mass as elements",
    ),
    ("CELAS1", "springs are not supported"),
    ("CELAS2", "springs are not supported"),
    ("CBUSH", "bushings are not supported"),
    (
        "CBAR",
        "beam elements are not supported: squeal takes solid elements",
    ),
    (
        "CBEAM",
        "beam elements are not supported: squeal takes solid elements",
    ),
    (
        "CQUAD4",
        "shell elements are not supported: squeal takes solid elements",
    ),
    (
        "CTRIA3",
        "shell elements are not supported: squeal takes solid elements",
    ),
];

const READ: [&str; 10] = [
    "GRID", "CORD2R", "CORD2C", "CORD2S", "CTETRA", "CPENTA", "CHEXA", "PSOLID", "SET1", "SPC1",
];

/// A coordinate system: its type (`R`, `C`, `S`), origin and axes in the basic frame.
#[derive(Debug, Clone, Copy)]
struct Frame {
    kind: char,
    origin: [f64; 3],
    axes: [[f64; 3]; 3],
}

impl Frame {
    const BASIC: Frame = Frame {
        kind: 'R',
        origin: [0.0; 3],
        axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// A point given by its coordinates in this system (angles in degrees), in the basic frame.
    fn to_basic(self, [a, b, c]: [f64; 3]) -> [f64; 3] {
        let local = match self.kind {
            'C' => {
                let theta = b.to_radians();
                [a * theta.cos(), a * theta.sin(), c]
            }
            'S' => {
                let (theta, phi) = (b.to_radians(), c.to_radians());
                [
                    a * theta.sin() * phi.cos(),
                    a * theta.sin() * phi.sin(),
                    a * theta.cos(),
                ]
            }
            _ => [a, b, c],
        };
        std::array::from_fn(|i| {
            self.origin[i] + (0..3).map(|k| local[k] * self.axes[k][i]).sum::<f64>()
        })
    }
}

/// The coordinate systems by id, each resolved through the systems its points are given in.
fn frames(cards: &[Card]) -> Result<HashMap<i64, Frame>, DeckError> {
    let mut defined: HashMap<i64, &Card> = HashMap::new();
    for card in cards.iter().filter(|card| card.name.starts_with("CORD2")) {
        let cid = card.int(0, "CID")?;
        if cid <= 0 {
            return Err(DeckError::at(
                &card.at,
                format!("{}: CID must be positive, found {cid}", card.name),
            ));
        }
        if let Some(first) = defined.insert(cid, card) {
            return Err(DeckError::at(
                &card.at,
                format!(
                    "coordinate system {cid} is defined twice (first at {})",
                    first.at
                ),
            ));
        }
    }
    let mut resolved: HashMap<i64, Frame> = HashMap::from([(0, Frame::BASIC)]);
    for &cid in defined.keys() {
        resolve(cid, &defined, &mut resolved, &mut Vec::new())?;
    }
    Ok(resolved)
}

fn resolve(
    cid: i64,
    defined: &HashMap<i64, &Card>,
    resolved: &mut HashMap<i64, Frame>,
    chain: &mut Vec<i64>,
) -> Result<Frame, DeckError> {
    if let Some(frame) = resolved.get(&cid) {
        return Ok(*frame);
    }
    let card = defined[&cid];
    if chain.contains(&cid) {
        return Err(DeckError::at(
            &card.at,
            format!("coordinate systems {chain:?} are defined in terms of each other"),
        ));
    }
    chain.push(cid);
    let rid = card.int_or(1, 0, "RID")?;
    let reference = match defined.get(&rid) {
        Some(_) => resolve(rid, defined, resolved, chain)?,
        None if rid == 0 => Frame::BASIC,
        None => {
            return Err(DeckError::at(
                &card.at,
                format!(
                    "{} {cid}: its points are in system {rid}, which no CORD2 defines",
                    card.name
                ),
            ));
        }
    };
    let point = |start: usize| -> Result<[f64; 3], DeckError> {
        let mut x = [0.0; 3];
        for (k, value) in x.iter_mut().enumerate() {
            *value = card.real(start + k, "a point coordinate")?;
        }
        Ok(reference.to_basic(x))
    };
    let (a, b, c) = (point(2)?, point(5)?, point(8)?);
    let axis3 = sub(b, a);
    let axis2 = cross(axis3, sub(c, a));
    if !(norm(axis3) > 0.0 && norm(axis2) > 1e-12 * norm(axis3) * norm(sub(c, a))) {
        return Err(DeckError::at(
            &card.at,
            format!(
                "{} {cid}: points A, B and C must not lie on one line",
                card.name
            ),
        ));
    }
    let unit = |v: [f64; 3]| v.map(|component| component / norm(v));
    let (axis3, axis2) = (unit(axis3), unit(axis2));
    let frame = Frame {
        kind: card.name.chars().last().unwrap_or('R'),
        origin: a,
        axes: [cross(axis2, axis3), axis2, axis3],
    };
    chain.pop();
    resolved.insert(cid, frame);
    Ok(frame)
}

/// An element as read: id, property, kind, grid ids in squeal's order, where.
struct Solid {
    id: i64,
    property: i64,
    kind: ElementKind,
    grids: Vec<i64>,
    at: Source,
}

/// The kind of a solid card with `n` grid points.
fn solid_kind(card: &str, n: usize) -> Option<ElementKind> {
    match (card, n) {
        ("CTETRA", 4) => Some(ElementKind::Tet4),
        ("CTETRA", 10) => Some(ElementKind::Tet10),
        ("CPENTA", 6) => Some(ElementKind::Wedge6),
        ("CPENTA", 15) => Some(ElementKind::Wedge15),
        ("CHEXA", 8) => Some(ElementKind::Hex8),
        ("CHEXA", 20) => Some(ElementKind::Hex20),
        _ => None,
    }
}

fn read_solid(card: &Card) -> Result<Solid, DeckError> {
    let id = card.int(0, "EID")?;
    let property = card.int(1, "PID")?;
    let fields = &card.fields[2.min(card.fields.len())..];
    let n_given = fields
        .iter()
        .rposition(|field| !field.is_empty())
        .map_or(0, |last| last + 1);
    let kind = solid_kind(&card.name, n_given).ok_or_else(|| {
        DeckError::at(
            &card.at,
            format!(
                "{} {id}: {n_given} grid points, expected {}",
                card.name,
                match card.name.as_str() {
                    "CTETRA" => "4 or 10",
                    "CPENTA" => "6 or 15",
                    _ => "8 or 20",
                }
            ),
        )
    })?;
    let mut grids = Vec::with_capacity(n_given);
    for (k, field) in fields.iter().take(n_given).enumerate() {
        if field.is_empty() {
            return Err(DeckError::at(
                &card.at,
                format!(
                    "{} {id}: grid point G{} is blank: give every mid-edge node or none",
                    card.name,
                    k + 1
                ),
            ));
        }
        grids.push(card.int(2 + k, "a grid point")?);
    }
    Ok(Solid {
        id,
        property,
        kind,
        grids: formats::from_file(kind, Format::Nastran, &grids),
        at: card.at.clone(),
    })
}

/// The element turned the other way round (Nastran takes either orientation): corners
/// mirrored, each mid-edge node following its edge.
fn mirrored(kind: ElementKind, nodes: &[u32]) -> Vec<u32> {
    let corners: &[usize] = match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => &[0, 2, 1, 3],
        ElementKind::Wedge6 | ElementKind::Wedge15 => &[3, 4, 5, 0, 1, 2],
        ElementKind::Hex8 | ElementKind::Hex20 => &[4, 5, 6, 7, 0, 1, 2, 3],
    };
    let mut out: Vec<u32> = corners.iter().map(|&c| nodes[c]).collect();
    for &[a, b] in crate::fem::element::topology::edges(kind)
        .iter()
        .take(kind.n_nodes() - kind.n_corners())
    {
        let old = mid_edge_node(kind, corners[a], corners[b]).expect("an edge");
        out.push(nodes[old]);
    }
    out
}

/// Grid ids of a SET1 or SPC1 list from field `start`: ids and `a THRU b` ranges.
fn grid_list(card: &Card, start: usize) -> Result<Vec<i64>, DeckError> {
    let mut ids = Vec::new();
    let mut k = start;
    while k < card.fields.len() {
        let field = card.field(k);
        if field.is_empty() {
            k += 1;
            continue;
        }
        if card.field(k + 1).eq_ignore_ascii_case("THRU") {
            let (first, last) = (card.int(k, "a grid id")?, card.int(k + 2, "a grid id")?);
            if last < first || last - first > 10_000_000 {
                return Err(DeckError::at(
                    &card.at,
                    format!("{}: `{first} THRU {last}` is no range", card.name),
                ));
            }
            ids.extend(first..=last);
            k += 3;
        } else {
            ids.push(card.int(k, "a grid id")?);
            k += 1;
        }
    }
    Ok(ids)
}

/// A property's name: the deck's own (`$HMNAME PROP <pid> "<name>"` above its PSOLID), or
/// `pid<N>`.
fn property_name(card: &Card, pid: i64) -> String {
    card.comments
        .iter()
        .find_map(|comment| {
            let rest = comment.strip_prefix("HMNAME PROP")?;
            let (id, name) = rest.split_once('"')?;
            (id.trim().parse::<i64>().ok()? == pid)
                .then(|| name.trim_end_matches('"').to_lowercase())
        })
        .unwrap_or_else(|| format!("pid{pid}"))
}

/// The parts: `options.parts` items `name=pid` (a name may take several properties), or one
/// part per PSOLID. Returns the part names and the part of each property.
fn parts(
    cards: &[Card],
    options: &ReadOptions,
) -> Result<(Vec<String>, HashMap<i64, u32>), DeckError> {
    let mut names_of: BTreeMap<i64, String> = BTreeMap::new();
    for card in cards.iter().filter(|card| card.name == "PSOLID") {
        let pid = card.int(0, "PID")?;
        if names_of.insert(pid, property_name(card, pid)).is_some() {
            return Err(DeckError::at(
                &card.at,
                format!("PSOLID {pid} is defined twice"),
            ));
        }
    }
    let mut names: Vec<String> = Vec::new();
    let mut part_of: HashMap<i64, u32> = HashMap::new();
    if options.parts.is_empty() {
        for (pid, name) in &names_of {
            part_of.insert(*pid, names.len() as u32);
            names.push(name.clone());
        }
        return Ok((names, part_of));
    }
    for item in &options.parts {
        let (name, pid) = item.split_once('=').ok_or_else(|| {
            DeckError::whole(format!(
                "parts: `{item}` should be `name=property id` (e.g. `disc=1`)"
            ))
        })?;
        let (name, pid) = (name.trim().to_lowercase(), pid.trim());
        let pid: i64 = pid.parse().map_err(|_| {
            DeckError::whole(format!("parts: `{item}`: `{pid}` is not a property id"))
        })?;
        if !names_of.contains_key(&pid) {
            return Err(DeckError::whole(format!(
                "parts: `{item}`: no PSOLID {pid} (properties: {})",
                names_of
                    .keys()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let part = match names.iter().position(|known| *known == name) {
            Some(part) => part,
            None => {
                names.push(name);
                names.len() - 1
            }
        };
        if part_of
            .insert(pid, part as u32)
            .is_some_and(|other| other != part as u32)
        {
            return Err(DeckError::whole(format!(
                "parts: property {pid} is in two parts"
            )));
        }
    }
    Ok((names, part_of))
}

/// The deck's mesh: solid elements in their parts, node sets, contact pairs.
pub fn build_mesh(cards: &[Card], options: &ReadOptions) -> Result<Mesh, DeckError> {
    for card in cards {
        let name = card.name.as_str();
        if READ.contains(&name) || SKIPPED.contains(&name) {
            continue;
        }
        let why = REFUSED.iter().find(|(refused, _)| *refused == name).map_or(
            "squeal reads GRID, CORD2R/C/S, CTETRA, CPENTA, CHEXA, PSOLID, SET1 and SPC1",
            |(_, why)| why,
        );
        return Err(DeckError::at(
            &card.at,
            format!("card {name} is not supported: {why}"),
        ));
    }
    let frames = frames(cards)?;
    let mut grids: BTreeMap<i64, ([f64; 3], &Source)> = BTreeMap::new();
    for card in cards.iter().filter(|card| card.name == "GRID") {
        let id = card.int(0, "ID")?;
        let cp = card.int_or(1, 0, "CP")?;
        let frame = frames.get(&cp).ok_or_else(|| {
            DeckError::at(
                &card.at,
                format!("GRID {id}: its CP {cp} is no coordinate system of the deck"),
            )
        })?;
        let mut x = [0.0; 3];
        for (k, value) in x.iter_mut().enumerate() {
            *value = card.real(2 + k, "a coordinate")?;
        }
        if let Some((_, first)) = grids.insert(id, (frame.to_basic(x), &card.at)) {
            return Err(DeckError::at(
                &card.at,
                format!("GRID {id} is defined twice (first at {first})"),
            ));
        }
    }
    let solids: Vec<Solid> = cards
        .iter()
        .filter(|card| matches!(card.name.as_str(), "CTETRA" | "CPENTA" | "CHEXA"))
        .map(read_solid)
        .collect::<Result<_, _>>()?;
    if solids.is_empty() {
        return Err(DeckError::whole(
            "no solid elements: the deck has no CTETRA, CPENTA or CHEXA",
        ));
    }
    let (part_names, part_of) = parts(cards, options)?;
    // Only grid points of elements carry stiffness: number them by increasing id.
    let mut used: Vec<i64> = solids
        .iter()
        .flat_map(|solid| solid.grids.iter().copied())
        .collect();
    used.sort_unstable();
    used.dedup();
    let mut index_of: HashMap<i64, u32> = HashMap::with_capacity(used.len());
    let mut nodes = Vec::with_capacity(used.len());
    for id in &used {
        index_of.insert(*id, nodes.len() as u32);
        nodes.push(grids.get(id).map(|(x, _)| *x).unwrap_or([f64::NAN; 3]));
    }
    let mut elements = Elements::new();
    let mut element_ids = Vec::with_capacity(solids.len());
    for solid in &solids {
        let label = format!("{} {}", solid_card(solid.kind), solid.id);
        let part = *part_of.get(&solid.property).ok_or_else(|| {
            let why = if options.parts.is_empty() {
                "no PSOLID defines it".to_string()
            } else {
                format!("no part takes it (parts: {})", options.parts.join(", "))
            };
            DeckError::at(
                &solid.at,
                format!("{label}: property {}: {why}", solid.property),
            )
        })?;
        if let Some(missing) = solid.grids.iter().find(|id| !grids.contains_key(id)) {
            return Err(DeckError::at(
                &solid.at,
                format!("{label}: grid point {missing} is not defined"),
            ));
        }
        let mut element: Vec<u32> = solid.grids.iter().map(|id| index_of[id]).collect();
        let coords = |element: &[u32]| -> Vec<[f64; 3]> {
            element.iter().map(|&node| nodes[node as usize]).collect()
        };
        if let Some(inverted) = first_inverted(solid.kind, &coords(&element)) {
            let turned = mirrored(solid.kind, &element);
            if first_inverted(solid.kind, &coords(&turned)).is_some() {
                return Err(DeckError::at(
                    &solid.at,
                    format!(
                        "{label} is inverted or degenerate (det J = {:.3e} at {}) whichever way it is turned: check its grid points",
                        inverted.det_j, inverted.location
                    ),
                ));
            }
            element = turned;
        }
        elements.push(solid.kind, part, &element);
        element_ids.push(solid.id);
    }
    if let Some((first, second)) = crate::mesh::first_duplicate(&elements) {
        return Err(DeckError::at(
            &solids[second].at,
            format!(
                "element {} has the grid points of element {}: a duplicated element doubles its stiffness and mass",
                element_ids[second], element_ids[first]
            ),
        ));
    }
    let node_sets = node_sets(cards, &index_of)?;
    let mut mesh = Mesh {
        nodes,
        elements,
        parts: part_names,
        node_sets,
        contact_pairs: Vec::new(),
    };
    if let Some(contact) = &options.contact {
        mesh.contact_pairs = contact_pairs(&mesh, contact, &used, &element_ids)?;
    }
    Ok(mesh)
}

fn solid_card(kind: ElementKind) -> &'static str {
    match kind {
        ElementKind::Tet4 | ElementKind::Tet10 => "CTETRA",
        ElementKind::Wedge6 | ElementKind::Wedge15 => "CPENTA",
        ElementKind::Hex8 | ElementKind::Hex20 => "CHEXA",
    }
}

/// `set<SID>` for each SET1, `spc<SID>` for the grid points of each SPC1 set.
fn node_sets(
    cards: &[Card],
    index_of: &HashMap<i64, u32>,
) -> Result<BTreeMap<String, Vec<u32>>, DeckError> {
    let mut sets: BTreeMap<String, Vec<u32>> = BTreeMap::new();
    for card in cards {
        let (name, start) = match card.name.as_str() {
            "SET1" => (format!("set{}", card.int(0, "SID")?), 1),
            "SPC1" => (format!("spc{}", card.int(0, "SID")?), 2),
            _ => continue,
        };
        let set = sets.entry(name.clone()).or_default();
        for id in grid_list(card, start)? {
            let node = index_of.get(&id).ok_or_else(|| {
                DeckError::at(
                    &card.at,
                    format!(
                        "{} (set `{name}`): grid point {id} belongs to no element",
                        card.name
                    ),
                )
            })?;
            set.push(*node);
        }
    }
    for set in sets.values_mut() {
        set.sort_unstable();
        set.dedup();
    }
    Ok(sets)
}

/// The contact pairs between the node sets `contact` names; the disc's faces are the boundary
/// faces whose nodes are all in its set.
fn contact_pairs(
    mesh: &Mesh,
    contact: &ContactSides,
    grid_of: &[i64],
    element_ids: &[i64],
) -> Result<Vec<ContactPair>, DeckError> {
    fn side<'a>(mesh: &Mesh, name: &'a str, param: &str) -> Result<Side<'a>, DeckError> {
        let nodes = mesh.node_sets.get(name).ok_or_else(|| {
            DeckError::whole(format!(
                "{param}: no node set named `{name}` (node sets: {}); set contact_disc and contact_pad to \"\" for a mesh without contact",
                mesh.node_sets.keys().cloned().collect::<Vec<_>>().join(", ")
            ))
        })?;
        Ok(Side::new(name, nodes.iter().copied()))
    }
    let disc = side(mesh, &contact.disc, "contact_disc")?;
    let pad = side(mesh, &contact.pad, "contact_pad")?;
    let disc_faces = interface::contact_quads(mesh, interface::boundary_faces(mesh, &disc))
        .map_err(|face| {
            DeckError::whole(format!(
                "contact_disc `{}`: a face of element {} is a {}: node-to-node contact faces must be 4-node quadrangles (quad4)",
                contact.disc, element_ids[face.element], face.kind
            ))
        })?;
    if disc_faces.is_empty() {
        return Err(DeckError::whole(format!(
            "contact_disc `{}` holds no element face on the boundary",
            contact.disc
        )));
    }
    let label = |node: u32| grid_of[node as usize].to_string();
    interface::pair_nodes(
        mesh,
        &disc,
        &pad,
        &disc_faces,
        contact.relative_tolerance,
        &label,
    )
    .map_err(DeckError::whole)
}
