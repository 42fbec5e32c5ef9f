//! Writing a run's outputs to its output folder: tables as Parquet, figures as SVG and PNG,
//! documents under their extension, swept instances in hive-style folders (`stage/mu=0.38/`).
//! The export record (`OUT/.squeal-exports.json`) says which bytes each output's files hold, so
//! that an output already there is not written again.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use squeal_cache::Digest;
use squeal_contract::Artifact;

use super::execute::Memo;
use crate::plan::Context;
use crate::{output, ports};

const EXPORTS_FILE: &str = ".squeal-exports.json";

/// What the last export of an output wrote (`out/.squeal-exports.json`).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(super) struct Export {
    digest: Digest,
    /// Paths relative to the output folder.
    files: Vec<String>,
}

/// The export record: each output (its path under the output folder, without extension) and
/// what its last export wrote.
pub(super) type Exports = BTreeMap<String, Export>;

/// The export record of `out_dir`; empty when there is none, or it does not read.
pub(super) fn read_record(out_dir: &Path) -> Exports {
    std::fs::read(out_dir.join(EXPORTS_FILE))
        .ok()
        .and_then(|bytes| serde_json::from_slice(&bytes).ok())
        .unwrap_or_default()
}

pub(super) fn write_record(out_dir: &Path, exports: &Exports) -> std::io::Result<()> {
    output::write_if_changed(
        &out_dir.join(EXPORTS_FILE),
        &serde_json::to_vec_pretty(exports).expect("serialises"),
    )
}

/// Writes each output of instance `idx` that people read. Skipped when the export record
/// says these bytes are already there.
pub(super) fn export(
    context: &Context,
    memo: &Memo,
    out_dir: &Path,
    exports: &Mutex<Exports>,
    idx: usize,
    outputs: &BTreeMap<String, Digest>,
) -> Result<(), String> {
    let instances = context.instances;
    let instance = &instances.list[idx];
    let mut dir = PathBuf::from(&context.study.stages[instance.stage].name);
    for segment in instances.coord_segments(instance) {
        dir.push(segment);
    }
    let record = || {
        exports
            .lock()
            .expect("no export panics while holding the lock")
    };
    for (name, digest) in outputs {
        if ports::is_implicit(name) {
            // In the manifest already.
            continue;
        }
        let relative = dir.join(name);
        let relative_key = relative.to_string_lossy().into_owned();
        let up_to_date = record().get(&relative_key).is_some_and(|export| {
            export.digest == *digest && export.files.iter().all(|file| out_dir.join(file).exists())
        });
        if up_to_date {
            continue;
        }
        let artifact = memo
            .load(context.cache, digest)
            .map_err(|err| format!("output `{name}`: {err}"))?;
        let files: Vec<(PathBuf, &[u8])>;
        let parquet;
        match artifact.as_ref() {
            Artifact::Table(table) => {
                parquet = output::parquet_bytes(table)
                    .map_err(|err| format!("output `{name}`: {err}"))?;
                files = vec![(relative.with_extension("parquet"), &parquet)];
            }
            Artifact::Figure(figure) => {
                files = vec![
                    (relative.with_extension("svg"), figure.svg.as_bytes()),
                    (relative.with_extension("png"), &figure.png),
                ];
            }
            Artifact::Document(document) => {
                files = vec![(
                    relative.with_extension(&document.extension),
                    &document.bytes,
                )];
            }
            // Meshes, models, modes and bases feed other stages; people see them through the
            // tables, figures and documents those stages write.
            Artifact::Mesh(_)
            | Artifact::Model(_)
            | Artifact::RealModes(_)
            | Artifact::Equilibrium(_)
            | Artifact::Basis(_)
            | Artifact::ComplexModes(_)
            | Artifact::Material(_) => files = Vec::new(),
        }
        for (file, bytes) in &files {
            let path = out_dir.join(file);
            output::write_atomic(&path, bytes)
                .map_err(|err| format!("writing {}: {err}", path.display()))?;
        }
        let files = files
            .iter()
            .map(|(file, _)| file.to_string_lossy().into_owned())
            .collect();
        record().insert(
            relative_key,
            Export {
                digest: *digest,
                files,
            },
        );
    }
    Ok(())
}
