//! Stages that turn meshes, models and modes into files other tools read: VTU for ParaView
//! ([`vtu`]), Matrix Market for scipy and MATLAB ([`matrix_market`]). Each returns
//! [`Document`](crate::Document) outputs; the engine writes them as `<output>.<extension>`.

pub mod matrix_market;
pub mod vtu;

use crate::artifact::{Artifact, Document};
use crate::mesh::Mesh;
use crate::model::{Model, RealModes};
use crate::stage::{Inputs, StageError};

fn mesh_input<'i>(inputs: &'i Inputs, port: &str) -> Result<&'i Mesh, StageError> {
    match inputs.one(port)? {
        Artifact::Mesh(mesh) => Ok(mesh),
        other => Err(wrong_type(port, "a mesh", other)),
    }
}

fn model_input<'i>(inputs: &'i Inputs, port: &str) -> Result<&'i Model, StageError> {
    match inputs.one(port)? {
        Artifact::Model(model) => Ok(model),
        other => Err(wrong_type(port, "a model", other)),
    }
}

fn real_modes_input<'i>(inputs: &'i Inputs, port: &str) -> Result<&'i RealModes, StageError> {
    match inputs.one(port)? {
        Artifact::RealModes(modes) => Ok(modes),
        other => Err(wrong_type(port, "real modes", other)),
    }
}

fn wrong_type(port: &str, expected: &str, found: &Artifact) -> StageError {
    StageError::new(format!(
        "input `{port}` is {}, expected {expected}",
        found.artifact_type()
    ))
}

pub fn document(extension: &str, text: String) -> Artifact {
    Artifact::Document(Document {
        extension: extension.to_string(),
        bytes: text.into_bytes(),
    })
}

/// Checks that `dof_of_node` numbers the free DOFs 0..n once each, with one entry per node.
fn check_dof_map(model: &Model) -> Result<(), StageError> {
    let n_dofs = model.n_dofs();
    if model.dof_of_node.len() != model.mesh.n_nodes() {
        return Err(StageError::new(format!(
            "model maps {} nodes to DOFs but its mesh has {}",
            model.dof_of_node.len(),
            model.mesh.n_nodes()
        )));
    }
    let mut seen = vec![false; n_dofs];
    for (node, dofs) in model.dof_of_node.iter().enumerate() {
        for dof in dofs.iter().flatten() {
            let dof = *dof as usize;
            if dof >= n_dofs || std::mem::replace(&mut seen[dof], true) {
                return Err(StageError::new(format!(
                    "model maps node {node} to DOF {dof}, out of range or already taken (n = {n_dofs})"
                )));
            }
        }
    }
    if let Some(missing) = seen.iter().position(|taken| !taken) {
        return Err(StageError::new(format!(
            "model has {n_dofs} DOFs but no node maps to DOF {missing}"
        )));
    }
    Ok(())
}
