//! Every example study runs, and a few of its numbers are checked.

mod common;

use std::path::Path;

use arrow::array::{Array, Int64Array};
use common::{Workspace, read_parquet, strings};

fn pipeline(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("pipelines")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn quick_study_runs_and_is_coarse() {
    let workspace = Workspace::new();
    let study = pipeline("quick.yaml");
    workspace.run_ok(&["run", &study, "--out", "out", "--cache", "cache"]);
    let summary = read_parquet(&workspace.path().join("out/mesh/summary.parquet"));
    let counts = summary
        .column_by_name("count")
        .unwrap()
        .as_any()
        .downcast_ref::<Int64Array>()
        .unwrap();
    let quantities = strings(&summary, "quantity");
    let dofs = counts.value(
        quantities
            .iter()
            .position(|quantity| quantity == "dofs")
            .unwrap(),
    );
    assert_eq!(dofs, 3 * (5 * 48 * 3 + 4 * 27));
    assert!(dofs < 3_000);
}

#[test]
fn every_pipeline_validates() {
    let workspace = Workspace::new();
    for entry in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines")).unwrap()
    {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|ext| ext == "yaml") {
            let output = workspace.squeal(&["validate", &path.display().to_string()]);
            assert!(
                output.status.success(),
                "{}: {}",
                path.display(),
                String::from_utf8_lossy(&output.stderr)
            );
        }
    }
}
