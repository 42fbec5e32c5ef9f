//! What a job asks Slurm for. Four sources, the first that says wins: the stage's
//! `resources:` in the study, the command line (or its `SQUEAL_SLURM_*` environment
//! variables), the study's `slurm:` section, and the stage kind's own declaration
//! ([`squeal_contract::Resources`]).

use squeal_contract::{Placement, Stage};

use crate::resources::{JobDefaults, StageResources};

/// What one stage's jobs ask for, all sources merged.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRequest {
    pub placement: Placement,
    pub cpus_per_task: u32,
    /// Slurm's `--mem` syntax, e.g. `4096M`.
    pub mem: String,
    pub time: Option<String>,
    pub partition: Option<String>,
    pub account: Option<String>,
    pub sbatch_args: Vec<String>,
}

/// The request of a stage's jobs.
pub fn request(stage: &dyn Stage, own: &StageResources, defaults: &JobDefaults) -> JobRequest {
    let declared = stage.resources();
    // A stage that reads files or the clock is never cached: a job could not hand its
    // outputs to the driver, so it runs there.
    let placement = if stage.pure() {
        own.placement.unwrap_or(declared.placement)
    } else {
        Placement::Driver
    };
    JobRequest {
        placement,
        cpus_per_task: own
            .cpus_per_task
            .or(defaults.cpus_per_task)
            .unwrap_or(declared.threads),
        mem: own
            .mem
            .clone()
            .or(defaults.mem.clone())
            .unwrap_or_else(|| format!("{}M", declared.memory_mb)),
        time: own.time.clone().or(defaults.time.clone()),
        partition: defaults.partition.clone(),
        account: defaults.account.clone(),
        sbatch_args: defaults.sbatch_args.clone(),
    }
}
