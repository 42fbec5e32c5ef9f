//! The scheduler: runs the planned instances on rayon, upstream first, as many at once as
//! their dependencies and `--jobs` allow.
//!
//! Each instance, once its inputs are settled, is decided again ([`Context::decide`]) with the
//! digests its upstream just produced: a stage whose upstream reran but produced identical bytes
//! is found cached (early cutoff). A failed stage skips its dependents; independent branches
//! finish and are cached.

use std::collections::{BTreeMap, HashMap};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use squeal_cache::{ActionRecord, Digest};
use squeal_stages::{
    Artifact, Input, Inputs, Outputs, Params, Progress, RunContext, StageError, Table,
};

use crate::checkpoint::CacheCheckpoints;
use crate::outcome::{Elsewhere, InstanceOutcome, RunOutcome, Status};
use crate::output;
use crate::plan::{Context, Decision, ResolvedInputs};
use crate::ports::{self, COMPUTE_TIME_OUTPUT};

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

struct Shared {
    reports: Vec<Option<InstanceOutcome>>,
    inputs: Vec<Option<ResolvedInputs>>,
    pending: Vec<usize>,
    running: Vec<String>,
    exports: BTreeMap<String, Export>,
}

struct Executor<'a> {
    context: &'a Context<'a>,
    options: &'a RunOptions,
    dependents: Vec<Vec<usize>>,
    shared: Mutex<Shared>,
    /// Artifacts decoded or produced during this run, so consumers need not read them back.
    memo: Mutex<HashMap<Digest, Arc<Artifact>>>,
    progress: ProgressBar,
    /// Holds the overall bar and one bar per stage that reports its progress.
    bars: MultiProgress,
}

const EXPORTS_FILE: &str = ".squeal-exports.json";

/// Resolution of a stage's progress bar.
const STAGE_BAR_STEPS: u64 = 1000;

/// Runs every instance of the context and writes the outputs, the manifest and the record.
/// Runs the selected instances (all by default); writes the outputs and the manifest when
/// `options.out_dir` is set, and the run record when `record_path` is.
pub fn run(
    context: &Context,
    options: &RunOptions,
    record_path: Option<&Path>,
) -> std::io::Result<RunOutcome> {
    let started = Instant::now();
    // Results must not depend on the thread count: the cache keys downstream work by them.
    squeal_stages::fix_global_parallelism();
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
    let exports_path = options.out_dir.as_ref().map(|dir| dir.join(EXPORTS_FILE));
    let exports = exports_path
        .as_ref()
        .and_then(|path| std::fs::read(path).ok())
        .and_then(|bytes| serde_json::from_slice(&bytes).ok())
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
            reports: vec![None; n_instances],
            inputs: vec![None; n_instances],
            pending,
            running: Vec::new(),
            exports,
        }),
        memo: Mutex::new(HashMap::new()),
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
    let shared = executor
        .shared
        .into_inner()
        .expect("no worker panics while holding the lock");
    let settled: Vec<(usize, InstanceOutcome)> = shared
        .reports
        .into_iter()
        .enumerate()
        .filter(|&(idx, _)| selected(idx))
        .map(|(idx, report)| (idx, report.expect("every selected instance is settled")))
        .collect();

    if let Some(record_path) = record_path {
        let mut record = context.record.clone();
        for (idx, report) in &settled {
            if let (Some(key), Some(inputs), Status::Ran | Status::Cached) =
                (report.key, &shared.inputs[*idx], &report.status)
            {
                record.instances.insert(
                    report.name.clone(),
                    context.record_of(*idx, key, inputs, &report.outputs),
                );
            }
        }
        record.save(record_path)?;
    }
    let report = RunOutcome {
        instances: settled.into_iter().map(|(_, report)| report).collect(),
        wall_s: started.elapsed().as_secs_f64(),
    };
    if let (Some(out_dir), Some(exports_path)) = (&options.out_dir, &exports_path) {
        output::write_if_changed(
            exports_path,
            &serde_json::to_vec_pretty(&shared.exports).expect("serialises"),
        )?;
        crate::manifest::write(&out_dir.join("manifest.parquet"), &report)?;
    }
    Ok(report)
}

/// A bar for one stage's own progress (fraction, time left, its message).
fn stage_progress_bar(bars: &MultiProgress, name: &str) -> ProgressBar {
    let bar = bars.add(ProgressBar::new(STAGE_BAR_STEPS));
    bar.set_style(
        ProgressStyle::with_template("  {prefix} [{bar:30}] {percent:>3}% eta {eta} {wide_msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix(name.to_string());
    bar
}

fn spawn<'s>(scope: &rayon::Scope<'s>, executor: &'s Executor<'s>, idx: usize) {
    scope.spawn(move |scope| {
        let report = executor.process(idx);
        for dependent in executor.settle(idx, report) {
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
    fn settle(&self, idx: usize, report: InstanceOutcome) -> Vec<usize> {
        let mut shared = self.lock();
        shared.running.retain(|name| *name != report.name);
        shared.reports[idx] = Some(report);
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

    fn process(&self, idx: usize) -> InstanceOutcome {
        let context = self.context;
        let instance = &context.instances.list[idx];
        let decl = &context.study.stages[instance.stage];
        let mut report = InstanceOutcome {
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
                        shared.reports[up].as_ref().map(|report| &report.status),
                        Some(Status::Ran | Status::Cached)
                    )
                });
            if let Some(&up) = blocked {
                report.status = Status::Skipped(context.instances.list[up].name.clone());
                return report;
            }
            context.resolve_inputs(idx, &|up| {
                shared.reports[up]
                    .as_ref()
                    .map(|report| report.outputs.clone())
            })
        };
        self.lock().inputs[idx] = Some(inputs.clone());
        match (
            self.options.ran_elsewhere.get(&idx),
            context.decide(idx, &inputs),
        ) {
            (Some(Elsewhere::Failed(message)), _) => {
                report.status = Status::Failed(message.clone());
                return report;
            }
            (
                Some(Elsewhere::Ran { wall_s, why }),
                Decision::Cached {
                    key,
                    outputs,
                    compute_s,
                },
            ) => {
                report.key = Some(key);
                report.reasons = vec![why.clone()];
                report.wall_s = *wall_s;
                report.outputs = outputs;
                report.compute_s = compute_s;
            }
            (Some(Elsewhere::Ran { .. }), Decision::Runs { .. }) => {
                report.status = Status::Failed(
                    "its job ended, but its outputs are not in the cache (is the cache on a \
                     file system the jobs share?)"
                        .into(),
                );
                return report;
            }
            (
                None,
                Decision::Cached {
                    key,
                    outputs,
                    compute_s,
                },
            ) => {
                report.key = Some(key);
                report.status = Status::Cached;
                report.outputs = outputs;
                report.compute_s = compute_s;
                tracing::debug!(stage = %instance.name, "cached");
            }
            (None, Decision::Runs { key, reasons }) => {
                let key = key.expect("inputs are settled, so the key is known");
                report.key = Some(key);
                report.reasons = reasons;
                tracing::info!(stage = %instance.name, reason = %report.reasons.join("; "), "runs");
                self.lock().running.push(instance.name.clone());
                let started = Instant::now();
                let result = self.execute(idx, key, &inputs);
                report.wall_s = started.elapsed().as_secs_f64();
                match result {
                    Ok((outputs, compute_s)) => {
                        report.outputs = outputs;
                        report.compute_s = compute_s;
                    }
                    Err(message) => {
                        // The caller prints the failure once, with the run's summary.
                        tracing::debug!(stage = %instance.name, "failed: {message}");
                        report.status = Status::Failed(message);
                        return report;
                    }
                }
            }
        }
        let compute_time = self.compute_time_output(report.compute_s);
        report
            .outputs
            .insert(COMPUTE_TIME_OUTPUT.to_string(), compute_time);
        if let Err(message) = self.export(idx, &report.outputs) {
            report.status = Status::Failed(message);
        }
        report
    }

    /// Loads the inputs, runs the stage, stores and records its outputs.
    fn execute(
        &self,
        idx: usize,
        key: Digest,
        inputs: &ResolvedInputs,
    ) -> Result<(BTreeMap<String, Digest>, f64), String> {
        let context = self.context;
        let instance = &context.instances.list[idx];
        let stage = &context.study.stages[instance.stage].stage;
        let mut stage_inputs = Inputs::default();
        for input in &instance.inputs {
            let (port, artifacts) = (&input.port, &inputs[&input.port]);
            let mut loaded = Vec::with_capacity(artifacts.len());
            for artifact in artifacts {
                let digest = artifact.digest.expect("settled inputs have digests");
                let value = self
                    .load(&digest)
                    .map_err(|err| format!("input `{}`: {err}", artifact.reference))?;
                loaded.push((context.point_coords(idx, artifact.instance), value));
            }
            let value = match input.arity {
                squeal_stages::Arity::One => Input::One(loaded.pop().expect("one artifact").1),
                squeal_stages::Arity::Many => Input::Many(loaded),
            };
            stage_inputs.0.insert(port.clone(), value);
        }
        let params = Params(instance.params.clone());
        // The stage's own bar appears with its first report.
        let stage_bar: Arc<OnceLock<ProgressBar>> = Arc::new(OnceLock::new());
        let reporter = {
            let (stage_bar, bars, name) =
                (stage_bar.clone(), self.bars.clone(), instance.name.clone());
            Progress::new(move |fraction, message| {
                let bar = stage_bar.get_or_init(|| stage_progress_bar(&bars, &name));
                bar.set_position((fraction * STAGE_BAR_STEPS as f64) as u64);
                bar.set_message(message.to_string());
            })
        };
        let checkpoints = CacheCheckpoints::new(context.cache, &key, &instance.name, stage.kind());
        let run_context = RunContext {
            progress: &reporter,
            checkpoints: &checkpoints,
        };
        let started = Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| {
            stage.run_with(&params, &stage_inputs, &run_context)
        }));
        let compute_s = started.elapsed().as_secs_f64();
        // Finished, or failed for a reason a resume would meet again: the checkpoint goes.
        checkpoints.discard();
        if let Some(bar) = stage_bar.get() {
            bar.finish_and_clear();
            self.bars.remove(bar);
        }
        let outputs: Outputs = match result {
            Ok(Ok(outputs)) => outputs,
            Ok(Err(StageError { message })) => return Err(message),
            Err(payload) => {
                let message = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|text| text.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                return Err(format!("internal error in `{}`: {message}", stage.kind()));
            }
        };
        let declared = stage.outputs();
        for port in &declared {
            match outputs.get(port.name) {
                Some(artifact) if artifact.artifact_type() == port.ty => {}
                Some(artifact) => {
                    return Err(format!(
                        "internal error: output `{}` is a {}, declared {}",
                        port.name,
                        artifact.artifact_type(),
                        port.ty
                    ));
                }
                None => {
                    return Err(format!(
                        "internal error: output `{}` was not produced",
                        port.name
                    ));
                }
            }
        }
        if let Some(extra) = outputs
            .keys()
            .find(|name| !declared.iter().any(|port| port.name == *name))
        {
            return Err(format!("internal error: undeclared output `{extra}`"));
        }
        let mut digests = BTreeMap::new();
        for (name, artifact) in outputs {
            let digest = context
                .cache
                .put_object(&artifact.encode())
                .map_err(|err| format!("storing output `{name}` in the cache: {err}"))?;
            self.memo
                .lock()
                .expect("memo lock")
                .insert(digest, Arc::new(artifact));
            digests.insert(name, digest);
        }
        if stage.pure() {
            let action = ActionRecord {
                stage: instance.name.clone(),
                kind: stage.kind().into(),
                outputs: digests.clone(),
                wall_s: compute_s,
            };
            context
                .cache
                .put_action(&key, &action)
                .map_err(|err| format!("recording the outputs in the cache: {err}"))?;
        }
        Ok((digests, compute_s))
    }

    /// The implicit output [`COMPUTE_TIME_OUTPUT`]: a one-row table of the instance's compute
    /// time that downstream stages can take as an input. It lives in this run's memory only:
    /// the figure itself is kept in the action record, and a timing must not become a cache
    /// object that two otherwise identical runs disagree on.
    fn compute_time_output(&self, compute_s: f64) -> Digest {
        let artifact = Artifact::Table(Table::new().with(COMPUTE_TIME_OUTPUT, vec![compute_s]));
        let digest = Digest::of(&artifact.encode());
        self.memo
            .lock()
            .expect("memo lock")
            .insert(digest, Arc::new(artifact));
        digest
    }

    fn load(&self, digest: &Digest) -> Result<Arc<Artifact>, String> {
        if let Some(artifact) = self.memo.lock().expect("memo lock").get(digest) {
            return Ok(artifact.clone());
        }
        let bytes = self
            .context
            .cache
            .get_object(digest)
            .map_err(|err| err.to_string())?;
        let artifact = Arc::new(Artifact::decode(&bytes).map_err(|err| err.to_string())?);
        self.memo
            .lock()
            .expect("memo lock")
            .insert(*digest, artifact.clone());
        Ok(artifact)
    }

    /// Writes each output people read: tables to Parquet, figures to SVG and PNG, documents
    /// under their extension. Skipped when the export record says these bytes are already there.
    fn export(&self, idx: usize, outputs: &BTreeMap<String, Digest>) -> Result<(), String> {
        let instances = self.context.instances;
        let instance = &instances.list[idx];
        let Some(out_dir) = &self.options.out_dir else {
            return Ok(());
        };
        let mut dir = PathBuf::from(&self.context.study.stages[instance.stage].name);
        for segment in instances.coord_segments(instance) {
            dir.push(segment);
        }
        for (name, digest) in outputs {
            if ports::is_implicit(name) {
                // In the manifest already.
                continue;
            }
            let relative = dir.join(name);
            let relative_key = relative.to_string_lossy().into_owned();
            let up_to_date = self
                .lock()
                .exports
                .get(&relative_key)
                .is_some_and(|export| {
                    export.digest == *digest
                        && export.files.iter().all(|file| out_dir.join(file).exists())
                });
            if up_to_date {
                continue;
            }
            let artifact = self
                .load(digest)
                .map_err(|err| format!("output `{name}`: {err}"))?;
            let files: Vec<(PathBuf, &[u8])>;
            let parquet;
            match artifact.as_ref() {
                Artifact::Table(table) => {
                    parquet = output::parquet_bytes(table)
                        .map_err(|err| format!("output `{name}`: {err}"))?;
                    files = vec![(relative.with_extension("parquet"), &parquet)];
                }
                Artifact::Figure(figure) => {
                    files = vec![
                        (relative.with_extension("svg"), figure.svg.as_bytes()),
                        (relative.with_extension("png"), &figure.png),
                    ];
                }
                Artifact::Document(document) => {
                    files = vec![(
                        relative.with_extension(&document.extension),
                        &document.bytes,
                    )];
                }
                // Meshes, models, modes and bases feed other stages; people see them through
                // the tables, figures and documents those stages write.
                Artifact::Mesh(_)
                | Artifact::Model(_)
                | Artifact::RealModes(_)
                | Artifact::Equilibrium(_)
                | Artifact::Basis(_) => files = Vec::new(),
            }
            for (file, bytes) in &files {
                let path = out_dir.join(file);
                output::write_atomic(&path, bytes)
                    .map_err(|err| format!("writing {}: {err}", path.display()))?;
            }
            let files = files
                .iter()
                .map(|(file, _)| file.to_string_lossy().into_owned())
                .collect();
            self.lock().exports.insert(
                relative_key,
                Export {
                    digest: *digest,
                    files,
                },
            );
        }
        Ok(())
    }
}

/// What the last export of an output wrote (`out/.squeal-exports.json`).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Export {
    digest: Digest,
    /// Paths relative to the output folder.
    files: Vec<String>,
}

fn params_json(instance: &crate::instances::Instance) -> String {
    let map: serde_json::Map<String, serde_json::Value> = instance
        .params
        .iter()
        .map(|(name, value)| {
            let json = match value {
                squeal_stages::Value::Bool(value) => serde_json::Value::from(*value),
                squeal_stages::Value::Int(value) => serde_json::Value::from(*value),
                squeal_stages::Value::Float(value) => serde_json::Value::from(*value),
                squeal_stages::Value::Str(value) => serde_json::Value::from(value.clone()),
            };
            (name.clone(), json)
        })
        .collect();
    serde_json::Value::Object(map).to_string()
}
