//! `mesh.gmsh`: import a hexahedral mesh written by Gmsh (MSH 4.1, ASCII).
//!
//! # What is read
//!
//! A file saved by Gmsh 4 with `Mesh.MshFileVersion = 4.1` and `Mesh.Binary = 0` (the
//! defaults; `gmsh -3 -format msh41 brake.geo`). The sections used are
//!
//! ```text
//! $MeshFormat      4.1 0 8
//! $PhysicalNames   dim tag "name"                       (one line per physical group)
//! $Entities        entity tag, bounding box, its physical tags, its boundary
//! $Nodes           blocks: entityDim entityTag parametric n, then n tags, then n "x y z [u v w]"
//! $Elements        blocks: entityDim entityTag elementType n, then n "tag node node ..."
//! ```
//!
//! every other section (`$Periodic`, `$NodeData`, `$Comments`, ...) is skipped, as the format
//! allows. Blank lines and trailing spaces are accepted.
//!
//! # What it becomes
//!
//! - 8-node hexahedra (Gmsh element type 5) become [`Mesh::hexes`]. Gmsh's hexahedron node
//!   order is ours (node 0 at (−1, −1, −1), 1 (1, −1, −1), 2 (1, 1, −1), 3 (−1, 1, −1), 4..7
//!   the same at ζ = 1), so connectivity is copied as is. Every hexahedron must be right-handed
//!   (det J > 0 at its eight corners).
//! - The physical volume of each hexahedron's entity is its part; the part names are the
//!   group names (`disc`, `pad`), which name materials downstream. A hexahedron in no physical
//!   volume, or in two, is an error.
//! - Each named physical surface, curve or point becomes a node set holding every node of its
//!   elements (groups of different dimensions with one name are merged).
//! - Nodes are renumbered from 0 in increasing Gmsh tag order; nodes that belong to no
//!   hexahedron (geometry points, isolated nodes) are dropped, since they would carry no
//!   stiffness.
//! - Contact pairs: the nodes of physical surface `contact_disc` are paired with the
//!   coincident (distinct) nodes of `contact_pad`: the interface must be conforming with its
//!   nodes duplicated, one copy per side, and every node on either side must find exactly one
//!   partner within `contact_tolerance` × the shortest edge of the disc's contact faces. Each
//!   pair gets the disc's outward unit normal and its tributary area, integrated over the
//!   bilinear quadrangle faces: nᵢ ∝ Σ_faces ∫ Nᵢ n dA, Aᵢ = Σ_faces ∫ Nᵢ dA.
//!
//! What is refused, each with one line naming the file, the line and the element type or group:
//! binary files, MSH 2.x and 4.0, partitioned meshes, tetrahedra, prisms, pyramids and
//! second-order elements, unnamed physical groups, missing contact groups, unmatched or
//! ambiguous contact nodes, interfaces whose nodes are shared rather than duplicated.

use std::collections::{BTreeMap, HashMap};
use std::fmt;

use crate::artifact::mesh::{ContactPair, Mesh, cross, dot, norm, sub};
use crate::artifact::{Artifact, ArtifactType};
use crate::fem::hex8::{NODE_REFERENCE, det_j_at};
use crate::stage::{Inputs, Outputs, ParamSpec, ParamType, Params, PortSpec, Stage, StageError};

/// Gmsh element type of the 8-node hexahedron.
const GMSH_HEXAHEDRON: u32 = 5;

/// How to find contact pairs: the names of the two physical surfaces of the interface.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactGroups {
    pub disc: String,
    pub pad: String,
    /// Largest distance between paired nodes, relative to the shortest contact face edge.
    pub relative_tolerance: f64,
}

/// Options of [`read_msh`]; `contact: None` reads no contact pairs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    pub contact: Option<ContactGroups>,
}

/// Why a file could not be imported: the 1-based line (for parse errors) and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct MshError {
    pub line: Option<usize>,
    pub message: String,
}

impl MshError {
    fn at(line: usize, message: impl Into<String>) -> Self {
        MshError {
            line: Some(line),
            message: message.into(),
        }
    }

    fn whole_file(message: impl Into<String>) -> Self {
        MshError {
            line: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for MshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "line {line}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

/// `mesh.gmsh`: reads a user file, so it is impure and never cached (an unchanged file still
/// gives identical bytes, which leaves downstream stages cached).
pub struct GmshImport;

/// The parameters of `mesh.gmsh`, as declared.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct GmshParams {
    path: String,
    contact_disc: String,
    contact_pad: String,
    contact_tolerance: f64,
}

impl Stage for GmshImport {
    fn kind(&self) -> &'static str {
        "mesh.gmsh"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Import a hexahedral Gmsh mesh (MSH 4.1 ASCII) with parts, node sets and contact pairs; reads a file, so never cached"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec {
                name: "path",
                ty: ParamType::Path,
                default: None,
                unit: "",
                doc: "the .msh file (relative to the study's folder)",
            },
            ParamSpec::string(
                "contact_disc",
                "contact_disc",
                "physical surface of the disc side of the contact interface (\"\" = no contact)",
            ),
            ParamSpec::string(
                "contact_pad",
                "contact_pad",
                "physical surface of the pad side of the contact interface (\"\" = no contact)",
            ),
            ParamSpec::float(
                "contact_tolerance",
                1e-3,
                "",
                "largest distance between paired nodes, relative to the shortest contact face edge",
            )
            .at_least(0.0),
        ]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "mesh",
            ArtifactType::Mesh,
            "hexahedra, parts, node sets and contact pairs",
        )]
    }
    fn pure(&self) -> bool {
        false
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<GmshParams>().map(drop)
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let params: GmshParams = params.typed()?;
        let path = params.path.as_str();
        if path.is_empty() {
            return Err(StageError::new("path is empty: name the .msh file to read"));
        }
        let contact = match (params.contact_disc.as_str(), params.contact_pad.as_str()) {
            ("", "") => None,
            ("", _) | (_, "") => {
                return Err(StageError::new(
                    "contact_disc and contact_pad must both name a physical surface, or both be empty",
                ));
            }
            (disc, pad) => Some(ContactGroups {
                disc: disc.to_string(),
                pad: pad.to_string(),
                relative_tolerance: params.contact_tolerance,
            }),
        };
        let bytes = std::fs::read(path).map_err(|err| StageError::new(format!("{path}: {err}")))?;
        let mesh = read_msh_bytes(&bytes, &ReadOptions { contact }).map_err(|err| {
            StageError::new(match err.line {
                Some(line) => format!("{path}:{line}: {}", err.message),
                None => format!("{path}: {}", err.message),
            })
        })?;
        Ok(Outputs::from([(
            "mesh".to_string(),
            Artifact::Mesh(Box::new(mesh)),
        )]))
    }
}

/// Reads the bytes of a .msh file: refuses binary files before asking for UTF-8 text.
pub fn read_msh_bytes(bytes: &[u8], options: &ReadOptions) -> Result<Mesh, MshError> {
    // The header of a binary file is text; the data after it is not.
    let head_len = bytes
        .iter()
        .enumerate()
        .filter(|(_, byte)| **byte == b'\n')
        .nth(2)
        .map_or(bytes.len(), |(pos, _)| pos);
    let head = String::from_utf8_lossy(&bytes[..head_len]);
    check_format_header(&head)?;
    let text = std::str::from_utf8(bytes).map_err(|err| {
        let line = 1 + bytes[..err.valid_up_to()]
            .iter()
            .filter(|byte| **byte == b'\n')
            .count();
        MshError::at(line, "not UTF-8 text: is this a binary .msh file?")
    })?;
    read_msh(text, options)
}

/// Reads the text of a MSH 4.1 ASCII file into a [`Mesh`].
pub fn read_msh(text: &str, options: &ReadOptions) -> Result<Mesh, MshError> {
    check_format_header(text)?;
    let sections = split_sections(text)?;
    let section = |name: &str| sections.iter().find(|section| section.name == name);
    if let Some(partitioned) = section("PartitionedEntities") {
        return Err(MshError::at(
            partitioned.header_line,
            "partitioned meshes are not supported: save the mesh unpartitioned",
        ));
    }
    let physical_names = match section("PhysicalNames") {
        Some(names) => parse_physical_names(names)?,
        None => HashMap::new(),
    };
    let entities = match section("Entities") {
        Some(entities) => parse_entities(entities)?,
        None => HashMap::new(),
    };
    let nodes =
        parse_nodes(section("Nodes").ok_or_else(|| MshError::whole_file("no $Nodes section"))?)?;
    let elements = parse_elements(
        section("Elements").ok_or_else(|| MshError::whole_file("no $Elements section"))?,
        &nodes,
        &entities,
        &physical_names,
    )?;
    build_mesh(&nodes, elements, options)
}

/// Checks `$MeshFormat` / `4.1 0 8` at the top of the file.
fn check_format_header(text: &str) -> Result<(), MshError> {
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
struct Section<'a> {
    name: &'a str,
    header_line: usize,
    end_line: usize,
    lines: Vec<(usize, &'a str)>,
}

fn split_sections(text: &str) -> Result<Vec<Section<'_>>, MshError> {
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
type GroupKey = (u32, i64);

fn parse_physical_names(section: &Section) -> Result<HashMap<GroupKey, String>, MshError> {
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
fn parse_entities(section: &Section) -> Result<HashMap<EntityKey, Vec<i64>>, MshError> {
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
struct Nodes {
    /// Tag → coordinates, in file order.
    coords: HashMap<u64, [f64; 3]>,
}

fn parse_nodes(section: &Section) -> Result<Nodes, MshError> {
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
fn element_type_name(element_type: u32) -> String {
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

/// The first-order element types accepted on points, curves and surfaces: node count, dimension.
fn boundary_element_shape(element_type: u32) -> Option<(usize, u32)> {
    match element_type {
        15 => Some((1, 0)),
        1 => Some((2, 1)),
        2 => Some((3, 2)),
        3 => Some((4, 2)),
        _ => None,
    }
}

/// A hexahedron as read: Gmsh tags, the line it is on, its physical volume.
struct HexRecord {
    tag: u64,
    line: usize,
    nodes: [u64; 8],
    group: GroupKey,
}

/// A physical group of points, curves or surfaces: its nodes and, for contact, its faces.
#[derive(Default)]
struct BoundaryGroup {
    node_tags: Vec<u64>,
    /// Quadrangles: node tags, element tag, line.
    quads: Vec<([u64; 4], u64, usize)>,
    /// The first element that is not a quadrangle (contact surfaces must have none).
    first_other: Option<(u32, u64, usize)>,
}

struct Elements {
    hexes: Vec<HexRecord>,
    /// Physical volumes holding hexahedra, by group key, with their names.
    volume_names: BTreeMap<GroupKey, String>,
    /// Named physical groups of dimension 0..2.
    boundary_groups: BTreeMap<GroupKey, (String, BoundaryGroup)>,
}

fn dimension_word(dim: u32) -> &'static str {
    match dim {
        0 => "point",
        1 => "curve",
        2 => "surface",
        _ => "volume",
    }
}

fn group_name(
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

/// The physical volume of a block of hexahedra: exactly one, with a name.
fn volume_group(
    entity_tag: i64,
    element_type: u32,
    physicals: &[i64],
    names: &HashMap<GroupKey, String>,
    block_line: usize,
) -> Result<(GroupKey, String), MshError> {
    if element_type != GMSH_HEXAHEDRON {
        return Err(MshError::at(
            block_line,
            format!(
                "volume {entity_tag}: {} elements are not supported, only 8-node hexahedra (type 5)",
                element_type_name(element_type)
            ),
        ));
    }
    match physicals {
        [] => Err(MshError::at(
            block_line,
            format!(
                "the hexahedra of volume {entity_tag} are in no physical volume: add it to one, whose name is its part (Physical Volume(\"disc\") = {{{entity_tag}}})"
            ),
        )),
        [physical] => {
            let key = (3, *physical);
            Ok((key, group_name(names, key, block_line)?))
        }
        several => {
            let listed: Vec<String> = several
                .iter()
                .map(|tag| names.get(&(3, *tag)).cloned().unwrap_or(tag.to_string()))
                .collect();
            Err(MshError::at(
                block_line,
                format!(
                    "volume {entity_tag} is in {} physical volumes ({}): its hexahedra need exactly one part",
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
                    "{word} {entity_tag}: {} elements are not supported on a {word}, only first-order points, lines, triangles and quadrangles",
                    element_type_name(element_type)
                ),
            ))
        }
    }
}

fn parse_elements(
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
        hexes: Vec::new(),
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
        let n_nodes = if dim == 3 {
            let (key, name) = volume_group(entity_tag, element_type, physicals, names, block_line)?;
            elements.volume_names.insert(key, name);
            8
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
                        format!(
                            "element {element_tag} refers to node {tag}, which is not in $Nodes"
                        ),
                    ));
                }
                node_tags.push(tag);
            }
            if dim == 3 {
                elements.hexes.push(HexRecord {
                    tag: element_tag,
                    line: line_no,
                    nodes: node_tags.try_into().expect("eight node tags"),
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
    if elements.hexes.is_empty() {
        return Err(MshError::whole_file(
            "no hexahedra: the mesh has no 3D elements in a physical volume",
        ));
    }
    Ok(elements)
}

fn build_mesh(nodes: &Nodes, elements: Elements, options: &ReadOptions) -> Result<Mesh, MshError> {
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

/// Pairs the coincident nodes of the disc and pad contact surfaces, with the disc's outward
/// normal and tributary area at each pair.
fn pair_contact_nodes(
    mesh: &Mesh,
    elements: &Elements,
    index_of_tag: &HashMap<u64, u32>,
    contact: &ContactGroups,
) -> Result<Vec<ContactPair>, MshError> {
    let disc_group = contact_group(elements, &contact.disc, "contact_disc")?;
    let pad_group = contact_group(elements, &contact.pad, "contact_pad")?;
    let tag_of_index: HashMap<u32, u64> =
        index_of_tag.iter().map(|(tag, idx)| (*idx, *tag)).collect();
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

    let FaceIntegrals {
        normal_sums,
        area_sums,
        shortest_edge,
    } = integrate_disc_faces(mesh, disc_group, &disc_nodes, index_of_tag, &contact.disc)?;

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
        let Some(normal_sum) = normal_sums.get(&disc_node) else {
            return Err(MshError::whole_file(format!(
                "node {} of `{}` is on none of its quadrangles",
                tag_of_index[&disc_node], contact.disc
            )));
        };
        let length = norm(*normal_sum);
        if length <= 0.0 || !length.is_finite() {
            return Err(MshError::whole_file(format!(
                "node {} of `{}`: its faces' normals cancel out",
                tag_of_index[&disc_node], contact.disc
            )));
        }
        pairs.push(ContactPair {
            disc_node,
            pad_node,
            normal: normal_sum.map(|component| component / length),
            area: area_sums[&disc_node],
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

/// Per disc contact node: Σ ∫ Nᵢ n dA and Σ ∫ Nᵢ dA over its faces; and the shortest edge.
struct FaceIntegrals {
    normal_sums: HashMap<u32, [f64; 3]>,
    area_sums: HashMap<u32, f64>,
    shortest_edge: f64,
}

/// Integrates the disc's contact faces, each oriented out of the hexahedron it bounds.
fn integrate_disc_faces(
    mesh: &Mesh,
    disc_group: &BoundaryGroup,
    disc_nodes: &[u32],
    index_of_tag: &HashMap<u64, u32>,
    disc_name: &str,
) -> Result<FaceIntegrals, MshError> {
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

    let mut normal_sums: HashMap<u32, [f64; 3]> = HashMap::new();
    let mut area_sums: HashMap<u32, f64> = HashMap::new();
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
        // 2×2 Gauss points integrate Nᵢ (x_ξ × x_η) exactly on a bilinear quadrangle.
        let gauss = 1.0 / 3f64.sqrt();
        for (xi, eta) in [
            (-gauss, -gauss),
            (gauss, -gauss),
            (gauss, gauss),
            (-gauss, gauss),
        ] {
            let (shape, normal_da) = quad_tangents(&corners, xi, eta);
            let da = norm(normal_da);
            for (local, node) in quad.iter().enumerate() {
                let sum = normal_sums.entry(*node).or_insert([0.0; 3]);
                for axis in 0..3 {
                    sum[axis] += shape[local] * normal_da[axis];
                }
                *area_sums.entry(*node).or_insert(0.0) += shape[local] * da;
            }
        }
    }

    Ok(FaceIntegrals {
        normal_sums,
        area_sums,
        shortest_edge,
    })
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

/// Shape functions of a bilinear quadrangle at (ξ, η) and x_ξ × x_η (normal times dA/dξdη).
fn quad_tangents(corners: &[[f64; 3]; 4], xi: f64, eta: f64) -> ([f64; 4], [f64; 3]) {
    const REFERENCE: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let mut shape = [0.0; 4];
    let mut d_xi = [0.0; 3];
    let mut d_eta = [0.0; 3];
    for (node, [xi_n, eta_n]) in REFERENCE.iter().enumerate() {
        shape[node] = (1.0 + xi * xi_n) * (1.0 + eta * eta_n) / 4.0;
        for axis in 0..3 {
            d_xi[axis] += corners[node][axis] * xi_n * (1.0 + eta * eta_n) / 4.0;
            d_eta[axis] += corners[node][axis] * eta_n * (1.0 + xi * xi_n) / 4.0;
        }
    }
    (shape, cross(d_xi, d_eta))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::Value;

    fn data(name: &str) -> String {
        let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
        std::fs::read_to_string(&path).unwrap_or_else(|err| panic!("{path}: {err}"))
    }

    fn with_contact() -> ReadOptions {
        ReadOptions {
            contact: Some(ContactGroups {
                disc: "contact_disc".into(),
                pad: "contact_pad".into(),
                relative_tolerance: 1e-3,
            }),
        }
    }

    /// Reading `text` fails on `line` with a message containing `expected`.
    fn check_error(text: &str, options: &ReadOptions, line: Option<usize>, expected: &str) {
        let err = read_msh(text, options).expect_err("the file should be refused");
        assert_eq!(err.line, line, "{err}");
        assert!(err.message.contains(expected), "`{err}` lacks `{expected}`");
        assert!(!err.message.contains('\n'), "one line: {err}");
    }

    /// The 1-based number of the first line of `text` that contains `needle`.
    fn line_of(text: &str, needle: &str) -> usize {
        1 + text
            .lines()
            .position(|line| line.contains(needle))
            .unwrap_or_else(|| panic!("no line holds `{needle}`"))
    }

    #[test]
    fn block_reads_hexes_part_and_face_set() {
        let mesh = read_msh(&data("block_2x1x1.msh"), &ReadOptions::default()).unwrap();
        assert_eq!(mesh.nodes.len(), 12);
        assert_eq!(mesh.parts, ["steel"]);
        assert_eq!(mesh.hex_part, [0, 0]);
        // Tags 1..12 become 0..11; connectivity is copied in Gmsh order.
        assert_eq!(mesh.hexes[0], [0, 4, 6, 1, 3, 8, 10, 2]);
        assert_eq!(mesh.hexes[1], [4, 5, 7, 6, 8, 9, 11, 10]);
        assert_eq!(mesh.nodes[5], [2.0, 0.0, 0.0]);
        assert_eq!(mesh.node_sets.keys().collect::<Vec<_>>(), ["x0"]);
        assert_eq!(mesh.node_sets["x0"], [0, 1, 2, 3]);
        assert!(
            mesh.node_sets["x0"]
                .iter()
                .all(|n| mesh.nodes[*n as usize][0] == 0.0)
        );
        assert!(mesh.contact_pairs.is_empty());
    }

    #[test]
    fn two_parts_pair_duplicated_interface_nodes() {
        let mesh = read_msh(&data("two_part.msh"), &with_contact()).unwrap();
        assert_eq!(mesh.parts, ["disc", "pad"]);
        assert_eq!(mesh.hex_part, [0, 0, 1, 1]);
        assert_eq!(mesh.nodes.len(), 24);
        assert_eq!(mesh.contact_pairs.len(), 6);
        for pair in &mesh.contact_pairs {
            let disc = mesh.nodes[pair.disc_node as usize];
            let pad = mesh.nodes[pair.pad_node as usize];
            assert_ne!(pair.disc_node, pair.pad_node);
            assert!(norm(sub(disc, pad)) < 1e-8, "{disc:?} {pad:?}");
            // One face is written clockwise in the file: the normal is oriented all the same.
            assert!(norm(sub(pair.normal, [0.0, 0.0, 1.0])) < 1e-12, "{pair:?}");
            // Corner nodes take a quarter of one unit face, the middle ones two quarters.
            let expected = if disc[0] == 1.0 { 0.5 } else { 0.25 };
            assert!((pair.area - expected).abs() < 1e-12, "{pair:?}");
        }
        let total: f64 = mesh.contact_pairs.iter().map(|pair| pair.area).sum();
        assert!((total - 2.0).abs() < 1e-12);
        assert_eq!(mesh.node_sets["pad_back"].len(), 6);
        assert_eq!(mesh.node_sets["contact_disc"].len(), 6);
    }

    #[test]
    fn tilted_face_has_its_normal_and_area() {
        // Rotate the two-part block about x by 30°: normals rotate, areas stay.
        let angle = 30f64.to_radians();
        let text = data("two_part.msh");
        let mesh = read_msh(&text, &with_contact()).unwrap();
        let mut rotated = mesh.clone();
        for node in &mut rotated.nodes {
            let [x, y, z] = *node;
            *node = [
                x,
                y * angle.cos() - z * angle.sin(),
                y * angle.sin() + z * angle.cos(),
            ];
        }
        let elements = parse_elements_of(&text);
        let index_of_tag = tags_to_indices(&text);
        let contact = with_contact().contact.unwrap();
        let pairs = pair_contact_nodes(&rotated, &elements, &index_of_tag, &contact).unwrap();
        let expected = [0.0, -angle.sin(), angle.cos()];
        for (pair, original) in pairs.iter().zip(&mesh.contact_pairs) {
            assert!(norm(sub(pair.normal, expected)) < 1e-12, "{pair:?}");
            assert!((pair.area - original.area).abs() < 1e-12);
        }
    }

    fn parse_elements_of(text: &str) -> Elements {
        let sections = split_sections(text).unwrap();
        let find = |name: &str| sections.iter().find(|s| s.name == name).unwrap();
        let names = parse_physical_names(find("PhysicalNames")).unwrap();
        let entities = parse_entities(find("Entities")).unwrap();
        let nodes = parse_nodes(find("Nodes")).unwrap();
        parse_elements(find("Elements"), &nodes, &entities, &names).unwrap()
    }

    fn tags_to_indices(text: &str) -> HashMap<u64, u32> {
        let elements = parse_elements_of(text);
        let mut tags: Vec<u64> = elements.hexes.iter().flat_map(|hex| hex.nodes).collect();
        tags.sort_unstable();
        tags.dedup();
        tags.into_iter().zip(0..).collect()
    }

    #[test]
    fn file_written_by_gmsh_reads_the_same() {
        // Written by Gmsh 4.15 (two OpenCASCADE boxes, transfinite, recombined): nodes are
        // classified on points, curves and surfaces, lines end with a space.
        let mesh = read_msh(&data("two_part_gmsh.msh"), &with_contact()).unwrap();
        assert_eq!(mesh.parts, ["disc", "pad"]);
        assert_eq!(mesh.hexes.len(), 4);
        assert_eq!(mesh.nodes.len(), 24);
        assert_eq!(mesh.contact_pairs.len(), 6);
        let total: f64 = mesh.contact_pairs.iter().map(|pair| pair.area).sum();
        assert!((total - 2.0).abs() < 1e-12);
        for pair in &mesh.contact_pairs {
            assert!(norm(sub(pair.normal, [0.0, 0.0, 1.0])) < 1e-12, "{pair:?}");
        }
        assert_eq!(mesh.node_sets["clamp"].len(), 6);
        assert!(
            mesh.node_sets["clamp"]
                .iter()
                .all(|n| mesh.nodes[*n as usize][2] == 0.0)
        );
    }

    #[test]
    fn stage_reads_the_file_and_names_it_in_errors() {
        let stage = GmshImport;
        assert!(!stage.pure());
        let params = |path: &str, disc: &str, pad: &str| {
            Params(BTreeMap::from([
                ("path".to_string(), Value::Str(path.into())),
                ("contact_disc".to_string(), Value::Str(disc.into())),
                ("contact_pad".to_string(), Value::Str(pad.into())),
                ("contact_tolerance".to_string(), Value::Float(1e-3)),
            ]))
        };
        let path = format!("{}/tests/data/two_part.msh", env!("CARGO_MANIFEST_DIR"));
        let outputs = stage
            .run(
                &params(&path, "contact_disc", "contact_pad"),
                &Inputs::default(),
            )
            .unwrap();
        let Artifact::Mesh(mesh) = &outputs["mesh"] else {
            panic!("not a mesh")
        };
        assert_eq!(mesh.contact_pairs.len(), 6);

        let block = format!("{}/tests/data/block_2x1x1.msh", env!("CARGO_MANIFEST_DIR"));
        let err = stage
            .run(
                &params(&block, "contact_disc", "contact_pad"),
                &Inputs::default(),
            )
            .unwrap_err();
        assert!(
            err.message.starts_with(&format!("{block}: contact_disc")),
            "{err}"
        );
        assert!(err.message.contains("physical surfaces: x0"), "{err}");
        assert!(
            stage
                .run(&params(&block, "", ""), &Inputs::default())
                .is_ok()
        );

        let err = stage
            .run(&params(&block, "contact_disc", ""), &Inputs::default())
            .unwrap_err();
        assert!(err.message.contains("both"), "{err}");

        // Parse errors carry `file:line:`.
        let old_format =
            std::env::temp_dir().join(format!("squeal-gmsh-old-format-{}.msh", std::process::id()));
        let text = std::fs::read_to_string(&block).unwrap();
        std::fs::write(&old_format, text.replace("4.1 0 8", "2.2 0 8")).unwrap();
        let old_format = old_format.to_string_lossy().into_owned();
        let err = stage
            .run(&params(&old_format, "", ""), &Inputs::default())
            .unwrap_err();
        let _ = std::fs::remove_file(&old_format);
        assert!(
            err.message
                .starts_with(&format!("{old_format}:2: MSH 2.2 is not supported")),
            "{err}"
        );

        let missing = format!("{}/tests/data/no_such.msh", env!("CARGO_MANIFEST_DIR"));
        let err = stage
            .run(&params(&missing, "", ""), &Inputs::default())
            .unwrap_err();
        assert!(err.message.starts_with(&missing), "{err}");
    }

    #[test]
    fn unsupported_formats_are_refused_on_their_header_line() {
        let block = data("block_2x1x1.msh");
        let none = ReadOptions::default();
        check_error(
            &block.replace("4.1 0 8", "2.2 0 8"),
            &none,
            Some(2),
            "MSH 2.2 is not supported",
        );
        check_error(
            &block.replace("4.1 0 8", "4 0 8"),
            &none,
            Some(2),
            "MSH 4 is not supported",
        );
        check_error(
            &block.replace("4.1 0 8", "4.1 1 8"),
            &none,
            Some(2),
            "binary MSH",
        );
        check_error("$Nodes\n", &none, Some(1), "not a Gmsh MSH file");

        // A binary file is refused from its header, before its bytes are decoded.
        let mut binary = b"$MeshFormat\n4.1 1 8\n".to_vec();
        binary.extend_from_slice(&[1, 0, 0, 0, 0xff, 0xfe, b'\n']);
        let err = read_msh_bytes(&binary, &none).unwrap_err();
        assert!(err.message.contains("binary MSH"), "{err}");
        let mut garbage = block.clone().into_bytes();
        garbage.extend_from_slice(&[0xff, 0xfe]);
        let err = read_msh_bytes(&garbage, &none).unwrap_err();
        assert!(err.message.contains("not UTF-8"), "{err}");
    }

    #[test]
    fn unsupported_elements_are_named() {
        let block = data("block_2x1x1.msh");
        let none = ReadOptions::default();
        // A tetrahedron block.
        let tets = block.replace("3 1 5 2\n", "3 1 4 2\n");
        check_error(
            &tets,
            &none,
            Some(line_of(&tets, "3 1 4 2")),
            "volume 1: 4-node tetrahedron (Gmsh type 4) elements are not supported",
        );
        // A second-order hexahedron block.
        let quadratic = block.replace("3 1 5 2\n", "3 1 12 2\n");
        check_error(
            &quadratic,
            &none,
            Some(line_of(&quadratic, "3 1 12 2")),
            "27-node hexahedron",
        );
        // Second-order quadrangles on a named surface.
        let faces = block.replace("2 1 3 1\n", "2 1 10 1\n");
        check_error(
            &faces,
            &none,
            Some(line_of(&faces, "2 1 10 1")),
            "9-node quadrangle",
        );
        // A hexahedron missing a node.
        let short = block.replace("2 5 6 8 7 9 10 12 11", "2 5 6 8 7 9 10 12");
        check_error(
            &short,
            &none,
            Some(line_of(&short, "2 5 6 8 7 9 10 12")),
            "needs 8 nodes, found 7",
        );
    }

    #[test]
    fn groups_must_exist_be_named_and_hold_every_hexahedron() {
        let block = data("block_2x1x1.msh");
        let none = ReadOptions::default();
        // Volume entity 1 in no physical group.
        let orphan = block.replace("1 0 0 0 2 1 1 1 1 1 1 1", "1 0 0 0 2 1 1 0 1 1");
        check_error(
            &orphan,
            &none,
            Some(line_of(&orphan, "3 1 5 2")),
            "in no physical volume",
        );
        // Volume entity 1 in two groups.
        let twice = block.replace("1 0 0 0 2 1 1 1 1 1 1 1", "1 0 0 0 2 1 1 2 1 7 1 1");
        check_error(
            &twice,
            &none,
            Some(line_of(&twice, "3 1 5 2")),
            "2 physical volumes (steel, 7)",
        );
        // A group without a name.
        let unnamed = block.replace("3 1 \"steel\"", "3 9 \"steel\"");
        check_error(
            &unnamed,
            &none,
            Some(line_of(&unnamed, "3 1 5 2")),
            "physical volume 1 has no name",
        );
        // Contact groups asked of a mesh that has none.
        check_error(
            &block,
            &with_contact(),
            None,
            "no physical surface named `contact_disc`",
        );
    }

    #[test]
    fn malformed_text_names_its_line() {
        let block = data("block_2x1x1.msh");
        let none = ReadOptions::default();
        let bad_number = block.replace("\n2 0 0\n", "\n2 0 zero\n");
        check_error(
            &bad_number,
            &none,
            Some(line_of(&bad_number, "2 0 zero")),
            "`zero` is not a valid number",
        );
        let unknown_node = block.replace("2 5 6 8 7 9 10 12 11", "2 5 6 8 7 9 10 12 99");
        check_error(
            &unknown_node,
            &none,
            Some(line_of(&unknown_node, "12 99")),
            "refers to node 99",
        );
        let truncated = &block[..block.find("$EndElements").unwrap()];
        check_error(
            truncated,
            &none,
            Some(line_of(truncated, "$Elements")),
            "not closed by $EndElements",
        );
        let inverted = block.replace("2 5 6 8 7 9 10 12 11", "2 9 10 12 11 5 6 8 7");
        check_error(
            &inverted,
            &none,
            Some(line_of(&inverted, "2 9 10 12 11 5 6 8 7")),
            "hexahedron 2 is inverted",
        );
        let miscounted = block.replace("2 3 1 3\n", "2 4 1 3\n");
        check_error(
            &miscounted,
            &none,
            Some(line_of(&miscounted, "2 4 1 3")),
            "announces 4 elements, blocks hold 3",
        );
    }

    #[test]
    fn contact_nodes_must_match_one_to_one() {
        let two = data("two_part.msh");
        // Move a pad node away from its disc partner.
        let moved = two.replace("1.0000000001 1 0.5", "1.3 1 0.5");
        check_error(
            &moved,
            &with_contact(),
            None,
            "node 11 of `contact_disc` at (1, 1, 0.5) has no node of `contact_pad`",
        );
        // A loose tolerance finds two candidates.
        let mut loose = with_contact();
        loose.contact.as_mut().unwrap().relative_tolerance = 1.5;
        check_error(&two, &loose, None, "lower contact_tolerance");
        // A shared (not duplicated) interface node.
        let shared = two.replace("3 101 104 105 102", "3 7 104 105 102");
        check_error(&shared, &with_contact(), None, "node 7 is on both");
        // A triangle in a contact surface.
        let triangle = two.replace(
            "2 2 3 2\n3 101 104 105 102\n4 102 105 106 103\n",
            "2 2 2 2\n3 101 104 105\n4 102 105 106\n",
        );
        check_error(
            &triangle,
            &with_contact(),
            Some(line_of(&triangle, "3 101 104 105")),
            "element 3 is a 3-node triangle",
        );
    }
}
