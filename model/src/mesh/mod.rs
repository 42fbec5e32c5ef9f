//! Meshes for a study: the parametric brake (`mesh.brake`), structured blocks and annuli, Gmsh
//! files (`mesh.gmsh`) and Abaqus input files (`mesh.abaqus`), which share the pairing of their
//! contact interface (`interface`). The [`Mesh`](crate::artifact::Mesh) type itself is an
//! artifact.

pub mod abaqus;
pub mod brake;
pub mod cad;
pub mod contact_faces;
pub mod convert;
pub mod deck_error;
pub mod gmsh;
pub mod interface;
pub mod mortar_pairs;
pub mod nastran;
pub mod structured;

use std::collections::HashMap;

use crate::artifact::Elements;

/// The first element with the same nodes as an earlier one (in any order), with that earlier
/// one: a duplicated element silently doubles its stiffness and mass.
pub fn first_duplicate(elements: &Elements) -> Option<(usize, usize)> {
    let mut seen: HashMap<Vec<u32>, usize> = HashMap::with_capacity(elements.len());
    for (idx, element) in elements.iter().enumerate() {
        let mut key = element.nodes.to_vec();
        key.sort_unstable();
        if let Some(first) = seen.insert(key, idx) {
            return Some((first, idx));
        }
    }
    None
}
