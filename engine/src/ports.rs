//! The outputs every stage has besides those it declares. The study validates references
//! against them, the scheduler produces them, the manifest and the export leave them out of
//! `out/`, and `squeal stages` names them.

use squeal_contract::{ArtifactType, PortSpec, Stage};

/// The output every stage has besides those it declares: a one-row table, column
/// `compute_s`, of the seconds the instance took to compute its outputs (in this run, or when
/// the cached outputs were computed). A study wires it like any output to put run time beside
/// results (run time against error); downstream reruns only when the instance reruns.
pub const COMPUTE_TIME_OUTPUT: &str = "compute_s";

/// The `compute_s` output as a port.
pub fn compute_time_port() -> PortSpec {
    PortSpec::one(
        COMPUTE_TIME_OUTPUT,
        ArtifactType::Table,
        "seconds the instance took to compute its outputs",
    )
}

/// The outputs the engine adds to every stage.
pub fn implicit_outputs() -> [PortSpec; 1] {
    [compute_time_port()]
}

/// Whether `name` is one of the [`implicit_outputs`].
pub fn is_implicit(name: &str) -> bool {
    implicit_outputs().iter().any(|port| port.name == name)
}

/// A stage's outputs: those it declares, then the implicit ones.
pub fn outputs_of(stage: &dyn Stage) -> impl Iterator<Item = PortSpec> {
    stage.outputs().into_iter().chain(implicit_outputs())
}
