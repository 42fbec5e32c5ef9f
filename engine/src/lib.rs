//! The engine: study files → validated DAG → plan → parallel, cached execution → Parquet.
//!
//! It knows nothing of brakes: stages come from a [`Registry`] the binary fills, and only the
//! stage contract of `squeal-stages` is used here. Only this crate and `squeal-cache` touch
//! the file system.

pub mod checkpoint;
pub mod dag;
pub mod instances;
pub mod key;
pub mod manifest;
pub mod outcome;
pub mod output;
pub mod plan;
pub mod ports;
pub mod record;
pub mod report;
pub mod resources;
pub mod run;
pub mod slurm;
pub mod spec;
pub mod study;
pub mod units;

pub use instances::Instances;
pub use outcome::{InstanceOutcome, RunOutcome, Status};
pub use plan::{Context, Decision, PlanLine};
pub use run::RunOptions;
pub use spec::SpecError;
pub use study::{Override, Registry, Study};
