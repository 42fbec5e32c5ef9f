//! The keyword blocks into one flat model: parts instanced (translated, rotated) into the
//! assembly, every label and set name made global, then the [`Mesh`].

use std::collections::{BTreeMap, HashMap};

use super::deck::{Block, DataLine, InpError, Source, label, number};
use super::{ContactSets, ReadOptions};
use crate::artifact::mesh::{ContactPair, Mesh, cross, dot, norm, sub};
use crate::fem::faces::{HEX_FACES, Side, faces_within};
use crate::fem::hex8::first_inverted_corner;
use crate::mesh::interface;

/// Element types read as 8-node hexahedra (squeal's own incompatible-mode element).
const HEXAHEDRA: [&str; 6] = ["C3D8", "C3D8I", "C3D8R", "C3D8H", "C3D8IH", "C3D8RH"];

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

/// A surface: faces of elements (`TYPE=ELEMENT`, face 0..5 for S1..S6) or nodes.
#[derive(Debug, Clone)]
enum Surface<L> {
    Faces(Vec<(L, usize)>),
    Nodes(Vec<L>),
}

/// Nodes, hexahedra and named sets, labelled by `L`: a part's own labels (`u64`) or, once
/// flattened, indices into the model.
#[derive(Debug, Clone)]
struct Sets<L> {
    nsets: BTreeMap<String, Vec<L>>,
    elsets: BTreeMap<String, Vec<L>>,
    surfaces: BTreeMap<String, Surface<L>>,
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
struct Part {
    nodes: BTreeMap<u64, ([f64; 3], Source)>,
    hexes: BTreeMap<u64, ([u64; 8], Source)>,
    sets: Sets<u64>,
}

struct Instance {
    name: String,
    part: String,
    translation: [f64; 3],
    /// Axis points a, b and the angle in radians, applied after the translation.
    rotation: Option<([f64; 3], [f64; 3], f64)>,
    at: Source,
}

/// Where definitions go while the deck is read.
enum Scope {
    Model,
    Part(String),
    Assembly,
    Instance,
    Step,
}

/// The deck, read.
pub struct Deck {
    parts: BTreeMap<String, Part>,
    part_order: Vec<String>,
    instances: Vec<Instance>,
    /// Set and surface definitions of the assembly, resolved after flattening.
    assembly_blocks: Vec<Block>,
    uses_parts: bool,
}

pub fn interpret(blocks: Vec<Block>) -> Result<Deck, InpError> {
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
                    return Err(InpError::at(
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
                            return Err(InpError::at(
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
                return Err(InpError::at(
                    &block.at,
                    format!("keyword *{keyword} is not supported{hint}"),
                ));
            }
        }
    }
    if deck.uses_parts && deck.parts.contains_key("") {
        return Err(InpError::whole(
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
        return Err(InpError::whole(format!(
            "parts {} are defined but no *ASSEMBLY instances them",
            deck.part_order.join(", ")
        )));
    }
    Ok(deck)
}

fn instance(block: &Block) -> Result<Instance, InpError> {
    block.only_params(&["NAME", "PART"])?;
    let name = block.required("NAME")?.to_lowercase();
    let part = block.required("PART")?.to_lowercase();
    let values = |line: &DataLine, count: usize, what: &str| -> Result<Vec<f64>, InpError> {
        let fields: Vec<&String> = line.fields.iter().filter(|f| !f.is_empty()).collect();
        if fields.len() != count {
            return Err(InpError::at(
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
                    return Err(InpError::at(
                        &second.at,
                        "*INSTANCE rotation: points a and b coincide",
                    ));
                }
                rotation = Some((a, b, r[6].to_radians()));
            }
        }
        [_, _, third, ..] => {
            return Err(InpError::at(
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

fn read_nodes(part: &mut Part, block: &Block) -> Result<(), InpError> {
    block.only_params(&["NSET"])?;
    let mut labels = Vec::with_capacity(block.data.len());
    for line in &block.data {
        let fields: Vec<&String> = line.fields.iter().filter(|f| !f.is_empty()).collect();
        if fields.len() != 4 {
            return Err(InpError::at(
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
            return Err(InpError::at(
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

fn read_elements(part: &mut Part, block: &Block) -> Result<(), InpError> {
    block.only_params(&["TYPE", "ELSET"])?;
    let element_type = block.required("TYPE")?.to_uppercase();
    if !HEXAHEDRA.contains(&element_type.as_str()) {
        return Err(InpError::at(
            &block.at,
            format!(
                "element type {element_type} is not supported: squeal reads 8-node hexahedra ({})",
                HEXAHEDRA.join(", ")
            ),
        ));
    }
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
        if continues && pending.len() < 9 {
            continue;
        }
        let at = pending.first().map_or(&line.at, |(_, at)| *at).clone();
        if pending.len() != 9 {
            return Err(InpError::at(
                &at,
                format!(
                    "{element_type}: a label and 8 nodes expected, found {} values",
                    pending.len()
                ),
            ));
        }
        let element = label(pending[0].0, &at, "element label")?;
        let mut nodes = [0; 8];
        for (slot, (field, at)) in nodes.iter_mut().zip(&pending[1..]) {
            *slot = label(field, at, "node label")?;
        }
        if let Some((_, first)) = part.hexes.insert(element, (nodes, at.clone())) {
            return Err(InpError::at(
                &at,
                format!("element {element} is defined twice (first at {first})"),
            ));
        }
        labels.push(element);
        pending.clear();
    }
    if let Some((_, at)) = pending.first() {
        return Err(InpError::at(
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
fn set_entries<L: Clone>(
    block: &Block,
    sets: &BTreeMap<String, Vec<L>>,
    labelled: &dyn Fn(u64, &Source) -> Result<L, InpError>,
) -> Result<Vec<L>, InpError> {
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
                    return Err(InpError::at(
                        &line.at,
                        "GENERATE: first, last[, increment] expected",
                    ));
                }
            };
            if last < first {
                return Err(InpError::at(&line.at, "GENERATE: last is below first"));
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
fn members<L: Clone>(
    field: &str,
    at: &Source,
    sets: &BTreeMap<String, Vec<L>>,
    labelled: &dyn Fn(u64, &Source) -> Result<L, InpError>,
) -> Result<Vec<L>, InpError> {
    if field.bytes().all(|byte| byte.is_ascii_digit()) {
        Ok(vec![labelled(label(field, at, "label")?, at)?])
    } else {
        sets.get(&field.to_lowercase())
            .cloned()
            .ok_or_else(|| InpError::at(at, format!("no set named `{field}` is defined above")))
    }
}

fn read_set(part: &mut Part, block: &Block) -> Result<(), InpError> {
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
fn face_index(field: &str, at: &Source) -> Result<usize, InpError> {
    match field.to_uppercase().as_str() {
        "S1" => Ok(0),
        "S2" => Ok(1),
        "S3" => Ok(2),
        "S4" => Ok(3),
        "S5" => Ok(4),
        "S6" => Ok(5),
        other => Err(InpError::at(
            at,
            format!("face `{other}` of a hexahedron: S1 to S6 expected"),
        )),
    }
}

/// A surface's data lines: `(set or label, face)` per line for `TYPE=ELEMENT`, node sets or
/// labels for `TYPE=NODE`.
fn surface_entries<L: Copy>(
    block: &Block,
    elements: impl Fn(&str, &Source) -> Result<Vec<L>, InpError>,
    nodes: impl Fn(&str, &Source) -> Result<Vec<L>, InpError>,
) -> Result<Surface<L>, InpError> {
    block.only_params(&["NAME", "TYPE", "INTERNAL"])?;
    let of_nodes = match block.param("TYPE").map(str::to_uppercase).as_deref() {
        None | Some("ELEMENT") => false,
        Some("NODE") => true,
        Some(other) => {
            return Err(InpError::at(
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
                    InpError::at(&line.at, "a face S1..S6 is needed after the element set")
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

fn read_surface(part: &mut Part, block: &Block) -> Result<(), InpError> {
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

/// The model flattened: every instance's nodes and hexahedra, in instance then label order.
struct Flat {
    nodes: Vec<[f64; 3]>,
    /// `instance.label` (or `label` without parts), for messages.
    node_names: Vec<String>,
    hexes: Vec<[usize; 8]>,
    hex_names: Vec<String>,
    hex_sources: Vec<Source>,
    sets: Sets<usize>,
}

impl Deck {
    fn flatten(&self) -> Result<Flat, InpError> {
        let mut flat = Flat {
            nodes: Vec::new(),
            node_names: Vec::new(),
            hexes: Vec::new(),
            hex_names: Vec::new(),
            hex_sources: Vec::new(),
            sets: Sets::default(),
        };
        let mut instance_names: Vec<String> = Vec::new();
        for instance in &self.instances {
            let part = self.parts.get(&instance.part).ok_or_else(|| {
                InpError::at(&instance.at, format!("no part named `{}`", instance.part))
            })?;
            if instance_names.contains(&instance.name) {
                return Err(InpError::at(
                    &instance.at,
                    format!("instance `{}` is defined twice", instance.name),
                ));
            }
            instance_names.push(instance.name.clone());
            flat.add_instance(instance, part)?;
        }
        self.assembly_sets(&mut flat, &instance_names)?;
        Ok(flat)
    }

    /// The assembly's own sets and surfaces: labels of the instance its `INSTANCE=` names,
    /// or names of flattened sets (`instance.set`).
    fn assembly_sets(&self, flat: &mut Flat, instance_names: &[String]) -> Result<(), InpError> {
        let index = |names: &[String]| -> HashMap<String, usize> {
            names
                .iter()
                .enumerate()
                .map(|(idx, name)| (name.clone(), idx))
                .collect()
        };
        let (node_index, element_index) = if self.assembly_blocks.is_empty() {
            (HashMap::new(), HashMap::new())
        } else {
            (index(&flat.node_names), index(&flat.hex_names))
        };
        for block in &self.assembly_blocks {
            let instance = block.param("INSTANCE").map(str::to_lowercase);
            if let Some(name) = &instance
                && !instance_names.contains(name)
            {
                return Err(InpError::at(
                    &block.at,
                    format!("no instance named `{name}`"),
                ));
            }
            let global = |names: &HashMap<String, usize>,
                          label_of: &str,
                          at: &Source|
             -> Result<usize, InpError> {
                let Some(instance) = &instance else {
                    return Err(InpError::at(
                        at,
                        "a label in an assembly-level set needs the set's INSTANCE= parameter",
                    ));
                };
                let wanted = format!("{instance}.{label_of}");
                names.get(&wanted).copied().ok_or_else(|| {
                    InpError::at(at, format!("instance `{instance}` has no {label_of}"))
                })
            };
            let node = |value: u64, at: &Source| global(&node_index, &value.to_string(), at);
            let element = |value: u64, at: &Source| global(&element_index, &value.to_string(), at);
            match block.keyword.as_str() {
                "NSET" | "ELSET" => {
                    let is_nset = block.keyword == "NSET";
                    let name_param = if is_nset { "NSET" } else { "ELSET" };
                    block.only_params(&[
                        name_param, "GENERATE", "INTERNAL", "UNSORTED", "INSTANCE",
                    ])?;
                    let name = block.required(name_param)?.to_lowercase();
                    let sets = &flat.sets;
                    let entries = if is_nset {
                        set_entries(block, &sets.nsets, &node)?
                    } else {
                        set_entries(block, &sets.elsets, &element)?
                    };
                    let target = if is_nset {
                        &mut flat.sets.nsets
                    } else {
                        &mut flat.sets.elsets
                    };
                    target.entry(name).or_default().extend(entries);
                }
                _ => {
                    let name = block.required("NAME")?.to_lowercase();
                    let sets = &flat.sets;
                    let surface = surface_entries(
                        block,
                        |field, at| members(field, at, &sets.elsets, &element),
                        |field, at| members(field, at, &sets.nsets, &node),
                    )?;
                    flat.sets.surfaces.insert(name, surface);
                }
            }
        }
        Ok(())
    }
}

impl Flat {
    /// Appends `part`'s nodes (placed by `instance`), hexahedra and sets.
    fn add_instance(&mut self, instance: &Instance, part: &Part) -> Result<(), InpError> {
        let prefix = |name: &str| {
            if instance.name.is_empty() {
                name.to_string()
            } else {
                format!("{}.{name}", instance.name)
            }
        };
        let node_offset = self.nodes.len();
        let node_index: HashMap<u64, usize> = part
            .nodes
            .keys()
            .enumerate()
            .map(|(idx, node)| (*node, node_offset + idx))
            .collect();
        for (node, (x, _)) in &part.nodes {
            self.nodes.push(instance.place(*x));
            self.node_names.push(prefix(&node.to_string()));
        }
        let element_offset = self.hexes.len();
        let element_index: HashMap<u64, usize> = part
            .hexes
            .keys()
            .enumerate()
            .map(|(idx, element)| (*element, element_offset + idx))
            .collect();
        for (element, (nodes, at)) in &part.hexes {
            let mut hex = [0; 8];
            for (slot, node) in hex.iter_mut().zip(nodes) {
                *slot = *node_index.get(node).ok_or_else(|| {
                    InpError::at(
                        at,
                        format!("element {element} refers to node {node}, which no *NODE defines"),
                    )
                })?;
            }
            self.hexes.push(hex);
            self.hex_names.push(prefix(&element.to_string()));
            self.hex_sources.push(at.clone());
        }
        let nodes_of = |labels: &[u64], set: &str| -> Result<Vec<usize>, InpError> {
            labels
                .iter()
                .map(|node| {
                    node_index.get(node).copied().ok_or_else(|| {
                        InpError::whole(format!(
                            "node set `{}`: node {node} is not defined",
                            prefix(set)
                        ))
                    })
                })
                .collect()
        };
        let elements_of = |labels: &[u64], set: &str| -> Result<Vec<usize>, InpError> {
            labels
                .iter()
                .map(|element| {
                    element_index.get(element).copied().ok_or_else(|| {
                        InpError::whole(format!(
                            "set `{}`: element {element} is not a hexahedron of its part",
                            prefix(set)
                        ))
                    })
                })
                .collect()
        };
        for (name, labels) in &part.sets.nsets {
            self.sets
                .nsets
                .insert(prefix(name), nodes_of(labels, name)?);
        }
        for (name, labels) in &part.sets.elsets {
            self.sets
                .elsets
                .insert(prefix(name), elements_of(labels, name)?);
        }
        for (name, surface) in &part.sets.surfaces {
            let surface = match surface {
                Surface::Faces(faces) => {
                    let labels: Vec<u64> = faces.iter().map(|(element, _)| *element).collect();
                    let elements = elements_of(&labels, name)?;
                    Surface::Faces(
                        elements
                            .into_iter()
                            .zip(faces.iter().map(|(_, face)| *face))
                            .collect(),
                    )
                }
                Surface::Nodes(nodes) => Surface::Nodes(nodes_of(nodes, name)?),
            };
            self.sets.surfaces.insert(prefix(name), surface);
        }
        if !instance.name.is_empty() {
            // An instance is itself a set of its nodes and of its elements.
            let nodes = (node_offset..self.nodes.len()).collect();
            let elements = (element_offset..self.hexes.len()).collect();
            self.sets.nsets.insert(instance.name.clone(), nodes);
            self.sets.elsets.insert(instance.name.clone(), elements);
        }
        Ok(())
    }
}

impl Instance {
    /// A part's point in the assembly: translated, then rotated about the axis a → b.
    fn place(&self, x: [f64; 3]) -> [f64; 3] {
        let moved = [
            x[0] + self.translation[0],
            x[1] + self.translation[1],
            x[2] + self.translation[2],
        ];
        let Some((a, b, angle)) = self.rotation else {
            return moved;
        };
        let axis = sub(b, a);
        let length = norm(axis);
        let k = axis.map(|c| c / length);
        let p = sub(moved, a);
        let (sin, cos) = angle.sin_cos();
        let k_cross_p = cross(k, p);
        let k_dot_p = dot(k, p);
        std::array::from_fn(|axis| {
            a[axis] + p[axis] * cos + k_cross_p[axis] * sin + k[axis] * k_dot_p * (1.0 - cos)
        })
    }
}

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
    contact: &ContactSets,
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
