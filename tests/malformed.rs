//! A corpus of malformed studies (`tests/malformed/*.yaml`) and bad command-line overrides:
//! each must fail validation before anything runs, with one line naming `file:line:col`, the
//! field path and the problem, exit code 2 and no panic.

mod common;

use std::path::Path;

use common::Workspace;

/// `squeal ARGS` must fail with exactly `error: <expected>` (one line) and exit code 2.
fn check(args: &[&str], expected: &str) {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/malformed");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_squeal"))
        .args(args)
        .current_dir(&corpus)
        .env("SQUEAL_TEST_KINDS", "1")
        .output()
        .expect("run squeal");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "squeal {args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line for {args:?}: {stderr}");
    assert_eq!(
        stderr.trim_end(),
        format!("error: {expected}"),
        "squeal {args:?}"
    );
}

fn check_file(file: &str, expected: &str) {
    check(&["validate", file], &format!("{file}:{expected}"));
}

#[test]
fn yaml_syntax() {
    check_file(
        "syntax_unclosed_flow.yaml",
        "4:33: stages.source.params.rows: unclosed bracket '['",
    );
    check_file(
        "syntax_bad_indentation.yaml",
        "4:4: stages: while parsing a block mapping, did not find expected key",
    );
}

#[test]
fn unknown_or_missing_keys() {
    check_file(
        "unknown_top_level_key.yaml",
        "2:1: stagez: unknown field `stagez`, expected one of study, description, targets, stages, slurm",
    );
    check_file(
        "unknown_stage_key.yaml",
        "4:5: stages.source.param: unknown field `param`, expected one of kind, params, inputs, matrix, resources",
    );
    check_file(
        "missing_kind.yaml",
        "3:5: stages.source: missing field `kind`",
    );
    check_file(
        "stages_not_a_mapping.yaml",
        "2:3: stages: expected a mapping",
    );
    check_file(
        "inputs_not_a_mapping.yaml",
        "6:13: stages.scaled.inputs: expected a mapping",
    );
    check_file(
        "no_stages.yaml",
        "1:1: stages: a study needs at least one stage",
    );
}

#[test]
fn unknown_kinds() {
    check_file(
        "unknown_kind.yaml",
        "3:11: stages.source.kind: unknown stage kind `test.konstant` (did you mean `test.constant`? \
         `squeal stages` lists them all)",
    );
}

#[test]
fn parameter_types_units_and_ranges() {
    check_file(
        "unknown_parameter.yaml",
        "6:11: stages.source.params.mu: `test.constant` has no parameter `mu` (parameters: value, rows)",
    );
    check_file(
        "wrong_type_string_for_float.yaml",
        "5:14: stages.source.params.value: expected a number with an optional unit (dimensionless), found \"high\"",
    );
    check_file(
        "wrong_type_float_for_int.yaml",
        "5:13: stages.source.params.rows: expected int >= 1, found 2.5",
    );
    check_file(
        "wrong_type_bool_for_float.yaml",
        "7:24: stages.slow.params.seconds: expected float >= 0, found true",
    );
    // YAML 1.2: `true` and `false` are the booleans, `no` is a string.
    check_file(
        "bool_written_no.yaml",
        "4:33: stages.stability.params.friction_damping: expected bool, found \"no\"",
    );
    check_file(
        "wrong_type_mapping_for_float.yaml",
        "4:22: stages.source.params.value: expected a number, string, bool or list",
    );
    check_file(
        "wrong_unit.yaml",
        "7:24: stages.slow.params.seconds: unit `Hz` does not match the parameter's unit (`s`)",
    );
    check_file(
        "unit_on_dimensionless.yaml",
        "4:22: stages.source.params.value: unit `mm` does not match the parameter's unit (dimensionless)",
    );
    check_file(
        "out_of_range.yaml",
        "4:21: stages.source.params.rows: 0 is out of range: expected an int >= 1",
    );
}

/// A list parameter's items are read as the stage reads them, before anything runs.
#[test]
fn list_items_of_the_wrong_type() {
    check_file(
        "list_item_wrong_type.yaml",
        "4:35: stages.basis.params.modes: `two` is not an integer",
    );
    check_file(
        "sweep_list_item_wrong_type.yaml",
        "6:14: stages.basis.matrix.modes: value 1: `x` is not an integer",
    );
}

#[test]
fn references() {
    check_file(
        "dangling_stage_reference.yaml",
        "6:22: stages.scaled.inputs.table: no stage named `sauce`",
    );
    check_file(
        "dangling_output_reference.yaml",
        "6:22: stages.scaled.inputs.table: stage `source` has no output `mesh` (outputs: table)",
    );
    check_file(
        "reference_without_output.yaml",
        "6:22: stages.scaled.inputs.table: expected `stage.output`",
    );
    check_file(
        "unknown_input_port.yaml",
        "8:14: stages.scaled.inputs.model: `test.affine` has no input `model` (inputs: table)",
    );
    check_file(
        "gather_input_into_one.yaml",
        "6:44: stages.gathered.inputs.extra: `table.gather` has no input `extra` (inputs: tables)",
    );
    check_file(
        "missing_input.yaml",
        "3:11: stages.scaled: missing input `table` (a table with an f64 column `x`)",
    );
    check_file(
        "unknown_target.yaml",
        "1:19: targets[1]: no stage named `spectrum`",
    );
    check_file(
        "list_into_one_port.yaml",
        "6:22: stages.scaled.inputs.table: input `table` takes one `stage.output`, not a list",
    );
    check_file(
        "empty_list_input.yaml",
        "6:23: stages.total.inputs.tables: the list is empty",
    );
    check_file(
        "list_item_dangling.yaml",
        "9:11: stages.total.inputs.tables[1]: no stage named `sauce`",
    );
    check_file(
        "listed_twice.yaml",
        "6:38: stages.total.inputs.tables[1]: `source.table` is listed twice",
    );
    check_file(
        "list_input_wrong_shape.yaml",
        "6:23: stages.total.inputs.tables: invalid type: map, expected `stage.output` or a list of them",
    );
    check_file(
        "wrong_output_type.yaml",
        "9:22: stages.scaled.inputs.table: `view.mesh` is a document, but input `table` takes a table",
    );
}

#[test]
fn duplicate_names() {
    check_file(
        "duplicate_stage_name.yaml",
        "4:3: stages: duplicate key `source`",
    );
}

#[test]
fn sweeps() {
    check_file(
        "empty_sweep.yaml",
        "5:14: stages.source.matrix.value: empty sweep: give at least one value",
    );
    check_file(
        "sweep_too_large.yaml",
        "5:14: stages.source.matrix.value: 100000000 values: a sweep takes at most 10000 (split the study)",
    );
    check_file(
        "matrix_too_large.yaml",
        "9:15: stages.scaled.matrix.offset: the matrix crosses 1000000 points: a stage takes at most 100000 (split the study)",
    );
    check_file(
        "sweep_of_unknown_parameter.yaml",
        "5:11: stages.source.matrix.mu: `test.constant` has no parameter `mu` (parameters: value, rows)",
    );
    check_file(
        "sweep_and_param_both_set.yaml",
        "6:14: stages.source.matrix.value: `value` is both set in params and swept",
    );
    check_file(
        "sweep_wrong_type.yaml",
        "5:13: stages.source.matrix.rows: value 2: expected int >= 1, found \"three\"",
    );
    check_file(
        "sweep_repeated_value.yaml",
        "5:14: stages.source.matrix.value: value 2 (0.1) is repeated",
    );
    check_file(
        "sweep_range_unknown_key.yaml",
        "5:14: stages.source.matrix.value: expected a list of values or {start, stop, num}",
    );
}

#[test]
fn cycles_name_their_stages_in_order() {
    check_file(
        "cycle_of_three.yaml",
        "3:11: stages.first: cycle: first -> second -> third -> first",
    );
    check_file("cycle_self.yaml", "5:11: stages.loop: cycle: loop -> loop");
}

/// `squeal plan` on a study made valid by a first `--set`, then `set` on top.
fn run(set: &str) -> [&str; 6] {
    [
        "plan",
        "out_of_range.yaml",
        "--set",
        "source.rows=2",
        "--set",
        set,
    ]
}

#[test]
fn bad_set_values() {
    check(
        &["validate", "missing_input.yaml", "--set", "scaled.scale=2"],
        "missing_input.yaml:3:11: stages.scaled: missing input `table` (a table with an f64 column `x`)",
    );
    check(
        &run("source"),
        "--set source: --set: expected stage.param=value",
    );
    check(
        &run("source.rows"),
        "--set source.rows: --set: expected stage.param=value",
    );
    check(&run("=3"), "--set =3: --set: expected stage.param=value");
    check(
        &run("sink.rows=3"),
        "--set sink.rows=3: --set: no stage named `sink`",
    );
    check(
        &run("source.mu=0.3"),
        "--set source.mu=0.3: stages.source.params.mu: `test.constant` has no parameter `mu` (parameters: value, rows)",
    );
    check(
        &run("source.rows=many"),
        "--set source.rows=many: stages.source.params.rows: expected int >= 1, found \"many\"",
    );
    check(
        &run("source.rows=-2"),
        "--set source.rows=-2: stages.source.params.rows: -2 is out of range: expected an int >= 1",
    );
    check(
        &run("source.value=2 kHz"),
        "--set source.value=2 kHz: stages.source.params.value: unit `kHz` does not match the parameter's unit (dimensionless)",
    );
    check(
        &run("source.value=[1, 2]"),
        "--set source.value=[1, 2]: stages.source.params.value: expected float, found [1, 2]",
    );
    check(
        &run("source.value={a: 1}"),
        "--set source.value={a: 1}: --set: the value is not a YAML scalar or list",
    );
    // A file where the outputs would go: refused before anything runs.
    check(
        &[
            "run",
            "out_of_range.yaml",
            "--set",
            "source.rows=2",
            "--out",
            "cycle_self.yaml",
        ],
        "--out cycle_self.yaml: --out: a file is in the way: the outputs go to a folder",
    );
    check(
        &["plan", "missing_kind.yaml", "--target", "nowhere"],
        "missing_kind.yaml:3:5: stages.source: missing field `kind`",
    );
    check(
        &[
            "plan",
            "out_of_range.yaml",
            "--set",
            "source.rows=2",
            "--target",
            "nowhere",
        ],
        "--target nowhere: --target: no stage named `nowhere`",
    );
}

#[test]
fn a_missing_study_file_is_a_usage_error() {
    let workspace = Workspace::new();
    let output = workspace.squeal(&["validate", "absent.yaml"]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.starts_with("error: absent.yaml:1:1: (file): cannot read: No such file"),
        "{stderr}"
    );
}

#[test]
fn the_corpus_is_covered() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/malformed");
    let source = include_str!("malformed.rs");
    let files: Vec<String> = std::fs::read_dir(corpus)
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(files.len() >= 20, "{} files", files.len());
    for file in files {
        assert!(
            source.contains(&format!("\"{file}\"")),
            "{file} has no expectation"
        );
    }
}
