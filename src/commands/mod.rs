//! One file per command: each opens the study through the engine's [`Workbench`], prints what
//! it did, and returns the exit code.

pub mod cache;
pub mod dag;
pub mod plan;
pub mod report;
pub mod run;
pub mod slurm;
pub mod stages;
pub mod validate;
pub mod worker;

use std::path::Path;

use squeal_engine::{Error, Registry, Workbench};

use crate::cli::StudyArgs;

/// The study of `args`, with the cache `cache` (`--cache`) or the one beside it.
fn open(registry: &Registry, cache: Option<&Path>, args: &StudyArgs) -> Result<Workbench, Error> {
    Workbench::open(registry, &args.study, &args.set, &args.targets, cache)
}
