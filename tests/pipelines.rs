//! Every example study runs, and a few of its numbers are checked.

mod common;

use std::path::Path;

use arrow::array::{Array, Int64Array};
use common::{Workspace, floats, read_parquet, strings};

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

    let modes = read_parquet(&workspace.path().join("out/modes/table.parquet"));
    assert_eq!(modes.num_rows(), 12);
    let frequencies = floats(&modes, "freq_hz");
    assert!(
        frequencies.windows(2).all(|pair| pair[0] <= pair[1]),
        "{frequencies:?}"
    );
    assert!(
        frequencies[0] > 10.0,
        "clamped: no rigid-body mode, got {frequencies:?}"
    );
    assert!(
        floats(&modes, "residual")
            .iter()
            .all(|residual| *residual <= 1e-8)
    );

    let summary = read_parquet(&workspace.path().join("out/equilibrium/summary.parquet"));
    let value = |name: &str| {
        let index = strings(&summary, "quantity")
            .iter()
            .position(|quantity| quantity == name)
            .unwrap();
        floats(&summary, "value")[index]
    };
    assert!(value("complementarity_residual") <= 1e-10);
    assert!(value("equation_residual") <= 1e-10);
    assert!(value("closed_pairs") > 0.0);
    assert!(
        (value("friction_force_total_N") - 0.38 * value("normal_force_total_N")).abs()
            <= 1e-9 * value("normal_force_total_N")
    );
    let contact = read_parquet(&workspace.path().join("out/equilibrium/contact.parquet"));
    assert_eq!(contact.num_rows(), 4 * 9);
    assert!(workspace.path().join("out/mode_shapes/vtu.vtu").exists());
    let vtu = std::fs::read_to_string(workspace.path().join("out/equilibrium/vtu.vtu")).unwrap();
    assert!(vtu.contains("Name=\"contact_pressure\"") && vtu.contains("Name=\"displacement\""));
    let png = std::fs::read(workspace.path().join("out/equilibrium/pressure.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let svg =
        std::fs::read_to_string(workspace.path().join("out/equilibrium/pressure.svg")).unwrap();
    assert!(svg.contains("upper pad face"));
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

#[test]
fn the_readme_example_is_a_valid_study() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let start = readme.find("```yaml\n").expect("a yaml example") + "```yaml\n".len();
    let example = &readme[start..start + readme[start..].find("```").unwrap()];
    let workspace = Workspace::new();
    workspace.write("example.yaml", example);
    let output = workspace.squeal(&["validate", "example.yaml"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("(4 stages, 12 instances for the targets)"),
        "{stdout}"
    );
}
