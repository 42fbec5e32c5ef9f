//! `squeal report`: one self-contained HTML page of the study's last run.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use squeal_engine::Registry;

use crate::cli::StudyArgs;

pub fn report(
    registry: &Registry,
    cache: Option<&Path>,
    args: &StudyArgs,
    out: Option<PathBuf>,
    page: Option<PathBuf>,
) -> Result<ExitCode> {
    let bench = super::open(registry, cache, args)?;
    let path = bench.report(out, page, env!("CARGO_PKG_VERSION"))?;
    println!("{}", path.display());
    Ok(ExitCode::SUCCESS)
}
