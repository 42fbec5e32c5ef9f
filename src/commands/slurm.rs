//! `squeal run --executor slurm`: the driver of a run whose long stages are Slurm jobs.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Result;
use squeal_engine::Registry;

use super::run::{exit_code, print_summary};
use crate::cli::{SlurmArgs, StudyArgs};

pub fn run_slurm(
    registry: &Registry,
    cache: Option<&Path>,
    args: &StudyArgs,
    out: Option<PathBuf>,
    jobs: Option<usize>,
    slurm: &SlurmArgs,
) -> Result<ExitCode> {
    let settings = slurm.settings();
    settings.check()?;
    let bench = super::open(registry, cache, args)?;
    let out_dir = bench.out_dir(out)?;
    if slurm.dry_run {
        print!("{}", bench.slurm_dry_run(&out_dir, jobs, &settings)?);
        return Ok(ExitCode::SUCCESS);
    }
    // A first Ctrl-C (or SIGTERM) cancels the jobs and writes what finished; a second one
    // exits at once.
    let interrupted = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, interrupted.clone())?;
        signal_hook::flag::register(signal, interrupted.clone())?;
    }
    let run = bench.run_slurm(&out_dir, jobs, &settings, interrupted)?;
    eprintln!(
        "slurm: submitted {}; scripts and logs in {}",
        run.submitted,
        run.dir.display()
    );
    print_summary(bench.study(), &run.outcome, &out_dir);
    Ok(exit_code(&run.outcome))
}
