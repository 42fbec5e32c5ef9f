//! The Parquet files a run writes read back with the promised columns and rows, and sweeps
//! fan out and gather as documented.

mod common;

use common::{Workspace, floats, read_parquet, strings};

const SWEEP: &str = "\
study: sweep
targets: [gathered]
stages:
  source:
    kind: test.constant
    params: { value: 2.0, rows: 3 }
  scaled:
    kind: test.affine
    inputs: { table: source.table }
    matrix:
      scale: [1, 10]
      offset: { start: 0.0, stop: 1.0, num: 3 }
  rounded:
    kind: test.round
    inputs: { table: scaled.table }
  gathered:
    kind: table.gather
    inputs: { tables: rounded.table }
  unused:
    kind: test.fail
    inputs: { table: source.table }
";

#[test]
fn manifest_has_one_row_per_instance_with_the_promised_columns() {
    let workspace = Workspace::new();
    workspace.write("sweep.yaml", SWEEP);
    workspace.run_ok(&["run", "sweep.yaml", "--out", "out"]);
    let manifest = read_parquet(&workspace.path().join("out/manifest.parquet"));
    let columns: Vec<String> = manifest
        .schema()
        .fields()
        .iter()
        .map(|field| field.name().clone())
        .collect();
    for column in [
        "stage",
        "kind",
        "key",
        "status",
        "wall_s",
        "compute_s",
        "params_json",
        "reason",
        "outputs_json",
    ] {
        assert!(
            columns.contains(&column.to_string()),
            "{column} missing from {columns:?}"
        );
    }
    // 1 source + 6 sweep points × 2 stages + 1 gather; `unused` is not needed by the target.
    assert_eq!(manifest.num_rows(), 14);
    let stages = strings(&manifest, "stage");
    assert!(
        stages.contains(&"scaled[scale=10,offset=0.5]".to_string()),
        "{stages:?}"
    );
    assert!(
        stages.contains(&"rounded[scale=1,offset=1]".to_string()),
        "{stages:?}"
    );
    assert!(!stages.iter().any(|stage| stage.starts_with("unused")));
    assert!(
        strings(&manifest, "status")
            .iter()
            .all(|status| status == "ran")
    );
    let params = strings(&manifest, "params_json");
    let scaled = stages
        .iter()
        .position(|stage| stage == "scaled[scale=10,offset=0.5]")
        .unwrap();
    let params: serde_json::Value = serde_json::from_str(&params[scaled]).unwrap();
    assert_eq!(params, serde_json::json!({ "scale": 10.0, "offset": 0.5 }));
    assert!(floats(&manifest, "wall_s").iter().all(|wall| *wall >= 0.0));
    assert!(strings(&manifest, "key").iter().all(|key| key.len() == 64));
    let computed: Vec<(String, f64)> = stages
        .iter()
        .cloned()
        .zip(floats(&manifest, "compute_s"))
        .collect();

    workspace.run_ok(&["run", "sweep.yaml", "--out", "out"]);
    let manifest = read_parquet(&workspace.path().join("out/manifest.parquet"));
    assert!(
        strings(&manifest, "status")
            .iter()
            .all(|status| status == "cached")
    );
    // A cached instance reports the time its outputs took to compute, from the cache.
    let recalled: Vec<(String, f64)> = strings(&manifest, "stage")
        .into_iter()
        .zip(floats(&manifest, "compute_s"))
        .collect();
    assert_eq!(recalled, computed);
    assert!(floats(&manifest, "wall_s").iter().all(|wall| *wall == 0.0));
}

#[test]
fn gathered_tables_carry_the_swept_parameters_as_columns() {
    let workspace = Workspace::new();
    workspace.write("sweep.yaml", SWEEP);
    workspace.run_ok(&["run", "sweep.yaml", "--out", "out"]);
    let gathered = read_parquet(&workspace.path().join("out/gathered/gathered.parquet"));
    let columns: Vec<String> = gathered
        .schema()
        .fields()
        .iter()
        .map(|field| field.name().clone())
        .collect();
    assert_eq!(columns, ["scale", "offset", "x"]);
    assert_eq!(gathered.num_rows(), 18);
    let (scale, offset, x) = (
        floats(&gathered, "scale"),
        floats(&gathered, "offset"),
        floats(&gathered, "x"),
    );
    for row in 0..18 {
        assert_eq!(
            x[row],
            (2.0 * scale[row] + offset[row]).round(),
            "row {row}"
        );
    }
    assert_eq!(offset[..9], [0.0, 0.0, 0.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0]);
    // Swept instances write hive-style folders that pyarrow, polars and duckdb read as columns.
    let point = read_parquet(
        &workspace
            .path()
            .join("out/scaled/scale=10/offset=0.5/table.parquet"),
    );
    assert_eq!(floats(&point, "x"), [20.5, 20.5, 20.5]);
}

#[test]
fn two_swept_inputs_from_one_sweep_are_joined_not_crossed() {
    let workspace = Workspace::new();
    let study = "\
stages:
  source:
    kind: test.constant
    matrix: { value: [1, 2, 3] }
  left:
    kind: test.affine
    inputs: { table: source.table }
  right:
    kind: test.round
    inputs: { table: source.table }
    matrix: { decimals: [0, 1] }
  both:
    kind: table.gather
    inputs: { tables: right.table }
  per_value:
    kind: test.affine
    inputs: { table: left.table }
    params: { scale: 3 }
";
    workspace.write("join.yaml", study);
    workspace.run_ok(&["run", "join.yaml", "--out", "out"]);
    let stages = common::statuses(&workspace.path().join("out"));
    let names: Vec<&str> = stages.keys().map(String::as_str).collect();
    assert_eq!(
        names
            .iter()
            .filter(|name| name.starts_with("left["))
            .count(),
        3
    );
    assert_eq!(
        names
            .iter()
            .filter(|name| name.starts_with("right["))
            .count(),
        6
    );
    assert_eq!(
        names
            .iter()
            .filter(|name| name.starts_with("per_value["))
            .count(),
        3
    );
    assert!(names.contains(&"right[value=2,decimals=1]"), "{names:?}");
    let gathered = read_parquet(&workspace.path().join("out/both/gathered.parquet"));
    assert_eq!(gathered.num_rows(), 6);
    assert_eq!(floats(&gathered, "value"), [1.0, 1.0, 2.0, 2.0, 3.0, 3.0]);
}

#[test]
fn dag_renders_every_instance_and_edge() {
    let workspace = Workspace::new();
    workspace.write("sweep.yaml", SWEEP);
    let output = workspace.squeal(&["dag", "sweep.yaml", "--format", "dot"]);
    let dot = String::from_utf8_lossy(&output.stdout);
    assert!(dot.starts_with("digraph \"sweep\" {"), "{dot}");
    assert_eq!(
        dot.matches("[label=\"").count(),
        14 + 18,
        "14 nodes and 18 edges:\n{dot}"
    );
    let output = workspace.squeal(&["dag", "sweep.yaml", "--format", "mermaid"]);
    let mermaid = String::from_utf8_lossy(&output.stdout);
    assert!(mermaid.starts_with("flowchart LR"), "{mermaid}");
    assert_eq!(mermaid.matches("-->").count(), 18);
}

#[test]
fn every_stage_offers_its_compute_time_as_an_output() {
    let workspace = Workspace::new();
    workspace.write(
        "timed.yaml",
        "\
study: timed
targets: [times]
stages:
  source:
    kind: test.constant
    params: { value: 2.0, rows: 3 }
  scaled:
    kind: test.affine
    inputs: { table: source.table }
    matrix:
      scale: [1, 10]
  times:
    kind: table.gather
    inputs: { tables: scaled.compute_s }
",
    );
    workspace.run_ok(&["run", "timed.yaml", "--out", "out"]);
    let times = read_parquet(&workspace.path().join("out/times/gathered.parquet"));
    let manifest = read_parquet(&workspace.path().join("out/manifest.parquet"));
    let stages = strings(&manifest, "stage");
    let compute = floats(&manifest, "compute_s");
    let of = |name: &str| compute[stages.iter().position(|s| s == name).unwrap()];
    assert_eq!(floats(&times, "scale"), [1.0, 10.0]);
    assert_eq!(
        floats(&times, "compute_s"),
        [of("scaled[scale=1]"), of("scaled[scale=10]")]
    );
    // Not exported as a file: the manifest has it.
    assert!(
        !workspace
            .path()
            .join("out/scaled/scale=1/compute_s.parquet")
            .exists()
    );
    // Cached, the same times: the gather does not rerun.
    workspace.run_ok(&["run", "timed.yaml", "--out", "out"]);
    let manifest = read_parquet(&workspace.path().join("out/manifest.parquet"));
    assert!(
        strings(&manifest, "status")
            .iter()
            .all(|status| status == "cached")
    );
}

#[test]
fn a_stage_takes_gathered_and_single_inputs_together() {
    // `pareto` gathers the errors and run times of a sweep and takes one reference time:
    // inputs of both arities, declared in an order other than their names'.
    let workspace = Workspace::new();
    workspace.write("front.yaml", common::PARETO_STUDY);
    workspace.run_ok(&["run", "front.yaml", "--out", "out"]);
    let front = read_parquet(&workspace.path().join("out/front/points.parquet"));
    assert_eq!(floats(&front, "value"), [0.5, 0.25]);
    assert_eq!(floats(&front, "x"), [0.5, 0.25]);
    let speed_up = floats(&front, "speed_up");
    assert!(
        speed_up.iter().all(|s| s.is_finite() && *s > 0.0),
        "{speed_up:?}"
    );
    assert!(workspace.path().join("out/front/fronts.png").exists());
}

#[test]
fn a_study_naming_a_renamed_output_loads_with_a_warning_giving_the_new_name() {
    let workspace = Workspace::new();
    workspace.write(
        "renamed.yaml",
        "\
stages:
  mesh:
    kind: mesh.brake
  model:
    kind: assemble
    inputs: { mesh: mesh.mesh }
  modes:
    kind: modes
    inputs: { model: model.model }
  all_modes:
    kind: table.gather
    inputs: { tables: modes.table }
",
    );
    let stderr = workspace.run_ok(&["validate", "renamed.yaml"]);
    assert!(
        stderr.contains(
            "renamed.yaml:12:23: stages.all_modes.inputs.tables: output `modes.table` is now \
             `modes.frequencies`; the old name is read until the next release"
        ),
        "{stderr}"
    );
    let dag = workspace.squeal(&["dag", "renamed.yaml", "--format", "dot"]);
    assert!(
        String::from_utf8_lossy(&dag.stdout).contains("frequencies"),
        "the old name resolves to the new output"
    );
}

#[test]
fn a_range_sweep_names_its_points_as_a_person_writes_them() {
    let workspace = Workspace::new();
    workspace.write(
        "range.yaml",
        "\
stages:
  source:
    kind: test.constant
    matrix:
      value: { start: 0.0, stop: 0.6, num: 7 }
",
    );
    let plan = workspace.squeal(&["plan", "range.yaml"]);
    let stdout = String::from_utf8_lossy(&plan.stdout);
    for value in ["0", "0.1", "0.2", "0.3", "0.4", "0.5", "0.6"] {
        assert!(
            stdout.contains(&format!("source[value={value}] ")),
            "{value}: {stdout}"
        );
    }
    assert!(!stdout.contains("9999"), "{stdout}");
}

#[test]
fn a_swept_path_resolves_against_the_study_folder_and_names_one_folder() {
    let workspace = Workspace::new();
    std::fs::create_dir_all(workspace.path().join("study/data")).unwrap();
    for (name, scale) in [("a", 1.0), ("b", 2.0)] {
        let rows: String = (0..4)
            .map(|i| format!("{i},{}\n", scale * i as f64))
            .collect();
        workspace.write(&format!("study/data/{name}.csv"), &format!("t,x\n{rows}"));
    }
    workspace.write(
        "study/signals.yaml",
        "\
stages:
  read:
    kind: signal.read
    matrix: { path: [data/a.csv, data/b.csv] }
",
    );
    // Run from the workspace, not the study's folder: the paths are the study's.
    workspace.run_ok(&["run", "study/signals.yaml", "--out", "out"]);
    for (name, scale) in [("a", 1.0), ("b", 2.0)] {
        let signal = read_parquet(
            &workspace
                .path()
                .join(format!("out/read/path=data%2F{name}.csv/signal.parquet")),
        );
        assert_eq!(
            floats(&signal, "x"),
            [0.0, 1.0, 2.0, 3.0].map(|x| scale * x)
        );
    }
}

#[test]
fn a_list_parameter_takes_a_yaml_list_or_its_comma_separated_string() {
    let workspace = Workspace::new();
    workspace.write("signal.csv", "t,x,y,z\n0,1,2,3\n1,4,5,6\n");
    let study = |columns: &str| {
        format!(
            "\
stages:
  read:
    kind: signal.read
    params: {{ path: signal.csv, {columns} }}
"
        )
    };
    for (file, columns) in [
        ("list.yaml", "columns: [z, x]"),
        ("text.yaml", "columns: \"z, x\""),
    ] {
        workspace.write(file, &study(columns));
        let out = format!("out_{file}");
        workspace.run_ok(&["run", file, "--out", &out]);
        let signal = read_parquet(&workspace.path().join(out).join("read/signal.parquet"));
        let names: Vec<&str> = signal
            .schema_ref()
            .fields()
            .iter()
            .map(|field| field.name().as_str())
            .collect();
        assert_eq!(names, ["t", "z", "x"], "{file}");
    }
    let plan = workspace.squeal(&["plan", "list.yaml", "--set", "read.columns=[y]"]);
    assert!(plan.status.success());
    let sweep = "\
stages:
  read:
    kind: signal.read
    params: { path: signal.csv }
    matrix: { columns: [[x, y], [z]] }
";
    workspace.write("sweep.yaml", sweep);
    let plan = workspace.squeal(&["plan", "sweep.yaml"]);
    let stdout = String::from_utf8_lossy(&plan.stdout);
    for name in ["read[columns=x, y]", "read[columns=z]"] {
        assert!(stdout.contains(name), "{name}: {stdout}");
    }
}
