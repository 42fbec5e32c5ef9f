//! `squeal worker`: one stage instance inside a Slurm job, as `run --executor slurm` submits it.

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;
use squeal_engine::{Registry, Workbench};

use crate::cli::WorkerArgs;

pub fn worker(registry: &Registry, cache: Option<&Path>, args: &WorkerArgs) -> Result<ExitCode> {
    let invocation = args.invocation(cache.map(Path::to_path_buf));
    let status = Workbench::work(registry, &invocation, args.jobs)?;
    if status.succeeded() {
        eprintln!(
            "{}: {} in {:.3} s",
            status.instance, status.status, status.wall_s
        );
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "error: {} {}: {}",
            status.instance, status.status, status.message
        );
        Ok(ExitCode::FAILURE)
    }
}
