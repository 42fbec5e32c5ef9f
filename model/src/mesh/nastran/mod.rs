//! `mesh.nastran`: import a mesh of solid elements from Nastran bulk data (`.bdf`, `.nas`,
//! `.dat`).
//!
//! # What is read
//!
//! Bulk data in small (8-column), large (16-column, `GRID*`) or free (comma) fields, with
//! continuation lines, `$` comments and `INCLUDE`; anything before `BEGIN BULK` (executive and
//! case control) is skipped, and `ENDDATA` ends the deck.
//!
//! | card | read as |
//! |---|---|
//! | `GRID` | a grid point, its coordinates in its `CP` system (`CD` is not used: squeal's DOFs are along the basic axes) |
//! | `CORD2R`, `CORD2C`, `CORD2S` | rectangular, cylindrical and spherical systems (angles in degrees), defined by points A, B, C in another system (`RID`) |
//! | `CTETRA` (4 or 10), `CPENTA` (6 or 15), `CHEXA` (8 or 20) | solid elements; Nastran's node orders (its hexahedra and wedges list the vertical edges' middles before the top face's) to squeal's; an element given the other way round is turned |
//! | `PSOLID` | a property: the parts gather elements by property |
//! | `SET1` | the node set `set<SID>` (ids and `THRU` ranges) |
//! | `SPC1` | the node set `spc<SID>` of its grid points (the components are not read: `assemble`'s `clamped` says which axes a set holds) |
//!
//! Cards that carry no mesh are skipped ([`build::SKIPPED`]: `PARAM`, `EIGRL`, `MAT1`,
//! `MAT9`, `SPC`, loads, …: the stages set materials, loads and solutions themselves). Rigid
//! and interpolation elements (`RBE2`, `RBE3`, `RBAR`), `MPC`, masses, springs, beams, shells
//! and every other card are refused with `file:line:` and the card's name: dropped, they would
//! change the model.
//!
//! # What it becomes
//!
//! - Parts: `parts` items `name=PID` (a name may gather several properties: `pad=2`,
//!   `pad=3`); without `parts`, one part per `PSOLID`, named by the deck's HyperMesh comment
//!   (`$HMNAME PROP 2 "lining"`) or `pid<N>`.
//! - Grid points of no element are dropped; the others are numbered by increasing id.
//! - Contact pairs: as `mesh.abaqus` builds them from node sets ([`crate::mesh::interface`]),
//!   between the node sets `contact_disc` and `contact_pad` (`set10`, `set11`).

use std::path::{Path, PathBuf};

use crate::artifact::mesh::Mesh;
use crate::artifact::{Artifact, ArtifactType};
use crate::mesh::deck_error::DeckError;
use crate::mesh::interface::{self, ContactSides};
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};

pub mod build;
mod cards;

/// Options of [`read_bdf`]: the parts, and the contact sides.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// `name=PID` items; empty for one part per property.
    pub parts: Vec<String>,
    /// The contact sides: node sets.
    pub contact: Option<ContactSides>,
}

/// Reads the bulk data at `path` (with its includes) into a [`Mesh`].
pub fn read_bdf(path: &Path, options: &ReadOptions) -> Result<Mesh, DeckError> {
    build::build_mesh(&cards::read_cards(path)?, options)
}

/// Reads bulk data text (`file` names it in messages; includes resolve in `dir`).
pub fn read_bdf_text(
    text: &str,
    file: &str,
    dir: &Path,
    options: &ReadOptions,
) -> Result<Mesh, DeckError> {
    build::build_mesh(&cards::parse_cards(text, file, dir)?, options)
}

/// `mesh.nastran`: reads a user file, so it is impure and never cached.
pub struct NastranImport;

crate::stage_params! {
    /// The parameters of `mesh.nastran`.
    pub struct NastranParams {
        /// the bulk data file (relative to the study's folder)
        path: PathBuf,
        /// parts as `name=PID` (several items may share a name); empty for one part per PSOLID
        parts: Vec<String> = Vec::new(),
        /// node set (`set<SID>`) of the disc side of the contact interface ("" = no contact)
        contact_disc: String = String::new(),
        /// node set (`set<SID>`) of the pad side of the contact interface ("" = no contact)
        contact_pad: String = String::new(),
        /// largest distance between paired nodes, relative to the shortest contact face edge
        #[min = 0.0]
        contact_tolerance: f64 = 1e-3,
    }
}

impl HasParams for NastranImport {
    type Params = NastranParams;
}

impl Stage for NastranImport {
    fn kind(&self) -> &'static str {
        "mesh.nastran"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Import Nastran bulk data (GRID with CORD2R/C/S, CTETRA, CPENTA, CHEXA of first and second order, PSOLID parts, SET1/SPC1 node sets; small, large and free fields, INCLUDE) with contact pairs; reads a file, so never cached"
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
        let contact =
            interface::contact_sides(&params.contact_disc, &params.contact_pad, "a node set")?.map(
                |[disc, pad]| ContactSides {
                    disc,
                    pad,
                    relative_tolerance: params.contact_tolerance,
                },
            );
        let options = ReadOptions {
            parts: params.parts.clone(),
            contact,
        };
        let mesh = read_bdf(&params.path, &options)
            .map_err(|err| StageError::new(err.in_file(&params.path)))?;
        Ok(Outputs::from([(
            "mesh".to_string(),
            Artifact::Mesh(Box::new(mesh)),
        )]))
    }
}

#[cfg(test)]
mod tests;
