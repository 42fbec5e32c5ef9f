//! Meshes for a study: the parametric brake (`mesh.brake`), structured blocks and annuli, and
//! Gmsh files (`mesh.gmsh`). The [`Mesh`](crate::artifact::Mesh) type itself is an artifact.

pub mod brake;
pub mod contact_faces;
pub mod gmsh;
pub mod structured;
