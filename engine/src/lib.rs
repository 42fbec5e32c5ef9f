//! The engine: study files → validated DAG → plan → parallel, cached execution → Parquet.
//!
//! It knows nothing of brakes: stages come from a [`Registry`] the binary fills, and only the
//! stage contract of `squeal-stages` is used here. Only this crate and `squeal-cache` touch
//! the file system.
//!
//! The command line goes through one door, [`Workbench`]: a study opened with its arguments,
//! which plans, runs (here or on Slurm), reports, names the cache entries it uses, and serves
//! as a Slurm job's worker. The modules are layered, each importing only from those listed
//! before it (ARCHITECTURE.md has the table; `tests/layering.rs` keeps the files free of
//! import cycles).

mod spec;
mod units;

mod checkpoint;
mod key;
mod output;
mod record;

mod ports;
mod resources;

mod study;

mod instances;

mod plan;

mod manifest;
mod outcome;

mod run;

mod dag;
mod report;
mod slurm;

mod workbench;

// What the binary uses.
pub use dag::Format as DagFormat;
pub use instances::Instances;
pub use outcome::{InstanceOutcome, RunOutcome, Status};
pub use plan::{Decision, PlanLine};
pub use ports::compute_time_port;
pub use resources::JobDefaults;
pub use slurm::Submitted;
pub use slurm::worker::{TaskStatus, WorkerInvocation};
pub use spec::{Location, SpecError};
pub use study::{Registry, Study};
pub use workbench::{Error, SlurmArgs, SlurmOutcome, Workbench};

// The layers under the workbench, for the engine's integration tests and benchmarks.
pub use plan::{Context, plan};
pub use record::RunRecord;
pub use run::{RunOptions, run};
pub use study::Override;
