//! `manifest.parquet`: one row per stage instance of a run — what ran, what was cached, why,
//! how long it took, with which parameters and which output digests. This module writes it
//! and reads it back (for `squeal report`); nothing else names its columns.

use std::collections::BTreeMap;
use std::path::Path;

use squeal_cache::Digest;
use squeal_contract::{ColumnData, Table};

use crate::outcome::{InstanceOutcome, RunOutcome, Status};
use crate::{output, ports};

/// One row of the manifest: one instance of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct ManifestRow {
    /// The instance, `stage` or `stage[mu=0.38]` (column `stage`).
    pub instance: String,
    /// Its stage in the study (column `stage_name`).
    pub stage: String,
    pub kind: String,
    /// The cache key; none for an instance whose inputs never settled (column `key`, hex or
    /// empty).
    pub key: Option<Digest>,
    /// `ran`, `cached`, `failed` or `skipped`.
    pub status: String,
    /// Why it ran, or why it failed or was skipped.
    pub reason: String,
    pub wall_s: f64,
    pub compute_s: f64,
    pub params_json: String,
    /// Output name → digest, without the implicit outputs (column `outputs_json`).
    pub outputs: BTreeMap<String, Digest>,
}

impl ManifestRow {
    pub fn of(instance: &InstanceOutcome) -> ManifestRow {
        ManifestRow {
            instance: instance.name.clone(),
            stage: instance.stage.clone(),
            kind: instance.kind.clone(),
            key: instance.key,
            status: instance.status.label().to_string(),
            reason: match &instance.status {
                Status::Failed(message) => format!("failed: {message}"),
                Status::Skipped(upstream) => format!("skipped: `{upstream}` did not complete"),
                Status::Ran | Status::Cached => instance.reasons.join("; "),
            },
            wall_s: instance.wall_s,
            compute_s: instance.compute_s,
            params_json: instance.params_json.clone(),
            outputs: instance
                .outputs
                .iter()
                .filter(|(name, _)| !ports::is_implicit(name))
                .map(|(name, digest)| (name.clone(), *digest))
                .collect(),
        }
    }
}

/// Writes the manifest of a run (unless the file already holds these bytes).
pub fn write(path: &Path, outcome: &RunOutcome) -> std::io::Result<()> {
    let rows: Vec<ManifestRow> = outcome.instances.iter().map(ManifestRow::of).collect();
    output::write_parquet_if_changed(path, &table(&rows))
}

/// Reads a manifest back; an error names the file, or the column it lacks.
pub fn read(path: &Path) -> Result<Vec<ManifestRow>, String> {
    rows(&output::read_parquet(path)?)
}

/// The manifest's columns, in their order.
fn table(rows: &[ManifestRow]) -> Table {
    let text = |get: &dyn Fn(&ManifestRow) -> String| rows.iter().map(get).collect::<Vec<_>>();
    let number = |get: &dyn Fn(&ManifestRow) -> f64| rows.iter().map(get).collect::<Vec<_>>();
    Table::new()
        .with("stage", text(&|row| row.instance.clone()))
        .with("stage_name", text(&|row| row.stage.clone()))
        .with("kind", text(&|row| row.kind.clone()))
        .with(
            "key",
            text(&|row| row.key.map(|key| key.hex()).unwrap_or_default()),
        )
        .with("status", text(&|row| row.status.clone()))
        .with("reason", text(&|row| row.reason.clone()))
        .with("wall_s", number(&|row| row.wall_s))
        .with("compute_s", number(&|row| row.compute_s))
        .with("params_json", text(&|row| row.params_json.clone()))
        .with(
            "outputs_json",
            text(&|row| {
                let outputs: serde_json::Map<String, serde_json::Value> = row
                    .outputs
                    .iter()
                    .map(|(name, digest)| (name.clone(), digest.hex().into()))
                    .collect();
                serde_json::Value::Object(outputs).to_string()
            }),
        )
}

/// The rows of a manifest's table. A key or an output digest that does not parse is left out.
fn rows(table: &Table) -> Result<Vec<ManifestRow>, String> {
    let text = |name: &str| match table.column(name) {
        Some(ColumnData::Str(values)) => Ok(values.clone()),
        _ => Err(format!(
            "the manifest has no text column `{name}`: rerun `squeal run`"
        )),
    };
    let number = |name: &str| match table.column(name) {
        Some(ColumnData::F64(values)) => Ok(values.clone()),
        _ => Err(format!(
            "the manifest has no number column `{name}`: rerun `squeal run`"
        )),
    };
    let (instances, stages, kinds) = (text("stage")?, text("stage_name")?, text("kind")?);
    let (keys, statuses, reasons) = (text("key")?, text("status")?, text("reason")?);
    let (walls, computes) = (number("wall_s")?, number("compute_s")?);
    let (params, outputs) = (text("params_json")?, text("outputs_json")?);
    Ok((0..instances.len())
        .map(|row| ManifestRow {
            instance: instances[row].clone(),
            stage: stages[row].clone(),
            kind: kinds[row].clone(),
            key: keys[row].parse().ok(),
            status: statuses[row].clone(),
            reason: reasons[row].clone(),
            wall_s: walls[row],
            compute_s: computes[row],
            params_json: params[row].clone(),
            outputs: serde_json::from_str::<BTreeMap<String, String>>(&outputs[row])
                .unwrap_or_default()
                .into_iter()
                .filter_map(|(name, digest)| digest.parse().ok().map(|digest| (name, digest)))
                .collect(),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outcome() -> RunOutcome {
        let digest = |text: &str| Digest::of(text.as_bytes());
        let instance = |name: &str, status: Status, key: bool| InstanceOutcome {
            name: name.into(),
            stage: "stage".into(),
            kind: "test.kind".into(),
            key: key.then(|| digest(name)),
            status,
            reasons: vec!["new".into(), "parameter `mu` changed 0.3 → 0.38".into()],
            wall_s: 1.25,
            compute_s: 0.5,
            params_json: "{\"mu\":0.38}".into(),
            outputs: [
                ("table".to_string(), digest("table")),
                (ports::COMPUTE_TIME_OUTPUT.to_string(), digest("time")),
                ("figure".to_string(), digest("figure")),
            ]
            .into_iter()
            .collect(),
        };
        RunOutcome {
            instances: vec![
                instance("stage[mu=0.38]", Status::Ran, true),
                instance("cached", Status::Cached, true),
                instance("broken", Status::Failed("did not converge".into()), true),
                instance("after", Status::Skipped("broken".into()), false),
            ],
            wall_s: 3.0,
        }
    }

    #[test]
    fn the_manifest_has_its_columns_in_their_order_and_types() {
        let rows: Vec<ManifestRow> = outcome().instances.iter().map(ManifestRow::of).collect();
        let columns: Vec<(String, &str)> = table(&rows)
            .columns()
            .iter()
            .map(|column| {
                let ty = match column.data {
                    ColumnData::Str(_) => "text",
                    ColumnData::F64(_) => "f64",
                    ColumnData::I64(_) => "i64",
                    ColumnData::Bool(_) => "bool",
                };
                (column.name.clone(), ty)
            })
            .collect();
        let expected = [
            ("stage", "text"),
            ("stage_name", "text"),
            ("kind", "text"),
            ("key", "text"),
            ("status", "text"),
            ("reason", "text"),
            ("wall_s", "f64"),
            ("compute_s", "f64"),
            ("params_json", "text"),
            ("outputs_json", "text"),
        ]
        .map(|(name, ty)| (name.to_string(), ty));
        assert_eq!(columns, expected);
    }

    #[test]
    fn a_manifest_reads_back_as_it_was_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("manifest.parquet");
        write(&path, &outcome()).unwrap();
        let rows = read(&path).unwrap();
        assert_eq!(
            rows,
            outcome()
                .instances
                .iter()
                .map(ManifestRow::of)
                .collect::<Vec<_>>()
        );
        let reasons: Vec<&str> = rows.iter().map(|row| row.reason.as_str()).collect();
        assert_eq!(
            reasons,
            [
                "new; parameter `mu` changed 0.3 → 0.38",
                "new; parameter `mu` changed 0.3 → 0.38",
                "failed: did not converge",
                "skipped: `broken` did not complete"
            ]
        );
        assert!(
            rows.iter()
                .all(|row| !row.outputs.contains_key(ports::COMPUTE_TIME_OUTPUT))
        );
        assert_eq!(rows[3].key, None);
    }

    #[test]
    fn a_manifest_without_a_column_is_refused_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("manifest.parquet");
        let table = Table::new().with("stage", vec!["a".to_string()]);
        output::write_parquet_if_changed(&path, &table).unwrap();
        assert_eq!(
            read(&path),
            Err("the manifest has no text column `stage_name`: rerun `squeal run`".into())
        );
    }
}
