//! Meshes for a study: the parametric brake (`mesh.brake`), structured blocks and annuli, Gmsh
//! files (`mesh.gmsh`) and Abaqus input files (`mesh.abaqus`), which share the pairing of their
//! contact interface (`interface`). The [`Mesh`](crate::artifact::Mesh) type itself is an
//! artifact.

pub mod abaqus;
pub mod brake;
pub mod contact_faces;
pub mod gmsh;
pub mod interface;
pub mod structured;
