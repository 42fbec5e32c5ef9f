//! The stage contract: what a stage declares (parameters, typed inputs and outputs) and its
//! pure `run`.
//!
//! Parameters are SI throughout; a parameter's unit is part of its declaration, and the engine
//! converts values written with a unit (`40 mm`, `17 kHz`) before a stage sees them.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use crate::artifact::{Artifact, ArtifactType, ArtifactValue};
pub use crate::params::{DeclaredParams, HasParams, ParamSpec, ParamType, Params};
use crate::table::Table;
pub use crate::value::{Coords, StageError, Value};

/// How many artifacts an input port takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// One artifact; a swept upstream makes this stage fan out, one instance per point.
    One,
    /// Every point of a swept upstream at once, each with its sweep coordinates (a gather).
    Many,
    /// One artifact from each of the stages a study lists (`[steel.material, lining.material]`),
    /// in the list's order; each is joined as a one-artifact input is, so a swept one fans
    /// this stage out. Read with [`Inputs::many`], the coordinates empty unless a gather's.
    List,
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

    /// A port that takes a list of references (see [`Arity::List`]).
    pub fn list(name: &'static str, ty: ArtifactType, doc: &'static str) -> Self {
        PortSpec {
            arity: Arity::List,
            ..PortSpec::one(name, ty, doc)
        }
    }

    /// This input may be left unconnected; the stage reads it with [`Inputs::get_optional`].
    pub fn optional(mut self) -> Self {
        self.optional = true;
        self
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
            Some(Input::One(_)) => Err(StageError::new(format!(
                "input `{port}` is neither a gather nor a list"
            ))),
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

    pub fn table(&self, port: &str) -> Result<&Table, StageError> {
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

    /// The values of a list (or gather) input, typed, in the study's order; empty when the
    /// study leaves the port unconnected.
    pub fn get_list<T: ArtifactValue>(&self, port: &str) -> Result<Vec<&T>, StageError> {
        if !self.0.contains_key(port) {
            return Ok(Vec::new());
        }
        self.many(port)?
            .iter()
            .map(|(_, artifact)| {
                T::from_artifact(artifact).ok_or_else(|| {
                    StageError::new(format!(
                        "input `{port}` holds a {}, expected {}",
                        artifact.artifact_type(),
                        T::TYPE
                    ))
                })
            })
            .collect()
    }
}

/// The outputs of one run, by port name.
pub type Outputs = BTreeMap<String, Artifact>;

/// Wraps a table as the single output `name`, a common shape for stage results.
pub fn single_output(name: &str, table: Table) -> Outputs {
    Outputs::from([(name.to_string(), Artifact::Table(table))])
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
///
/// Its parameters come from the struct it names in [`HasParams`] (declared with
/// [`stage_params!`](crate::stage_params)): the engine validates a study against that
/// declaration ([`DeclaredParams::params`]), and `run` reads the same struct with
/// `params.read::<Self>()?`.
pub trait Stage: DeclaredParams + Send + Sync {
    /// The `kind:` written in a study, e.g. `mesh.brake`.
    fn kind(&self) -> &'static str;
    /// Bumped whenever the implementation changes its results; part of the cache key. The
    /// history of each kind's versions is in CHANGELOG.md.
    fn version(&self) -> u32;
    /// One line for `squeal stages`.
    fn doc(&self) -> &'static str;
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
    /// What outside the study determines a pure stage's outputs — the bytes of a file its
    /// parameters name, the version of a program it runs — each named: part of its cache key,
    /// so that an edited file or another program reruns it. An error (a missing file) is
    /// the stage's own to report when it runs: the key then holds the error's message.
    fn external_inputs(&self, params: &Params) -> Result<Vec<(String, Vec<u8>)>, StageError> {
        let _ = params;
        Ok(Vec::new())
    }
    /// Where a cluster executor runs the stage and what it asks for; [`Resources::LIGHT`]
    /// unless the stage takes minutes.
    fn resources(&self) -> Resources {
        Resources::LIGHT
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
/// downstream work by them. Every numerical stage's tests call it.
pub fn assert_outputs_independent_of_threads(
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
