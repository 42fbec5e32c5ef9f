//! `manifest.parquet`: one row per stage instance of a run — what ran, what was cached, why,
//! how long it took, with which parameters and which output digests.

use std::path::Path;

use squeal_stages::Table;

use crate::outcome::{InstanceOutcome, RunOutcome, Status};

pub fn table(report: &RunOutcome) -> Table {
    let rows = &report.instances;
    let column =
        |get: &dyn Fn(&InstanceOutcome) -> String| rows.iter().map(get).collect::<Vec<String>>();
    Table::new()
        .with("stage", column(&|row| row.name.clone()))
        .with("stage_name", column(&|row| row.stage.clone()))
        .with("kind", column(&|row| row.kind.clone()))
        .with(
            "key",
            column(&|row| row.key.map(|key| key.hex()).unwrap_or_default()),
        )
        .with("status", column(&|row| row.status.label().to_string()))
        .with(
            "reason",
            column(&|row| match &row.status {
                Status::Failed(message) => format!("failed: {message}"),
                Status::Skipped(upstream) => {
                    format!("skipped: `{upstream}` did not complete")
                }
                _ => row.reasons.join("; "),
            }),
        )
        .with(
            "wall_s",
            rows.iter().map(|row| row.wall_s).collect::<Vec<f64>>(),
        )
        .with(
            "compute_s",
            rows.iter().map(|row| row.compute_s).collect::<Vec<f64>>(),
        )
        .with("params_json", column(&|row| row.params_json.clone()))
        .with(
            "outputs_json",
            column(&|row| {
                let outputs: serde_json::Map<String, serde_json::Value> = row
                    .outputs
                    .iter()
                    .filter(|(name, _)| !crate::ports::is_implicit(name))
                    .map(|(name, digest)| (name.clone(), digest.hex().into()))
                    .collect();
                serde_json::Value::Object(outputs).to_string()
            }),
        )
}

pub fn write(path: &Path, report: &RunOutcome) -> std::io::Result<()> {
    crate::output::write_parquet_if_changed(path, &table(report))
}
