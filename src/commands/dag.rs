//! `squeal dag`: the DAG of stage instances, as Graphviz dot or Mermaid.

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;
use squeal_engine::Registry;

use crate::cli::{DagFormat, StudyArgs};

pub fn dag(
    registry: &Registry,
    cache: Option<&Path>,
    args: &StudyArgs,
    format: DagFormat,
) -> Result<ExitCode> {
    print!("{}", super::open(registry, cache, args)?.dag(format.into()));
    Ok(ExitCode::SUCCESS)
}
