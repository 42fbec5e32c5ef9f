//! Instances flattened into one model: every part's nodes and elements placed (translated,
//! rotated) in instance then label order, its sets named `instance.set`, and the assembly's
//! own sets resolved against the result.

use std::collections::HashMap;

use super::deck::{DeckError, Source};
use super::interpret::{
    Deck, Instance, Part, Sets, Surface, members, set_entries, surface_entries,
};
use crate::artifact::ElementKind;
use crate::artifact::mesh::{cross, dot, norm, sub};

/// The model flattened: every instance's nodes and elements, in instance then label order.
pub(super) struct Flat {
    pub(super) nodes: Vec<[f64; 3]>,
    /// `instance.label` (or `label` without parts), for messages.
    pub(super) node_names: Vec<String>,
    /// Each element's kind and nodes (squeal's order).
    pub(super) elements: Vec<(ElementKind, Vec<usize>)>,
    pub(super) element_names: Vec<String>,
    pub(super) element_sources: Vec<Source>,
    pub(super) sets: Sets<usize>,
}

impl Deck {
    pub(super) fn flatten(&self) -> Result<Flat, DeckError> {
        let mut flat = Flat {
            nodes: Vec::new(),
            node_names: Vec::new(),
            elements: Vec::new(),
            element_names: Vec::new(),
            element_sources: Vec::new(),
            sets: Sets::default(),
        };
        let mut instance_names: Vec<String> = Vec::new();
        for instance in &self.instances {
            let part = self.parts.get(&instance.part).ok_or_else(|| {
                DeckError::at(&instance.at, format!("no part named `{}`", instance.part))
            })?;
            if instance_names.contains(&instance.name) {
                return Err(DeckError::at(
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
    fn assembly_sets(&self, flat: &mut Flat, instance_names: &[String]) -> Result<(), DeckError> {
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
            (index(&flat.node_names), index(&flat.element_names))
        };
        for block in &self.assembly_blocks {
            let instance = block.param("INSTANCE").map(str::to_lowercase);
            if let Some(name) = &instance
                && !instance_names.contains(name)
            {
                return Err(DeckError::at(
                    &block.at,
                    format!("no instance named `{name}`"),
                ));
            }
            let global = |names: &HashMap<String, usize>,
                          label_of: &str,
                          at: &Source|
             -> Result<usize, DeckError> {
                let Some(instance) = &instance else {
                    return Err(DeckError::at(
                        at,
                        "a label in an assembly-level set needs the set's INSTANCE= parameter",
                    ));
                };
                let wanted = format!("{instance}.{label_of}");
                names.get(&wanted).copied().ok_or_else(|| {
                    DeckError::at(at, format!("instance `{instance}` has no {label_of}"))
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
    /// Appends `part`'s nodes (placed by `instance`), elements and sets.
    fn add_instance(&mut self, instance: &Instance, part: &Part) -> Result<(), DeckError> {
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
        let element_offset = self.elements.len();
        let element_index: HashMap<u64, usize> = part
            .elements
            .keys()
            .enumerate()
            .map(|(idx, element)| (*element, element_offset + idx))
            .collect();
        for (element, (kind, nodes, at)) in &part.elements {
            let indices = nodes
                .iter()
                .map(|node| {
                    node_index.get(node).copied().ok_or_else(|| {
                        DeckError::at(
                            at,
                            format!(
                                "element {element} refers to node {node}, which no *NODE defines"
                            ),
                        )
                    })
                })
                .collect::<Result<Vec<usize>, DeckError>>()?;
            self.elements.push((*kind, indices));
            self.element_names.push(prefix(&element.to_string()));
            self.element_sources.push(at.clone());
        }
        let nodes_of = |labels: &[u64], set: &str| -> Result<Vec<usize>, DeckError> {
            labels
                .iter()
                .map(|node| {
                    node_index.get(node).copied().ok_or_else(|| {
                        DeckError::whole(format!(
                            "node set `{}`: node {node} is not defined",
                            prefix(set)
                        ))
                    })
                })
                .collect()
        };
        let elements_of = |labels: &[u64], set: &str| -> Result<Vec<usize>, DeckError> {
            labels
                .iter()
                .map(|element| {
                    element_index.get(element).copied().ok_or_else(|| {
                        DeckError::whole(format!(
                            "set `{}`: element {element} is not an element of its part",
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
            let elements = (element_offset..self.elements.len()).collect();
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
