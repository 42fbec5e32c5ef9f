//! `mesh.gmsh`: import a mesh of solid elements written by Gmsh (MSH 4.1, ASCII).
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
//! - Solid elements become [`Mesh::elements`]: 4- and 10-node tetrahedra (Gmsh types 4, 11),
//!   8- and 20-node hexahedra (5, 17), 6- and 15-node prisms (6, 18), mixed freely. Corners
//!   are in Gmsh's order, which is squeal's; mid-edge nodes are renumbered to squeal's order
//!   ([`crate::fem::element::formats`]). Every element must be right-handed (det J > 0 at its
//!   nodes and quadrature points).
//! - The physical volume of each element's entity is its part; the part names are the group
//!   names (`disc`, `pad`), which name materials downstream. An element in no physical
//!   volume, or in two, is an error.
//! - Each named physical surface, curve or point becomes a node set holding every node of its
//!   elements (groups of different dimensions with one name are merged).
//! - Nodes are renumbered from 0 in increasing Gmsh tag order; nodes that belong to no
//!   solid element (geometry points, isolated nodes) are dropped, since they would carry no
//!   stiffness.
//! - Contact pairs: the nodes of physical surface `contact_disc` are paired with the
//!   coincident (distinct) nodes of `contact_pad`: the interface must be conforming with its
//!   nodes duplicated, one copy per side, and every node on either side must find exactly one
//!   partner within `contact_tolerance` × the shortest edge of the disc's contact faces. Each
//!   pair gets the disc's outward unit normal and its tributary area, integrated over the
//!   bilinear quadrangle faces: nᵢ ∝ Σ_faces ∫ Nᵢ n dA, Aᵢ = Σ_faces ∫ Nᵢ dA
//!   ([`super::contact_faces`]).
//!
//! What is refused, each with one line naming the file, the line and the element type or group:
//! binary files, MSH 2.x and 4.0, partitioned meshes, pyramids and elements of third order or
//! with face and volume nodes (27-node hexahedra, 18-node prisms), unnamed physical groups,
//! missing contact groups, contact surfaces of other faces than 4-node quadrangles
//! (node-to-node contact; pair independent meshes with `contact.mortar`), unmatched or
//! ambiguous contact nodes, interfaces whose nodes are shared rather than duplicated.

use std::collections::HashMap;
use std::fmt;
use std::path::PathBuf;

use crate::artifact::mesh::Mesh;
use crate::artifact::{Artifact, ArtifactType};
use crate::mesh::interface::{self, ContactSides};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};

mod build;
mod parse;

use build::build_mesh;
use parse::{
    check_format_header, parse_elements, parse_entities, parse_nodes, parse_physical_names,
    split_sections,
};

/// Options of [`read_msh`]; `contact: None` reads no contact pairs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// How to find contact pairs: the names of the two physical surfaces of the interface.
    pub contact: Option<ContactSides>,
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

crate::stage_params! {
    /// How a .msh file becomes a mesh: what `mesh.gmsh` and `mesh.cad` share.
    pub struct MshReading {
        /// physical surface of the disc side of the contact interface ("" = no contact)
        contact_disc: String = "contact_disc".into(),
        /// physical surface of the pad side of the contact interface ("" = no contact)
        contact_pad: String = "contact_pad".into(),
        /// largest distance between paired nodes, relative to the shortest contact face edge
        #[min = 0.0]
        contact_tolerance: f64 = 1e-3,
    }
}

impl MshReading {
    /// The reader's options: the contact sides to pair, if any.
    pub fn options(&self) -> Result<ReadOptions, StageError> {
        let contact =
            interface::contact_sides(&self.contact_disc, &self.contact_pad, "a physical surface")?
                .map(|[disc, pad]| ContactSides {
                    disc,
                    pad,
                    relative_tolerance: self.contact_tolerance,
                });
        Ok(ReadOptions { contact })
    }
}

crate::stage_params! {
    /// The parameters of `mesh.gmsh`.
    pub struct GmshParams {
        ..reading: MshReading,
        /// the .msh file (relative to the study's folder)
        path: PathBuf,
    }
}

impl HasParams for GmshImport {
    type Params = GmshParams;
}

impl Stage for GmshImport {
    fn kind(&self) -> &'static str {
        "mesh.gmsh"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Import a Gmsh mesh (MSH 4.1 ASCII) of tetrahedra, hexahedra and prisms with parts, node sets and contact pairs; reads a file, so never cached"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::one(
            "mesh",
            ArtifactType::Mesh,
            "solid elements, parts, node sets and contact pairs",
        )]
    }
    fn pure(&self) -> bool {
        false
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let params = params.read::<Self>()?;
        let path = params.path.display();
        let options = params.reading.options()?;
        let bytes =
            std::fs::read(&params.path).map_err(|err| StageError::new(format!("{path}: {err}")))?;
        let mesh = read_msh_bytes(&bytes, &options).map_err(|err| {
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

#[cfg(test)]
mod tests;
