//! The stage contract: what a stage declares (parameters, typed inputs and outputs) and its
//! pure `run`.
//!
//! Parameters are SI throughout; a parameter's unit is part of its declaration, and the engine
//! converts values written with a unit (`40 mm`, `17 kHz`) before a stage sees them.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use crate::artifact::{Artifact, ArtifactType, ArtifactValue};

/// A parameter value after validation and unit conversion.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(value) => write!(f, "{value}"),
            Value::Int(value) => write!(f, "{value}"),
            // `{}` prints the shortest representation that round-trips.
            Value::Float(value) => write!(f, "{value}"),
            Value::Str(value) => f.write_str(value),
        }
    }
}

/// The type of a declared parameter.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamType {
    Bool,
    Int {
        min: i64,
    },
    Float {
        min: f64,
    },
    Str,
    /// A list, kept as one string with its items comma-separated; written as a YAML list
    /// (`[35, 36]`) or as that string (`"35, 36"`).
    List,
    /// A file path. The engine makes a relative path absolute: relative to the study's folder
    /// when written in the study, to the working directory when given on the command line.
    Path,
    /// One of a fixed set of names (solver methods, window functions, ...).
    Choice(&'static [&'static str]),
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamType::Bool => f.write_str("bool"),
            ParamType::Int { min } if *min > i64::MIN => write!(f, "int >= {min}"),
            ParamType::Int { .. } => f.write_str("int"),
            ParamType::Float { min } if min.is_finite() => write!(f, "float >= {min}"),
            ParamType::Float { .. } => f.write_str("float"),
            ParamType::Str => f.write_str("string"),
            ParamType::List => f.write_str("list"),
            ParamType::Path => f.write_str("path"),
            ParamType::Choice(names) => write!(f, "one of {}", names.join(" | ")),
        }
    }
}

/// A declared parameter: name, type, default, SI unit ("" if dimensionless), one-line doc.
#[derive(Debug, Clone)]
pub struct ParamSpec {
    pub name: &'static str,
    pub ty: ParamType,
    /// `None` makes the parameter required.
    pub default: Option<Value>,
    pub unit: &'static str,
    pub doc: &'static str,
}

impl ParamSpec {
    pub fn float(name: &'static str, default: f64, unit: &'static str, doc: &'static str) -> Self {
        let ty = ParamType::Float {
            min: f64::NEG_INFINITY,
        };
        let default = Some(Value::Float(default));
        ParamSpec {
            name,
            ty,
            default,
            unit,
            doc,
        }
    }

    pub fn int(name: &'static str, default: i64, doc: &'static str) -> Self {
        let ty = ParamType::Int { min: i64::MIN };
        ParamSpec {
            name,
            ty,
            default: Some(Value::Int(default)),
            unit: "",
            doc,
        }
    }

    /// A string; chain [`ParamSpec::required`] for one without a default.
    pub fn string(name: &'static str, default: &str, doc: &'static str) -> Self {
        let default = Some(Value::Str(default.to_string()));
        ParamSpec {
            name,
            ty: ParamType::Str,
            default,
            unit: "",
            doc,
        }
    }

    /// A list (see [`ParamType::List`]); its default is written comma-separated.
    pub fn list(name: &'static str, default: &str, doc: &'static str) -> Self {
        ParamSpec {
            ty: ParamType::List,
            ..ParamSpec::string(name, default, doc)
        }
    }

    /// A required file path (see [`ParamType::Path`]).
    pub fn path(name: &'static str, doc: &'static str) -> Self {
        ParamSpec {
            name,
            ty: ParamType::Path,
            default: None,
            unit: "",
            doc,
        }
    }

    /// A file path that may be left out (empty by default).
    pub fn optional_path(name: &'static str, doc: &'static str) -> Self {
        ParamSpec {
            default: Some(Value::Str(String::new())),
            ..ParamSpec::path(name, doc)
        }
    }

    pub fn bool(name: &'static str, default: bool, doc: &'static str) -> Self {
        ParamSpec {
            name,
            ty: ParamType::Bool,
            default: Some(Value::Bool(default)),
            unit: "",
            doc,
        }
    }

    pub fn choice(
        name: &'static str,
        choices: &'static [&'static str],
        default: &'static str,
        doc: &'static str,
    ) -> Self {
        let default = Some(Value::Str(default.to_string()));
        ParamSpec {
            name,
            ty: ParamType::Choice(choices),
            default,
            unit: "",
            doc,
        }
    }

    /// Lower bound (inclusive) for a numeric parameter.
    pub fn at_least(mut self, bound: f64) -> Self {
        self.ty = match self.ty {
            ParamType::Float { .. } => ParamType::Float { min: bound },
            ParamType::Int { .. } => ParamType::Int { min: bound as i64 },
            other => other,
        };
        self
    }

    pub fn required(mut self) -> Self {
        self.default = None;
        self
    }
}

/// How many artifacts an input port takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// One artifact; a swept upstream makes this stage fan out, one instance per point.
    One,
    /// Every point of a swept upstream at once, each with its sweep coordinates (a gather).
    Many,
}

/// A declared input or output.
#[derive(Debug, Clone)]
pub struct PortSpec {
    pub name: &'static str,
    pub ty: ArtifactType,
    pub arity: Arity,
    /// An input a study may leave unconnected (outputs are never optional).
    pub optional: bool,
    pub doc: &'static str,
}

impl PortSpec {
    pub fn one(name: &'static str, ty: ArtifactType, doc: &'static str) -> Self {
        PortSpec {
            name,
            ty,
            arity: Arity::One,
            optional: false,
            doc,
        }
    }

    pub fn many(name: &'static str, ty: ArtifactType, doc: &'static str) -> Self {
        PortSpec {
            name,
            ty,
            arity: Arity::Many,
            optional: false,
            doc,
        }
    }

    /// This input may be left unconnected; the stage reads it with [`Inputs::get_optional`].
    pub fn optional(mut self) -> Self {
        self.optional = true;
        self
    }
}

/// Sweep coordinates of a stage instance: swept parameter name and value, in sweep order.
pub type Coords = Vec<(String, Value)>;

/// Validated parameters of one stage instance: every declared parameter is present and typed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params(pub BTreeMap<String, Value>);

impl Params {
    /// The parameters of `stage` at their defaults, with `overrides` (for callers that run a
    /// stage directly: tests and benchmarks).
    pub fn defaults(stage: &dyn Stage, overrides: &[(&str, Value)]) -> Params {
        let mut values: BTreeMap<String, Value> = stage
            .params()
            .into_iter()
            .filter_map(|spec| Some((spec.name.to_string(), spec.default?)))
            .collect();
        for (name, value) in overrides {
            values.insert(name.to_string(), value.clone());
        }
        Params(values)
    }

    fn get(&self, name: &str) -> &Value {
        self.0
            .get(name)
            .unwrap_or_else(|| panic!("parameter `{name}` is not declared by this stage"))
    }

    pub fn float(&self, name: &str) -> f64 {
        match self.get(name) {
            Value::Float(value) => *value,
            Value::Int(value) => *value as f64,
            other => panic!("parameter `{name}` is not a number: {other}"),
        }
    }

    pub fn int(&self, name: &str) -> i64 {
        match self.get(name) {
            Value::Int(value) => *value,
            other => panic!("parameter `{name}` is not an integer: {other}"),
        }
    }

    pub fn bool(&self, name: &str) -> bool {
        match self.get(name) {
            Value::Bool(value) => *value,
            other => panic!("parameter `{name}` is not a bool: {other}"),
        }
    }

    /// The parameters read into a stage's typed struct, whose field names are the declared
    /// names. Declare the struct `#[serde(deny_unknown_fields)]`: a name spelt differently in
    /// the struct and in [`Stage::params`] is then an error (missing or unknown field), which
    /// the test of every kind's [`Stage::check_params`] catches before any study runs.
    pub fn typed<T: serde::de::DeserializeOwned>(&self) -> Result<T, StageError> {
        let fields = self
            .0
            .iter()
            .map(|(name, value)| {
                let value = match value {
                    Value::Bool(value) => serde_json::Value::from(*value),
                    Value::Int(value) => serde_json::Value::from(*value),
                    Value::Float(value) => serde_json::Value::from(*value),
                    Value::Str(value) => serde_json::Value::from(value.as_str()),
                };
                (name.clone(), value)
            })
            .collect();
        serde_json::from_value(serde_json::Value::Object(fields))
            .map_err(|err| StageError::new(format!("parameters: {err}")))
    }

    pub fn str(&self, name: &str) -> &str {
        match self.get(name) {
            Value::Str(value) => value,
            other => panic!("parameter `{name}` is not a string: {other}"),
        }
    }
}

/// What an input port receives.
#[derive(Debug, Clone)]
pub enum Input {
    One(Arc<Artifact>),
    Many(Vec<(Coords, Arc<Artifact>)>),
}

/// The inputs of one run, by port name.
#[derive(Debug, Clone, Default)]
pub struct Inputs(pub BTreeMap<String, Input>);

impl Inputs {
    pub fn one(&self, port: &str) -> Result<&Artifact, StageError> {
        match self.0.get(port) {
            Some(Input::One(artifact)) => Ok(artifact),
            Some(Input::Many(_)) => Err(StageError::new(format!("input `{port}` is a gather"))),
            None => Err(StageError::new(format!("input `{port}` is missing"))),
        }
    }

    pub fn many(&self, port: &str) -> Result<&[(Coords, Arc<Artifact>)], StageError> {
        match self.0.get(port) {
            Some(Input::Many(points)) => Ok(points),
            Some(Input::One(_)) => Err(StageError::new(format!("input `{port}` is not a gather"))),
            None => Err(StageError::new(format!("input `{port}` is missing"))),
        }
    }

    /// The value of a one-artifact input, typed: `inputs.get::<Model>("model")`.
    pub fn get<T: ArtifactValue>(&self, port: &str) -> Result<&T, StageError> {
        let artifact = self.one(port)?;
        T::from_artifact(artifact).ok_or_else(|| {
            StageError::new(format!(
                "input `{port}` is {}, expected {}",
                artifact.artifact_type(),
                T::TYPE
            ))
        })
    }

    pub fn table(&self, port: &str) -> Result<&crate::Table, StageError> {
        self.get(port)
    }

    /// An optional input: `None` when the study leaves it unconnected.
    pub fn get_optional<T: ArtifactValue>(&self, port: &str) -> Result<Option<&T>, StageError> {
        if self.0.contains_key(port) {
            self.get(port).map(Some)
        } else {
            Ok(None)
        }
    }
}

/// The outputs of one run, by port name.
pub type Outputs = BTreeMap<String, Artifact>;

/// Why a stage failed: a one-line message with the figures that matter
/// (residual, iteration count, offending element).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct StageError {
    pub message: String,
}

impl From<squeal_linalg::Error> for StageError {
    fn from(err: squeal_linalg::Error) -> Self {
        StageError::new(err.to_string())
    }
}

impl StageError {
    pub fn new(message: impl Into<String>) -> Self {
        StageError {
            message: message.into(),
        }
    }
}

/// Where a long stage reports how far it is: a fraction in [0, 1] and a short message (the
/// engine shows them as a progress bar with an estimate of the time left). Reports are cheap;
/// the sink decides how often to draw.
#[derive(Clone, Default)]
pub struct Progress {
    sink: Option<Arc<ProgressSink>>,
}

/// What receives the reports: `(fraction, message)`.
type ProgressSink = dyn Fn(f64, &str) + Send + Sync;

impl Progress {
    /// Reports go nowhere.
    pub fn none() -> Progress {
        Progress { sink: None }
    }

    pub fn new(sink: impl Fn(f64, &str) + Send + Sync + 'static) -> Progress {
        Progress {
            sink: Some(Arc::new(sink)),
        }
    }

    pub fn report(&self, fraction: f64, message: &str) {
        if let Some(sink) = &self.sink {
            sink(fraction.clamp(0.0, 1.0), message);
        }
    }
}

impl fmt::Debug for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.sink.is_some() {
            "Progress(reporting)"
        } else {
            "Progress(none)"
        })
    }
}

/// Where a long stage keeps its state so that a run killed part-way resumes on the next
/// `squeal run`. The engine keeps the latest checkpoint of a stage instance in the cache, under
/// its cache key (same parameters, inputs and version), verified like every entry, and
/// discards it once the stage has finished. A stage must resume to the very bytes an
/// uninterrupted run gives: it saves its whole state, and what it does not save it recomputes
/// exactly.
pub trait Checkpoints: Send + Sync {
    /// The latest checkpoint of this stage instance, if any.
    fn load(&self) -> Option<Vec<u8>>;
    /// Whether a checkpoint is due (the store sets the cadence).
    fn due(&self) -> bool;
    /// Keeps `state` as the latest checkpoint; a failure to keep it only loses the resume.
    fn save(&self, state: &[u8]);
}

/// No checkpoints: nothing to resume from, none due.
pub struct NoCheckpoints;

impl Checkpoints for NoCheckpoints {
    fn load(&self) -> Option<Vec<u8>> {
        None
    }
    fn due(&self) -> bool {
        false
    }
    fn save(&self, _state: &[u8]) {}
}

/// What the engine gives a running stage besides its parameters and inputs.
pub struct RunContext<'a> {
    pub progress: &'a Progress,
    pub checkpoints: &'a dyn Checkpoints,
}

impl RunContext<'_> {
    /// No progress shown, no checkpoints.
    pub fn detached() -> RunContext<'static> {
        static NONE: Progress = Progress { sink: None };
        RunContext {
            progress: &NONE,
            checkpoints: &NoCheckpoints,
        }
    }
}

/// Where an executor that spreads a study over a cluster runs a stage's instances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// Beside the engine, in the process that plans the run: stages that take seconds (meshes,
    /// assembly, gathers, figures, exports), where a job would cost more than it saves.
    Driver,
    /// As a job of its own, with the resources below: stages that take minutes.
    Job,
}

/// What a stage's instance typically needs: where it runs, how many threads it keeps busy and
/// its memory, sized for the default brake (about 30,000 DOFs). Requests for a scheduler, not
/// limits the stage enforces; a study overrides them per stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resources {
    pub placement: Placement,
    pub threads: u32,
    pub memory_mb: u64,
}

impl Resources {
    /// Seconds of work: runs in the driver.
    pub const LIGHT: Resources = Resources {
        placement: Placement::Driver,
        threads: 1,
        memory_mb: 1024,
    };

    /// Minutes of work: a job with `threads` cores and `memory_mb` megabytes.
    pub const fn job(threads: u32, memory_mb: u64) -> Resources {
        Resources {
            placement: Placement::Job,
            threads,
            memory_mb,
        }
    }
}

/// A kind of stage. Implementations are pure: `run` is a deterministic function of the
/// parameters and inputs. A stage that is not (reads the clock, a file outside the study)
/// returns `false` from [`Stage::pure`] and is never cached.
pub trait Stage: Send + Sync {
    /// The `kind:` written in a study, e.g. `mesh.brake`.
    fn kind(&self) -> &'static str;
    /// Bumped whenever the implementation changes its results; part of the cache key.
    fn version(&self) -> u32;
    /// One line for `squeal stages`.
    fn doc(&self) -> &'static str;
    fn params(&self) -> Vec<ParamSpec>;
    fn inputs(&self) -> Vec<PortSpec>;
    fn outputs(&self) -> Vec<PortSpec>;
    /// Outputs renamed since the last release, `(old, new)`: a study naming the old one still
    /// loads, with a warning, until the release after.
    fn renamed_outputs(&self) -> &'static [(&'static str, &'static str)] {
        &[]
    }
    fn pure(&self) -> bool {
        true
    }
    /// Where a cluster executor runs the stage and what it asks for; [`Resources::LIGHT`]
    /// unless the stage takes minutes.
    fn resources(&self) -> Resources {
        Resources::LIGHT
    }
    /// Reads `params` into the stage's typed parameter struct ([`Params::typed`]), as `run`
    /// does first. Stages that read their parameters that way override it, so that the test
    /// of every kind catches a parameter the struct and the declaration name differently.
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        let _ = params;
        Ok(())
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError>;
    /// [`Stage::run`] with progress reports and checkpoints; what the engine calls. Long
    /// stages override it (and implement `run` as this with [`RunContext::detached`]).
    fn run_with(
        &self,
        params: &Params,
        inputs: &Inputs,
        context: &RunContext,
    ) -> Result<Outputs, StageError> {
        let _ = context;
        self.run(params, inputs)
    }
}

/// Asserts that `stage` gives the same output bytes on 2 and 3 threads as on 1: the cache keys
/// downstream work by them.
#[cfg(test)]
pub(crate) fn assert_outputs_independent_of_threads(
    stage: &dyn Stage,
    params: &Params,
    inputs: &Inputs,
    what: &str,
) {
    let encoded = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| stage.run(params, inputs).unwrap())
            .iter()
            .map(|(name, artifact)| (name.clone(), artifact.encode()))
            .collect::<Vec<_>>()
    };
    let one = encoded(1);
    for threads in [2, 3] {
        assert!(
            one == encoded(threads),
            "{what}: outputs differ on {threads} threads"
        );
    }
}
