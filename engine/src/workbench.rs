//! The engine's one door for the command line: a study opened with its arguments, and what
//! can be done with it — show its DAG, plan, run here or on Slurm, report, name the cache
//! entries it uses — and the Slurm worker, which settles one instance inside a job.
//!
//! It owns the layout beside a study: the cache (`.squeal/cache`, unless `--cache` says
//! otherwise), the run record (`.squeal/record/<stem>.json`), the Slurm runs' scripts and logs
//! (`.squeal/slurm/<stem>-<seconds>-<pid>/`) and the default output folder (`out/<stem>`,
//! relative to where squeal runs).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use squeal_cache::{Cache, CacheError, Digest};

use crate::dag::{self, Format};
use crate::instances::Instances;
use crate::outcome::RunOutcome;
use crate::plan::{self, Context, Decision, PlanLine};
use crate::record::RunRecord;
use crate::resources::{self, JobDefaults};
use crate::run::{self, RunOptions};
use crate::slurm::worker::{self, TaskStatus, WorkerInvocation};
use crate::slurm::{self, SlurmOptions, Submitted};
use crate::spec::SpecError;
use crate::study::{Override, Registry, Study};
use crate::{manifest, output, report};

/// Why a command could not do its work.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The study or an argument is wrong: the user's to fix (`squeal` exits with 2).
    #[error(transparent)]
    Usage(#[from] SpecError),
    #[error(transparent)]
    Cache(#[from] CacheError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// Reading or writing failed; `doing` says what squeal was doing.
    #[error("{doing}")]
    File {
        doing: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Failed(String),
}

impl Error {
    /// A user error in the study or the arguments.
    pub fn is_usage(&self) -> bool {
        matches!(self, Error::Usage(_))
    }

    /// A usage error in command-line argument `arg`.
    pub fn usage(arg: &str, message: impl Into<String>) -> Error {
        Error::Usage(SpecError::command_line(arg, arg, message))
    }

    fn file(doing: String) -> impl FnOnce(std::io::Error) -> Error {
        move |source| Error::File { doing, source }
    }
}

/// A study, validated and expanded for its targets, with the folders squeal keeps beside it.
pub struct Workbench {
    /// The study file as named on the command line.
    path: PathBuf,
    /// The `--set` overrides as written (Slurm jobs get them again).
    sets: Vec<String>,
    cache_dir: PathBuf,
    study: Study,
    instances: Instances,
}

impl Workbench {
    /// The cache: `cache` (`--cache`) if given, else `.squeal/cache` beside the study (or in
    /// `SQUEAL_STATE_DIR`), or in the current folder without a study.
    pub fn cache_dir(cache: Option<&Path>, study: Option<&Path>) -> PathBuf {
        match (cache, study) {
            (Some(dir), _) => dir.to_path_buf(),
            (None, Some(study)) => state_dir(study).join("cache"),
            (None, None) => PathBuf::from(".squeal/cache"),
        }
    }

    /// Reads and validates the study at `path` with `--set` overrides `sets`, for the stages
    /// `targets` (the study's own targets when empty). Nothing is opened or written yet.
    pub fn open(
        registry: &Registry,
        path: &Path,
        sets: &[String],
        targets: &[String],
        cache: Option<&Path>,
    ) -> Result<Workbench, Error> {
        Workbench::open_for(registry, path, sets, cache, |study| {
            if targets.is_empty() {
                return Ok(study.targets.clone());
            }
            targets
                .iter()
                .map(|name| {
                    study.index_of(name).ok_or_else(|| {
                        Error::Usage(SpecError::command_line(
                            format!("--target {name}"),
                            "--target",
                            format!("no stage named `{name}`"),
                        ))
                    })
                })
                .collect()
        })
    }

    /// [`Workbench::open`], with the targets chosen from the validated study.
    fn open_for(
        registry: &Registry,
        path: &Path,
        sets: &[String],
        cache: Option<&Path>,
        targets: impl FnOnce(&Study) -> Result<Vec<usize>, Error>,
    ) -> Result<Workbench, Error> {
        let overrides: Vec<Override> = sets
            .iter()
            .map(|arg| arg.parse())
            .collect::<Result<_, SpecError>>()?;
        let study = Study::load(path, registry, &overrides)?;
        let targets = targets(&study)?;
        let instances = Instances::expand(&study, &targets);
        Ok(Workbench {
            path: path.to_path_buf(),
            sets: sets.to_vec(),
            cache_dir: Workbench::cache_dir(cache, Some(path)),
            study,
            instances,
        })
    }

    pub fn study(&self) -> &Study {
        &self.study
    }

    /// The instances the targets need, upstream first.
    pub fn instances(&self) -> &Instances {
        &self.instances
    }

    /// The DAG of the instances, as Graphviz dot or Mermaid.
    pub fn dag(&self, format: Format) -> String {
        dag::render(&self.study, &self.instances, format)
    }

    fn context<'a>(&'a self, cache: &'a Cache, record: &'a RunRecord) -> Context<'a> {
        Context {
            study: &self.study,
            instances: &self.instances,
            cache,
            record,
        }
    }

    fn record_path(&self) -> PathBuf {
        RunRecord::path_for(&self.path, &state_dir(&self.path).join("record"))
    }

    /// For each instance, cached or why it runs.
    pub fn plan(&self) -> Result<Vec<PlanLine>, Error> {
        let cache = Cache::open(&self.cache_dir)?;
        let record = RunRecord::load(&self.record_path());
        Ok(plan::plan(&self.context(&cache, &record)))
    }

    /// The keys of the instances found cached in `cache` (for `cache gc`, which keeps them).
    pub fn referenced_keys(&self, cache: &Cache) -> HashSet<Digest> {
        let record = RunRecord::default();
        plan::plan(&self.context(cache, &record))
            .into_iter()
            .filter_map(|line| match line.decision {
                Decision::Cached { key, .. } => Some(key),
                Decision::Runs { .. } => None,
            })
            .collect()
    }

    /// Where a run writes: `out`, or `out/STEM`. A file in the way is a usage error before
    /// anything runs, not an error after the whole study has.
    pub fn out_dir(&self, out: Option<PathBuf>) -> Result<PathBuf, Error> {
        let out_dir = out.unwrap_or_else(|| default_out_dir(&self.path));
        if out_dir.exists() && !out_dir.is_dir() {
            return Err(Error::Usage(SpecError::command_line(
                format!("--out {}", out_dir.display()),
                "--out",
                "a file is in the way: the outputs go to a folder",
            )));
        }
        Ok(out_dir)
    }

    /// Runs the study here with `jobs` threads, writing its outputs and manifest to `out_dir`
    /// and its run record.
    pub fn run(&self, out_dir: &Path, jobs: Option<usize>) -> Result<RunOutcome, Error> {
        let cache = Cache::open(&self.cache_dir)?;
        let record_path = self.record_path();
        let record = RunRecord::load(&record_path);
        let options = RunOptions::local(jobs, out_dir.to_path_buf(), true);
        run::run(&self.context(&cache, &record), &options, Some(&record_path))
            .map_err(Error::file(format!("running {}", self.path.display())))
    }

    /// What a Slurm run would submit, as the shell commands and scripts; submits nothing.
    pub fn slurm_dry_run(
        &self,
        out_dir: &Path,
        jobs: Option<usize>,
        args: &SlurmArgs,
    ) -> Result<String, Error> {
        let interrupted = Arc::new(AtomicBool::new(false));
        let (cache, record, _) = self.slurm_state()?;
        let options = self.slurm_options(out_dir, jobs, args, interrupted)?;
        Ok(slurm::dry_run(&self.context(&cache, &record), &options))
    }

    /// Runs the study on Slurm: the driver's share here, the rest as jobs, then every output
    /// written as a local run writes it. `interrupted` (set on Ctrl-C) cancels the jobs.
    pub fn run_slurm(
        &self,
        out_dir: &Path,
        jobs: Option<usize>,
        args: &SlurmArgs,
        interrupted: Arc<AtomicBool>,
    ) -> Result<SlurmOutcome, Error> {
        let (cache, record, record_path) = self.slurm_state()?;
        let options = self.slurm_options(out_dir, jobs, args, interrupted)?;
        let (outcome, submitted) =
            slurm::run(&self.context(&cache, &record), &options, &record_path)
                .map_err(Error::Failed)?;
        Ok(SlurmOutcome {
            outcome,
            submitted,
            dir: options.dir,
        })
    }

    /// The cache, at its absolute path (the jobs' command line names it), and the run record.
    fn slurm_state(&self) -> Result<(Cache, RunRecord, PathBuf), Error> {
        let cache = Cache::open(absolute(&self.cache_dir))?;
        let record_path = self.record_path();
        let record = RunRecord::load(&record_path);
        Ok((cache, record, record_path))
    }

    fn slurm_options(
        &self,
        out_dir: &Path,
        jobs: Option<usize>,
        args: &SlurmArgs,
        interrupted: Arc<AtomicBool>,
    ) -> Result<SlurmOptions, Error> {
        let study_bytes = std::fs::read(&self.path)
            .map_err(Error::file(format!("reading {}", self.path.display())))?;
        let program = std::env::current_exe().map_err(Error::file(
            "locating the squeal binary for the jobs".into(),
        ))?;
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |elapsed| elapsed.as_secs());
        let run_name = format!("{}-{stamp}-{}", stem(&self.path), std::process::id());
        Ok(SlurmOptions {
            defaults: args.requests.clone(),
            program,
            worker: WorkerInvocation {
                cache: Some(absolute(&self.cache_dir)),
                study: absolute(&self.path),
                sets: self.sets.clone(),
                study_digest: blake3::hash(&study_bytes).to_hex().to_string(),
                ..WorkerInvocation::default()
            },
            dir: absolute(&state_dir(&self.path))
                .join("slurm")
                .join(run_name),
            jobs,
            out_dir: out_dir.to_path_buf(),
            progress: true,
            poll: Duration::from_secs_f64(args.poll_s),
            interrupted,
        })
    }

    /// Writes one HTML page of the last run in `out` (`out/STEM` by default) to `page`
    /// (`OUT/report.html` by default); the page's path. `version` is squeal's, for the
    /// provenance.
    pub fn report(
        &self,
        out: Option<PathBuf>,
        page: Option<PathBuf>,
        version: &str,
    ) -> Result<PathBuf, Error> {
        let out_dir = out.unwrap_or_else(|| default_out_dir(&self.path));
        let manifest_path = out_dir.join("manifest.parquet");
        if !manifest_path.is_file() {
            return Err(Error::Failed(format!(
                "no run of {} in {} (no manifest.parquet): run `squeal run {}` first",
                self.path.display(),
                out_dir.display(),
                self.path.display()
            )));
        }
        let manifest = manifest::read(&manifest_path).map_err(Error::Failed)?;
        let study_bytes = std::fs::read(&self.path)
            .map_err(Error::file(format!("reading {}", self.path.display())))?;
        let cache = Cache::open(&self.cache_dir)?;
        let html = report::render(&report::ReportInput {
            study: &self.study,
            instances: &self.instances,
            manifest: &manifest,
            cache: &cache,
            study_bytes: &study_bytes,
            version,
            out_dir: &out_dir,
        });
        let path = page.unwrap_or_else(|| out_dir.join("report.html"));
        output::write_atomic(&path, html.as_bytes())
            .map_err(Error::file(format!("writing {}", path.display())))?;
        Ok(path)
    }

    /// What `squeal worker` does inside a Slurm job: settles the task's instance, and whatever
    /// upstream of it is not cached, with `jobs` threads; writes to the cache only, and leaves
    /// the instance's status where the driver looks for it. The status, also when the instance
    /// failed; an error when the job could not even try.
    pub fn work(
        registry: &Registry,
        invocation: &WorkerInvocation,
        jobs: Option<usize>,
    ) -> Result<TaskStatus, Error> {
        let path = &invocation.study;
        let bytes =
            std::fs::read(path).map_err(Error::file(format!("reading {}", path.display())))?;
        if blake3::hash(&bytes).to_hex().as_str() != invocation.study_digest {
            return Err(Error::Failed(format!(
                "{} changed since this job was submitted: rerun `squeal run` to plan it again",
                path.display()
            )));
        }
        let stage = &invocation.stage;
        let bench = Workbench::open_for(
            registry,
            path,
            &invocation.sets,
            invocation.cache.as_deref(),
            |study| match study.index_of(stage) {
                Some(idx) => Ok(vec![idx]),
                None => Err(Error::Failed(format!("the study has no stage `{stage}`"))),
            },
        )?;
        let task = worker::task_index().map_err(Error::Failed)?;
        let name = worker::instance_of_task(&invocation.instances, task).map_err(Error::Failed)?;
        let target = bench
            .instances
            .list
            .iter()
            .position(|instance| instance.name == name)
            .ok_or_else(|| Error::Failed(format!("the study has no instance `{name}`")))?;
        let cache = Cache::open(&bench.cache_dir)?;
        let record = RunRecord::default();
        let status = worker::run_instance(&bench.context(&cache, &record), target, jobs)?;
        let status_path = worker::status_path(&invocation.status, task);
        status
            .write(&status_path)
            .map_err(Error::file(format!("writing {}", status_path.display())))?;
        Ok(status)
    }
}

/// `run --executor slurm`'s own settings, from the command line.
#[derive(Debug, Clone)]
pub struct SlurmArgs {
    /// What every job asks for, over the study's `slurm:` section.
    pub requests: JobDefaults,
    /// Seconds between two looks at the queue.
    pub poll_s: f64,
}

impl SlurmArgs {
    /// Checks the settings before the study is read; an error names the option.
    pub fn check(&self) -> Result<(), Error> {
        let requests = &self.requests;
        if let Some(time) = &requests.time {
            resources::check_time(time).map_err(|message| Error::usage("--time", message))?;
        }
        if let Some(mem) = &requests.mem {
            resources::check_mem(mem).map_err(|message| Error::usage("--mem", message))?;
        }
        if requests.cpus_per_task == Some(0) {
            return Err(Error::usage(
                "--cpus-per-task",
                "a job needs at least one CPU",
            ));
        }
        if !(self.poll_s.is_finite() && self.poll_s > 0.0) {
            return Err(Error::usage("--poll", "give a positive number of seconds"));
        }
        Ok(())
    }
}

/// How a Slurm run ended.
#[derive(Debug)]
pub struct SlurmOutcome {
    pub outcome: RunOutcome,
    pub submitted: Submitted,
    /// The run's scripts, instance lists, logs and status files.
    pub dir: PathBuf,
}

/// Where squeal keeps a study's default cache, run record and Slurm runs: `SQUEAL_STATE_DIR`
/// when set (for a study in a folder the user may not write), else `.squeal` beside the study.
fn state_dir(study: &Path) -> PathBuf {
    match std::env::var_os(STATE_DIR_VARIABLE) {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => study.parent().unwrap_or(Path::new(".")).join(".squeal"),
    }
}

/// The environment variable that moves [`state_dir`].
const STATE_DIR_VARIABLE: &str = "SQUEAL_STATE_DIR";

/// `out/STEM`.
fn default_out_dir(study: &Path) -> PathBuf {
    PathBuf::from("out").join(stem(study))
}

/// The study file's name without its extension.
fn stem(study: &Path) -> String {
    study
        .file_stem()
        .map_or("study".into(), |stem| stem.to_string_lossy().into_owned())
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}
