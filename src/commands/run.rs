//! `squeal run` on this machine, and the summary every run prints.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use squeal_engine::{Registry, RunOutcome, Status, Study};

use crate::cli::StudyArgs;

pub fn run_local(
    registry: &Registry,
    cache: Option<&Path>,
    args: &StudyArgs,
    out: Option<PathBuf>,
    jobs: Option<usize>,
) -> Result<ExitCode> {
    let bench = super::open(registry, cache, args)?;
    let out_dir = bench.out_dir(out)?;
    let outcome = bench.run(&out_dir, jobs)?;
    print_summary(bench.study(), &outcome, &out_dir);
    Ok(exit_code(&outcome))
}

/// One line per instance that did not come from the cache, then the totals.
pub fn print_summary(study: &Study, outcome: &RunOutcome, out_dir: &Path) {
    for instance in &outcome.instances {
        match &instance.status {
            Status::Ran => eprintln!(
                "ran     {} ({}) in {:.3} s",
                instance.name,
                instance.reasons.join("; "),
                instance.wall_s
            ),
            Status::Cached => {}
            Status::Failed(message) => eprintln!("FAILED  {}: {message}", instance.name),
            Status::Skipped(upstream) => {
                eprintln!("skipped {}: `{upstream}` did not complete", instance.name)
            }
        }
    }
    eprintln!(
        "{}: {} instances in {:.2} s: {} ran, {} cached, {} failed, {} skipped; outputs in {}",
        study.name,
        outcome.instances.len(),
        outcome.wall_s,
        outcome.count("ran"),
        outcome.count("cached"),
        outcome.count("failed"),
        outcome.count("skipped"),
        out_dir.display()
    );
}

/// 0 when every instance ran or was cached, 1 otherwise.
pub fn exit_code(outcome: &RunOutcome) -> ExitCode {
    if outcome.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
