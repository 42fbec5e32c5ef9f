//! The science of squeal gathered into one registry: every stage kind, under one path per
//! science module.
//!
//! The stages live in crates bounded by what they build on, so that an edit rebuilds only its
//! own crate and the binary: `squeal-fem` (element kernels, faces, VTU cells) and `squeal-plot`
//! (figures) under `squeal-model` (meshes, materials, assembly, real modes, exports),
//! `squeal-dynamics` (contact, equilibrium, stability, bases, transient) and `squeal-signal`
//! (wavelet, spectrum, SVD projection, comparison). This crate re-exports them as
//! `squeal_stages::mesh`, `squeal_stages::transient`, … and holds the stages that gather and
//! check sweeps and the engine's test kinds.
//!
//! No crate here knows YAML, DAGs, caches or files: a stage is a pure function of its
//! parameters and its input artifacts ([`stage::Stage::run`]). The one exception is
//! `signal.read` ([`signal::read`]), which reads a user's Parquet or CSV file and therefore
//! declares itself impure, so the engine never caches it. The engine finds stages through the
//! registry the binary builds from [`all_kinds`].

// The stage contract (its own crate, `squeal-contract`), under the names the stages use.
pub use squeal_contract::{artifact, choice, params, stage, stage_params, table, value};

// Shared kernels and formats.
pub use squeal_dynamics::contact;
pub use squeal_fem::{self as fem, vtu_writer};
pub use squeal_plot as plot;

// The stages: mesh → assemble → modes, equilibrium → stability → basis → transient → signal,
// exports, and the stages that gather and check sweeps.
pub use squeal_dynamics::{basis, equilibrium, stability, transient};
pub use squeal_model::{assemble, export, material, mesh, modes};
pub use squeal_signal as signal;

pub mod check;
pub mod gather;

// Stage kinds for exercising the engine.
pub mod test_kinds;

use std::sync::Arc;

pub use squeal_contract::{
    Arity, Artifact, ArtifactType, Checkpoints, Column, ColumnData, Coords, DeclaredParams,
    Document, Figure, HasParams, Input, Inputs, NoCheckpoints, Outputs, ParamSpec, ParamType,
    Params, Placement, PortSpec, Progress, Resources, RunContext, Stage, StageError, Table, Value,
};
pub use squeal_linalg::{fix_global_parallelism, numeric_platform};

/// Every production stage kind, in the order `squeal stages` lists them.
pub fn all_kinds() -> Vec<Arc<dyn Stage>> {
    let mut kinds: Vec<Arc<dyn Stage>> = vec![
        Arc::new(mesh::brake::MeshBrake),
        Arc::new(mesh::gmsh::GmshImport),
        Arc::new(mesh::cad::MeshCad),
        Arc::new(mesh::abaqus::AbaqusImport),
        Arc::new(mesh::nastran::NastranImport),
        Arc::new(mesh::mortar_pairs::ContactMortar),
        Arc::new(material::Isotropic),
        Arc::new(material::TransverselyIsotropic),
        Arc::new(material::Orthotropic),
        Arc::new(assemble::Assemble),
        Arc::new(modes::Modes),
        Arc::new(equilibrium::SlidingEquilibrium),
        Arc::new(stability::Stability),
        Arc::new(stability::track::Track),
        Arc::new(stability::matrices::StabilityMatrices),
        Arc::new(basis::ReductionBasis),
        Arc::new(basis::pareto::Pareto),
        Arc::new(transient::Transient),
        Arc::new(transient::lumped::TransientMatrices),
        Arc::new(export::vtu::MeshVtu),
        Arc::new(export::vtu::ModesVtu),
        Arc::new(export::matrix_market::MatrixMarket),
        Arc::new(gather::Gather),
        Arc::new(check::Check),
    ];
    kinds.extend(signal::kinds());
    kinds
}

/// Stage kinds for exercising the engine (constant sources, arithmetic, sleeps, failures).
/// They are registered only when a test asks for them.
pub fn test_kinds() -> Vec<Arc<dyn Stage>> {
    test_kinds::kinds()
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

    /// Every declared parameter at its default, or at a placeholder of its type.
    fn defaults_of(kind: &dyn Stage) -> Params {
        Params(
            kind.params()
                .iter()
                .map(|spec| {
                    let value = spec.default.clone().unwrap_or_else(|| placeholder(spec));
                    (spec.name.to_string(), value)
                })
                .collect(),
        )
    }

    #[test]
    fn every_stage_reads_its_declared_parameters_into_its_typed_struct() {
        for kind in all_kinds().into_iter().chain(test_kinds()) {
            let params = defaults_of(kind.as_ref());
            if let Err(err) = kind.read_params(&params) {
                panic!("{}: {err}", kind.kind());
            }
        }
    }

    /// A choice is an enum the stage matches on without a catch-all arm, so a choice that reads
    /// into its own variant reaches its own code. This walks every choice of every stage kind
    /// and shows that no two names of one parameter read into the same typed parameters (no
    /// choice is an alias of another, nor falls through to a default), and that every default
    /// is one of its choices.
    #[test]
    fn every_declared_choice_reads_into_a_value_of_its_own() {
        let mut n_choices = 0;
        for kind in all_kinds().into_iter().chain(test_kinds()) {
            let base = defaults_of(kind.as_ref());
            for spec in kind.params() {
                let ParamType::Choice(names) = spec.ty else {
                    continue;
                };
                let default = spec.default.as_ref().map(ToString::to_string);
                assert!(
                    default.as_deref().is_none_or(|name| names.contains(&name)),
                    "{}.{}: the default {default:?} is not a choice",
                    kind.kind(),
                    spec.name
                );
                let read: Vec<String> = names
                    .iter()
                    .map(|name| {
                        let mut params = base.clone();
                        params
                            .0
                            .insert(spec.name.into(), Value::Str(name.to_string()));
                        let typed = kind.read_params(&params).unwrap_or_else(|err| {
                            panic!("{}.{} = {name}: {err}", kind.kind(), spec.name)
                        });
                        format!("{typed:?}")
                    })
                    .collect();
                for (a, b) in
                    (0..names.len()).flat_map(|a| (a + 1..names.len()).map(move |b| (a, b)))
                {
                    assert_ne!(
                        read[a],
                        read[b],
                        "{}.{}: `{}` and `{}` read the same",
                        kind.kind(),
                        spec.name,
                        names[a],
                        names[b]
                    );
                }
                n_choices += names.len();
            }
        }
        assert!(n_choices >= 20, "only {n_choices} choices found");
    }
}
