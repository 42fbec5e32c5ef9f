//! How a run ended: each instance's outcome (ran, cached, failed, skipped; why, how long, its
//! output digests) and the run's. The scheduler makes them, the manifest writes them, the
//! Slurm worker and driver exchange them, and the command line prints them.

use std::collections::BTreeMap;

use squeal_cache::Digest;

/// How an instance ended that another executor (a Slurm job) ran.
#[derive(Debug, Clone, PartialEq)]
pub enum Elsewhere {
    /// Its outputs should be in the cache; `why` says where it ran.
    Ran {
        wall_s: f64,
        why: String,
    },
    Failed(String),
}

/// How an instance ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    Ran,
    Cached,
    Failed(String),
    /// Not run because this upstream instance failed or was skipped.
    Skipped(String),
}

impl Status {
    /// `ran`, `cached`, `failed` or `skipped`: the manifest's `status`.
    pub fn label(&self) -> &'static str {
        match self {
            Status::Ran => "ran",
            Status::Cached => "cached",
            Status::Failed(_) => "failed",
            Status::Skipped(_) => "skipped",
        }
    }
}

/// One instance of a run: what it is, how it ended and why, its times and output digests.
#[derive(Debug, Clone)]
pub struct InstanceOutcome {
    pub name: String,
    pub stage: String,
    pub kind: String,
    pub key: Option<Digest>,
    pub status: Status,
    pub reasons: Vec<String>,
    pub wall_s: f64,
    /// Seconds the stage took to compute its outputs: in this run, or when the cached outputs
    /// were computed.
    pub compute_s: f64,
    pub params_json: String,
    pub outputs: BTreeMap<String, Digest>,
}

/// Every settled instance of a run, upstream first, and the run's wall time.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    pub instances: Vec<InstanceOutcome>,
    pub wall_s: f64,
}

impl RunOutcome {
    /// The instances whose status has this label.
    pub fn count(&self, label: &str) -> usize {
        self.instances
            .iter()
            .filter(|instance| instance.status.label() == label)
            .count()
    }

    /// Nothing failed or was skipped.
    pub fn succeeded(&self) -> bool {
        self.count("failed") + self.count("skipped") == 0
    }
}
