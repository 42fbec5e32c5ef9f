//! The Slurm commands the driver calls: `sbatch` to submit, `squeue` to follow, `scancel` to
//! stop. Their own configuration (`SLURM_CONF`, the cluster) comes from the environment.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

/// A job's (or an array task's) state as `squeue` reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct JobState {
    /// `PENDING`, `RUNNING`, `COMPLETED`, `FAILED`, `TIMEOUT`, `OUT_OF_MEMORY`, `CANCELLED`, …
    pub state: String,
    /// Why it waits or ended: `Dependency`, `DependencyNeverSatisfied`, `NonZeroExitCode`, …
    pub reason: String,
}

impl JobState {
    /// Ended, one way or another.
    pub fn is_terminal(&self) -> bool {
        !matches!(
            self.state.as_str(),
            "PENDING"
                | "RUNNING"
                | "CONFIGURING"
                | "COMPLETING"
                | "RESIZING"
                | "REQUEUED"
                | "REQUEUE_HOLD"
                | "REQUEUE_FED"
                | "SUSPENDED"
                | "STOPPED"
                | "SIGNALING"
                | "STAGE_OUT"
                | "RESV_DEL_HOLD"
        )
    }
}

fn run(program: &str, args: &[String]) -> Result<String, String> {
    let output = Command::new(program)
        .args(args)
        .output()
        .map_err(|err| format!("cannot run `{program}`: {err} (is Slurm installed here?)"))?;
    if !output.status.success() {
        return Err(format!(
            "`{program} {}` failed ({}): {}",
            args.join(" "),
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&output.stdout).into_owned())
}

/// Submits `script`; returns the job id (`sbatch --parsable` prints `id` or `id;cluster`).
pub fn sbatch(args: &[String], script: &Path) -> Result<String, String> {
    let mut all = args.to_vec();
    all.push(script.to_string_lossy().into_owned());
    let printed = run("sbatch", &all)?;
    let id = printed.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.bytes().all(|byte| byte.is_ascii_digit()) {
        return Err(format!("sbatch printed `{}`, not a job id", printed.trim()));
    }
    Ok(id)
}

/// The states of the user's jobs Slurm still knows, keyed `id` or `id_task` (array tasks).
pub fn states() -> Result<HashMap<String, JobState>, String> {
    let printed = run(
        "squeue",
        &[
            "--me".into(),
            "--noheader".into(),
            "--array".into(),
            "--states=all".into(),
            "--format=%i|%T|%r".into(),
        ],
    )?;
    Ok(parse_states(&printed))
}

pub fn parse_states(printed: &str) -> HashMap<String, JobState> {
    printed
        .lines()
        .filter_map(|line| {
            let mut fields = line.trim().split('|');
            let id = fields.next()?.to_string();
            let state = fields.next()?.to_string();
            let reason = fields.next().unwrap_or("").to_string();
            Some((id, JobState { state, reason }))
        })
        .collect()
}

/// Cancels jobs (whole arrays by their id).
pub fn scancel(ids: &[String]) -> Result<(), String> {
    if ids.is_empty() {
        return Ok(());
    }
    run("scancel", ids).map(drop)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_become_states_by_job_and_task() {
        let states = parse_states(
            "12_0|COMPLETED|None\n12_2|FAILED|NonZeroExitCode\n13|PENDING|Dependency\n\
             14_1|CANCELLED|DependencyNeverSatisfied\n",
        );
        assert_eq!(states.len(), 4);
        assert!(states["12_0"].is_terminal());
        assert_eq!(states["12_2"].reason, "NonZeroExitCode");
        assert!(!states["13"].is_terminal());
        assert_eq!(states["14_1"].state, "CANCELLED");
    }
}
