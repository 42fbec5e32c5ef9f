//! `squeal worker`: what a Slurm job runs. It settles one instance and whatever upstream of it
//! is not cached yet (instances the driver placed with it, never another job's: those ran
//! before it, by the job's dependencies), writes outputs to the shared cache only, and leaves a
//! status file for the driver. Its command line is [`WorkerInvocation`]: the driver writes it
//! into each job's script, and the job's `squeal` parses it back into the same fields.

use std::collections::HashMap;
use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::outcome::{InstanceOutcome, Status};
use crate::plan::Context;
use crate::run::{self, RunOptions};

/// The command line of `squeal worker`, after the program:
/// `--cache CACHE worker STUDY [--set STAGE.PARAM=VALUE]… --study-digest HEX --stage STAGE
/// --instances FILE --status PATTERN`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WorkerInvocation {
    /// The shared cache (the global `--cache`, before the subcommand); without it, the one
    /// beside the study.
    pub cache: Option<PathBuf>,
    /// The study file.
    pub study: PathBuf,
    /// The driver's `--set` overrides, as written.
    pub sets: Vec<String>,
    /// The blake3 of the study file when the job was submitted: a job refuses an edited study.
    pub study_digest: String,
    /// The instance's stage.
    pub stage: String,
    /// The submission's instance names; the task runs line SLURM_ARRAY_TASK_ID + 1.
    pub instances: PathBuf,
    /// Where to write the outcome; `{task}` stands for the task index.
    pub status: String,
}

impl WorkerInvocation {
    /// The arguments, in the order `squeal` takes them.
    pub fn to_args(&self) -> Vec<String> {
        let text = |path: &Path| path.to_string_lossy().into_owned();
        let mut args = Vec::new();
        if let Some(cache) = &self.cache {
            args.extend(["--cache".to_string(), text(cache)]);
        }
        args.extend(["worker".to_string(), text(&self.study)]);
        for set in &self.sets {
            args.extend(["--set".to_string(), set.clone()]);
        }
        args.extend([
            "--study-digest".to_string(),
            self.study_digest.clone(),
            "--stage".into(),
            self.stage.clone(),
            "--instances".into(),
            text(&self.instances),
            "--status".into(),
            self.status.clone(),
        ]);
        args
    }
}

/// What a task leaves for the driver: its instance's outcome.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TaskStatus {
    pub instance: String,
    /// `ran`, `cached`, `failed` or `skipped`.
    pub status: String,
    /// Why it failed or was skipped; empty otherwise.
    pub message: String,
    pub wall_s: f64,
}

/// The array index of this task (`SLURM_ARRAY_TASK_ID`), 0 for a job that is not an array.
pub fn task_index() -> Result<usize, String> {
    match std::env::var("SLURM_ARRAY_TASK_ID") {
        Err(_) => Ok(0),
        Ok(text) => text
            .parse()
            .map_err(|_| format!("SLURM_ARRAY_TASK_ID is `{text}`, not an index")),
    }
}

/// Line `task + 1` of the submission's instance list.
pub fn instance_of_task(list: &Path, task: usize) -> Result<String, String> {
    let text = std::fs::read_to_string(list)
        .map_err(|err| format!("reading {}: {err}", list.display()))?;
    text.lines()
        .nth(task)
        .map(str::to_string)
        .ok_or_else(|| format!("{} has no line for task {task}", list.display()))
}

/// The status file of `task`, from a pattern with `{task}`.
pub fn status_path(pattern: &str, task: usize) -> PathBuf {
    PathBuf::from(pattern.replace("{task}", &task.to_string()))
}

/// Settles instance `target` and its uncached upstream, with `jobs` threads; the target's
/// outcome.
pub fn run_instance(
    context: &Context,
    target: usize,
    jobs: Option<usize>,
) -> io::Result<TaskStatus> {
    let list = &context.instances.list;
    let mut select = vec![false; list.len()];
    select[target] = true;
    // Instances come upstream first: one sweep down from the target closes the set.
    for idx in (0..=target).rev() {
        if select[idx] {
            for input in &list[idx].inputs {
                for &up in &input.from {
                    select[up] = true;
                }
            }
        }
    }
    let options = RunOptions {
        jobs,
        out_dir: None,
        progress: false,
        select: Some(select),
        ran_elsewhere: HashMap::new(),
    };
    let report = run::run(context, &options, None)?;
    let own = report
        .instances
        .iter()
        .find(|report| report.name == list[target].name)
        .expect("the target is selected");
    let mut status = TaskStatus::of(own);
    if let Status::Skipped(_) = own.status {
        // Name the failure upstream, which happened in this job.
        if let Some(failed) = report
            .instances
            .iter()
            .find_map(|report| match &report.status {
                Status::Failed(message) => Some(format!("`{}` failed: {message}", report.name)),
                _ => None,
            })
        {
            status.message = failed;
        }
    }
    Ok(status)
}

impl TaskStatus {
    pub fn of(report: &InstanceOutcome) -> TaskStatus {
        let message = match &report.status {
            Status::Ran | Status::Cached => String::new(),
            Status::Failed(message) => message.clone(),
            Status::Skipped(upstream) => format!("`{upstream}` did not complete"),
        };
        TaskStatus {
            instance: report.name.clone(),
            status: report.status.label().into(),
            message,
            wall_s: report.wall_s,
        }
    }

    pub fn succeeded(&self) -> bool {
        matches!(self.status.as_str(), "ran" | "cached")
    }

    pub fn write(&self, path: &Path) -> io::Result<()> {
        crate::output::write_atomic(path, &serde_json::to_vec_pretty(self).expect("serialises"))
    }

    pub fn read(path: &Path) -> Option<TaskStatus> {
        serde_json::from_slice(&std::fs::read(path).ok()?).ok()
    }
}
