//! The brakes and models the unit tests of several crates start from, here rather than in one
//! stage's tests that another's borrow.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::artifact::{Artifact, Mesh, Model};
use crate::assemble::{Assemble, AssembleParams, with_default_materials};
use crate::mesh::brake::{BrakeGeometry, brake};
use crate::stage::{Input, Inputs, Params, Stage, StageError, Value};
use crate::table::Table;

/// The coarse brake.
pub fn coarse_brake() -> Mesh {
    brake(&BrakeGeometry::coarse()).unwrap()
}

/// A brake small enough for a dense reference solve of its linearised problem.
pub fn small_brake() -> Mesh {
    brake(&BrakeGeometry::small()).unwrap()
}

/// [`with_default_materials`]: `mesh` with the default materials (some overridden by name),
/// `clamped` held.
pub fn test_model(
    mesh: &Mesh,
    clamped: &str,
    overrides: &[(&str, f64)],
) -> (Model, AssembleParams) {
    with_default_materials(mesh, clamped, overrides)
        .unwrap_or_else(|err| panic!("assembly failed: {err}"))
}

/// Runs `assemble` on `mesh` with `clamped` and the default materials.
pub fn try_assemble(mesh: &Mesh, clamped: &str) -> Result<(Model, Table), StageError> {
    let params = Params::defaults(&Assemble, &[("clamped", Value::Str(clamped.into()))]);
    let inputs = Inputs(BTreeMap::from([(
        "mesh".to_string(),
        Input::One(Arc::new(Artifact::Mesh(Box::new(mesh.clone())))),
    )]));
    let mut outputs = Assemble.run(&params, &inputs)?;
    let model = match outputs.remove("model") {
        Some(Artifact::Model(model)) => *model,
        other => panic!("no model output: {other:?}"),
    };
    let summary = match outputs.remove("summary") {
        Some(Artifact::Table(table)) => table,
        other => panic!("no summary output: {other:?}"),
    };
    Ok((model, summary))
}

/// [`try_assemble`], unwrapped.
pub fn assemble(mesh: &Mesh, clamped: &str) -> (Model, Table) {
    try_assemble(mesh, clamped).unwrap_or_else(|err| panic!("assembly failed: {err}"))
}
