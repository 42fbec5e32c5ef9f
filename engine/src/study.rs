//! A validated study: every kind known, every parameter typed and in SI, every reference
//! resolved to a typed output, no cycle. Nothing runs before this succeeds.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use petgraph::graph::{DiGraph, NodeIndex};
use serde_saphyr::Spanned;
use squeal_contract::{Arity, ParamSpec, ParamType, PortSpec, Stage, Value};

use crate::resources::{JobDefaults, StageResources};
use crate::spec::{self, Located, Location, RawInput, RawStage, RawSweep, RawValue, SpecError};
use crate::units;

/// The stage kinds a study may use, by kind name.
#[derive(Default, Clone)]
pub struct Registry {
    kinds: BTreeMap<&'static str, Arc<dyn Stage>>,
}

impl Registry {
    pub fn new(kinds: impl IntoIterator<Item = Arc<dyn Stage>>) -> Registry {
        Registry {
            kinds: kinds
                .into_iter()
                .map(|stage| (stage.kind(), stage))
                .collect(),
        }
    }

    pub fn get(&self, kind: &str) -> Option<&Arc<dyn Stage>> {
        self.kinds.get(kind)
    }

    pub fn iter(&self) -> impl Iterator<Item = &Arc<dyn Stage>> {
        self.kinds.values()
    }
}

/// A `--set stage.param=value` override.
#[derive(Debug, Clone)]
pub struct Override {
    pub stage: String,
    pub param: String,
    pub value: RawValue,
    /// The argument as written, for error messages.
    pub arg: String,
}

impl std::str::FromStr for Override {
    type Err = SpecError;

    fn from_str(arg: &str) -> Result<Override, SpecError> {
        let error =
            |message: &str| SpecError::command_line(format!("--set {arg}"), "--set", message);
        let (target, text) = arg
            .split_once('=')
            .ok_or_else(|| error("expected stage.param=value"))?;
        let (stage, param) = target
            .split_once('.')
            .ok_or_else(|| error("expected stage.param=value"))?;
        if stage.is_empty() || param.is_empty() {
            return Err(error("expected stage.param=value"));
        }
        let value = spec::parse_value(text)
            .ok_or_else(|| error("the value is not a YAML scalar or list"))?;
        Ok(Override {
            stage: stage.into(),
            param: param.into(),
            value,
            arg: arg.into(),
        })
    }
}

#[derive(Debug, Clone)]
pub struct InputDecl {
    pub port: String,
    /// Index of the upstream stage in [`Study::stages`].
    pub from: usize,
    pub output: String,
    pub arity: Arity,
}

/// One stage of a study, validated.
#[derive(Clone)]
pub struct StageDecl {
    pub name: String,
    pub stage: Arc<dyn Stage>,
    /// Every declared parameter that is not swept, defaults filled in, SI.
    pub params: BTreeMap<String, Value>,
    /// Swept parameters and their values, in file order.
    pub matrix: Vec<(String, Vec<Value>)>,
    pub inputs: Vec<InputDecl>,
    /// Placement and requests for a cluster executor (`resources:`).
    pub resources: StageResources,
}

pub struct Study {
    /// The file as named in messages.
    pub file: String,
    pub name: String,
    pub description: String,
    /// In file order, which the engine keeps wherever order is visible.
    pub stages: Vec<StageDecl>,
    /// Indices of the target stages.
    pub targets: Vec<usize>,
    /// What every Slurm job asks for unless the command line or a stage says otherwise.
    pub slurm: JobDefaults,
    /// The study's folder, against which relative paths in the study resolve.
    pub folder: PathBuf,
}

impl Study {
    /// Reads, parses and validates a study file.
    pub fn load(
        path: &Path,
        registry: &Registry,
        overrides: &[Override],
    ) -> Result<Study, SpecError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|err| SpecError {
            location: Location::File {
                file: file.clone(),
                line: 1,
                col: 1,
            },
            path: "(file)".into(),
            message: format!("cannot read: {err}"),
        })?;
        let stem = path
            .file_stem()
            .map_or("study".into(), |stem| stem.to_string_lossy().into_owned());
        let folder = path.parent().unwrap_or(Path::new(""));
        let base_dir = std::path::absolute(folder).unwrap_or_else(|_| folder.to_path_buf());
        Study::from_text(&file, &stem, &text, &base_dir, registry, overrides)
    }

    /// Validates a study's text. `file` names it in messages; relative paths in it resolve
    /// against `base_dir`.
    pub fn from_text(
        file: &str,
        default_name: &str,
        text: &str,
        base_dir: &Path,
        registry: &Registry,
        overrides: &[Override],
    ) -> Result<Study, SpecError> {
        let raw = spec::parse(file, text)?;
        let stage_index: HashMap<&str, usize> = raw
            .stages
            .0
            .iter()
            .enumerate()
            .map(|(idx, (name, _))| (name.as_str(), idx))
            .collect();
        if raw.stages.0.is_empty() {
            return Err(SpecError {
                location: Location::File {
                    file: file.into(),
                    line: 1,
                    col: 1,
                },
                path: "stages".into(),
                message: "a study needs at least one stage".into(),
            });
        }
        for item in overrides {
            if !stage_index.contains_key(item.stage.as_str()) {
                return Err(SpecError {
                    location: Location::CommandLine(format!("--set {}", item.arg)),
                    path: "--set".into(),
                    message: format!("no stage named `{}`", item.stage),
                });
            }
        }
        let validator = Validator {
            file,
            base_dir,
            registry,
            raw_stages: &raw.stages.0,
            stage_index: &stage_index,
        };
        let mut stages = Vec::with_capacity(raw.stages.0.len());
        for (name, raw_stage) in &raw.stages.0 {
            let own_overrides: Vec<&Override> = overrides
                .iter()
                .filter(|item| item.stage == *name)
                .collect();
            stages.push(validator.stage(name, raw_stage, &own_overrides)?);
        }
        let targets = match &raw.targets {
            None => (0..stages.len()).collect(),
            Some(targets) => targets
                .iter()
                .enumerate()
                .map(|(idx, target)| {
                    let target = spec::located(file, target.clone());
                    stage_index
                        .get(target.value.as_str())
                        .copied()
                        .ok_or_else(|| {
                            target.error(
                                format!("targets[{idx}]"),
                                format!("no stage named `{}`", target.value),
                            )
                        })
                })
                .collect::<Result<_, _>>()?,
        };
        check_acyclic(file, &raw.stages.0, &stages)?;
        let slurm = match &raw.slurm {
            Some(section) => JobDefaults::from_raw(file, section)?,
            None => JobDefaults::default(),
        };
        Ok(Study {
            slurm,
            folder: base_dir.to_path_buf(),
            file: file.into(),
            name: raw.study.unwrap_or_else(|| default_name.into()),
            description: raw.description,
            stages,
            targets,
        })
    }

    /// Stage indices by name.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.stages.iter().position(|stage| stage.name == name)
    }

    /// A swept value as the stage receives it: a path resolved against the study's folder, like
    /// a path in `params` (the instance keeps the value as written, for its name and folder).
    pub fn swept_value(&self, stage: usize, param: &str, value: &Value) -> Value {
        let is_path = self.stages[stage]
            .stage
            .params()
            .iter()
            .any(|spec| spec.name == param && spec.ty == ParamType::Path);
        match value {
            Value::Str(path) if is_path => Value::Str(resolved(&self.folder, path)),
            _ => value.clone(),
        }
    }
}

/// `path` against `base` (an absolute `path` stays as it is).
fn resolved(base: &Path, path: &str) -> String {
    base.join(path).display().to_string()
}

/// What checking one stage needs to know of the whole study.
struct Validator<'a> {
    file: &'a str,
    /// The study's folder, against which relative paths in the study resolve.
    base_dir: &'a Path,
    registry: &'a Registry,
    raw_stages: &'a [(String, RawStage)],
    stage_index: &'a HashMap<&'a str, usize>,
}

impl Validator<'_> {
    fn resolve_path(&self, path: &str, location: &Location) -> String {
        let base = match location {
            Location::File { .. } => self.base_dir.to_path_buf(),
            Location::CommandLine(_) => std::env::current_dir().unwrap_or_default(),
        };
        resolved(&base, path)
    }

    fn stage(
        &self,
        name: &str,
        raw: &RawStage,
        overrides: &[&Override],
    ) -> Result<StageDecl, SpecError> {
        let Validator { file, registry, .. } = *self;
        let path = format!("stages.{name}");
        let kind = spec::located(file, raw.kind.clone());
        let stage = registry.get(&kind.value).cloned().ok_or_else(|| {
            let hint = match closest(&kind.value, registry.iter().map(|stage| stage.kind())) {
                Some(known) => format!("did you mean `{known}`? "),
                None => String::new(),
            };
            kind.error(
                format!("{path}.kind"),
                format!(
                    "unknown stage kind `{}` ({hint}`squeal stages` lists them all)",
                    kind.value
                ),
            )
        })?;
        let specs = stage.params();
        let find_spec = |param: &str, located: &dyn Fn(String) -> SpecError| {
            specs.iter().find(|spec| spec.name == param).ok_or_else(|| {
                let known: Vec<&str> = specs.iter().map(|spec| spec.name).collect();
                let known = if known.is_empty() {
                    "none".into()
                } else {
                    known.join(", ")
                };
                located(format!(
                    "`{}` has no parameter `{param}` (parameters: {known})",
                    kind.value
                ))
            })
        };

        // Written values: the file's params, then --set overrides on top.
        let mut written: Vec<(String, Located<RawValue>)> = raw
            .params
            .0
            .iter()
            .map(|(param, value)| (param.clone(), spec::located(file, value.clone())))
            .collect();
        for item in overrides {
            let located = Located {
                value: item.value.clone(),
                location: Location::CommandLine(format!("--set {}", item.arg)),
            };
            match written.iter_mut().find(|(param, _)| *param == item.param) {
                Some((_, slot)) => *slot = located,
                None => written.push((item.param.clone(), located)),
            }
        }
        let mut params = BTreeMap::new();
        for (param, value) in &written {
            let param_path = format!("{path}.params.{param}");
            let spec = find_spec(param, &|message| value.error(&param_path, message))?;
            let mut converted = units::convert(spec, &value.value)
                .map_err(|message| value.error(&param_path, message))?;
            if let (ParamType::Path, Value::Str(path)) = (&spec.ty, &converted) {
                converted = Value::Str(self.resolve_path(path, &value.location));
            }
            stage
                .check_param(param, &converted)
                .map_err(|message| value.error(&param_path, message))?;
            params.insert(param.clone(), converted);
        }

        let mut matrix = Vec::new();
        for (param, sweep) in &raw.matrix.0 {
            let sweep_path = format!("{path}.matrix.{param}");
            let sweep: Located<RawSweep> = spec::located(file, sweep.clone());
            let spec = find_spec(param, &|message| sweep.error(&sweep_path, message))?;
            if params.contains_key(param) {
                return Err(sweep.error(
                    &sweep_path,
                    format!("`{param}` is both set in params and swept"),
                ));
            }
            let values = sweep_values(spec, &sweep.value)
                .map_err(|message| sweep.error(&sweep_path, message))?;
            for (idx, value) in values.iter().enumerate() {
                stage.check_param(param, value).map_err(|message| {
                    sweep.error(&sweep_path, format!("value {idx}: {message}"))
                })?;
            }
            matrix.push((param.clone(), values));
            let points = matrix.iter().fold(1usize, |points, (_, values)| {
                points.saturating_mul(values.len())
            });
            if points > MAX_MATRIX_POINTS {
                return Err(sweep.error(
                    &sweep_path,
                    format!(
                        "the matrix crosses {points} points: a stage takes at most {MAX_MATRIX_POINTS} (split the study)"
                    ),
                ));
            }
        }
        for spec in &specs {
            let swept = matrix.iter().any(|(param, _)| param == spec.name);
            if !params.contains_key(spec.name) && !swept {
                match &spec.default {
                    Some(default) => {
                        params.insert(spec.name.to_string(), default.clone());
                    }
                    None => {
                        return Err(kind
                            .error(&path, format!("missing required parameter `{}`", spec.name)));
                    }
                }
            }
        }

        let inputs = self.inputs(&path, &kind, stage.as_ref(), raw)?;
        let resources = match &raw.resources {
            Some(resources) => StageResources::from_raw(file, name, resources)?,
            None => StageResources::default(),
        };
        Ok(StageDecl {
            name: name.into(),
            stage,
            params,
            matrix,
            inputs,
            resources,
        })
    }

    fn inputs(
        &self,
        path: &str,
        kind: &Located<String>,
        stage: &dyn Stage,
        raw: &RawStage,
    ) -> Result<Vec<InputDecl>, SpecError> {
        let file = self.file;
        let ports = stage.inputs();
        let mut inputs = Vec::new();
        for (port_name, connection) in &raw.inputs.0 {
            let input_path = format!("{path}.inputs.{port_name}");
            let connection = spec::located(file, connection.clone());
            let port = ports
                .iter()
                .find(|port| port.name == port_name)
                .ok_or_else(|| {
                    let known: Vec<&str> = ports.iter().map(|port| port.name).collect();
                    let known = if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    };
                    connection.error(
                        &input_path,
                        format!(
                            "`{}` has no input `{port_name}` (inputs: {known})",
                            kind.value
                        ),
                    )
                })?;
            let references = match (&connection.value, port.arity) {
                (RawInput::One(reference), _) => vec![Located {
                    location: connection.location.clone(),
                    value: reference.clone(),
                }],
                (RawInput::List(references), Arity::List) => {
                    if references.is_empty() {
                        return Err(connection.error(&input_path, "the list is empty"));
                    }
                    references
                        .iter()
                        .map(|reference| spec::located(file, reference.clone()))
                        .collect()
                }
                (RawInput::List(_), _) => {
                    return Err(connection.error(
                        &input_path,
                        format!("input `{port_name}` takes one `stage.output`, not a list"),
                    ));
                }
            };
            for (item, reference) in references.iter().enumerate() {
                let item_path = match connection.value {
                    RawInput::One(_) => input_path.clone(),
                    RawInput::List(_) => format!("{input_path}[{item}]"),
                };
                let (from, output) = self.resolve(&item_path, reference, port)?;
                if inputs
                    .iter()
                    .any(|input: &InputDecl| input.port == port.name && input.from == from)
                {
                    return Err(reference
                        .error(&item_path, format!("`{}` is listed twice", reference.value)));
                }
                inputs.push(InputDecl {
                    port: port_name.clone(),
                    from,
                    output,
                    arity: port.arity,
                });
            }
        }
        for port in ports.iter().filter(|port| !port.optional) {
            if !inputs.iter().any(|input| input.port == port.name) {
                return Err(kind.error(
                    path,
                    format!("missing input `{}` ({})", port.name, port.doc),
                ));
            }
        }
        Ok(inputs)
    }

    /// The upstream stage and output that `reference` (`stage.output`) names, checked against
    /// the port it feeds.
    fn resolve(
        &self,
        input_path: &str,
        reference: &Located<String>,
        port: &PortSpec,
    ) -> Result<(usize, String), SpecError> {
        let Validator {
            registry,
            raw_stages,
            stage_index,
            ..
        } = *self;
        let port_name = port.name;
        let (from_name, output) = reference
            .value
            .split_once('.')
            .ok_or_else(|| reference.error(input_path, "expected `stage.output`"))?;
        let from = *stage_index
            .get(from_name)
            .ok_or_else(|| reference.error(input_path, format!("no stage named `{from_name}`")))?;
        let mut output = output;
        // The upstream kind was validated or will be: look it up without failing twice.
        if let Some(upstream) = registry.get(&raw_stages[from].1.kind.value) {
            if let Some((_, new)) = upstream
                .renamed_outputs()
                .iter()
                .find(|(old, _)| *old == output)
            {
                let message = format!(
                    "output `{from_name}.{output}` is now `{from_name}.{new}`; \
                     the old name is read until the next release"
                );
                tracing::warn!("{}", reference.error(input_path, message));
                output = new;
            }
            let out = crate::ports::outputs_of(upstream.as_ref())
                .find(|out| out.name == output)
                .ok_or_else(|| {
                    let known: Vec<&str> = upstream.outputs().iter().map(|out| out.name).collect();
                    reference.error(
                        input_path,
                        format!(
                            "stage `{from_name}` has no output `{output}` (outputs: {})",
                            known.join(", ")
                        ),
                    )
                })?;
            if out.ty != port.ty {
                return Err(reference.error(
                    input_path,
                    format!(
                        "`{from_name}.{output}` is a {}, but input `{port_name}` takes a {}",
                        out.ty, port.ty
                    ),
                ));
            }
        }
        Ok((from, output.into()))
    }
}

/// Most values one swept parameter takes, and most points one stage's matrix crosses: beyond,
/// a study is more likely a typo than a plan, and expanding it alone would take minutes.
pub const MAX_SWEEP_VALUES: usize = 10_000;
pub const MAX_MATRIX_POINTS: usize = 100_000;

/// A range's point rounded to 12 significant digits: `mu=0.1` in names, folders and keys, not
/// the `0.09999999999999999` that `0 + 0.6/6` gives.
fn round_significant(value: f64) -> f64 {
    if value == 0.0 || !value.is_finite() {
        return value;
    }
    format!("{value:.11e}").parse().unwrap_or(value)
}

fn sweep_values(spec: &ParamSpec, sweep: &RawSweep) -> Result<Vec<Value>, String> {
    let count = match sweep {
        RawSweep::List(values) => values.len(),
        RawSweep::Range(range) => range.num,
    };
    if count > MAX_SWEEP_VALUES {
        return Err(format!(
            "{count} values: a sweep takes at most {MAX_SWEEP_VALUES} (split the study)"
        ));
    }
    let raw_values: Vec<RawValue> = match sweep {
        RawSweep::List(values) => values.clone(),
        RawSweep::Range(range) => {
            if range.num == 1 {
                vec![RawValue::Float(range.start)]
            } else {
                let step = (range.stop - range.start) / (range.num - 1) as f64;
                (0..range.num)
                    .map(|idx| RawValue::Float(round_significant(range.start + step * idx as f64)))
                    .collect()
            }
        }
    };
    if raw_values.is_empty() {
        return Err("empty sweep: give at least one value".into());
    }
    let values: Vec<Value> = raw_values
        .iter()
        .enumerate()
        .map(|(idx, raw)| {
            units::convert(spec, raw).map_err(|message| format!("value {idx}: {message}"))
        })
        .collect::<Result<_, _>>()?;
    for (idx, value) in values.iter().enumerate() {
        if values[..idx].contains(value) {
            return Err(format!("value {idx} ({value}) is repeated"));
        }
    }
    Ok(values)
}

/// A cycle is an error naming its stages in order, at the first stage's `kind:`.
fn check_acyclic(
    file: &str,
    raw_stages: &[(String, RawStage)],
    stages: &[StageDecl],
) -> Result<(), SpecError> {
    let mut graph = DiGraph::<usize, ()>::with_capacity(stages.len(), stages.len());
    let nodes: Vec<NodeIndex> = (0..stages.len()).map(|idx| graph.add_node(idx)).collect();
    for (idx, stage) in stages.iter().enumerate() {
        for input in &stage.inputs {
            graph.update_edge(nodes[input.from], nodes[idx], ());
        }
    }
    let Err(cycle) = petgraph::algo::toposort(&graph, None) else {
        return Ok(());
    };
    // Walk upstream from the reported node until a stage repeats: that loop is the cycle.
    let mut walk = vec![graph[cycle.node_id()]];
    loop {
        let current = *walk.last().expect("walk is never empty");
        let next = stages[current]
            .inputs
            .iter()
            .map(|input| input.from)
            .find(|from| reaches(&graph, nodes[current], nodes[*from]))
            .expect("a stage on a cycle has an input on the cycle");
        if let Some(start) = walk.iter().position(|&idx| idx == next) {
            let mut cycle: Vec<&str> = walk[start..]
                .iter()
                .rev()
                .map(|&idx| stages[idx].name.as_str())
                .collect();
            cycle.push(cycle[0]);
            let first = walk[start..]
                .iter()
                .copied()
                .min()
                .expect("cycle is not empty");
            let kind: Spanned<String> = raw_stages[first].1.kind.clone();
            return Err(spec::located(file, kind).error(
                format!("stages.{}", stages[first].name),
                format!("cycle: {}", cycle.join(" -> ")),
            ));
        }
        walk.push(next);
    }
}

/// Whether `to` reaches `from` back, i.e. the edge from → to lies on a cycle.
fn reaches(graph: &DiGraph<usize, ()>, from: NodeIndex, to: NodeIndex) -> bool {
    petgraph::algo::has_path_connecting(graph, from, to, None)
}

/// The candidate nearest to `word` by edit distance, if it is near enough to be a typo.
fn closest<'a>(word: &str, candidates: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    let distance = |a: &str, b: &str| {
        let b: Vec<char> = b.chars().collect();
        let mut previous: Vec<usize> = (0..=b.len()).collect();
        for (i, ca) in a.chars().enumerate() {
            let mut current = vec![i + 1];
            for (j, cb) in b.iter().enumerate() {
                current.push(
                    (previous[j] + usize::from(ca != *cb))
                        .min(previous[j + 1] + 1)
                        .min(current[j] + 1),
                );
            }
            previous = current;
        }
        previous[b.len()]
    };
    candidates
        .map(|candidate| (distance(word, candidate), candidate))
        .filter(|(edits, _)| *edits <= 2.max(word.len() / 4))
        .min()
        .map(|(_, candidate)| candidate)
}
