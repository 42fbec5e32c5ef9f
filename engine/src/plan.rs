//! The planner: for each stage instance, cached or runs, and why.
//!
//! The same `decide` serves `squeal plan` (walking the instances in order, with the digests
//! the cache already knows) and the scheduler (with the digests upstream stages just produced).
//! A cached entry counts only if its record and every object it names verify.

use std::collections::BTreeMap;

use squeal_cache::{Cache, CacheError, Digest};
use squeal_contract::{Coords, Value};

use crate::instances::Instances;
use crate::key::{InputDigests, cache_key};
use crate::record::{InstanceRecord, RunRecord};
use crate::study::Study;

/// One upstream artifact feeding an instance; `digest` is `None` while its producer has yet
/// to run.
#[derive(Debug, Clone)]
pub struct ResolvedInput {
    /// `stage.output`, as in the spec, with the upstream instance's coordinates.
    pub reference: String,
    pub instance: usize,
    pub output: String,
    pub digest: Option<Digest>,
}

/// Input port → upstream artifacts, in declaration order.
pub type ResolvedInputs = BTreeMap<String, Vec<ResolvedInput>>;

#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    Cached {
        key: Digest,
        outputs: BTreeMap<String, Digest>,
        /// Seconds the stage took when it computed the cached outputs.
        compute_s: f64,
    },
    Runs {
        key: Option<Digest>,
        reasons: Vec<String>,
    },
}

impl Decision {
    pub fn describe(&self) -> String {
        match self {
            Decision::Cached { .. } => "cached".into(),
            Decision::Runs { reasons, .. } => format!("runs: {}", reasons.join("; ")),
        }
    }
}

/// Everything the planner consults.
pub struct Context<'a> {
    pub study: &'a Study,
    pub instances: &'a Instances,
    pub cache: &'a Cache,
    pub record: &'a RunRecord,
}

impl Context<'_> {
    /// The inputs of `idx`, with the digests `outputs_of` knows.
    pub fn resolve_inputs(
        &self,
        idx: usize,
        outputs_of: &dyn Fn(usize) -> Option<BTreeMap<String, Digest>>,
    ) -> ResolvedInputs {
        let instance = &self.instances.list[idx];
        let mut resolved = ResolvedInputs::new();
        for input in &instance.inputs {
            // A list port's connections gather under its name, in order.
            let artifacts = resolved.entry(input.port.clone()).or_default();
            artifacts.extend(input.from.iter().map(|&up| ResolvedInput {
                reference: format!("{}.{}", self.instances.list[up].name, input.output),
                instance: up,
                output: input.output.clone(),
                digest: outputs_of(up).and_then(|outputs| outputs.get(&input.output).copied()),
            }));
        }
        resolved
    }

    /// The coordinates that identify upstream instance `up` among the artifacts `idx` receives:
    /// those the consumer does not fix itself (empty for a fan-out, the swept values for a gather).
    pub fn point_coords(&self, idx: usize, up: usize) -> Coords {
        let own = &self.instances.list[idx].coords;
        let free: Vec<(usize, Value)> = self.instances.list[up]
            .coords
            .iter()
            .filter(|(axis, _)| !own.iter().any(|(own_axis, _)| own_axis == axis))
            .cloned()
            .collect();
        self.instances.labelled(&free)
    }

    /// The cache key, once every input digest is known.
    pub fn key(&self, idx: usize, inputs: &ResolvedInputs) -> Option<Digest> {
        let instance = &self.instances.list[idx];
        let stage = &self.study.stages[instance.stage].stage;
        let mut digests = InputDigests::new();
        for (port, artifacts) in inputs {
            let entry = digests.entry(port.clone()).or_default();
            for artifact in artifacts {
                entry.push((self.point_coords(idx, artifact.instance), artifact.digest?));
            }
        }
        // What outside the study the stage reads, as inputs no study can name (`@name`).
        let params = squeal_contract::Params(instance.params.clone());
        match stage.external_inputs(&params) {
            Ok(externals) => {
                for (name, bytes) in externals {
                    digests.insert(format!("@{name}"), vec![(Vec::new(), Digest::of(&bytes))]);
                }
            }
            Err(err) => {
                digests.insert(
                    "@error".into(),
                    vec![(Vec::new(), Digest::of(err.message.as_bytes()))],
                );
            }
        }
        Some(cache_key(
            stage.kind(),
            stage.version(),
            &instance.params,
            &digests,
        ))
    }

    pub fn decide(&self, idx: usize, inputs: &ResolvedInputs) -> Decision {
        let instance = &self.instances.list[idx];
        let stage = &self.study.stages[instance.stage].stage;
        let key = self.key(idx, inputs);
        let previous = self.record.instances.get(&instance.name);
        if !stage.pure() {
            return Decision::Runs {
                key,
                reasons: vec!["not pure: never cached".into()],
            };
        }
        let Some(key) = key else {
            return Decision::Runs {
                key: None,
                reasons: self.explain(idx, inputs, previous),
            };
        };
        let corrupt = |err: CacheError| Decision::Runs {
            key: Some(key),
            reasons: vec![format!("cache entry corrupt: {err}")],
        };
        match self.cache.get_action(&key) {
            Ok(Some(action)) => {
                // An entry from an implementation that declared other outputs (a forgotten
                // version bump) is stale, not a result.
                let declared: Vec<&str> = stage.outputs().iter().map(|port| port.name).collect();
                if !action.outputs.keys().map(String::as_str).eq(declared
                    .iter()
                    .copied()
                    .collect::<std::collections::BTreeSet<_>>(
                )) {
                    return Decision::Runs {
                        key: Some(key),
                        reasons: vec![
                            "cached outputs differ from the stage's declared outputs".into(),
                        ],
                    };
                }
                for digest in action.outputs.values() {
                    if let Err(err) = self.cache.verify_object(digest) {
                        let _ = self.cache.remove_action(&key);
                        return corrupt(err);
                    }
                }
                Decision::Cached {
                    key,
                    outputs: action.outputs,
                    compute_s: action.wall_s,
                }
            }
            Ok(None) => {
                let mut reasons = self.explain(idx, inputs, previous);
                if reasons.is_empty() {
                    reasons.push("not in cache".into());
                }
                Decision::Runs {
                    key: Some(key),
                    reasons,
                }
            }
            Err(err) => corrupt(err),
        }
    }

    /// What differs from the last recorded run of this instance.
    fn explain(
        &self,
        idx: usize,
        inputs: &ResolvedInputs,
        previous: Option<&InstanceRecord>,
    ) -> Vec<String> {
        let instance = &self.instances.list[idx];
        let stage = &self.study.stages[instance.stage].stage;
        let Some(previous) = previous else {
            return vec!["new".into()];
        };
        let mut reasons = Vec::new();
        if previous.kind != stage.kind() {
            reasons.push(format!("kind changed {} → {}", previous.kind, stage.kind()));
        } else if previous.version != stage.version() {
            reasons.push(format!(
                "stage version changed {} → {}",
                previous.version,
                stage.version()
            ));
        }
        // An empty string would read as nothing at all.
        let shown = |text: &str| {
            if text.is_empty() {
                "\"\"".to_string()
            } else {
                text.to_string()
            }
        };
        for (name, value) in &instance.params {
            let value = value.to_string();
            match previous.params.get(name) {
                Some(old) if *old == value => {}
                Some(old) => reasons.push(format!(
                    "parameter `{name}` changed {} → {}",
                    shown(old),
                    shown(&value)
                )),
                None => reasons.push(format!("parameter `{name}` is new ({})", shown(&value))),
            }
        }
        for (port, artifacts) in inputs {
            let old = previous.inputs.get(port).map_or(&[][..], Vec::as_slice);
            if old.len() != artifacts.len() {
                reasons.push(format!(
                    "input `{port}` now has {} artifacts (was {})",
                    artifacts.len(),
                    old.len()
                ));
                continue;
            }
            for (artifact, (old_reference, old_digest)) in artifacts.iter().zip(old) {
                match artifact.digest {
                    None => reasons.push(format!("input `{}` is recomputed", artifact.reference)),
                    Some(digest)
                        if digest != *old_digest || artifact.reference != *old_reference =>
                    {
                        reasons.push(format!("input `{}` changed", artifact.reference))
                    }
                    Some(_) => {}
                }
            }
        }
        reasons
    }

    /// The record of an instance that ran or was found cached.
    pub fn record_of(
        &self,
        idx: usize,
        key: Digest,
        inputs: &ResolvedInputs,
        outputs: &BTreeMap<String, Digest>,
    ) -> InstanceRecord {
        let instance = &self.instances.list[idx];
        let stage = &self.study.stages[instance.stage].stage;
        InstanceRecord {
            kind: stage.kind().into(),
            version: stage.version(),
            key,
            params: instance
                .params
                .iter()
                .map(|(name, value)| (name.clone(), value.to_string()))
                .collect(),
            inputs: inputs
                .iter()
                .map(|(port, artifacts)| {
                    let known = artifacts
                        .iter()
                        .filter_map(|artifact| Some((artifact.reference.clone(), artifact.digest?)))
                        .collect();
                    (port.clone(), known)
                })
                .collect(),
            outputs: outputs.clone(),
        }
    }
}

/// One line of `squeal plan`.
#[derive(Debug, Clone)]
pub struct PlanLine {
    pub instance: String,
    pub decision: Decision,
}

/// Walks the instances in order; an instance whose upstream runs cannot be known cached.
pub fn plan(context: &Context) -> Vec<PlanLine> {
    plan_knowing(context, vec![None; context.instances.list.len()])
}

/// [`plan`], given the outputs of instances settled already (by index), which may not be
/// cached (a stage that is not pure).
pub fn plan_knowing(
    context: &Context,
    mut known: Vec<Option<BTreeMap<String, Digest>>>,
) -> Vec<PlanLine> {
    let mut lines = Vec::with_capacity(known.len());
    for idx in 0..context.instances.list.len() {
        let inputs = context.resolve_inputs(idx, &|up| known[up].clone());
        if known[idx].is_some() {
            // Settled in this run: the plan says cached, for a stage that is not pure too.
            if let Some(key) = context.key(idx, &inputs) {
                lines.push(PlanLine {
                    instance: context.instances.list[idx].name.clone(),
                    decision: Decision::Cached {
                        key,
                        outputs: known[idx].clone().expect("known"),
                        compute_s: 0.0,
                    },
                });
                continue;
            }
        }
        let decision = context.decide(idx, &inputs);
        if let Decision::Cached { outputs, .. } = &decision {
            known[idx] = Some(outputs.clone());
        }
        lines.push(PlanLine {
            instance: context.instances.list[idx].name.clone(),
            decision,
        });
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::Registry;

    const STUDY: &str = "\
stages:
  source:
    kind: test.constant
    params: { value: 2.0 }
  scaled:
    kind: test.affine
    inputs: { table: source.table }
";

    /// The plan lines of STUDY, run against `record` on an empty cache.
    fn plan_with(record: &RunRecord) -> Vec<String> {
        let registry = Registry::new(squeal_stages::test_kinds());
        let study = Study::from_text(
            "s.yaml",
            "s",
            STUDY,
            std::path::Path::new("."),
            &registry,
            &[],
        )
        .unwrap();
        let instances = Instances::expand(&study, &study.targets);
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let context = Context {
            study: &study,
            instances: &instances,
            cache: &cache,
            record,
        };
        plan(&context)
            .into_iter()
            .map(|line| format!("{} {}", line.instance, line.decision.describe()))
            .collect()
    }

    fn previous(kind: &str, version: u32, params: &[(&str, &str)]) -> InstanceRecord {
        InstanceRecord {
            kind: kind.into(),
            version,
            key: Digest::of(b"old key"),
            params: params
                .iter()
                .map(|(name, value)| (name.to_string(), value.to_string()))
                .collect(),
            inputs: BTreeMap::new(),
            outputs: BTreeMap::new(),
        }
    }

    #[test]
    fn reasons_name_what_changed_since_the_recorded_run() {
        assert_eq!(
            plan_with(&RunRecord::default()),
            ["source runs: new", "scaled runs: new"]
        );
        let mut record = RunRecord::default();
        record.instances.insert(
            "source".into(),
            previous("test.constant", 0, &[("value", "2"), ("rows", "1")]),
        );
        record
            .instances
            .insert("scaled".into(), previous("test.round", 1, &[]));
        assert_eq!(
            plan_with(&record),
            [
                "source runs: stage version changed 0 → 1",
                "scaled runs: kind changed test.round → test.affine; parameter `offset` is new (0); \
                 parameter `scale` is new (1); input `table` now has 1 artifacts (was 0)",
            ]
        );
        record.instances.insert(
            "source".into(),
            previous("test.constant", 1, &[("value", "2.5"), ("rows", "1")]),
        );
        assert_eq!(
            plan_with(&record)[0],
            "source runs: parameter `value` changed 2.5 → 2"
        );
        record.instances.insert(
            "source".into(),
            previous("test.constant", 1, &[("value", "2"), ("rows", "1")]),
        );
        assert_eq!(plan_with(&record)[0], "source runs: not in cache");
    }
}
