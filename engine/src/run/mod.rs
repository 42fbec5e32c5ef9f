//! The scheduler: runs the planned instances on rayon, upstream first, as many at once as
//! their dependencies and `--jobs` allow. Executing one instance is [`execute`]'s; writing
//! its outputs to the output folder is [`export`]'s.
//!
//! Each instance, once its inputs are settled, is decided again ([`Context::decide`]) with the
//! digests its upstream just produced: a stage whose upstream reran but produced identical bytes
//! is found cached (early cutoff). A failed stage skips its dependents; independent branches
//! finish and are cached.

mod execute;
mod export;

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use squeal_contract::Value;

use crate::instances::Instance;
use crate::outcome::{Elsewhere, InstanceOutcome, RunOutcome, Status};
use crate::output;
use crate::plan::{Context, Decision, ResolvedInputs};
use crate::ports::COMPUTE_TIME_OUTPUT;
use execute::Memo;
use export::Exports;

#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Worker threads; `None` uses every core.
    pub jobs: Option<usize>,
    /// Where tables, figures and the manifest go; `None` writes nothing but the cache (a
    /// cluster job, or the driver's runs before its jobs).
    pub out_dir: Option<PathBuf>,
    pub progress: bool,
    /// The instances to settle, closed upstream (an instance's inputs are selected with it);
    /// `None` settles every instance.
    pub select: Option<Vec<bool>>,
    /// Instances another executor ran (by index): never run here.
    pub ran_elsewhere: HashMap<usize, Elsewhere>,
}

impl RunOptions {
    /// Every instance, here, outputs written to `out_dir`.
    pub fn local(jobs: Option<usize>, out_dir: PathBuf, progress: bool) -> RunOptions {
        RunOptions {
            jobs,
            out_dir: Some(out_dir),
            progress,
            select: None,
            ran_elsewhere: HashMap::new(),
        }
    }
}

/// What the instances being settled share.
struct Shared {
    outcomes: Vec<Option<InstanceOutcome>>,
    inputs: Vec<Option<ResolvedInputs>>,
    /// Upstream instances each instance still waits for.
    pending: Vec<usize>,
    running: Vec<String>,
}

struct Executor<'a> {
    context: &'a Context<'a>,
    options: &'a RunOptions,
    dependents: Vec<Vec<usize>>,
    shared: Mutex<Shared>,
    memo: Memo,
    exports: Mutex<Exports>,
    progress: ProgressBar,
    /// Holds the overall bar and one bar per stage that reports its progress.
    bars: MultiProgress,
}

/// Runs the selected instances (all by default); writes the outputs and the manifest when
/// `options.out_dir` is set, and the run record when `record_path` is.
pub fn run(
    context: &Context,
    options: &RunOptions,
    record_path: Option<&Path>,
) -> std::io::Result<RunOutcome> {
    let started = Instant::now();
    // Results must not depend on the thread count: the cache keys downstream work by them.
    squeal_linalg::fix_global_parallelism();
    let n_instances = context.instances.list.len();
    let selected = |idx: usize| options.select.as_ref().is_none_or(|select| select[idx]);
    let n_selected = (0..n_instances).filter(|&idx| selected(idx)).count();
    let mut dependents = vec![Vec::new(); n_instances];
    let mut pending = vec![0; n_instances];
    for (idx, instance) in context.instances.list.iter().enumerate() {
        if !selected(idx) {
            continue;
        }
        let mut upstream: Vec<usize> = instance
            .inputs
            .iter()
            .flat_map(|input| input.from.iter().copied())
            .collect();
        upstream.sort_unstable();
        upstream.dedup();
        pending[idx] = upstream.len();
        for up in upstream {
            dependents[up].push(idx);
        }
    }
    if let Some(out_dir) = &options.out_dir {
        output::remove_stray_temporaries(out_dir);
    }
    if let Some(record_dir) = record_path.and_then(Path::parent) {
        output::remove_stray_temporaries(record_dir);
    }
    let exports = options
        .out_dir
        .as_deref()
        .map(export::read_record)
        .unwrap_or_default();
    let bars = MultiProgress::with_draw_target(if options.progress {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    });
    let progress = bars.add(ProgressBar::new(n_selected as u64));
    progress.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {wide_msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let roots: Vec<usize> = (0..n_instances)
        .filter(|&idx| selected(idx) && pending[idx] == 0)
        .collect();
    let executor = Executor {
        context,
        options,
        dependents,
        shared: Mutex::new(Shared {
            outcomes: vec![None; n_instances],
            inputs: vec![None; n_instances],
            pending,
            running: Vec::new(),
        }),
        memo: Memo::default(),
        exports: Mutex::new(exports),
        progress,
        bars,
    };
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(jobs) = options.jobs {
        builder = builder.num_threads(jobs.max(1));
    }
    let pool = builder.build().map_err(std::io::Error::other)?;
    pool.install(|| {
        rayon::scope(|scope| {
            for idx in roots {
                spawn(scope, &executor, idx);
            }
        })
    });
    executor.progress.finish_and_clear();
    let exports = executor
        .exports
        .into_inner()
        .expect("no export panics while holding the lock");
    let shared = executor
        .shared
        .into_inner()
        .expect("no worker panics while holding the lock");
    let settled: Vec<(usize, InstanceOutcome)> = shared
        .outcomes
        .into_iter()
        .enumerate()
        .filter(|&(idx, _)| selected(idx))
        .map(|(idx, outcome)| (idx, outcome.expect("every selected instance is settled")))
        .collect();

    if let Some(record_path) = record_path {
        let mut record = context.record.clone();
        for (idx, outcome) in &settled {
            if let (Some(key), Some(inputs), Status::Ran | Status::Cached) =
                (outcome.key, &shared.inputs[*idx], &outcome.status)
            {
                record.instances.insert(
                    outcome.name.clone(),
                    context.record_of(*idx, key, inputs, &outcome.outputs),
                );
            }
        }
        record.save(record_path).map_err(|err| {
            std::io::Error::new(
                err.kind(),
                format!(
                    "writing the run record {}: {err} (it goes beside the study: make that \
                     folder writable, or set SQUEAL_STATE_DIR to a folder you can write)",
                    record_path.display()
                ),
            )
        })?;
    }
    let outcome = RunOutcome {
        instances: settled.into_iter().map(|(_, outcome)| outcome).collect(),
        wall_s: started.elapsed().as_secs_f64(),
    };
    if let Some(out_dir) = &options.out_dir {
        let writing_outputs = |err: std::io::Error| {
            std::io::Error::new(
                err.kind(),
                format!(
                    "writing outputs to {}: {err} (give a folder you can write with --out)",
                    out_dir.display()
                ),
            )
        };
        export::write_record(out_dir, &exports).map_err(writing_outputs)?;
        crate::manifest::write(&out_dir.join("manifest.parquet"), &outcome)
            .map_err(writing_outputs)?;
    }
    Ok(outcome)
}

fn spawn<'s>(scope: &rayon::Scope<'s>, executor: &'s Executor<'s>, idx: usize) {
    scope.spawn(move |scope| {
        let outcome = executor.process(idx);
        for dependent in executor.settle(idx, outcome) {
            spawn(scope, executor, dependent);
        }
    });
}

impl Executor<'_> {
    fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.shared
            .lock()
            .expect("no worker panics while holding the lock")
    }

    /// Records the outcome and returns the dependents that became ready.
    fn settle(&self, idx: usize, outcome: InstanceOutcome) -> Vec<usize> {
        let mut shared = self.lock();
        shared.running.retain(|name| *name != outcome.name);
        shared.outcomes[idx] = Some(outcome);
        self.progress.inc(1);
        self.progress.set_message(shared.running.join(", "));
        let mut ready = Vec::new();
        for &dependent in &self.dependents[idx] {
            shared.pending[dependent] -= 1;
            if shared.pending[dependent] == 0 {
                ready.push(dependent);
            }
        }
        ready
    }

    /// Settles instance `idx`, whose upstream is settled: skipped, found cached, taken from
    /// another executor, or executed; then exported.
    fn process(&self, idx: usize) -> InstanceOutcome {
        let context = self.context;
        let instance = &context.instances.list[idx];
        let decl = &context.study.stages[instance.stage];
        let mut outcome = InstanceOutcome {
            name: instance.name.clone(),
            stage: decl.name.clone(),
            kind: decl.stage.kind().into(),
            key: None,
            status: Status::Ran,
            reasons: Vec::new(),
            wall_s: 0.0,
            compute_s: 0.0,
            params_json: params_json(instance),
            outputs: BTreeMap::new(),
        };
        let inputs = {
            let shared = self.lock();
            let blocked = instance
                .inputs
                .iter()
                .flat_map(|input| &input.from)
                .find(|&&up| {
                    !matches!(
                        shared.outcomes[up].as_ref().map(|outcome| &outcome.status),
                        Some(Status::Ran | Status::Cached)
                    )
                });
            if let Some(&up) = blocked {
                outcome.status = Status::Skipped(context.instances.list[up].name.clone());
                return outcome;
            }
            context.resolve_inputs(idx, &|up| {
                shared.outcomes[up]
                    .as_ref()
                    .map(|outcome| outcome.outputs.clone())
            })
        };
        self.lock().inputs[idx] = Some(inputs.clone());
        match (
            self.options.ran_elsewhere.get(&idx),
            context.decide(idx, &inputs),
        ) {
            (Some(Elsewhere::Failed(message)), _) => {
                outcome.status = Status::Failed(message.clone());
                return outcome;
            }
            (
                Some(Elsewhere::Ran { wall_s, why }),
                Decision::Cached {
                    key,
                    outputs,
                    compute_s,
                },
            ) => {
                outcome.key = Some(key);
                outcome.reasons = vec![why.clone()];
                outcome.wall_s = *wall_s;
                outcome.outputs = outputs;
                outcome.compute_s = compute_s;
            }
            (Some(Elsewhere::Ran { .. }), Decision::Runs { .. }) => {
                outcome.status = Status::Failed(
                    "its job ended, but its outputs are not in the cache (is the cache on a \
                     file system the jobs share?)"
                        .into(),
                );
                return outcome;
            }
            (
                None,
                Decision::Cached {
                    key,
                    outputs,
                    compute_s,
                },
            ) => {
                outcome.key = Some(key);
                outcome.status = Status::Cached;
                outcome.outputs = outputs;
                outcome.compute_s = compute_s;
                tracing::debug!(stage = %instance.name, "cached");
            }
            (None, Decision::Runs { key, reasons }) => {
                let key = key.expect("inputs are settled, so the key is known");
                outcome.key = Some(key);
                outcome.reasons = reasons;
                tracing::info!(stage = %instance.name, reason = %outcome.reasons.join("; "), "runs");
                self.lock().running.push(instance.name.clone());
                let started = Instant::now();
                let result = execute::execute(context, &self.memo, &self.bars, idx, key, &inputs);
                outcome.wall_s = started.elapsed().as_secs_f64();
                match result {
                    Ok((outputs, compute_s)) => {
                        outcome.outputs = outputs;
                        outcome.compute_s = compute_s;
                    }
                    Err(message) => {
                        // The caller prints the failure once, with the run's summary.
                        tracing::debug!(stage = %instance.name, "failed: {message}");
                        outcome.status = Status::Failed(message);
                        return outcome;
                    }
                }
            }
        }
        let compute_time = execute::compute_time_output(&self.memo, outcome.compute_s);
        outcome
            .outputs
            .insert(COMPUTE_TIME_OUTPUT.to_string(), compute_time);
        if let Some(out_dir) = &self.options.out_dir
            && let Err(message) = export::export(
                context,
                &self.memo,
                out_dir,
                &self.exports,
                idx,
                &outcome.outputs,
            )
        {
            outcome.status = Status::Failed(message);
        }
        outcome
    }
}

/// An instance's parameters as a JSON object, for the manifest.
fn params_json(instance: &Instance) -> String {
    let map: serde_json::Map<String, serde_json::Value> = instance
        .params
        .iter()
        .map(|(name, value)| {
            let json = match value {
                Value::Bool(value) => serde_json::Value::from(*value),
                Value::Int(value) => serde_json::Value::from(*value),
                Value::Float(value) => serde_json::Value::from(*value),
                Value::Str(value) => serde_json::Value::from(value.clone()),
            };
            (name.clone(), json)
        })
        .collect();
    serde_json::Value::Object(map).to_string()
}
