//! `squeal validate`: check a study without running anything.

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;
use squeal_engine::Registry;

use crate::cli::StudyArgs;

pub fn validate(registry: &Registry, cache: Option<&Path>, args: &StudyArgs) -> Result<ExitCode> {
    let bench = super::open(registry, cache, args)?;
    println!(
        "{}: ok ({} stages, {} instances for the targets)",
        bench.study().file,
        bench.study().stages.len(),
        bench.instances().list.len()
    );
    Ok(ExitCode::SUCCESS)
}
