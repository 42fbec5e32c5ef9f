//! Executing one instance: loading its inputs, running its stage with panics caught and its
//! progress on a bar of its own, checking the outputs against the stage's declaration, and
//! putting them in the cache. Artifacts decoded or produced during a run stay in memory
//! ([`Memo`]), so that consumers need not read them back.

use std::collections::{BTreeMap, HashMap};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use squeal_cache::{ActionRecord, Cache, Digest};
use squeal_contract::{
    Arity, Artifact, Input, Inputs, Outputs, Params, Progress, RunContext, StageError, Table,
};

use crate::checkpoint::CacheCheckpoints;
use crate::plan::{Context, ResolvedInputs};
use crate::ports::COMPUTE_TIME_OUTPUT;

/// Resolution of a stage's progress bar.
const STAGE_BAR_STEPS: u64 = 1000;

/// Artifacts decoded or produced during a run, by digest.
#[derive(Default)]
pub(super) struct Memo(Mutex<HashMap<Digest, Arc<Artifact>>>);

impl Memo {
    fn keep(&self, digest: Digest, artifact: Arc<Artifact>) {
        self.0.lock().expect("memo lock").insert(digest, artifact);
    }

    /// The artifact with this digest: from memory, or read from the cache and decoded.
    pub(super) fn load(&self, cache: &Cache, digest: &Digest) -> Result<Arc<Artifact>, String> {
        if let Some(artifact) = self.0.lock().expect("memo lock").get(digest) {
            return Ok(artifact.clone());
        }
        let bytes = cache.get_object(digest).map_err(|err| err.to_string())?;
        let artifact = Arc::new(Artifact::decode(&bytes).map_err(|err| err.to_string())?);
        self.keep(*digest, artifact.clone());
        Ok(artifact)
    }
}

/// Loads the inputs of instance `idx`, runs its stage, stores and records its outputs; their
/// digests and the seconds the stage took to compute them.
pub(super) fn execute(
    context: &Context,
    memo: &Memo,
    bars: &MultiProgress,
    idx: usize,
    key: Digest,
    inputs: &ResolvedInputs,
) -> Result<(BTreeMap<String, Digest>, f64), String> {
    let instance = &context.instances.list[idx];
    let stage = &context.study.stages[instance.stage].stage;
    let mut stage_inputs = Inputs::default();
    for (port, artifacts) in inputs {
        let arity = instance
            .inputs
            .iter()
            .find(|input| &input.port == port)
            .expect("resolved from the instance's inputs")
            .arity;
        let mut loaded = Vec::with_capacity(artifacts.len());
        for artifact in artifacts {
            let digest = artifact.digest.expect("settled inputs have digests");
            let value = memo
                .load(context.cache, &digest)
                .map_err(|err| format!("input `{}`: {err}", artifact.reference))?;
            loaded.push((context.point_coords(idx, artifact.instance), value));
        }
        let value = match arity {
            Arity::One => Input::One(loaded.pop().expect("one artifact").1),
            Arity::Many | Arity::List => Input::Many(loaded),
        };
        stage_inputs.0.insert(port.clone(), value);
    }
    let params = Params(instance.params.clone());
    // The stage's own bar appears with its first report.
    let stage_bar: Arc<OnceLock<ProgressBar>> = Arc::new(OnceLock::new());
    let reporter = {
        let (stage_bar, bars, name) = (stage_bar.clone(), bars.clone(), instance.name.clone());
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
        bars.remove(bar);
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
        memo.keep(digest, Arc::new(artifact));
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
/// time that downstream stages can take as an input. It lives in this run's memory only: the
/// figure itself is kept in the action record, and a timing must not become a cache object
/// that two otherwise identical runs disagree on.
pub(super) fn compute_time_output(memo: &Memo, compute_s: f64) -> Digest {
    let artifact = Artifact::Table(Table::new().with(COMPUTE_TIME_OUTPUT, vec![compute_s]));
    let digest = Digest::of(&artifact.encode());
    memo.keep(digest, Arc::new(artifact));
    digest
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
