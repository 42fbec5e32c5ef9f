//! The `squeal` command line: argument parsing, the stage registry and exit codes. Everything
//! else lives in the `squeal-engine`, `squeal-cache` and `squeal-stages` crates.

use std::collections::HashSet;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand, ValueEnum};
use squeal_cache::{Cache, GcPolicy};
use squeal_engine::{
    DagFormat as EngineDagFormat, Decision, Error, JobDefaults, Registry, RunOutcome,
    SlurmArgs as SlurmSettings, Status, Study, Workbench, WorkerInvocation,
};

/// Declarative, cached, parallel pipelines for brake squeal studies.
#[derive(Parser)]
#[command(name = "squeal", version, about)]
struct Cli {
    /// Log what the engine does (-v: stages, -vv: everything).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    /// Cache directory [default: .squeal/cache beside the study].
    #[arg(long, env = "SQUEAL_CACHE", global = true)]
    cache: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args)]
struct StudyArgs {
    /// The study file (YAML).
    study: PathBuf,
    /// Override a parameter: stage.param=value (part of the cache key).
    #[arg(long = "set", value_name = "STAGE.PARAM=VALUE")]
    set: Vec<String>,
    /// Compute these stages (and what they need) instead of the study's targets.
    #[arg(long = "target", value_name = "STAGE")]
    targets: Vec<String>,
}

#[derive(Subcommand)]
enum Command {
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
struct WorkerArgs {
    /// The study file (YAML).
    study: PathBuf,
    #[arg(id = "set", long = "set", value_name = "STAGE.PARAM=VALUE")]
    sets: Vec<String>,
    /// The instance's stage.
    #[arg(long)]
    stage: String,
    /// The submission's instance names; the task runs line SLURM_ARRAY_TASK_ID + 1.
    #[arg(long)]
    instances: PathBuf,
    /// Where to write the outcome; `{task}` stands for the task index.
    #[arg(long)]
    status: String,
    /// The blake3 of the study file when the job was submitted: a job refuses an edited study.
    #[arg(long)]
    study_digest: String,
    /// Threads [default: the job's CPUs].
    #[arg(long, short, env = "SLURM_CPUS_PER_TASK")]
    jobs: Option<usize>,
}

impl WorkerArgs {
    fn invocation(&self, cache: Option<PathBuf>) -> WorkerInvocation {
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
enum Executor {
    Local,
    Slurm,
}

/// What every Slurm job asks for: over the study's `slurm:` section, under a stage's
/// `resources:`.
#[derive(clap::Args)]
#[command(next_help_heading = "Slurm executor")]
struct SlurmArgs {
    #[arg(long, env = "SQUEAL_SLURM_PARTITION")]
    partition: Option<String>,
    #[arg(long, env = "SQUEAL_SLURM_ACCOUNT")]
    account: Option<String>,
    /// Time limit of a job (Slurm syntax: minutes, HH:MM:SS, D-HH:MM:SS).
    #[arg(long, env = "SQUEAL_SLURM_TIME")]
    time: Option<String>,
    /// Memory of a job (Slurm syntax: 4096M, 16G) [default: the stage's].
    #[arg(long, env = "SQUEAL_SLURM_MEM")]
    mem: Option<String>,
    /// CPUs of a job [default: the stage's].
    #[arg(long, env = "SQUEAL_SLURM_CPUS_PER_TASK")]
    cpus_per_task: Option<u32>,
    /// Any other sbatch option, e.g. --sbatch-arg=--qos=long (repeat for several).
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true)]
    sbatch_args: Vec<String>,
    /// Print the sbatch commands and scripts a run would submit; run and submit nothing.
    #[arg(long)]
    dry_run: bool,
    /// Seconds between two looks at the queue (squeue).
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 5.0,
        env = "SQUEAL_SLURM_POLL"
    )]
    poll: f64,
}

#[derive(Clone, Copy, ValueEnum)]
enum DagFormat {
    Dot,
    Mermaid,
}

#[derive(Subcommand)]
enum CacheCommand {
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("SQUEAL_LOG")
                .unwrap_or_else(|_| level.into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .init();
    std::panic::set_hook(Box::new(|info| tracing::error!("internal error: {info}")));
    match execute(cli) {
        Ok(code) => code,
        Err(err) if err.downcast_ref::<Error>().is_some_and(Error::is_usage) => {
            eprintln!("error: {err}");
            ExitCode::from(2)
        }
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

fn registry() -> Registry {
    let mut kinds = squeal_stages::all_kinds();
    if std::env::var_os("SQUEAL_TEST_KINDS").is_some_and(|value| value == "1") {
        kinds.extend(squeal_stages::test_kinds());
    }
    Registry::new(kinds)
}

fn open(cli: &Cli, args: &StudyArgs, registry: &Registry) -> Result<Workbench, Error> {
    Workbench::open(
        registry,
        &args.study,
        &args.set,
        &args.targets,
        cli.cache.as_deref(),
    )
}

fn execute(cli: Cli) -> Result<ExitCode> {
    let registry = registry();
    match &cli.command {
        Command::Validate(args) => {
            let bench = open(&cli, args, &registry)?;
            println!(
                "{}: ok ({} stages, {} instances for the targets)",
                bench.study().file,
                bench.study().stages.len(),
                bench.instances().list.len()
            );
        }
        Command::Stages => print_stages(&registry),
        Command::Plan(args) => {
            let lines = open(&cli, args, &registry)?.plan()?;
            let width = lines
                .iter()
                .map(|line| line.instance.len())
                .max()
                .unwrap_or(0);
            for line in &lines {
                println!("{:width$}  {}", line.instance, line.decision.describe());
            }
            let cached = lines
                .iter()
                .filter(|line| matches!(line.decision, Decision::Cached { .. }))
                .count();
            println!(
                "{} instances: {} cached, {} to run",
                lines.len(),
                cached,
                lines.len() - cached
            );
        }
        Command::Run {
            study: args,
            out,
            jobs,
            executor,
            slurm,
        } => {
            return match executor {
                Executor::Local => {
                    if slurm.dry_run {
                        return Err(Error::usage("--dry-run", "needs --executor slurm").into());
                    }
                    run(&cli, args, out.clone(), *jobs, &registry)
                }
                Executor::Slurm => run_slurm(&cli, args, out.clone(), *jobs, slurm, &registry),
            };
        }
        Command::Worker(args) => return worker(&cli, args, &registry),
        Command::Dag {
            study: args,
            format,
        } => {
            let format = match format {
                DagFormat::Dot => EngineDagFormat::Dot,
                DagFormat::Mermaid => EngineDagFormat::Mermaid,
            };
            print!("{}", open(&cli, args, &registry)?.dag(format));
        }
        Command::Report {
            study: args,
            out,
            output,
        } => {
            let bench = open(&cli, args, &registry)?;
            let page = bench.report(out.clone(), output.clone(), env!("CARGO_PKG_VERSION"))?;
            println!("{}", page.display());
        }
        Command::Cache(command) => return cache_command(&cli, command, &registry),
    }
    Ok(ExitCode::SUCCESS)
}

fn run(
    cli: &Cli,
    args: &StudyArgs,
    out: Option<PathBuf>,
    jobs: Option<usize>,
    registry: &Registry,
) -> Result<ExitCode> {
    let bench = open(cli, args, registry)?;
    let out_dir = bench.out_dir(out)?;
    let outcome = bench.run(&out_dir, jobs)?;
    print_summary(bench.study(), &outcome, &out_dir);
    Ok(exit_code(&outcome))
}

/// One line per instance that did not come from the cache, then the totals.
fn print_summary(study: &Study, outcome: &RunOutcome, out_dir: &Path) {
    for instance in &outcome.instances {
        match &instance.status {
            Status::Ran => eprintln!(
                "ran     {} ({}) in {:.3} s",
                instance.name,
                instance.reasons.join("; "),
                instance.wall_s
            ),
            Status::Cached => {}
            Status::Failed(message) => eprintln!("FAILED  {}: {message}", instance.name),
            Status::Skipped(upstream) => {
                eprintln!("skipped {}: `{upstream}` did not complete", instance.name)
            }
        }
    }
    eprintln!(
        "{}: {} instances in {:.2} s: {} ran, {} cached, {} failed, {} skipped; outputs in {}",
        study.name,
        outcome.instances.len(),
        outcome.wall_s,
        outcome.count("ran"),
        outcome.count("cached"),
        outcome.count("failed"),
        outcome.count("skipped"),
        out_dir.display()
    );
}

fn exit_code(outcome: &RunOutcome) -> ExitCode {
    if outcome.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn run_slurm(
    cli: &Cli,
    args: &StudyArgs,
    out: Option<PathBuf>,
    jobs: Option<usize>,
    slurm: &SlurmArgs,
    registry: &Registry,
) -> Result<ExitCode> {
    let settings = SlurmSettings {
        requests: JobDefaults {
            partition: slurm.partition.clone(),
            account: slurm.account.clone(),
            time: slurm.time.clone(),
            mem: slurm.mem.clone(),
            cpus_per_task: slurm.cpus_per_task,
            sbatch_args: slurm.sbatch_args.clone(),
        },
        poll_s: slurm.poll,
    };
    settings.check()?;
    let bench = open(cli, args, registry)?;
    let out_dir = bench.out_dir(out)?;
    if slurm.dry_run {
        print!("{}", bench.slurm_dry_run(&out_dir, jobs, &settings)?);
        return Ok(ExitCode::SUCCESS);
    }
    // A first Ctrl-C (or SIGTERM) cancels the jobs and writes what finished; a second one
    // exits at once.
    let interrupted = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, interrupted.clone())?;
        signal_hook::flag::register(signal, interrupted.clone())?;
    }
    let run = bench.run_slurm(&out_dir, jobs, &settings, interrupted)?;
    eprintln!(
        "slurm: submitted {}; scripts and logs in {}",
        run.submitted,
        run.dir.display()
    );
    print_summary(bench.study(), &run.outcome, &out_dir);
    Ok(exit_code(&run.outcome))
}

fn worker(cli: &Cli, args: &WorkerArgs, registry: &Registry) -> Result<ExitCode> {
    let status = Workbench::work(registry, &args.invocation(cli.cache.clone()), args.jobs)?;
    if status.succeeded() {
        eprintln!(
            "{}: {} in {:.3} s",
            status.instance, status.status, status.wall_s
        );
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "error: {} {}: {}",
            status.instance, status.status, status.message
        );
        Ok(ExitCode::FAILURE)
    }
}

fn cache_command(cli: &Cli, command: &CacheCommand, registry: &Registry) -> Result<ExitCode> {
    match command {
        CacheCommand::Stats => {
            let cache = Cache::open(Workbench::cache_dir(cli.cache.as_deref(), None))?;
            let stats = cache.stats()?;
            println!("cache {}", cache.root().display());
            println!("  actions     {}", stats.actions);
            println!(
                "  objects     {} ({})",
                stats.objects,
                format_size(stats.object_bytes)
            );
            println!("  temporaries {}", stats.stray_temporaries);
        }
        CacheCommand::Verify => {
            let cache = Cache::open(Workbench::cache_dir(cli.cache.as_deref(), None))?;
            let report = cache.verify()?;
            for problem in &report.problems {
                println!("{problem}");
            }
            println!(
                "verified {} actions and {} objects: {} problems",
                report.actions_checked,
                report.objects_checked,
                report.problems.len()
            );
            if !report.problems.is_empty() {
                return Ok(ExitCode::FAILURE);
            }
        }
        CacheCommand::Gc { studies, max_size } => {
            let dir =
                Workbench::cache_dir(cli.cache.as_deref(), studies.first().map(PathBuf::as_path));
            let keep_keys = if studies.is_empty() {
                None
            } else {
                let cache = Cache::open(&dir)?;
                let mut keys = HashSet::new();
                for study in studies {
                    let bench = Workbench::open(registry, study, &[], &[], Some(&dir))?;
                    keys.extend(bench.referenced_keys(&cache));
                }
                Some(keys)
            };
            let cache = Cache::open_exclusive(&dir)?;
            let report = cache.gc(&GcPolicy {
                keep_keys,
                max_bytes: *max_size,
            })?;
            println!(
                "removed {} actions and {} objects ({}); {} kept",
                report.actions_removed,
                report.objects_removed,
                format_size(report.bytes_freed),
                format_size(report.bytes_kept)
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn print_stages(registry: &Registry) {
    let compute_time = squeal_engine::compute_time_port();
    println!(
        "Every stage also has the output `{}` (table): {}.\n",
        compute_time.name, compute_time.doc
    );
    for stage in registry.iter() {
        let resources = stage.resources();
        let placement = match resources.placement {
            squeal_stages::Placement::Driver => String::new(),
            squeal_stages::Placement::Job => format!(
                "; a Slurm job of {} CPUs, {} MB",
                resources.threads, resources.memory_mb
            ),
        };
        println!(
            "{} (v{}{placement}): {}",
            stage.kind(),
            stage.version(),
            stage.doc()
        );
        for port in stage.inputs() {
            let many = if port.arity == squeal_stages::Arity::Many {
                ", gathers a sweep"
            } else {
                ""
            };
            let optional = if port.optional { ", optional" } else { "" };
            println!(
                "  input  {:<20} {}{many}{optional}: {}",
                port.name, port.ty, port.doc
            );
        }
        for port in stage.outputs() {
            println!("  output {:<20} {}: {}", port.name, port.ty, port.doc);
        }
        for param in stage.params() {
            let default = match &param.default {
                None => "required".to_string(),
                Some(squeal_stages::Value::Str(text)) if text.is_empty() => "default \"\"".into(),
                Some(value) => format!("default {value}"),
            };
            let unit = if param.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", param.unit)
            };
            println!(
                "  param  {:<20} {}{unit}, {default}: {}",
                param.name, param.ty, param.doc
            );
        }
    }
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

fn format_size(bytes: u64) -> String {
    match bytes {
        0..1_000 => format!("{bytes} B"),
        1_000..1_000_000 => format!("{:.1} kB", bytes as f64 / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1} MB", bytes as f64 / 1e6),
        _ => format!("{:.2} GB", bytes as f64 / 1e9),
    }
}
