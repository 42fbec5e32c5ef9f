//! The `squeal` command line: arguments (`cli.rs`), one file per command (`commands/`), the
//! stage registry and exit codes. Everything else lives in the `squeal-engine`, `squeal-cache`
//! and `squeal-stages` crates; the commands reach the engine through its `Workbench`.

mod cli;
mod commands;

use std::io::IsTerminal;
use std::process::ExitCode;

use anyhow::Result;
use clap::Parser;
use squeal_engine::{Error, Registry};

use cli::{Cli, Command, Executor};

/// Exit codes: 0 success; 1 a stage, the cache or a file failed; 2 a user error in the study
/// or the arguments.
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
    match dispatch(&cli, &registry()) {
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

/// Every production stage kind, and the engine's test kinds when `SQUEAL_TEST_KINDS=1`.
fn registry() -> Registry {
    let mut kinds = squeal_stages::all_kinds();
    if std::env::var_os("SQUEAL_TEST_KINDS").is_some_and(|value| value == "1") {
        kinds.extend(squeal_stages::test_kinds());
    }
    Registry::new(kinds)
}

fn dispatch(cli: &Cli, registry: &Registry) -> Result<ExitCode> {
    let cache = cli.cache.as_deref();
    match &cli.command {
        Command::Validate(args) => commands::validate::validate(registry, cache, args),
        Command::Stages => Ok(commands::stages::stages(registry)),
        Command::Plan(args) => commands::plan::plan(registry, cache, args),
        Command::Run {
            study,
            out,
            jobs,
            executor: Executor::Local,
            slurm,
        } => {
            if slurm.dry_run {
                return Err(Error::usage("--dry-run", "needs --executor slurm").into());
            }
            commands::run::run_local(registry, cache, study, out.clone(), *jobs)
        }
        Command::Run {
            study,
            out,
            jobs,
            executor: Executor::Slurm,
            slurm,
        } => commands::slurm::run_slurm(registry, cache, study, out.clone(), *jobs, slurm),
        Command::Worker(args) => commands::worker::worker(registry, cache, args),
        Command::Dag { study, format } => commands::dag::dag(registry, cache, study, *format),
        Command::Report { study, out, output } => {
            commands::report::report(registry, cache, study, out.clone(), output.clone())
        }
        Command::Cache(command) => commands::cache::cache(registry, cache, command),
    }
}
