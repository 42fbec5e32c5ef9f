//! What a study asks of the machines that run it: every job's defaults (the study's `slurm:`
//! section, or the command line) and a stage's own `resources:`, checked as they are read.
//! The study holds them; only the Slurm executor acts on them (`slurm/requests.rs`).

use serde_saphyr::Spanned;
use squeal_contract::Placement;

use crate::spec::{self, RawResources, RawSlurm, SpecError};

/// Requests for every job: the study's `slurm:` section, or the command line.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JobDefaults {
    pub partition: Option<String>,
    pub account: Option<String>,
    pub time: Option<String>,
    pub mem: Option<String>,
    pub cpus_per_task: Option<u32>,
    /// Passed to `sbatch` as they are, after squeal's own options.
    pub sbatch_args: Vec<String>,
}

/// A stage's `resources:`: whatever it leaves out comes from the defaults and the kind.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageResources {
    pub placement: Option<Placement>,
    pub cpus_per_task: Option<u32>,
    pub mem: Option<String>,
    pub time: Option<String>,
}

impl JobDefaults {
    pub fn from_raw(file: &str, raw: &RawSlurm) -> Result<JobDefaults, SpecError> {
        Ok(JobDefaults {
            partition: raw.partition.clone().map(|value| value.value),
            account: raw.account.clone().map(|value| value.value),
            time: checked(file, "slurm.time", &raw.time, check_time)?,
            mem: checked(file, "slurm.mem", &raw.mem, check_mem)?,
            cpus_per_task: cpus(file, "slurm.cpus_per_task", &raw.cpus_per_task)?,
            sbatch_args: raw
                .sbatch_args
                .iter()
                .map(|arg| arg.value.clone())
                .collect(),
        })
    }

    /// `self`, with whatever `over` sets replacing it (the command line over the study).
    pub fn overlaid(&self, over: &JobDefaults) -> JobDefaults {
        JobDefaults {
            partition: over.partition.clone().or(self.partition.clone()),
            account: over.account.clone().or(self.account.clone()),
            time: over.time.clone().or(self.time.clone()),
            mem: over.mem.clone().or(self.mem.clone()),
            cpus_per_task: over.cpus_per_task.or(self.cpus_per_task),
            sbatch_args: [self.sbatch_args.clone(), over.sbatch_args.clone()].concat(),
        }
    }
}

impl StageResources {
    pub fn from_raw(
        file: &str,
        stage: &str,
        raw: &RawResources,
    ) -> Result<StageResources, SpecError> {
        let path = |field: &str| format!("stages.{stage}.resources.{field}");
        let placement = match &raw.placement {
            None => None,
            Some(value) => Some(match value.value.as_str() {
                "driver" => Placement::Driver,
                "job" => Placement::Job,
                other => {
                    return Err(spec::located(file, value.clone()).error(
                        path("placement"),
                        format!("`{other}` is not a placement: use `driver` or `job`"),
                    ));
                }
            }),
        };
        Ok(StageResources {
            placement,
            cpus_per_task: cpus(file, &path("cpus_per_task"), &raw.cpus_per_task)?,
            mem: checked(file, &path("mem"), &raw.mem, check_mem)?,
            time: checked(file, &path("time"), &raw.time, check_time)?,
        })
    }
}

fn checked(
    file: &str,
    path: &str,
    value: &Option<Spanned<String>>,
    check: fn(&str) -> Result<(), String>,
) -> Result<Option<String>, SpecError> {
    value
        .as_ref()
        .map(|value| {
            check(&value.value)
                .map(|()| value.value.clone())
                .map_err(|message| spec::located(file, value.clone()).error(path, message))
        })
        .transpose()
}

fn cpus(file: &str, path: &str, value: &Option<Spanned<u32>>) -> Result<Option<u32>, SpecError> {
    match value {
        Some(cpus) if cpus.value == 0 => {
            Err(spec::located(file, cpus.clone()).error(path, "a job needs at least one CPU"))
        }
        other => Ok(other.as_ref().map(|cpus| cpus.value)),
    }
}

/// Slurm's `--mem`: a whole number with an optional unit, `K`, `M` (the default), `G` or `T`.
pub fn check_mem(text: &str) -> Result<(), String> {
    let digits = text.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
    let unit_len = text.len() - digits.len();
    if digits.is_empty() || unit_len > 1 || !digits.bytes().all(|byte| byte.is_ascii_digit()) {
        return Err(format!(
            "`{text}` is not a memory size for Slurm: write e.g. `4096M` or `16G`"
        ));
    }
    Ok(())
}

/// Slurm's `--time`: `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS`, or
/// `UNLIMITED`.
pub fn check_time(text: &str) -> Result<(), String> {
    let error = || {
        format!(
            "`{text}` is not a time limit for Slurm: write minutes (`30`), `HH:MM:SS`, \
             `D-HH:MM:SS` or `UNLIMITED`"
        )
    };
    if matches!(text, "UNLIMITED" | "INFINITE") {
        return Ok(());
    }
    let numbers = |part: &str| {
        !part.is_empty()
            && part
                .split(':')
                .all(|field| !field.is_empty() && field.bytes().all(|b| b.is_ascii_digit()))
    };
    let ok = match text.split_once('-') {
        Some((days, rest)) => {
            numbers(days) && !days.contains(':') && numbers(rest) && rest.split(':').count() <= 3
        }
        None => numbers(text) && text.split(':').count() <= 3,
    };
    if ok { Ok(()) } else { Err(error()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slurm_sizes_and_times_are_checked() {
        for good in ["4096", "4096M", "16G", "1T", "512k"] {
            assert_eq!(check_mem(good), Ok(()), "{good}");
        }
        for bad in ["", "G", "16GB", "1.5G", "-1", "lots"] {
            assert!(check_mem(bad).is_err(), "{bad}");
        }
        for good in [
            "30",
            "30:00",
            "01:30:00",
            "2-00",
            "2-12:00",
            "1-00:00:00",
            "UNLIMITED",
        ] {
            assert_eq!(check_time(good), Ok(()), "{good}");
        }
        for bad in ["", "1h", "1:2:3:4", "1-", "-1", "1-2-3", "a:00", "1:-2"] {
            assert!(check_time(bad).is_err(), "{bad}");
        }
    }
}
