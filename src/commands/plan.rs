//! `squeal plan`: for each stage instance, whether it is cached or why it runs.

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;
use squeal_engine::{Decision, Registry};

use crate::cli::StudyArgs;

pub fn plan(registry: &Registry, cache: Option<&Path>, args: &StudyArgs) -> Result<ExitCode> {
    let lines = super::open(registry, cache, args)?.plan()?;
    let width = lines
        .iter()
        .map(|line| line.instance.len())
        .max()
        .unwrap_or(0);
    for line in &lines {
        println!("{:width$}  {}", line.instance, line.decision.describe());
    }
    let cached = lines
        .iter()
        .filter(|line| matches!(line.decision, Decision::Cached { .. }))
        .count();
    println!(
        "{} instances: {} cached, {} to run",
        lines.len(),
        cached,
        lines.len() - cached
    );
    Ok(ExitCode::SUCCESS)
}
