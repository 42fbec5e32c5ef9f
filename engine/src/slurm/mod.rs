//! The Slurm executor: the same plan, cache and outputs as a local run, with the minutes of
//! work spread over a cluster's jobs.
//!
//! A run goes in three steps, all from the driver (`squeal run --executor slurm`):
//!
//! 1. **The driver's share before the jobs.** Each stage kind has a placement
//!    ([`squeal_contract::Placement`]): stages that take seconds (meshes, assembly, gathers,
//!    figures, exports, and on the default brake the real modes and the equilibrium) run in the
//!    driver, because a job costs about a second of scheduling alone; stages that take minutes
//!    (stability, transient, bases) become jobs. A study moves a stage with `resources: { placement: driver | job }`.
//!    What runs in the driver and needs no job's result runs first, on the driver's cores.
//! 2. **The jobs.** The plan is made again; every job instance that is not cached is submitted
//!    ([`submit`]: a stage's instances as one job array, dependencies as `afterok` or
//!    `aftercorr`, `--kill-on-invalid-dep`). Each job runs `squeal worker`, which settles its
//!    instance (and a driver-placed instance between two jobs, which it needs and nobody else
//!    computes) and writes to the shared cache only. The driver follows them with `squeue`,
//!    shows progress, and on Ctrl-C cancels what it submitted.
//! 3. **The driver's share after the jobs.** A local run of the whole study: the jobs' results
//!    are cached, the driver-placed stages downstream of them run, and the outputs, manifest
//!    and run record are written exactly as a local run writes them. A failed job's instance
//!    fails with its Slurm state and the end of its stderr; its dependents are skipped.
//!
//! A rerun submits only what is not cached: a job that failed, was cancelled or timed out.
//!
//! The cache must be on a file system every node sees, with the study and the `squeal` binary.
//! Concurrent jobs write to it safely: objects and action records are written to a temporary
//! file and renamed into place, which is atomic on NFS too; two jobs computing the same entry
//! write the same bytes. The shared lock that keeps `cache gc` out of a running study is an
//! `flock`, which NFS (v4, or v3 with `lockd`) maps to byte-range locks; on a file system
//! without working locks, do not run `cache gc` while jobs run.

pub mod client;
pub mod requests;
pub mod submit;
pub mod worker;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use squeal_contract::Placement;

use crate::outcome::{Elsewhere, RunOutcome, Status};
use crate::plan::{self, Context, Decision};
use crate::resources::JobDefaults;
use crate::run::{self, RunOptions};
use client::JobState;
use requests::JobRequest;
use submit::{Files, Submission};
use worker::{TaskStatus, WorkerInvocation};

/// How the driver runs a study on Slurm.
#[derive(Debug, Clone)]
pub struct SlurmOptions {
    /// Requests from the command line, over the study's `slurm:` section.
    pub defaults: JobDefaults,
    /// The `squeal` binary the jobs run.
    pub program: PathBuf,
    /// The command line of every job's worker; `stage`, `instances` and `status` are each
    /// submission's own.
    pub worker: WorkerInvocation,
    /// Where the run's scripts, instance lists, logs and status files go; on the shared file
    /// system.
    pub dir: PathBuf,
    /// The driver's threads (its own share of the stages).
    pub jobs: Option<usize>,
    pub out_dir: PathBuf,
    pub progress: bool,
    /// Seconds between two `squeue`.
    pub poll: Duration,
    /// Set by Ctrl-C (SIGINT) or SIGTERM: cancel the jobs, write what finished.
    pub interrupted: Arc<AtomicBool>,
}

/// What a run submitted, for the summary: `2 jobs (8 tasks)`.
#[derive(Debug, Clone, Default)]
pub struct Submitted {
    pub jobs: usize,
    pub tasks: usize,
}

impl std::fmt::Display for Submitted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({})",
            count(self.jobs, "job"),
            count(self.tasks, "task")
        )
    }
}

/// Each stage's request, all sources merged.
fn stage_requests(context: &Context, defaults: &JobDefaults) -> Vec<JobRequest> {
    let defaults = context.study.slurm.overlaid(defaults);
    context
        .study
        .stages
        .iter()
        .map(|decl| requests::request(decl.stage.as_ref(), &decl.resources, &defaults))
        .collect()
}

/// Which instances become jobs: those the plan runs whose stage is placed in a job, unless
/// `blocked` (downstream of a failure).
fn job_instances(
    context: &Context,
    lines: &[plan::PlanLine],
    requests: &[JobRequest],
    blocked: &[bool],
) -> Vec<bool> {
    context
        .instances
        .list
        .iter()
        .zip(lines)
        .enumerate()
        .map(|(idx, (instance, line))| {
            matches!(line.decision, Decision::Runs { .. })
                && requests[instance.stage].placement == Placement::Job
                && !blocked[idx]
        })
        .collect()
}

/// Instances with a job upstream (or that are jobs): `select` for the driver's first share is
/// the rest.
fn after_a_job(context: &Context, job: &[bool]) -> Vec<bool> {
    let list = &context.instances.list;
    let mut after = job.to_vec();
    for idx in 0..list.len() {
        let upstream_job = list[idx]
            .inputs
            .iter()
            .flat_map(|input| &input.from)
            .any(|&up| after[up]);
        after[idx] |= upstream_job;
    }
    after
}

/// Runs the study on Slurm; the report of the final local pass, with the jobs' instances as
/// ran or failed.
pub fn run(
    context: &Context,
    options: &SlurmOptions,
    record_path: &Path,
) -> Result<(RunOutcome, Submitted), String> {
    let started = Instant::now();
    let requests = stage_requests(context, &options.defaults);
    let n = context.instances.list.len();
    let mut ran_elsewhere: HashMap<usize, Elsewhere> = HashMap::new();

    // 1. The driver's share that needs no job.
    let no_block = vec![false; n];
    let job = job_instances(context, &plan::plan(context), &requests, &no_block);
    let before: Vec<bool> = after_a_job(context, &job)
        .into_iter()
        .map(|after| !after)
        .collect();
    let mut known = vec![None; n];
    let mut blocked = vec![false; n];
    if before.iter().any(|&selected| selected) {
        let first = run::run(
            context,
            &RunOptions {
                jobs: options.jobs,
                out_dir: None,
                progress: options.progress,
                select: Some(before.clone()),
                ran_elsewhere: HashMap::new(),
            },
            None,
        )
        .map_err(|err| err.to_string())?;
        let index_of: HashMap<&str, usize> = context
            .instances
            .list
            .iter()
            .enumerate()
            .map(|(idx, instance)| (instance.name.as_str(), idx))
            .collect();
        for report in &first.instances {
            let idx = index_of[report.name.as_str()];
            let pure = context.study.stages[context.instances.list[idx].stage]
                .stage
                .pure();
            match &report.status {
                Status::Ran | Status::Cached => known[idx] = Some(report.outputs.clone()),
                Status::Failed(message) => {
                    blocked[idx] = true;
                    ran_elsewhere.insert(idx, Elsewhere::Failed(message.clone()));
                }
                Status::Skipped(_) => blocked[idx] = true,
            }
            if report.status == Status::Ran && pure {
                ran_elsewhere.insert(
                    idx,
                    Elsewhere::Ran {
                        wall_s: report.wall_s,
                        why: report.reasons.join("; "),
                    },
                );
            }
        }
    }
    for idx in 0..n {
        if context.instances.list[idx]
            .inputs
            .iter()
            .flat_map(|input| &input.from)
            .any(|&up| blocked[up])
        {
            blocked[idx] = true;
        }
    }

    // 2. The jobs.
    let lines = plan::plan_knowing(context, known);
    let job = job_instances(context, &lines, &requests, &blocked);
    let submissions = submit::group(context.instances, &job);
    let mut submitted = Submitted::default();
    if !submissions.is_empty() {
        std::fs::create_dir_all(&options.dir)
            .map_err(|err| format!("creating {}: {err}", options.dir.display()))?;
        let jobs = submit_all(context, options, &requests, &submissions)?;
        submitted = Submitted {
            jobs: jobs.len(),
            tasks: submissions.iter().map(|s| s.instances.len()).sum(),
        };
        let outcomes = follow(options, &requests, &submissions, &jobs)?;
        ran_elsewhere.extend(outcomes);
    }

    // 3. The driver's share after the jobs, and every output.
    let mut report = run::run(
        context,
        &RunOptions {
            jobs: options.jobs,
            out_dir: Some(options.out_dir.clone()),
            progress: options.progress,
            select: None,
            ran_elsewhere,
        },
        Some(record_path),
    )
    .map_err(|err| format!("the final local pass: {err}"))?;
    report.wall_s = started.elapsed().as_secs_f64();
    Ok((report, submitted))
}

/// One submitted job (or array): its id and files.
struct Job {
    id: String,
    files: Files,
}

impl Job {
    /// `squeue`'s name of task `task` of submission `submission`.
    fn task_id(&self, submission: &Submission, task: usize) -> String {
        if submission.is_array() {
            format!("{}_{task}", self.id)
        } else {
            self.id.clone()
        }
    }
}

/// The `sbatch` arguments (before the script) of a submission.
fn sbatch_args(request: &JobRequest, dependency: Option<String>) -> Vec<String> {
    let mut args = vec!["--parsable".to_string()];
    if let Some(dependency) = dependency {
        args.push(format!("--dependency={dependency}"));
        args.push("--kill-on-invalid-dep=yes".into());
    }
    args.extend(request.sbatch_args.iter().cloned());
    args
}

/// The command a submission's jobs run: the program, then the worker's arguments.
fn worker_command(options: &SlurmOptions, stage: &str, files: &Files) -> Vec<String> {
    let invocation = WorkerInvocation {
        stage: stage.into(),
        instances: files.instances.clone(),
        status: files.status.to_string_lossy().into_owned(),
        ..options.worker.clone()
    };
    std::iter::once(options.program.to_string_lossy().into_owned())
        .chain(invocation.to_args())
        .collect()
}

/// The script, instance list and files of submission `number`.
fn prepare(
    context: &Context,
    options: &SlurmOptions,
    requests: &[JobRequest],
    number: usize,
    submission: &Submission,
) -> (Files, String, String) {
    let stage = &context.study.stages[submission.stage].name;
    let files = Files::new(&options.dir, number, stage, submission.is_array());
    let worker = worker_command(options, stage, &files);
    let script = submit::script(&submit::ScriptInput {
        job_name: &format!("squeal.{}.{stage}", context.study.name),
        files: &files,
        tasks: submission.instances.len(),
        request: &requests[submission.stage],
        worker: &worker,
    });
    let list: String = submission
        .instances
        .iter()
        .map(|&idx| format!("{}\n", context.instances.list[idx].name))
        .collect();
    (files, script, list)
}

/// Writes each script and submits it, upstream first; on an `sbatch` error, cancels what was
/// submitted.
fn submit_all(
    context: &Context,
    options: &SlurmOptions,
    requests: &[JobRequest],
    submissions: &[Submission],
) -> Result<Vec<Job>, String> {
    let mut jobs: Vec<Job> = Vec::with_capacity(submissions.len());
    for (number, submission) in submissions.iter().enumerate() {
        let (files, script, list) = prepare(context, options, requests, number + 1, submission);
        let write = |path: &Path, text: &str| {
            crate::output::write_atomic(path, text.as_bytes())
                .map_err(|err| format!("writing {}: {err}", path.display()))
        };
        let ids: Vec<String> = jobs.iter().map(|job| job.id.clone()).collect();
        let args = sbatch_args(
            &requests[submission.stage],
            submit::dependency(&submission.after, &ids),
        );
        let result = write(&files.instances, &list)
            .and_then(|()| write(&files.script, &script))
            .and_then(|()| client::sbatch(&args, &files.script));
        match result {
            Ok(id) => {
                tracing::info!(
                    stage = %context.study.stages[submission.stage].name,
                    "submitted job {id} ({} tasks)",
                    submission.instances.len()
                );
                jobs.push(Job { id, files });
            }
            Err(message) => {
                let _ = client::scancel(&ids);
                return Err(format!(
                    "submitting `{}`: {message}{}",
                    context.study.stages[submission.stage].name,
                    if ids.is_empty() {
                        String::new()
                    } else {
                        format!(
                            " (cancelled the {} submitted before)",
                            count(ids.len(), "job")
                        )
                    }
                ));
            }
        }
    }
    Ok(jobs)
}

/// A task's end, as the driver saw it.
enum End {
    Slurm(JobState),
    /// Slurm no longer lists it; its status file, if it wrote one, says how it ended.
    Forgotten,
    Interrupted,
}

/// Follows the jobs to their end; each instance's outcome.
fn follow(
    options: &SlurmOptions,
    requests: &[JobRequest],
    submissions: &[Submission],
    jobs: &[Job],
) -> Result<HashMap<usize, Elsewhere>, String> {
    let tasks: Vec<(usize, usize)> = submissions
        .iter()
        .enumerate()
        .flat_map(|(s, submission)| (0..submission.instances.len()).map(move |t| (s, t)))
        .collect();
    let bar = if options.progress {
        ProgressBar::with_draw_target(Some(tasks.len() as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} slurm: {wide_msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let mut ends: Vec<Option<End>> = (0..tasks.len()).map(|_| None).collect();
    let mut seen = vec![false; tasks.len()];
    let mut squeue_failures = 0;
    loop {
        if options.interrupted.load(Ordering::SeqCst) {
            let ids: Vec<String> = jobs.iter().map(|job| job.id.clone()).collect();
            client::scancel(&ids).map_err(|err| format!("cancelling the jobs: {err}"))?;
            eprintln!(
                "interrupted: cancelled Slurm jobs {}; what finished is kept",
                ids.join(", ")
            );
            for end in ends.iter_mut().filter(|end| end.is_none()) {
                *end = Some(End::Interrupted);
            }
            break;
        }
        let states = match client::states() {
            Ok(states) => {
                squeue_failures = 0;
                states
            }
            // The controller may be busy for a moment; give up after a minute of failures.
            Err(message) if squeue_failures * options.poll < Duration::from_secs(60) => {
                squeue_failures += 1;
                tracing::warn!("squeue failed ({message}); retrying");
                HashMap::new()
            }
            Err(message) => return Err(message),
        };
        let (mut running, mut pending) = (0, 0);
        for (slot, &(s, t)) in tasks.iter().enumerate() {
            if ends[slot].is_some() {
                continue;
            }
            let job = &jobs[s];
            match states.get(&job.task_id(&submissions[s], t)) {
                Some(state) => {
                    seen[slot] = true;
                    if state.is_terminal() {
                        ends[slot] = Some(End::Slurm(state.clone()));
                    } else if state.state == "RUNNING" {
                        running += 1;
                    } else {
                        pending += 1;
                    }
                }
                None if squeue_failures == 0 && (seen[slot] || job.files.status_of(t).exists()) => {
                    ends[slot] = Some(End::Forgotten);
                }
                None => pending += 1,
            }
        }
        let done = ends.iter().filter(|end| end.is_some()).count();
        bar.set_position(done as u64);
        bar.set_message(format!("{running} running, {pending} pending"));
        if done == tasks.len() {
            break;
        }
        let wake = Instant::now() + options.poll;
        while Instant::now() < wake && !options.interrupted.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(100).min(options.poll));
        }
    }
    bar.finish_and_clear();

    let mut outcomes = HashMap::new();
    for (slot, &(s, t)) in tasks.iter().enumerate() {
        let submission = &submissions[s];
        let job = &jobs[s];
        let idx = submission.instances[t];
        let task_id = job.task_id(submission, t);
        let status = TaskStatus::read(&job.files.status_of(t));
        let stderr_tail = || {
            tail(
                &job.files
                    .stderr_of(&job.id, submission.is_array().then_some(t)),
                8,
            )
        };
        let request = &requests[submission.stage];
        let outcome = match ends[slot].take().expect("every task ended") {
            End::Interrupted => Some(Elsewhere::Failed(format!(
                "Slurm job {task_id} cancelled: the run was interrupted"
            ))),
            End::Slurm(state) if state.state == "COMPLETED" => match status {
                // Found cached by the job (an upstream rerun gave the same bytes): the final
                // pass reports it cached.
                Some(status) if status.status == "cached" => None,
                status => Some(Elsewhere::Ran {
                    wall_s: status.map_or(0.0, |status| status.wall_s),
                    why: format!("in Slurm job {task_id}"),
                }),
            },
            End::Slurm(state) if state.reason == "DependencyNeverSatisfied" => {
                Some(Elsewhere::Failed(format!(
                    "Slurm job {task_id} {}: a job it waits for failed",
                    state.state
                )))
            }
            End::Slurm(state) => {
                let what = match state.state.as_str() {
                    "TIMEOUT" => match &request.time {
                        Some(time) => format!("it ran past its time limit (--time={time})"),
                        None => "it ran past the partition's time limit (set --time)".into(),
                    },
                    "OUT_OF_MEMORY" => {
                        format!("it used more than its memory (--mem={})", request.mem)
                    }
                    "CANCELLED" => "cancelled (scancel, or an administrator)".into(),
                    _ => match &status {
                        Some(status) if !status.succeeded() => status.message.clone(),
                        _ => state.reason.clone(),
                    },
                };
                Some(Elsewhere::Failed(format!(
                    "Slurm job {task_id} {}: {what}{}",
                    state.state,
                    stderr_tail()
                )))
            }
            End::Forgotten => match status {
                Some(status) if status.status == "cached" => None,
                Some(status) if status.succeeded() => Some(Elsewhere::Ran {
                    wall_s: status.wall_s,
                    why: format!("in Slurm job {task_id}"),
                }),
                Some(status) => Some(Elsewhere::Failed(format!(
                    "Slurm job {task_id}: {}{}",
                    status.message,
                    stderr_tail()
                ))),
                None => Some(Elsewhere::Failed(format!(
                    "Slurm job {task_id} ended unseen: Slurm no longer lists it and it left no \
                     status{}",
                    stderr_tail()
                ))),
            },
        };
        if let Some(outcome) = outcome {
            outcomes.insert(idx, outcome);
        }
    }
    Ok(outcomes)
}

/// `n thing` or `n things`.
pub fn count(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// The last `lines` non-empty lines of a job's stderr, as the end of a message.
fn tail(path: &Path, lines: usize) -> String {
    let Ok(text) = std::fs::read_to_string(path) else {
        return format!("; no stderr at {}", path.display());
    };
    let kept: Vec<&str> = text
        .lines()
        .filter(|line| !line.trim().is_empty())
        .collect();
    if kept.is_empty() {
        return String::new();
    }
    let start = kept.len().saturating_sub(lines);
    format!("; stderr ends:\n    {}", kept[start..].join("\n    "))
}

/// What a run would submit, as the shell commands and scripts, without submitting (or running)
/// anything. Job ids are shell variables.
pub fn dry_run(context: &Context, options: &SlurmOptions) -> String {
    let requests = stage_requests(context, &options.defaults);
    let n = context.instances.list.len();
    let lines = plan::plan(context);
    let job = job_instances(context, &lines, &requests, &vec![false; n]);
    let after = after_a_job(context, &job);
    let submissions = submit::group(context.instances, &job);
    let names = |select: &dyn Fn(usize) -> bool| -> String {
        let chosen: Vec<&str> = (0..n)
            .filter(|&idx| select(idx) && matches!(lines[idx].decision, Decision::Runs { .. }))
            .map(|idx| context.instances.list[idx].name.as_str())
            .collect();
        if chosen.is_empty() {
            "nothing".into()
        } else {
            chosen.join(", ")
        }
    };
    let mut text = format!(
        "# squeal would run in the driver first: {}\n",
        names(&|idx| !after[idx])
    );
    // Driver-placed instances a job needs run inside that job.
    let mut inside = vec![false; n];
    for idx in (0..n).rev() {
        if job[idx] || inside[idx] {
            for &up in context.instances.list[idx]
                .inputs
                .iter()
                .flat_map(|input| &input.from)
            {
                inside[up] = after[up] && !job[up];
            }
        }
    }
    let tasks: usize = submissions.iter().map(|s| s.instances.len()).sum();
    text += &format!(
        "# then submit {} ({}), which also run: {}\n\
         # then run in the driver: {}\n",
        count(submissions.len(), "job"),
        count(tasks, "task"),
        names(&|idx| inside[idx]),
        names(&|idx| after[idx] && !job[idx] && !inside[idx])
    );
    let ids: Vec<String> = (1..=submissions.len())
        .map(|number| format!("$job{number}"))
        .collect();
    for (number, submission) in submissions.iter().enumerate() {
        let (files, script, list) = prepare(context, options, &requests, number + 1, submission);
        let args = sbatch_args(
            &requests[submission.stage],
            submit::dependency(&submission.after, &ids),
        );
        // The ids are shell variables here: expanded, not quoted away.
        let args: Vec<String> = args
            .iter()
            .map(|arg| match arg.contains('$') {
                true => format!("\"{arg}\""),
                false => submit::quote(arg),
            })
            .collect();
        text += &format!(
            "\n# {}: {}\njob{}=$(sbatch {} {})\n# {}:\n{}# {}:\n{}",
            context.study.stages[submission.stage].name,
            if submission.is_array() {
                format!("array of {} tasks", submission.instances.len())
            } else {
                "one job".into()
            },
            number + 1,
            args.join(" "),
            submit::quote(&files.script.to_string_lossy()),
            files.script.display(),
            script,
            files.instances.display(),
            list
        );
    }
    text
}
