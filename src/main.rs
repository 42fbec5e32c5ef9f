//! The `squeal` command line: argument parsing, the stage registry and exit codes. Everything
//! else lives in the `squeal-engine`, `squeal-cache` and `squeal-stages` crates.

use std::collections::HashSet;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand, ValueEnum};
use squeal_cache::{Cache, GcPolicy};
use squeal_engine::plan::{self, Context, Decision};
use squeal_engine::record::RunRecord;
use squeal_engine::{Instances, Override, Registry, RunOptions, SpecError, Status, Study, dag};

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
    Worker {
        /// The study file (YAML).
        study: PathBuf,
        #[arg(long = "set", value_name = "STAGE.PARAM=VALUE")]
        set: Vec<String>,
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
    },
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

/// A user error in the study or the arguments: exit code 2.
#[derive(Debug, thiserror::Error)]
#[error(transparent)]
struct UsageError(#[from] SpecError);

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
        Err(err) if err.is::<UsageError>() => {
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

/// The folder beside the study where squeal keeps its cache and run records.
fn state_dir(study: &Path) -> PathBuf {
    study.parent().unwrap_or(Path::new(".")).join(".squeal")
}

fn cache_dir(cli_cache: &Option<PathBuf>, study: Option<&Path>) -> PathBuf {
    match (cli_cache, study) {
        (Some(dir), _) => dir.clone(),
        (None, Some(study)) => state_dir(study).join("cache"),
        (None, None) => PathBuf::from(".squeal/cache"),
    }
}

fn load_study(args: &StudyArgs, registry: &Registry) -> Result<(Study, Vec<usize>)> {
    let overrides: Vec<Override> = args
        .set
        .iter()
        .map(|arg| arg.parse())
        .collect::<Result<_, SpecError>>()
        .map_err(UsageError)?;
    let study = Study::load(&args.study, registry, &overrides).map_err(UsageError)?;
    let mut targets = study.targets.clone();
    if !args.targets.is_empty() {
        targets = args
            .targets
            .iter()
            .map(|name| {
                study.index_of(name).ok_or_else(|| SpecError {
                    location: squeal_engine::spec::Location::CommandLine(format!(
                        "--target {name}"
                    )),
                    path: "--target".into(),
                    message: format!("no stage named `{name}`"),
                })
            })
            .collect::<Result<_, _>>()
            .map_err(UsageError)?;
    }
    Ok((study, targets))
}

fn execute(cli: Cli) -> Result<ExitCode> {
    let registry = registry();
    match &cli.command {
        Command::Validate(args) => {
            let (study, targets) = load_study(args, &registry)?;
            let instances = Instances::expand(&study, &targets);
            println!(
                "{}: ok ({} stages, {} instances for the targets)",
                study.file,
                study.stages.len(),
                instances.list.len()
            );
        }
        Command::Stages => print_stages(&registry),
        Command::Plan(args) => {
            let (study, targets) = load_study(args, &registry)?;
            let instances = Instances::expand(&study, &targets);
            let cache = Cache::open(cache_dir(&cli.cache, Some(&args.study)))?;
            let record = RunRecord::load(&RunRecord::path_for(
                &args.study,
                &state_dir(&args.study).join("record"),
            ));
            let context = Context {
                study: &study,
                instances: &instances,
                cache: &cache,
                record: &record,
            };
            let lines = plan::plan(&context);
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
                        return Err(usage("--dry-run", "needs --executor slurm").into());
                    }
                    run(&cli, args, out.clone(), *jobs, &registry)
                }
                Executor::Slurm => run_slurm(&cli, args, out.clone(), *jobs, slurm, &registry),
            };
        }
        Command::Worker {
            study,
            set,
            stage,
            instances,
            status,
            study_digest,
            jobs,
        } => {
            let args = StudyArgs {
                study: study.clone(),
                set: set.clone(),
                targets: Vec::new(),
            };
            return worker(
                &cli,
                &args,
                stage,
                instances,
                status,
                study_digest,
                *jobs,
                &registry,
            );
        }
        Command::Dag {
            study: args,
            format,
        } => {
            let (study, targets) = load_study(args, &registry)?;
            let instances = Instances::expand(&study, &targets);
            let format = match format {
                DagFormat::Dot => dag::Format::Dot,
                DagFormat::Mermaid => dag::Format::Mermaid,
            };
            print!("{}", dag::render(&study, &instances, format));
        }
        Command::Report {
            study: args,
            out,
            output,
        } => report(&cli, args, out.clone(), output.clone(), &registry)?,
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
    let (study, targets) = load_study(args, registry)?;
    let out_dir = out_dir_of(out, &args.study)?;
    let instances = Instances::expand(&study, &targets);
    let cache = Cache::open(cache_dir(&cli.cache, Some(&args.study)))?;
    let record_path = RunRecord::path_for(&args.study, &state_dir(&args.study).join("record"));
    let record = RunRecord::load(&record_path);
    let context = Context {
        study: &study,
        instances: &instances,
        cache: &cache,
        record: &record,
    };
    let options = RunOptions::local(jobs, out_dir.clone(), true);
    let report = squeal_engine::run::run(&context, &options, Some(&record_path))
        .with_context(|| format!("writing outputs to {}", out_dir.display()))?;
    print_summary(&study, &report, &out_dir);
    Ok(exit_code(&report))
}

/// One line per instance that did not come from the cache, then the totals.
fn print_summary(study: &Study, report: &squeal_engine::RunOutcome, out_dir: &Path) {
    for instance in &report.instances {
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
        report.instances.len(),
        report.wall_s,
        report.count("ran"),
        report.count("cached"),
        report.count("failed"),
        report.count("skipped"),
        out_dir.display()
    );
}

fn exit_code(report: &squeal_engine::RunOutcome) -> ExitCode {
    if report.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// A usage error on the command line.
fn usage(arg: &str, message: &str) -> UsageError {
    UsageError(SpecError {
        location: squeal_engine::spec::Location::CommandLine(arg.into()),
        path: arg.into(),
        message: message.into(),
    })
}

fn run_slurm(
    cli: &Cli,
    args: &StudyArgs,
    out: Option<PathBuf>,
    jobs: Option<usize>,
    slurm: &SlurmArgs,
    registry: &Registry,
) -> Result<ExitCode> {
    use squeal_engine::{resources, slurm};
    if let Some(time) = &slurm.time {
        resources::check_time(time).map_err(|message| usage("--time", &message))?;
    }
    if let Some(mem) = &slurm.mem {
        resources::check_mem(mem).map_err(|message| usage("--mem", &message))?;
    }
    if slurm.cpus_per_task == Some(0) {
        return Err(usage("--cpus-per-task", "a job needs at least one CPU").into());
    }
    if !(slurm.poll.is_finite() && slurm.poll > 0.0) {
        return Err(usage("--poll", "give a positive number of seconds").into());
    }
    let (study, targets) = load_study(args, registry)?;
    let out_dir = out_dir_of(out, &args.study)?;
    let instances = Instances::expand(&study, &targets);
    let absolute = |path: &Path| std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let study_path = absolute(&args.study);
    let cache_path = absolute(&cache_dir(&cli.cache, Some(&args.study)));
    let cache = Cache::open(&cache_path)?;
    let record_path = RunRecord::path_for(&args.study, &state_dir(&args.study).join("record"));
    let record = RunRecord::load(&record_path);
    let context = Context {
        study: &study,
        instances: &instances,
        cache: &cache,
        record: &record,
    };
    let study_bytes =
        std::fs::read(&args.study).with_context(|| format!("reading {}", args.study.display()))?;
    let mut worker = vec![
        std::env::current_exe()
            .context("locating the squeal binary for the jobs")?
            .to_string_lossy()
            .into_owned(),
        "--cache".into(),
        cache_path.to_string_lossy().into_owned(),
        "worker".into(),
        study_path.to_string_lossy().into_owned(),
    ];
    for set in &args.set {
        worker.extend(["--set".to_string(), set.clone()]);
    }
    worker.extend([
        "--study-digest".to_string(),
        blake3::hash(&study_bytes).to_hex().to_string(),
    ]);
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |elapsed| elapsed.as_secs());
    let stem = study_path
        .file_stem()
        .map_or("study".into(), |stem| stem.to_string_lossy().into_owned());
    let interrupted = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let options = slurm::SlurmOptions {
        defaults: resources::JobDefaults {
            partition: slurm.partition.clone(),
            account: slurm.account.clone(),
            time: slurm.time.clone(),
            mem: slurm.mem.clone(),
            cpus_per_task: slurm.cpus_per_task,
            sbatch_args: slurm.sbatch_args.clone(),
        },
        worker,
        dir: absolute(&state_dir(&args.study))
            .join("slurm")
            .join(format!("{stem}-{stamp}-{}", std::process::id())),
        jobs,
        out_dir: out_dir.clone(),
        progress: true,
        poll: std::time::Duration::from_secs_f64(slurm.poll),
        interrupted: interrupted.clone(),
    };
    if slurm.dry_run {
        print!("{}", slurm::dry_run(&context, &options));
        return Ok(ExitCode::SUCCESS);
    }
    // A first Ctrl-C (or SIGTERM) cancels the jobs and writes what finished; a second one
    // exits at once.
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, interrupted.clone())?;
        signal_hook::flag::register(signal, interrupted.clone())?;
    }
    let (report, submitted) =
        slurm::run(&context, &options, &record_path).map_err(anyhow::Error::msg)?;
    eprintln!(
        "slurm: submitted {} ({}); scripts and logs in {}",
        slurm::count(submitted.jobs, "job"),
        slurm::count(submitted.tasks, "task"),
        options.dir.display()
    );
    print_summary(&study, &report, &out_dir);
    Ok(exit_code(&report))
}

#[allow(clippy::too_many_arguments)]
fn worker(
    cli: &Cli,
    args: &StudyArgs,
    stage: &str,
    instance_list: &Path,
    status_pattern: &str,
    study_digest: &str,
    jobs: Option<usize>,
    registry: &Registry,
) -> Result<ExitCode> {
    use squeal_engine::slurm::worker;
    let bytes =
        std::fs::read(&args.study).with_context(|| format!("reading {}", args.study.display()))?;
    let digest = blake3::hash(&bytes).to_hex().to_string();
    if digest != study_digest {
        anyhow::bail!(
            "{} changed since this job was submitted: rerun `squeal run` to plan it again",
            args.study.display()
        );
    }
    let (study, _) = load_study(args, registry)?;
    let stage_idx = study
        .index_of(stage)
        .ok_or_else(|| anyhow::anyhow!("the study has no stage `{stage}`"))?;
    let instances = Instances::expand(&study, &[stage_idx]);
    let task = worker::task_index().map_err(anyhow::Error::msg)?;
    let name = worker::instance_of_task(instance_list, task).map_err(anyhow::Error::msg)?;
    let target = instances
        .list
        .iter()
        .position(|instance| instance.name == name)
        .ok_or_else(|| anyhow::anyhow!("the study has no instance `{name}`"))?;
    let cache = Cache::open(cache_dir(&cli.cache, Some(&args.study)))?;
    let record = RunRecord::default();
    let context = Context {
        study: &study,
        instances: &instances,
        cache: &cache,
        record: &record,
    };
    let status = worker::run_instance(&context, target, jobs)?;
    let path = worker::status_path(status_pattern, task);
    status
        .write(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    if status.succeeded() {
        eprintln!("{name}: {} in {:.3} s", status.status, status.wall_s);
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!("error: {name} {}: {}", status.status, status.message);
        Ok(ExitCode::FAILURE)
    }
}

/// Where a run writes: `--out`, or `out/STEM`. A file in the way is a usage error before
/// anything runs, not an error after the whole study has.
fn out_dir_of(out: Option<PathBuf>, study: &Path) -> Result<PathBuf, UsageError> {
    let out_dir = out.unwrap_or_else(|| default_out_dir(study));
    if out_dir.exists() && !out_dir.is_dir() {
        return Err(UsageError(SpecError {
            location: squeal_engine::spec::Location::CommandLine(format!(
                "--out {}",
                out_dir.display()
            )),
            path: "--out".into(),
            message: "a file is in the way: the outputs go to a folder".into(),
        }));
    }
    Ok(out_dir)
}

/// `out/STEM`, STEM the study file name without its extension.
fn default_out_dir(study: &Path) -> PathBuf {
    let stem = study
        .file_stem()
        .map_or("study".into(), |stem| stem.to_string_lossy().into_owned());
    PathBuf::from("out").join(stem)
}

fn report(
    cli: &Cli,
    args: &StudyArgs,
    out: Option<PathBuf>,
    output: Option<PathBuf>,
    registry: &Registry,
) -> Result<()> {
    let (study, targets) = load_study(args, registry)?;
    let instances = Instances::expand(&study, &targets);
    let out_dir = out.unwrap_or_else(|| default_out_dir(&args.study));
    let manifest_path = out_dir.join("manifest.parquet");
    if !manifest_path.is_file() {
        anyhow::bail!(
            "no run of {} in {} (no manifest.parquet): run `squeal run {}` first",
            args.study.display(),
            out_dir.display(),
            args.study.display()
        );
    }
    let manifest = squeal_engine::manifest::read(&manifest_path).map_err(anyhow::Error::msg)?;
    let study_bytes =
        std::fs::read(&args.study).with_context(|| format!("reading {}", args.study.display()))?;
    let cache = Cache::open(cache_dir(&cli.cache, Some(&args.study)))?;
    let page = squeal_engine::report::render(&squeal_engine::report::ReportInput {
        study: &study,
        instances: &instances,
        manifest: &manifest,
        cache: &cache,
        study_bytes: &study_bytes,
        version: env!("CARGO_PKG_VERSION"),
        out_dir: &out_dir,
    });
    let path = output.unwrap_or_else(|| out_dir.join("report.html"));
    squeal_engine::output::write_atomic(&path, page.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    println!("{}", path.display());
    Ok(())
}

fn cache_command(cli: &Cli, command: &CacheCommand, registry: &Registry) -> Result<ExitCode> {
    match command {
        CacheCommand::Stats => {
            let cache = Cache::open(cache_dir(&cli.cache, None))?;
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
            let cache = Cache::open(cache_dir(&cli.cache, None))?;
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
            let dir = cache_dir(&cli.cache, studies.first().map(PathBuf::as_path));
            let keep_keys = if studies.is_empty() {
                None
            } else {
                Some(referenced_keys(&dir, studies, registry)?)
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

/// Keys of every cached instance of the given studies (their targets, with their parameters).
fn referenced_keys(
    dir: &Path,
    studies: &[PathBuf],
    registry: &Registry,
) -> Result<HashSet<squeal_cache::Digest>> {
    let cache = Cache::open(dir)?;
    let mut keys = HashSet::new();
    for path in studies {
        let args = StudyArgs {
            study: path.clone(),
            set: Vec::new(),
            targets: Vec::new(),
        };
        let (study, targets) = load_study(&args, registry)?;
        let instances = Instances::expand(&study, &targets);
        let record = RunRecord::default();
        let context = Context {
            study: &study,
            instances: &instances,
            cache: &cache,
            record: &record,
        };
        keys.extend(
            plan::plan(&context)
                .into_iter()
                .filter_map(|line| match line.decision {
                    Decision::Cached { key, .. } => Some(key),
                    Decision::Runs { .. } => None,
                }),
        );
    }
    Ok(keys)
}

fn print_stages(registry: &Registry) {
    let compute_time = squeal_engine::ports::compute_time_port();
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
