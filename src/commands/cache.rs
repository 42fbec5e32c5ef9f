//! `squeal cache init | stats | verify | gc`: share, inspect and maintain the cache.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Result;
use squeal_cache::{Cache, GcPolicy};
use squeal_engine::{Registry, Workbench};

use crate::cli::CacheCommand;

pub fn cache(
    registry: &Registry,
    cache: Option<&Path>,
    command: &CacheCommand,
) -> Result<ExitCode> {
    match command {
        CacheCommand::Init { dir, .. } => {
            let dir = dir
                .clone()
                .unwrap_or_else(|| Workbench::cache_dir(cache, None));
            let cache = Cache::init_shared(&dir)?;
            println!(
                "cache {} is shared by the members of its group: folders 2770 (setgid), entries 0440",
                cache.root().display()
            );
        }
        CacheCommand::Stats => {
            let cache = Cache::open(Workbench::cache_dir(cache, None))?;
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
            let cache = Cache::open(Workbench::cache_dir(cache, None))?;
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
            let dir = Workbench::cache_dir(cache, studies.first().map(PathBuf::as_path));
            let keep_keys = if studies.is_empty() {
                None
            } else {
                Some(referenced_keys(registry, &dir, studies)?)
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
            if !report.not_removed.is_empty() {
                println!(
                    "{} entries could not be removed (they belong to another user, in a folder \
                     you may not change):",
                    report.not_removed.len()
                );
                for line in &report.not_removed {
                    println!("  {line}");
                }
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Keys of every cached instance of the given studies (their targets, with their parameters).
fn referenced_keys(
    registry: &Registry,
    dir: &Path,
    studies: &[PathBuf],
) -> Result<HashSet<squeal_cache::Digest>> {
    let cache = Cache::open(dir)?;
    let mut keys = HashSet::new();
    for study in studies {
        let bench = Workbench::open(registry, study, &[], &[], Some(dir))?;
        keys.extend(bench.referenced_keys(&cache));
    }
    Ok(keys)
}

fn format_size(bytes: u64) -> String {
    match bytes {
        0..1_000 => format!("{bytes} B"),
        1_000..1_000_000 => format!("{:.1} kB", bytes as f64 / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1} MB", bytes as f64 / 1e6),
        _ => format!("{:.2} GB", bytes as f64 / 1e9),
    }
}
