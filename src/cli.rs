//! The command line's grammar: clap's types for every command and option, and their
//! conversions into what the engine takes.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use squeal_engine::{
    DagFormat as Format, JobDefaults, SlurmArgs as SlurmSettings, WorkerInvocation,
};

/// Declarative, cached, parallel pipelines for brake squeal studies.
#[derive(Parser)]
#[command(name = "squeal", version, about)]
pub struct Cli {
    /// Log what the engine does (-v: stages, -vv: everything).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
    /// Cache directory [default: .squeal/cache beside the study].
    #[arg(long, env = "SQUEAL_CACHE", global = true)]
    pub cache: Option<PathBuf>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Args)]
pub struct StudyArgs {
    /// The study file (YAML).
    pub study: PathBuf,
    /// Override a parameter: stage.param=value (part of the cache key).
    #[arg(long = "set", value_name = "STAGE.PARAM=VALUE")]
    pub set: Vec<String>,
    /// Compute these stages (and what they need) instead of the study's targets.
    #[arg(long = "target", value_name = "STAGE")]
    pub targets: Vec<String>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Check a study without running anything.
    Validate(StudyArgs),
    /// List every stage kind with its parameters, inputs and outputs.
    Stages,
    /// Show, for each stage instance, whether it is cached or why it runs.
    Plan(StudyArgs),
    /// Run a study and write its Parquet outputs.
    Run {
        #[command(flatten)]
        study: StudyArgs,
        /// Output directory [default: out/STEM, STEM the study file name without extension].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Threads, shared by the stages that run at once and their parallel parts [default:
        /// all cores].
        #[arg(long, short)]
        jobs: Option<usize>,
        /// Where the stages run: on this machine, or as jobs of a Slurm cluster (the cache,
        /// the study and this binary on a file system every node sees).
        #[arg(long, value_enum, default_value = "local")]
        executor: Executor,
        #[command(flatten)]
        slurm: SlurmArgs,
    },
    /// Run one stage instance inside a Slurm job: what `run --executor slurm` submits.
    Worker(WorkerArgs),
    /// Print the DAG of stage instances.
    Dag {
        #[command(flatten)]
        study: StudyArgs,
        #[arg(long, value_enum, default_value = "dot")]
        format: DagFormat,
    },
    /// Write one self-contained HTML page of the study's last run: the DAG with each
    /// instance's status, every figure, the key tables, the provenance.
    Report {
        #[command(flatten)]
        study: StudyArgs,
        /// The run's output directory [default: out/STEM, as `run`].
        #[arg(long)]
        out: Option<PathBuf>,
        /// The page to write [default: OUT/report.html].
        #[arg(long, short)]
        output: Option<PathBuf>,
    },
    /// Inspect and maintain the cache.
    #[command(subcommand)]
    Cache(CacheCommand),
}

/// `squeal worker`'s arguments: [`WorkerInvocation`]'s fields, which the driver writes into
/// each job's script, and the job's threads.
#[derive(clap::Args)]
pub struct WorkerArgs {
    /// The study file (YAML).
    pub study: PathBuf,
    #[arg(id = "set", long = "set", value_name = "STAGE.PARAM=VALUE")]
    pub sets: Vec<String>,
    /// The instance's stage.
    #[arg(long)]
    pub stage: String,
    /// The submission's instance names; the task runs line SLURM_ARRAY_TASK_ID + 1.
    #[arg(long)]
    pub instances: PathBuf,
    /// Where to write the outcome; `{task}` stands for the task index.
    #[arg(long)]
    pub status: String,
    /// The blake3 of the study file when the job was submitted: a job refuses an edited study.
    #[arg(long)]
    pub study_digest: String,
    /// Threads [default: the job's CPUs].
    #[arg(long, short, env = "SLURM_CPUS_PER_TASK")]
    pub jobs: Option<usize>,
}

impl WorkerArgs {
    /// The invocation, with the global `--cache`.
    pub fn invocation(&self, cache: Option<PathBuf>) -> WorkerInvocation {
        WorkerInvocation {
            cache,
            study: self.study.clone(),
            sets: self.sets.clone(),
            study_digest: self.study_digest.clone(),
            stage: self.stage.clone(),
            instances: self.instances.clone(),
            status: self.status.clone(),
        }
    }
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
pub enum Executor {
    Local,
    Slurm,
}

/// What every Slurm job asks for: over the study's `slurm:` section, under a stage's
/// `resources:`.
#[derive(clap::Args)]
#[command(next_help_heading = "Slurm executor")]
pub struct SlurmArgs {
    #[arg(long, env = "SQUEAL_SLURM_PARTITION")]
    pub partition: Option<String>,
    #[arg(long, env = "SQUEAL_SLURM_ACCOUNT")]
    pub account: Option<String>,
    /// Time limit of a job (Slurm syntax: minutes, HH:MM:SS, D-HH:MM:SS).
    #[arg(long, env = "SQUEAL_SLURM_TIME")]
    pub time: Option<String>,
    /// Memory of a job (Slurm syntax: 4096M, 16G) [default: the stage's].
    #[arg(long, env = "SQUEAL_SLURM_MEM")]
    pub mem: Option<String>,
    /// CPUs of a job [default: the stage's].
    #[arg(long, env = "SQUEAL_SLURM_CPUS_PER_TASK")]
    pub cpus_per_task: Option<u32>,
    /// Any other sbatch option, e.g. --sbatch-arg=--qos=long (repeat for several).
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    pub sbatch_args: Vec<String>,
    /// Print the sbatch commands and scripts a run would submit; run and submit nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Seconds between two looks at the queue (squeue).
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 5.0,
        env = "SQUEAL_SLURM_POLL"
    )]
    pub poll: f64,
}

impl SlurmArgs {
    /// What the engine's Slurm executor takes (the dry run is the command's to decide).
    pub fn settings(&self) -> SlurmSettings {
        SlurmSettings {
            requests: JobDefaults {
                partition: self.partition.clone(),
                account: self.account.clone(),
                time: self.time.clone(),
                mem: self.mem.clone(),
                cpus_per_task: self.cpus_per_task,
                sbatch_args: self.sbatch_args.clone(),
            },
            poll_s: self.poll,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum DagFormat {
    Dot,
    Mermaid,
}

impl From<DagFormat> for Format {
    fn from(format: DagFormat) -> Format {
        match format {
            DagFormat::Dot => Format::Dot,
            DagFormat::Mermaid => Format::Mermaid,
        }
    }
}

#[derive(Subcommand)]
pub enum CacheCommand {
    /// Share a cache with the members of its folder's group (create the folder with the
    /// team's group first): folders group-writable and setgid, entries read-only for the group,
    /// nothing for others.
    Init {
        /// The cache folder [default: --cache, or .squeal/cache].
        dir: Option<PathBuf>,
        /// Who shares it: `group`, the members of the folder's group.
        #[arg(long, value_parser = ["group"])]
        shared: String,
    },
    /// Entries and size.
    Stats,
    /// Re-hash every entry; corrupt ones are discarded and listed (exit code 1).
    Verify,
    /// Remove what is not needed: keep what the given studies use, and/or trim to a size.
    Gc {
        /// Keep only the entries these studies reference.
        studies: Vec<PathBuf>,
        /// Then evict least recently used entries down to this size (e.g. 500M, 20G).
        #[arg(long, value_parser = parse_size)]
        max_size: Option<u64>,
    },
}

fn parse_size(text: &str) -> Result<u64, String> {
    let text = text.trim();
    let split = text.find(|c: char| c.is_alphabetic()).unwrap_or(text.len());
    let number: f64 = text[..split]
        .trim()
        .parse()
        .map_err(|_| format!("not a size: `{text}`"))?;
    let factor = match text[split..].trim().to_ascii_uppercase().as_str() {
        "" | "B" => 1.0,
        "K" | "KB" => 1e3,
        "M" | "MB" => 1e6,
        "G" | "GB" => 1e9,
        "T" | "TB" => 1e12,
        unit => return Err(format!("unknown size unit `{unit}` (use K, M, G or T)")),
    };
    Ok((number * factor) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_workers_command_line_parses_back_into_the_same_invocation() {
        let invocation = WorkerInvocation {
            cache: Some("/shared/.squeal/cache".into()),
            study: "/shared/brake study.yaml".into(),
            sets: vec!["modes.count=12".into(), "contact.mu=[0.3, 0.4]".into()],
            study_digest: "af590d52".into(),
            stage: "stability".into(),
            instances: "/shared/.squeal/slurm/run/001-stability.instances".into(),
            status: "/shared/.squeal/slurm/run/001-stability-{task}.json".into(),
        };
        let args = std::iter::once("squeal".to_string()).chain(invocation.to_args());
        let cli = Cli::try_parse_from(args).expect("parses");
        let Command::Worker(worker) = &cli.command else {
            panic!("not the worker command");
        };
        assert_eq!(worker.invocation(cli.cache.clone()), invocation);
    }

    #[test]
    fn sizes_read_with_their_unit() {
        assert_eq!(parse_size("500M"), Ok(500_000_000));
        assert_eq!(parse_size(" 1.5 gb "), Ok(1_500_000_000));
        assert_eq!(parse_size("12"), Ok(12));
        assert!(parse_size("12 furlongs").is_err());
        assert!(parse_size("lots").is_err());
    }
}
