//! The science of squeal, and the contract every stage implements.
//!
//! This crate knows nothing of YAML, DAGs, caches or files: a stage is a pure function of its
//! parameters and its input artifacts ([`stage::Stage::run`]). The one exception is
//! `signal.read` ([`signal::read`]), which reads a user's Parquet or CSV file and therefore
//! declares itself impure, so the engine never caches it. The engine finds stages through the
//! registry the binary builds from [`all_kinds`].

#![allow(non_snake_case)]
// matrices are named as in the equations: M, K, C
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod artifact;
pub mod assemble;
pub mod basis;
pub mod check;
pub mod complex_modes;
pub mod contact;
pub mod equilibrium;
pub mod export;
pub mod fem;
pub mod mesh;

pub mod modes;
pub mod plot;
pub mod signal;
pub mod stability;
pub mod stage;
pub mod table;
pub mod testing;
pub mod transient;
pub mod vtu;

use std::sync::Arc;

pub use artifact::{Artifact, ArtifactType, Document, Figure};
pub use squeal_linalg::{fix_global_parallelism, numeric_platform};
pub use stage::{
    Arity, Checkpoints, Coords, Input, Inputs, NoCheckpoints, Outputs, ParamSpec, ParamType,
    Params, Placement, PortSpec, Progress, Resources, RunContext, Stage, StageError, Value,
};
pub use table::{Column, ColumnData, Table};

/// Every production stage kind, in the order `squeal stages` lists them.
pub fn all_kinds() -> Vec<Arc<dyn Stage>> {
    let mut kinds: Vec<Arc<dyn Stage>> = vec![
        Arc::new(mesh::brake::MeshBrake),
        Arc::new(mesh::gmsh::GmshImport),
        Arc::new(mesh::abaqus::AbaqusImport),
        Arc::new(assemble::Assemble),
        Arc::new(modes::Modes),
        Arc::new(equilibrium::SlidingEquilibrium),
        Arc::new(stability::Stability),
        Arc::new(stability::track::Track),
        Arc::new(stability::lumped::StabilityMatrices),
        Arc::new(basis::ReductionBasis),
        Arc::new(basis::pareto::Pareto),
        Arc::new(transient::Transient),
        Arc::new(export::vtu::MeshVtu),
        Arc::new(export::vtu::ModesVtu),
        Arc::new(export::matrix_market::MatrixMarket),
        Arc::new(table::Gather),
        Arc::new(check::Check),
    ];
    kinds.extend(signal::kinds());
    kinds
}

/// Stage kinds for exercising the engine (constant sources, arithmetic, sleeps, failures).
/// They are registered only when a test asks for them.
pub fn test_kinds() -> Vec<Arc<dyn Stage>> {
    testing::kinds()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value of the declared type for a parameter without a default.
    fn placeholder(spec: &ParamSpec) -> Value {
        match &spec.ty {
            ParamType::Bool => Value::Bool(false),
            ParamType::Int { min } => Value::Int((*min).max(1)),
            ParamType::Float { min } => Value::Float(min.max(1.0)),
            ParamType::Str | ParamType::List | ParamType::Path => {
                Value::Str("placeholder".to_string())
            }
            ParamType::Choice(names) => Value::Str(names[0].to_string()),
        }
    }

    #[test]
    fn every_stage_reads_its_declared_parameters_into_its_typed_struct() {
        for kind in all_kinds().into_iter().chain(test_kinds()) {
            let params = Params(
                kind.params()
                    .iter()
                    .map(|spec| {
                        let value = spec.default.clone().unwrap_or_else(|| placeholder(spec));
                        (spec.name.to_string(), value)
                    })
                    .collect(),
            );
            if let Err(err) = kind.check_params(&params) {
                panic!("{}: {err}", kind.kind());
            }
        }
    }
}
