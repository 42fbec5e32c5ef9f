//! The contract every stage implements and the engine runs: what a stage is ([`stage::Stage`]),
//! the parameters it declares once ([`params`]), the values that flow between stages
//! ([`artifact`], [`table`]) and a stage's errors ([`value`]).
//!
//! A crate of its own so that the engine is built against the contract, not the science:
//! editing a stage rebuilds the stages and the binary, never the engine. In layers: value →
//! table → artifact → params → stage (a module imports only from the layers before it).

#![allow(non_snake_case)]
// matrices are named as in the equations: M, K, C
// `!(x > 0.0)` is how numerical checks reject NaN together with x <= 0.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod artifact;
pub mod params;
pub mod stage;
pub mod table;
pub mod value;

pub use artifact::{Artifact, ArtifactType, Document, Figure};
pub use params::{DeclaredParams, HasParams, ParamSpec, ParamType, Params};
pub use stage::{
    Arity, Checkpoints, Input, Inputs, NoCheckpoints, Outputs, Placement, PortSpec, Progress,
    Resources, RunContext, Stage,
};
pub use table::{Column, ColumnData, Table};
pub use value::{Coords, StageError, Value};
