//! The keyword blocks interpreted: the parts' nodes, solid elements, sets and surfaces, the
//! instances that place them, and the assembly's own set definitions.

use std::collections::BTreeMap;

use super::deck::{Block, DataLine, DeckError, Source, label, number};
use crate::artifact::ElementKind;
use crate::artifact::mesh::{norm, sub};
use crate::fem::element::formats::{self, Format};

/// Element types and the kind each becomes. Reduced integration (R), hybrid (H) and modified
/// (M) variants are read as squeal's full element of the same nodes: squeal integrates each
/// kind by its own rule, and the 8-node hexahedra are its incompatible-mode element.
const SOLID_TYPES: [(&str, ElementKind); 20] = [
    ("C3D8", ElementKind::Hex8),
    ("C3D8I", ElementKind::Hex8),
    ("C3D8R", ElementKind::Hex8),
    ("C3D8H", ElementKind::Hex8),
    ("C3D8IH", ElementKind::Hex8),
    ("C3D8RH", ElementKind::Hex8),
    ("C3D20", ElementKind::Hex20),
    ("C3D20R", ElementKind::Hex20),
    ("C3D20H", ElementKind::Hex20),
    ("C3D20RH", ElementKind::Hex20),
    ("C3D4", ElementKind::Tet4),
    ("C3D4H", ElementKind::Tet4),
    ("C3D10", ElementKind::Tet10),
    ("C3D10H", ElementKind::Tet10),
    ("C3D10M", ElementKind::Tet10),
    ("C3D10MH", ElementKind::Tet10),
    ("C3D6", ElementKind::Wedge6),
    ("C3D6H", ElementKind::Wedge6),
    ("C3D15", ElementKind::Wedge15),
    ("C3D15H", ElementKind::Wedge15),
];

/// The kind of an Abaqus element type.
pub(super) fn solid_kind(element_type: &str) -> Option<ElementKind> {
    SOLID_TYPES
        .iter()
        .find(|(name, _)| *name == element_type)
        .map(|(_, kind)| *kind)
}

/// Keywords that carry no mesh (materials, sections, loads, steps: the stages set those),
/// skipped with their data lines; a `*STEP` is skipped to its `*END STEP`.
const NOT_MESH: [&str; 14] = [
    "HEADING",
    "PREPRINT",
    "MATERIAL",
    "ELASTIC",
    "DENSITY",
    "DAMPING",
    "SOLID SECTION",
    "BOUNDARY",
    "SURFACE INTERACTION",
    "FRICTION",
    "CONTACT PAIR",
    "INITIAL CONDITIONS",
    "AMPLITUDE",
    "TIE",
];

/// A surface: faces of elements (`TYPE=ELEMENT`, face 0..5 for S1..S6, checked against the
/// element's kind when flattened) or nodes.
#[derive(Debug, Clone)]
pub(super) enum Surface<L> {
    Faces(Vec<(L, usize)>),
    Nodes(Vec<L>),
}

/// Nodes, elements and named sets, labelled by `L`: a part's own labels (`u64`) or, once
/// flattened, indices into the model.
#[derive(Debug, Clone)]
pub(super) struct Sets<L> {
    pub(super) nsets: BTreeMap<String, Vec<L>>,
    pub(super) elsets: BTreeMap<String, Vec<L>>,
    pub(super) surfaces: BTreeMap<String, Surface<L>>,
}

impl<L> Default for Sets<L> {
    fn default() -> Self {
        Sets {
            nsets: BTreeMap::new(),
            elsets: BTreeMap::new(),
            surfaces: BTreeMap::new(),
        }
    }
}

#[derive(Debug, Default)]
pub(super) struct Part {
    pub(super) nodes: BTreeMap<u64, ([f64; 3], Source)>,
    /// Elements by label: kind, nodes (squeal's order) and where defined.
    pub(super) elements: BTreeMap<u64, (ElementKind, Vec<u64>, Source)>,
    pub(super) sets: Sets<u64>,
}

pub(super) struct Instance {
    pub(super) name: String,
    pub(super) part: String,
    pub(super) translation: [f64; 3],
    /// Axis points a, b and the angle in radians, applied after the translation.
    pub(super) rotation: Option<([f64; 3], [f64; 3], f64)>,
    pub(super) at: Source,
}

/// Where definitions go while the deck is read.
pub(super) enum Scope {
    Model,
    Part(String),
    Assembly,
    Instance,
    Step,
}

/// The deck, read.
pub struct Deck {
    pub(super) parts: BTreeMap<String, Part>,
    pub(super) part_order: Vec<String>,
    pub(super) instances: Vec<Instance>,
    /// Set and surface definitions of the assembly, resolved after flattening.
    pub(super) assembly_blocks: Vec<Block>,
    pub(super) uses_parts: bool,
}

pub fn interpret(blocks: Vec<Block>) -> Result<Deck, DeckError> {
    let mut deck = Deck {
        parts: BTreeMap::new(),
        part_order: Vec::new(),
        instances: Vec::new(),
        assembly_blocks: Vec::new(),
        uses_parts: false,
    };
    let mut scope = Scope::Model;
    for block in blocks {
        let keyword = block.keyword.as_str();
        if let Scope::Step = scope {
            if keyword == "END STEP" {
                scope = Scope::Model;
            }
            continue;
        }
        if NOT_MESH.contains(&keyword) {
            continue;
        }
        match (keyword, &scope) {
            ("STEP", Scope::Model) => scope = Scope::Step,
            ("PART", Scope::Model) => {
                block.only_params(&["NAME"])?;
                let name = block.required("NAME")?.to_lowercase();
                if deck.parts.contains_key(&name) {
                    return Err(DeckError::at(
                        &block.at,
                        format!("part `{name}` is defined twice"),
                    ));
                }
                deck.uses_parts = true;
                deck.part_order.push(name.clone());
                deck.parts.insert(name.clone(), Part::default());
                scope = Scope::Part(name);
            }
            ("END PART", Scope::Part(_)) => scope = Scope::Model,
            ("ASSEMBLY", Scope::Model) => {
                block.only_params(&["NAME"])?;
                scope = Scope::Assembly;
            }
            ("END ASSEMBLY", Scope::Assembly) => scope = Scope::Model,
            ("INSTANCE", Scope::Assembly) => {
                deck.instances.push(instance(&block)?);
                scope = Scope::Instance;
            }
            ("END INSTANCE", Scope::Instance) => scope = Scope::Assembly,
            ("NSET" | "ELSET" | "SURFACE", Scope::Assembly) => deck.assembly_blocks.push(block),
            ("NODE" | "ELEMENT" | "NSET" | "ELSET" | "SURFACE", Scope::Model | Scope::Part(_)) => {
                let name = match &scope {
                    Scope::Part(name) => name.clone(),
                    _ => {
                        if deck.uses_parts {
                            return Err(DeckError::at(
                                &block.at,
                                format!("*{keyword} outside a *PART in a deck that has parts"),
                            ));
                        }
                        if !deck.parts.contains_key("") {
                            deck.part_order.push(String::new());
                        }
                        String::new()
                    }
                };
                let part = deck.parts.entry(name).or_default();
                match keyword {
                    "NODE" => read_nodes(part, &block)?,
                    "ELEMENT" => read_elements(part, &block)?,
                    "NSET" | "ELSET" => read_set(part, &block)?,
                    _ => read_surface(part, &block)?,
                }
            }
            _ => {
                let hint = match keyword {
                    "END PART" | "END ASSEMBLY" | "END INSTANCE" | "INSTANCE" | "PART"
                    | "ASSEMBLY" => " here (unbalanced *PART/*ASSEMBLY/*INSTANCE?)",
                    _ => {
                        " (squeal reads the mesh: *NODE, *ELEMENT, *NSET, *ELSET, *SURFACE, *INCLUDE, *PART, *ASSEMBLY, *INSTANCE)"
                    }
                };
                return Err(DeckError::at(
                    &block.at,
                    format!("keyword *{keyword} is not supported{hint}"),
                ));
            }
        }
    }
    if deck.uses_parts && deck.parts.contains_key("") {
        return Err(DeckError::whole(
            "nodes or elements both inside and outside *PART",
        ));
    }
    if !deck.uses_parts {
        // A deck without parts is one implicit instance of one implicit part.
        deck.instances.push(Instance {
            name: String::new(),
            part: String::new(),
            translation: [0.0; 3],
            rotation: None,
            at: Source {
                file: "".into(),
                line: 0,
            },
        });
    } else if deck.instances.is_empty() {
        return Err(DeckError::whole(format!(
            "parts {} are defined but no *ASSEMBLY instances them",
            deck.part_order.join(", ")
        )));
    }
    Ok(deck)
}

fn instance(block: &Block) -> Result<Instance, DeckError> {
    block.only_params(&["NAME", "PART"])?;
    let name = block.required("NAME")?.to_lowercase();
    let part = block.required("PART")?.to_lowercase();
    let values = |line: &DataLine, count: usize, what: &str| -> Result<Vec<f64>, DeckError> {
        let fields: Vec<&String> = line.fields.iter().filter(|f| !f.is_empty()).collect();
        if fields.len() != count {
            return Err(DeckError::at(
                &line.at,
                format!(
                    "*INSTANCE {what}: {count} values expected, found {}",
                    fields.len()
                ),
            ));
        }
        fields
            .iter()
            .map(|field| number(field, &line.at, what))
            .collect()
    };
    let mut translation = [0.0; 3];
    let mut rotation = None;
    match &block.data[..] {
        [] => {}
        [first, rest @ ..] if rest.len() <= 1 => {
            let t = values(first, 3, "translation")?;
            translation = [t[0], t[1], t[2]];
            if let Some(second) = rest.first() {
                let r = values(second, 7, "rotation (a, b, angle in degrees)")?;
                let (a, b) = ([r[0], r[1], r[2]], [r[3], r[4], r[5]]);
                if norm(sub(b, a)) == 0.0 {
                    return Err(DeckError::at(
                        &second.at,
                        "*INSTANCE rotation: points a and b coincide",
                    ));
                }
                rotation = Some((a, b, r[6].to_radians()));
            }
        }
        [_, _, third, ..] => {
            return Err(DeckError::at(
                &third.at,
                "*INSTANCE takes at most two data lines (translation, rotation)",
            ));
        }
        _ => unreachable!("slices of length 1 and 2 are matched above"),
    }
    Ok(Instance {
        name,
        part,
        translation,
        rotation,
        at: block.at.clone(),
    })
}

fn read_nodes(part: &mut Part, block: &Block) -> Result<(), DeckError> {
    block.only_params(&["NSET"])?;
    let mut labels = Vec::with_capacity(block.data.len());
    for line in &block.data {
        let fields: Vec<&String> = line.fields.iter().filter(|f| !f.is_empty()).collect();
        if fields.len() != 4 {
            return Err(DeckError::at(
                &line.at,
                format!(
                    "*NODE: label, x, y, z expected, found {} values",
                    fields.len()
                ),
            ));
        }
        let node = label(fields[0], &line.at, "node label")?;
        let mut x = [0.0; 3];
        for axis in 0..3 {
            x[axis] = number(fields[axis + 1], &line.at, "node coordinate")?;
        }
        if let Some((_, first)) = part.nodes.insert(node, (x, line.at.clone())) {
            return Err(DeckError::at(
                &line.at,
                format!("node {node} is defined twice (first at {first})"),
            ));
        }
        labels.push(node);
    }
    if let Some(set) = block.param("NSET") {
        add_to(&mut part.sets.nsets, set, labels);
    }
    Ok(())
}

fn read_elements(part: &mut Part, block: &Block) -> Result<(), DeckError> {
    block.only_params(&["TYPE", "ELSET"])?;
    let element_type = block.required("TYPE")?.to_uppercase();
    let Some(kind) = solid_kind(&element_type) else {
        let known: Vec<&str> = SOLID_TYPES.iter().map(|(name, _)| *name).collect();
        return Err(DeckError::at(
            &block.at,
            format!(
                "element type {element_type} is not supported: squeal reads solid elements ({})",
                known.join(", ")
            ),
        ));
    };
    let n_nodes = kind.n_nodes();
    let mut labels = Vec::new();
    // An element's numbers may continue on the next line after a trailing comma.
    let mut pending: Vec<(&str, &Source)> = Vec::new();
    for line in &block.data {
        pending.extend(
            line.fields
                .iter()
                .filter(|field| !field.is_empty())
                .map(|field| (field.as_str(), &line.at)),
        );
        let continues = line.fields.last().is_some_and(String::is_empty);
        if continues && pending.len() < 1 + n_nodes {
            continue;
        }
        let at = pending.first().map_or(&line.at, |(_, at)| *at).clone();
        if pending.len() != 1 + n_nodes {
            return Err(DeckError::at(
                &at,
                format!(
                    "{element_type}: a label and {n_nodes} nodes expected, found {} values",
                    pending.len()
                ),
            ));
        }
        let element = label(pending[0].0, &at, "element label")?;
        let mut file_nodes = Vec::with_capacity(n_nodes);
        for (field, at) in &pending[1..] {
            file_nodes.push(label(field, at, "node label")?);
        }
        let nodes = formats::from_file(kind, Format::Abaqus, &file_nodes);
        if let Some((_, _, first)) = part.elements.insert(element, (kind, nodes, at.clone())) {
            return Err(DeckError::at(
                &at,
                format!("element {element} is defined twice (first at {first})"),
            ));
        }
        labels.push(element);
        pending.clear();
    }
    if let Some((_, at)) = pending.first() {
        return Err(DeckError::at(
            at,
            "the last element's line ends with a comma",
        ));
    }
    if let Some(set) = block.param("ELSET") {
        add_to(&mut part.sets.elsets, set, labels);
    }
    Ok(())
}

fn add_to<L>(sets: &mut BTreeMap<String, Vec<L>>, name: &str, labels: Vec<L>) {
    sets.entry(name.to_lowercase()).or_default().extend(labels);
}

/// The entries of a set's data lines: `GENERATE` ranges, or labels and names of sets of the
/// same kind, resolved by `lookup`.
pub(super) fn set_entries<L: Clone>(
    block: &Block,
    sets: &BTreeMap<String, Vec<L>>,
    labelled: &dyn Fn(u64, &Source) -> Result<L, DeckError>,
) -> Result<Vec<L>, DeckError> {
    let mut entries = Vec::new();
    if block.param("GENERATE").is_some() {
        for line in &block.data {
            let fields: Vec<&String> = line.fields.iter().filter(|f| !f.is_empty()).collect();
            let values = fields
                .iter()
                .map(|field| label(field, &line.at, "GENERATE"))
                .collect::<Result<Vec<u64>, _>>()?;
            let (first, last, step) = match values[..] {
                [first, last] => (first, last, 1),
                [first, last, step] => (first, last, step),
                _ => {
                    return Err(DeckError::at(
                        &line.at,
                        "GENERATE: first, last[, increment] expected",
                    ));
                }
            };
            if last < first {
                return Err(DeckError::at(&line.at, "GENERATE: last is below first"));
            }
            let mut value = first;
            while value <= last {
                entries.push(labelled(value, &line.at)?);
                value += step;
            }
        }
        return Ok(entries);
    }
    for line in &block.data {
        for field in line.fields.iter().filter(|f| !f.is_empty()) {
            entries.extend(members(field, &line.at, sets, labelled)?);
        }
    }
    Ok(entries)
}

/// A field of a set's or surface's data line: a label (`labelled` maps it), or the name of a
/// set of `sets` defined above.
pub(super) fn members<L: Clone>(
    field: &str,
    at: &Source,
    sets: &BTreeMap<String, Vec<L>>,
    labelled: &dyn Fn(u64, &Source) -> Result<L, DeckError>,
) -> Result<Vec<L>, DeckError> {
    if field.bytes().all(|byte| byte.is_ascii_digit()) {
        Ok(vec![labelled(label(field, at, "label")?, at)?])
    } else {
        sets.get(&field.to_lowercase())
            .cloned()
            .ok_or_else(|| DeckError::at(at, format!("no set named `{field}` is defined above")))
    }
}

fn read_set(part: &mut Part, block: &Block) -> Result<(), DeckError> {
    let is_nset = block.keyword == "NSET";
    let name_param = if is_nset { "NSET" } else { "ELSET" };
    block.only_params(&[name_param, "GENERATE", "INTERNAL", "UNSORTED"])?;
    let name = block.required(name_param)?;
    let sets = if is_nset {
        &part.sets.nsets
    } else {
        &part.sets.elsets
    };
    let entries = set_entries(block, sets, &|value, _| Ok(value))?;
    let target = if is_nset {
        &mut part.sets.nsets
    } else {
        &mut part.sets.elsets
    };
    add_to(target, name, entries);
    Ok(())
}

/// `S1`..`S6` as a face index.
fn face_index(field: &str, at: &Source) -> Result<usize, DeckError> {
    match field.to_uppercase().as_str() {
        "S1" => Ok(0),
        "S2" => Ok(1),
        "S3" => Ok(2),
        "S4" => Ok(3),
        "S5" => Ok(4),
        "S6" => Ok(5),
        other => Err(DeckError::at(
            at,
            format!("face `{other}` of an element: S1 to S6 expected"),
        )),
    }
}

/// A surface's data lines: `(set or label, face)` per line for `TYPE=ELEMENT`, node sets or
/// labels for `TYPE=NODE`.
pub(super) fn surface_entries<L: Copy>(
    block: &Block,
    elements: impl Fn(&str, &Source) -> Result<Vec<L>, DeckError>,
    nodes: impl Fn(&str, &Source) -> Result<Vec<L>, DeckError>,
) -> Result<Surface<L>, DeckError> {
    block.only_params(&["NAME", "TYPE", "INTERNAL"])?;
    let of_nodes = match block.param("TYPE").map(str::to_uppercase).as_deref() {
        None | Some("ELEMENT") => false,
        Some("NODE") => true,
        Some(other) => {
            return Err(DeckError::at(
                &block.at,
                format!("*SURFACE TYPE={other} is not supported (ELEMENT or NODE)"),
            ));
        }
    };
    let mut faces = Vec::new();
    let mut node_list = Vec::new();
    for line in &block.data {
        let fields: Vec<&String> = line.fields.iter().filter(|f| !f.is_empty()).collect();
        let Some(first) = fields.first() else {
            continue;
        };
        if of_nodes {
            node_list.extend(nodes(first, &line.at)?);
        } else {
            let face = fields
                .get(1)
                .ok_or_else(|| {
                    DeckError::at(&line.at, "a face S1..S6 is needed after the element set")
                })
                .and_then(|face| face_index(face, &line.at))?;
            faces.extend(
                elements(first, &line.at)?
                    .into_iter()
                    .map(|element| (element, face)),
            );
        }
    }
    Ok(if of_nodes {
        Surface::Nodes(node_list)
    } else {
        Surface::Faces(faces)
    })
}

fn read_surface(part: &mut Part, block: &Block) -> Result<(), DeckError> {
    let name = block.required("NAME")?.to_lowercase();
    let sets = &part.sets;
    let surface = surface_entries(
        block,
        |field, at| members(field, at, &sets.elsets, &|value, _| Ok(value)),
        |field, at| members(field, at, &sets.nsets, &|value, _| Ok(value)),
    )?;
    part.sets.surfaces.insert(name, surface);
    Ok(())
}
