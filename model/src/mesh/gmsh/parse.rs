//! The MSH 4.1 text, section by section, into node and element records with their line
//! numbers (for the errors).

use std::collections::{BTreeMap, HashMap};

use super::MshError;
use crate::artifact::ElementKind;
use crate::fem::element::formats::{self, Format};

/// Checks `$MeshFormat` / `4.1 0 8` at the top of the file.
pub(super) fn check_format_header(text: &str) -> Result<(), MshError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(idx, line)| (idx + 1, line.trim()))
        .filter(|(_, line)| !line.is_empty());
    match lines.next() {
        Some((_, "$MeshFormat")) => {}
        Some((line, _)) => {
            return Err(MshError::at(
                line,
                "not a Gmsh MSH file: expected $MeshFormat",
            ));
        }
        None => return Err(MshError::whole_file("empty file")),
    }
    let Some((line, format)) = lines.next() else {
        return Err(MshError::whole_file("$MeshFormat has no version line"));
    };
    let fields: Vec<&str> = format.split_whitespace().collect();
    let [version, file_type, _data_size] = fields[..] else {
        return Err(MshError::at(
            line,
            format!("expected `version file-type data-size`, found `{format}`"),
        ));
    };
    match version.parse::<f64>() {
        Ok(4.1) => {}
        Ok(number) if number < 4.1 => {
            return Err(MshError::at(
                line,
                format!(
                    "MSH {version} is not supported: save as MSH 4.1 (`gmsh -format msh41` or Mesh.MshFileVersion = 4.1)"
                ),
            ));
        }
        _ => {
            return Err(MshError::at(
                line,
                format!("unknown MSH version `{version}`: only 4.1 is supported"),
            ));
        }
    }
    match file_type {
        "0" => Ok(()),
        "1" => Err(MshError::at(
            line,
            "binary MSH is not supported: save as ASCII (Mesh.Binary = 0)",
        )),
        other => Err(MshError::at(
            line,
            format!("unknown file type `{other}` (0 is ASCII)"),
        )),
    }
}

/// A `$Name ... $EndName` section: its non-blank lines, trimmed, with their line numbers.
pub(super) struct Section<'a> {
    pub(super) name: &'a str,
    pub(super) header_line: usize,
    pub(super) end_line: usize,
    pub(super) lines: Vec<(usize, &'a str)>,
}

pub(super) fn split_sections(text: &str) -> Result<Vec<Section<'_>>, MshError> {
    let mut sections: Vec<Section> = Vec::new();
    let mut open: Option<Section> = None;
    for (idx, line) in text.lines().enumerate() {
        let (line_no, line) = (idx + 1, line.trim());
        if line.is_empty() {
            continue;
        }
        match open.as_mut() {
            Some(section) => {
                if line.strip_prefix("$End") == Some(section.name) {
                    section.end_line = line_no;
                    sections.extend(open.take());
                } else if line.starts_with('$') && section.name != "Comments" {
                    return Err(MshError::at(
                        line_no,
                        format!(
                            "`{line}` inside ${} (opened on line {}), which is not closed by $End{}",
                            section.name, section.header_line, section.name
                        ),
                    ));
                } else {
                    section.lines.push((line_no, line));
                }
            }
            None => {
                let Some(name) = line.strip_prefix('$') else {
                    return Err(MshError::at(
                        line_no,
                        format!("unexpected `{line}` outside a section"),
                    ));
                };
                if sections.iter().any(|section| section.name == name) {
                    return Err(MshError::at(line_no, format!("second ${name} section")));
                }
                open = Some(Section {
                    name,
                    header_line: line_no,
                    end_line: line_no,
                    lines: Vec::new(),
                });
            }
        }
    }
    match open {
        Some(section) => Err(MshError::at(
            section.header_line,
            format!(
                "${} is not closed by $End{} (truncated file?)",
                section.name, section.name
            ),
        )),
        None => Ok(sections),
    }
}

/// Reads a section line by line, with the line numbers for errors.
struct Cursor<'s, 'a> {
    section: &'s Section<'a>,
    next: usize,
}

impl<'s, 'a> Cursor<'s, 'a> {
    fn new(section: &'s Section<'a>) -> Self {
        Cursor { section, next: 0 }
    }

    /// The next line, split on whitespace; `what` names what was expected if there is none.
    fn line(&mut self, what: &str) -> Result<(usize, Vec<&'a str>), MshError> {
        let Some(&(line_no, line)) = self.section.lines.get(self.next) else {
            return Err(MshError::at(
                self.section.end_line,
                format!("${} ends early: expected {what}", self.section.name),
            ));
        };
        self.next += 1;
        Ok((line_no, line.split_whitespace().collect()))
    }

    fn raw_line(&mut self, what: &str) -> Result<(usize, &'a str), MshError> {
        let Some(&(line_no, line)) = self.section.lines.get(self.next) else {
            return Err(MshError::at(
                self.section.end_line,
                format!("${} ends early: expected {what}", self.section.name),
            ));
        };
        self.next += 1;
        Ok((line_no, line))
    }

    /// Extra lines after the declared content are a sign of a miscounted section.
    fn finish(&self) -> Result<(), MshError> {
        match self.section.lines.get(self.next) {
            Some(&(line_no, _)) => Err(MshError::at(
                line_no,
                format!(
                    "more lines in ${} than its header announces",
                    self.section.name
                ),
            )),
            None => Ok(()),
        }
    }
}

fn parse_number<T: std::str::FromStr>(
    token: Option<&&str>,
    line_no: usize,
    what: &str,
) -> Result<T, MshError> {
    let Some(token) = token else {
        return Err(MshError::at(line_no, format!("missing {what}")));
    };
    token
        .parse()
        .map_err(|_| MshError::at(line_no, format!("{what}: `{token}` is not a valid number")))
}

/// A physical group: its dimension (0 point .. 3 volume) and its tag.
pub(super) type GroupKey = (u32, i64);

pub(super) fn parse_physical_names(
    section: &Section,
) -> Result<HashMap<GroupKey, String>, MshError> {
    let mut cursor = Cursor::new(section);
    let (line_no, header) = cursor.line("the number of names")?;
    let n_names: usize = parse_number(header.first(), line_no, "number of names")?;
    let mut names = HashMap::with_capacity(n_names);
    for _ in 0..n_names {
        let (line_no, line) = cursor.raw_line("a `dim tag \"name\"` line")?;
        let mut fields = line.splitn(3, char::is_whitespace);
        let dim: u32 = parse_number(fields.next().as_ref(), line_no, "dimension")?;
        let tag: i64 = parse_number(fields.next().as_ref(), line_no, "physical tag")?;
        let name = fields.next().unwrap_or("").trim();
        let name = name
            .strip_prefix('"')
            .and_then(|name| name.strip_suffix('"'))
            .ok_or_else(|| {
                MshError::at(line_no, format!("expected a quoted name, found `{name}`"))
            })?;
        if dim > 3 {
            return Err(MshError::at(
                line_no,
                format!("dimension {dim} is not 0..3"),
            ));
        }
        names.insert((dim, tag), name.to_string());
    }
    cursor.finish()?;
    Ok(names)
}

/// An entity: its dimension and its tag.
type EntityKey = (u32, i64);

/// The physical tags of every entity.
pub(super) fn parse_entities(section: &Section) -> Result<HashMap<EntityKey, Vec<i64>>, MshError> {
    let mut cursor = Cursor::new(section);
    let (line_no, header) = cursor.line("`numPoints numCurves numSurfaces numVolumes`")?;
    let mut counts = [0usize; 4];
    for (dim, count) in counts.iter_mut().enumerate() {
        *count = parse_number(header.get(dim), line_no, "entity count")?;
    }
    let mut entities = HashMap::new();
    for (dim, &count) in counts.iter().enumerate() {
        // A point has its coordinates, the others a bounding box, before the physical tags.
        let n_coords = if dim == 0 { 3 } else { 6 };
        for _ in 0..count {
            let (line_no, fields) = cursor.line("an entity line")?;
            let tag: i64 = parse_number(fields.first(), line_no, "entity tag")?;
            let n_physicals: usize =
                parse_number(fields.get(1 + n_coords), line_no, "number of physical tags")?;
            let physicals = (0..n_physicals)
                .map(|idx| parse_number(fields.get(2 + n_coords + idx), line_no, "physical tag"))
                .collect::<Result<Vec<i64>, _>>()?;
            entities.insert((dim as u32, tag), physicals);
        }
    }
    cursor.finish()?;
    Ok(entities)
}

/// Node coordinates by Gmsh tag.
pub(super) struct Nodes {
    /// Tag → coordinates, in file order.
    pub(super) coords: HashMap<u64, [f64; 3]>,
}

pub(super) fn parse_nodes(section: &Section) -> Result<Nodes, MshError> {
    let mut cursor = Cursor::new(section);
    let (line_no, header) = cursor.line("`numEntityBlocks numNodes minNodeTag maxNodeTag`")?;
    let n_blocks: usize = parse_number(header.first(), line_no, "number of entity blocks")?;
    let n_nodes: usize = parse_number(header.get(1), line_no, "number of nodes")?;
    let mut coords = HashMap::with_capacity(n_nodes);
    let mut n_read = 0;
    for _ in 0..n_blocks {
        let (line_no, block) =
            cursor.line("a node block `entityDim entityTag parametric numNodesInBlock`")?;
        let entity_dim: usize = parse_number(block.first(), line_no, "entity dimension")?;
        let parametric: u32 = parse_number(block.get(2), line_no, "parametric flag")?;
        let n_in_block: usize = parse_number(block.get(3), line_no, "number of nodes in block")?;
        let mut tags = Vec::with_capacity(n_in_block);
        for _ in 0..n_in_block {
            let (line_no, fields) = cursor.line("a node tag")?;
            if fields.len() != 1 {
                return Err(MshError::at(line_no, "expected one node tag on the line"));
            }
            let tag: u64 = parse_number(fields.first(), line_no, "node tag")?;
            tags.push((line_no, tag));
        }
        // Parametric nodes carry their (u, v, w) on the entity after x y z.
        let n_fields = 3 + if parametric == 1 { entity_dim } else { 0 };
        for (tag_line, tag) in tags {
            let (line_no, fields) = cursor.line("node coordinates")?;
            if fields.len() != n_fields {
                return Err(MshError::at(
                    line_no,
                    format!("expected {n_fields} coordinates, found {}", fields.len()),
                ));
            }
            let mut xyz = [0.0f64; 3];
            for (axis, value) in xyz.iter_mut().enumerate() {
                *value = parse_number(fields.get(axis), line_no, "coordinate")?;
                if !value.is_finite() {
                    return Err(MshError::at(line_no, "coordinate is not finite"));
                }
            }
            if coords.insert(tag, xyz).is_some() {
                return Err(MshError::at(
                    tag_line,
                    format!("node {tag} is defined twice"),
                ));
            }
        }
        n_read += n_in_block;
    }
    if n_read != n_nodes {
        return Err(MshError::at(
            line_no,
            format!("header announces {n_nodes} nodes, blocks hold {n_read}"),
        ));
    }
    cursor.finish()?;
    Ok(Nodes { coords })
}

/// Gmsh's name for an element type, for error messages.
pub(super) fn element_type_name(element_type: u32) -> String {
    let name = match element_type {
        1 => "2-node line",
        2 => "3-node triangle",
        3 => "4-node quadrangle",
        4 => "4-node tetrahedron",
        5 => "8-node hexahedron",
        6 => "6-node prism",
        7 => "5-node pyramid",
        8 => "3-node line",
        9 => "6-node triangle",
        10 => "9-node quadrangle",
        11 => "10-node tetrahedron",
        12 => "27-node hexahedron",
        13 => "18-node prism",
        14 => "14-node pyramid",
        15 => "1-node point",
        16 => "8-node quadrangle",
        17 => "20-node hexahedron",
        18 => "15-node prism",
        19 => "13-node pyramid",
        _ => return format!("Gmsh element type {element_type}"),
    };
    format!("{name} (Gmsh type {element_type})")
}

/// The element types accepted on points, curves and surfaces: node count, dimension.
fn boundary_element_shape(element_type: u32) -> Option<(usize, u32)> {
    match element_type {
        15 => Some((1, 0)),
        1 => Some((2, 1)),
        8 => Some((3, 1)),
        2 => Some((3, 2)),
        3 => Some((4, 2)),
        9 => Some((6, 2)),
        16 => Some((8, 2)),
        _ => None,
    }
}

/// The solid element types squeal takes, by Gmsh type.
pub(super) fn solid_kind(element_type: u32) -> Option<ElementKind> {
    match element_type {
        4 => Some(ElementKind::Tet4),
        5 => Some(ElementKind::Hex8),
        6 => Some(ElementKind::Wedge6),
        11 => Some(ElementKind::Tet10),
        17 => Some(ElementKind::Hex20),
        18 => Some(ElementKind::Wedge15),
        _ => None,
    }
}

/// A solid element as read: its Gmsh tag and type, the line it is on, its node tags in
/// squeal's order, its physical volume.
pub(super) struct SolidRecord {
    pub(super) tag: u64,
    pub(super) element_type: u32,
    pub(super) kind: ElementKind,
    pub(super) line: usize,
    pub(super) nodes: Vec<u64>,
    pub(super) group: GroupKey,
}

/// A physical group of points, curves or surfaces: its nodes and, for contact, its faces.
#[derive(Default)]
pub(super) struct BoundaryGroup {
    pub(super) node_tags: Vec<u64>,
    /// Quadrangles: node tags, element tag, line.
    pub(super) quads: Vec<([u64; 4], u64, usize)>,
    /// The first element that is not a quadrangle (contact surfaces must have none).
    pub(super) first_other: Option<(u32, u64, usize)>,
}

pub(super) struct Elements {
    pub(super) solids: Vec<SolidRecord>,
    /// Physical volumes holding solid elements, by group key, with their names.
    pub(super) volume_names: BTreeMap<GroupKey, String>,
    /// Named physical groups of dimension 0..2.
    pub(super) boundary_groups: BTreeMap<GroupKey, (String, BoundaryGroup)>,
}

fn dimension_word(dim: u32) -> &'static str {
    match dim {
        0 => "point",
        1 => "curve",
        2 => "surface",
        _ => "volume",
    }
}

pub(super) fn group_name(
    names: &HashMap<GroupKey, String>,
    key: GroupKey,
    line_no: usize,
) -> Result<String, MshError> {
    names.get(&key).cloned().ok_or_else(|| {
        let word = dimension_word(key.0);
        MshError::at(
            line_no,
            format!(
                "physical {word} {} has no name in $PhysicalNames: name it (Physical {}(\"name\") = ...)",
                key.1,
                capitalised(word)
            ),
        )
    })
}

fn capitalised(word: &str) -> String {
    let mut chars = word.chars();
    chars
        .next()
        .map(|first| first.to_ascii_uppercase().to_string() + chars.as_str())
        .unwrap_or_default()
}

/// The kind and physical volume of a block of solid elements: exactly one, with a name.
fn volume_group(
    entity_tag: i64,
    element_type: u32,
    physicals: &[i64],
    names: &HashMap<GroupKey, String>,
    block_line: usize,
) -> Result<(ElementKind, GroupKey, String), MshError> {
    let Some(kind) = solid_kind(element_type) else {
        return Err(MshError::at(
            block_line,
            format!(
                "volume {entity_tag}: {} elements are not supported, only tetrahedra (types 4, 11), hexahedra (5, 17) and prisms (6, 18)",
                element_type_name(element_type)
            ),
        ));
    };
    match physicals {
        [] => Err(MshError::at(
            block_line,
            format!(
                "the elements of volume {entity_tag} are in no physical volume: add it to one, whose name is its part (Physical Volume(\"disc\") = {{{entity_tag}}})"
            ),
        )),
        [physical] => {
            let key = (3, *physical);
            Ok((kind, key, group_name(names, key, block_line)?))
        }
        several => {
            let listed: Vec<String> = several
                .iter()
                .map(|tag| names.get(&(3, *tag)).cloned().unwrap_or(tag.to_string()))
                .collect();
            Err(MshError::at(
                block_line,
                format!(
                    "volume {entity_tag} is in {} physical volumes ({}): its elements need exactly one part",
                    several.len(),
                    listed.join(", ")
                ),
            ))
        }
    }
}

/// Nodes per element of a block on a point, curve or surface; 0 for a block in no physical
/// group, which is skipped unread.
fn boundary_nodes_per_element(
    dim: u32,
    entity_tag: i64,
    element_type: u32,
    physicals: &[i64],
    block_line: usize,
) -> Result<usize, MshError> {
    match boundary_element_shape(element_type) {
        Some((n_nodes, element_dim)) if element_dim == dim => Ok(n_nodes),
        _ if physicals.is_empty() => Ok(0),
        _ => {
            let word = dimension_word(dim);
            Err(MshError::at(
                block_line,
                format!(
                    "{word} {entity_tag}: {} elements are not supported on a {word}, only points, lines, triangles and quadrangles (first or second order)",
                    element_type_name(element_type)
                ),
            ))
        }
    }
}

/// An element line `elementTag nodeTag…`: its tag and its `n_nodes` node tags, each in
/// `$Nodes`.
fn parse_element_line(
    fields: &[&str],
    line_no: usize,
    element_type: u32,
    n_nodes: usize,
    nodes: &Nodes,
) -> Result<(u64, Vec<u64>), MshError> {
    let element_tag: u64 = parse_number(fields.first(), line_no, "element tag")?;
    if fields.len() != 1 + n_nodes {
        return Err(MshError::at(
            line_no,
            format!(
                "element {element_tag} ({}) needs {n_nodes} nodes, found {}",
                element_type_name(element_type),
                fields.len() - 1
            ),
        ));
    }
    let mut node_tags = Vec::with_capacity(n_nodes);
    for field in &fields[1..] {
        let tag: u64 = parse_number(Some(field), line_no, "node tag")?;
        if !nodes.coords.contains_key(&tag) {
            return Err(MshError::at(
                line_no,
                format!("element {element_tag} refers to node {tag}, which is not in $Nodes"),
            ));
        }
        node_tags.push(tag);
    }
    Ok((element_tag, node_tags))
}

pub(super) fn parse_elements(
    section: &Section,
    nodes: &Nodes,
    entities: &HashMap<EntityKey, Vec<i64>>,
    names: &HashMap<GroupKey, String>,
) -> Result<Elements, MshError> {
    let mut cursor = Cursor::new(section);
    let (header_line, header) =
        cursor.line("`numEntityBlocks numElements minElementTag maxElementTag`")?;
    let n_blocks: usize = parse_number(header.first(), header_line, "number of entity blocks")?;
    let n_elements: usize = parse_number(header.get(1), header_line, "number of elements")?;
    let mut elements = Elements {
        solids: Vec::new(),
        volume_names: BTreeMap::new(),
        boundary_groups: BTreeMap::new(),
    };
    let mut n_read = 0;
    for _ in 0..n_blocks {
        let (block_line, block) =
            cursor.line("an element block `entityDim entityTag elementType numElementsInBlock`")?;
        let dim: u32 = parse_number(block.first(), block_line, "entity dimension")?;
        let entity_tag: i64 = parse_number(block.get(1), block_line, "entity tag")?;
        let element_type: u32 = parse_number(block.get(2), block_line, "element type")?;
        let n_in_block: usize =
            parse_number(block.get(3), block_line, "number of elements in block")?;
        if dim > 3 {
            return Err(MshError::at(
                block_line,
                format!("dimension {dim} is not 0..3"),
            ));
        }
        let physicals = entities
            .get(&(dim, entity_tag))
            .map_or(&[][..], Vec::as_slice);
        let mut solid = None;
        let n_nodes = if dim == 3 {
            let (kind, key, name) =
                volume_group(entity_tag, element_type, physicals, names, block_line)?;
            elements.volume_names.insert(key, name);
            solid = Some(kind);
            kind.n_nodes()
        } else {
            boundary_nodes_per_element(dim, entity_tag, element_type, physicals, block_line)?
        };
        let groups = physicals
            .iter()
            .map(|physical| -> Result<GroupKey, MshError> {
                let key = (dim, *physical);
                if dim < 3 && !elements.boundary_groups.contains_key(&key) {
                    let name = group_name(names, key, block_line)?;
                    elements
                        .boundary_groups
                        .insert(key, (name, BoundaryGroup::default()));
                }
                Ok(key)
            })
            .collect::<Result<Vec<_>, _>>()?;
        for _ in 0..n_in_block {
            let (line_no, fields) = cursor.line("an element line")?;
            if dim < 3 && groups.is_empty() {
                continue;
            }
            let (element_tag, node_tags) =
                parse_element_line(&fields, line_no, element_type, n_nodes, nodes)?;
            if let Some(kind) = solid {
                elements.solids.push(SolidRecord {
                    tag: element_tag,
                    element_type,
                    kind,
                    line: line_no,
                    nodes: formats::from_file(kind, Format::Gmsh, &node_tags),
                    group: groups[0],
                });
                continue;
            }
            for key in &groups {
                let (_, group) = elements
                    .boundary_groups
                    .get_mut(key)
                    .expect("group registered above");
                group.node_tags.extend_from_slice(&node_tags);
                if element_type == 3 {
                    let quad = [node_tags[0], node_tags[1], node_tags[2], node_tags[3]];
                    group.quads.push((quad, element_tag, line_no));
                } else if group.first_other.is_none() {
                    group.first_other = Some((element_type, element_tag, line_no));
                }
            }
        }
        n_read += n_in_block;
    }
    if n_read != n_elements {
        return Err(MshError::at(
            header_line,
            format!("header announces {n_elements} elements, blocks hold {n_read}"),
        ));
    }
    cursor.finish()?;
    if elements.solids.is_empty() {
        return Err(MshError::whole_file(
            "no solid elements: the mesh has no 3D elements in a physical volume",
        ));
    }
    Ok(elements)
}
