//! `mesh.abaqus`: import a mesh of solid elements from an Abaqus input file (`.inp`).
//!
//! # What is read
//!
//! | keyword | read as |
//! |---|---|
//! | `*NODE` (`NSET=`) | nodes, `label, x, y, z` |
//! | `*ELEMENT, TYPE=` (`ELSET=`) C3D4, C3D10, C3D6, C3D15, C3D8, C3D20 and their `I`, `R`, `H`, `M` variants | solid elements, `label, n1..nN` (a line ending with a comma continues on the next) |
//! | `*NSET`, `*ELSET` (`GENERATE`, `INSTANCE=` in the assembly) | labels, names of sets defined above, or `first, last, increment` ranges |
//! | `*SURFACE, TYPE=ELEMENT` | `element set or label, S1..S6`: element faces (S1..S4 on tetrahedra, S1..S5 on wedges) |
//! | `*SURFACE, TYPE=NODE` | node sets or labels |
//! | `*INCLUDE, INPUT=` | the file, relative to the including one, read in place |
//! | `*PART` / `*END PART` | a part's nodes, elements and sets |
//! | `*ASSEMBLY` with `*INSTANCE, NAME=, PART=` | the part placed in the model: the first data line translates it, the second rotates it by an angle (degrees) about the axis through points a and b, after the translation |
//!
//! Keywords that carry no mesh, whose content the stages set themselves, are skipped with
//! their data lines: `*HEADING`, `*PREPRINT`, `*MATERIAL`, `*ELASTIC`, `*DENSITY`,
//! `*DAMPING`, `*SOLID SECTION`, `*BOUNDARY`, `*SURFACE INTERACTION`, `*FRICTION`,
//! `*CONTACT PAIR`, `*INITIAL CONDITIONS`, `*AMPLITUDE`, `*TIE`, and every `*STEP` to its
//! `*END STEP`. Every other keyword, every other element type and every parameter not listed
//! is refused with `file:line:` naming it: one silently ignored could change the mesh.
//!
//! # What it becomes
//!
//! - Assemblies are flattened: each instance contributes its part's nodes and elements (in
//!   label order), and its sets under `instance.set`; an instance is itself a node and element
//!   set named after it. A deck without parts is one implicit instance whose names are as
//!   written. Names are case-insensitive in Abaqus, so squeal lower-cases them.
//! - Element types become squeal's kinds, node orders Abaqus's (which are squeal's):
//!   C3D4(H) `tet4`, C3D10(H, M, MH) `tet10`, C3D6(H) `wedge6`, C3D15(H) `wedge15`, C3D8(I, R,
//!   H, IH, RH) squeal's incompatible-mode `hex8`, C3D20(R, H, RH) `hex20`. Squeal integrates
//!   each kind by its own rule: reduced-integration and hybrid variants are read for their
//!   nodes. Every element is checked right-handed (det J > 0 at its nodes and quadrature
//!   points).
//! - Parts: the element sets named by `parts` (default `disc, pad`, the part names that
//!   `assemble` gives materials to); every element must be in exactly one.
//! - Node sets: every `*NSET`, and the nodes of every `*SURFACE`. Nodes of no element are
//!   dropped; a set holding one is an error.
//! - Contact pairs: as `mesh.gmsh` builds them ([`crate::mesh::interface`]), between the
//!   surfaces or node sets named by `contact_disc` and `contact_pad`. The disc's faces are a
//!   surface's own faces, or every boundary face whose nodes are all in the node set; they
//!   must be 4-node quadrangles (node-to-node contact).

use std::path::{Path, PathBuf};

use crate::artifact::mesh::Mesh;
use crate::artifact::{Artifact, ArtifactType};
use crate::mesh::interface::{self, ContactSides};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};

mod assembly;
mod build;
mod deck;
mod interpret;

pub use deck::DeckError;

/// Options of [`read_inp`]: the element sets that are parts, and the contact sides.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    pub parts: Vec<String>,
    /// The contact sides: surfaces or node sets.
    pub contact: Option<ContactSides>,
}

/// Reads the deck at `path` (with its includes) into a [`Mesh`].
pub fn read_inp(path: &Path, options: &ReadOptions) -> Result<Mesh, DeckError> {
    let blocks = deck::read_deck(path)?;
    build::build_mesh(&interpret::interpret(blocks)?, options)
}

/// Reads deck text (`file` names it in messages; includes resolve in `dir`).
pub fn read_inp_text(
    text: &str,
    file: &str,
    dir: &Path,
    options: &ReadOptions,
) -> Result<Mesh, DeckError> {
    let blocks = deck::parse_deck(text, file, dir)?;
    build::build_mesh(&interpret::interpret(blocks)?, options)
}

/// `mesh.abaqus`: reads a user file, so it is impure and never cached (an unchanged file
/// still gives identical bytes, which leaves downstream stages cached).
pub struct AbaqusImport;

crate::stage_params! {
    /// The parameters of `mesh.abaqus`.
    pub struct AbaqusParams {
        /// the .inp file (relative to the study's folder)
        path: PathBuf,
        /// element sets (or instances) that are the parts; every element in exactly one
        parts: Vec<String> = vec!["disc".into(), "pad".into()],
        /// surface or node set of the disc side of the contact interface ("" = no contact)
        contact_disc: String = "contact_disc".into(),
        /// surface or node set of the pad side of the contact interface ("" = no contact)
        contact_pad: String = "contact_pad".into(),
        /// largest distance between paired nodes, relative to the shortest contact face edge
        #[min = 0.0]
        contact_tolerance: f64 = 1e-3,
    }
}

impl HasParams for AbaqusImport {
    type Params = AbaqusParams;
}

impl Stage for AbaqusImport {
    fn kind(&self) -> &'static str {
        "mesh.abaqus"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Import an Abaqus input file (.inp: C3D4/C3D10/C3D6/C3D15/C3D8/C3D20 and variants, sets, surfaces, includes, parts and instances flattened) with contact pairs; reads a file, so never cached"
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
        let parts: Vec<String> = params
            .parts
            .iter()
            .map(|part| part.to_lowercase())
            .collect();
        if parts.is_empty() {
            return Err(StageError::new(
                "parts is empty: name the element sets that are the parts (e.g. `disc, pad`)",
            ));
        }
        let contact = interface::contact_sides(
            &params.contact_disc,
            &params.contact_pad,
            "a surface or node set",
        )?
        .map(|[disc, pad]| ContactSides {
            disc: disc.to_lowercase(),
            pad: pad.to_lowercase(),
            relative_tolerance: params.contact_tolerance,
        });
        let mesh = read_inp(&params.path, &ReadOptions { parts, contact })
            .map_err(|err| StageError::new(err.in_file(&params.path)))?;
        Ok(Outputs::from([(
            "mesh".to_string(),
            Artifact::Mesh(Box::new(mesh)),
        )]))
    }
}

#[cfg(test)]
mod tests;
