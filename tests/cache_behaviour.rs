//! What reruns, what stays cached, and how the cache survives crashes, corruption and
//! concurrent runs. Each test asserts *which stages ran*, from the manifest.

mod common;

use std::time::Duration;

use common::{Workspace, floats, ran, read_parquet, statuses, strings};

/// Five stages in a chain; `round` makes small changes upstream invisible downstream.
const CHAIN: &str = "\
study: chain
stages:
  source:
    kind: test.constant
    params: { value: 2.0, rows: 4 }
  scale:
    kind: test.affine
    inputs: { table: source.table }
    params: { scale: 1.5 }
  round:
    kind: test.round
    inputs: { table: scale.table }
  shift:
    kind: test.affine
    inputs: { table: round.table }
    params: { offset: 1.0 }
  last:
    kind: test.affine
    inputs: { table: shift.table }
    params: { scale: -1.0 }
";

fn check_reruns(workspace: &Workspace, args: &[&str], expected: &[&str]) {
    let mut all = vec!["run", "chain.yaml", "--out", "out"];
    all.extend_from_slice(args);
    workspace.run_ok(&all);
    assert_eq!(
        ran(&workspace.path().join("out")),
        expected,
        "after squeal {args:?}"
    );
}

#[test]
fn editing_one_parameter_reruns_exactly_the_affected_stages() {
    let workspace = Workspace::new();
    workspace.write("chain.yaml", CHAIN);
    check_reruns(
        &workspace,
        &[],
        &["last", "round", "scale", "shift", "source"],
    );
    check_reruns(&workspace, &[], &[]);
    check_reruns(&workspace, &["--set", "shift.offset=2"], &["last", "shift"]);
    // Editing the file itself does the same as --set.
    workspace.write("chain.yaml", &CHAIN.replace("offset: 1.0", "offset: 3.0"));
    check_reruns(&workspace, &[], &["last", "shift"]);
    check_reruns(&workspace, &[], &[]);
}

#[test]
fn identical_output_bytes_leave_dependents_cached() {
    let workspace = Workspace::new();
    workspace.write("chain.yaml", CHAIN);
    check_reruns(
        &workspace,
        &[],
        &["last", "round", "scale", "shift", "source"],
    );
    // 2 * 1.5 = 3 and 2 * 1.6 = 3.2 both round to 3: `round` reruns, `shift` and `last` do not.
    check_reruns(
        &workspace,
        &["--set", "scale.scale=1.6"],
        &["round", "scale"],
    );
    let plan = workspace.squeal(&["plan", "chain.yaml", "--set", "scale.scale=2.5"]);
    let plan = String::from_utf8_lossy(&plan.stdout);
    assert!(
        plan.contains("scale   runs: parameter `scale` changed 1.6 → 2.5"),
        "{plan}"
    );
    assert!(
        plan.contains("round   runs: input `scale.table` is recomputed"),
        "{plan}"
    );
    assert!(plan.contains("source  cached"), "{plan}");
}

#[test]
fn a_run_killed_mid_stage_completes_on_rerun_and_leaves_the_cache_clean() {
    let workspace = Workspace::new();
    // A large table makes the kill likely to land while objects are being written.
    let study = "\
stages:
  source:
    kind: test.constant
    params: { rows: 3000000 }
  slow:
    kind: test.sleep
    inputs: { table: source.table }
    params: { seconds: 0.3 }
  after:
    kind: test.affine
    inputs: { table: slow.table }
    params: { scale: 2.0 }
";
    workspace.write("slow.yaml", study);
    for delay_ms in [150, 400, 700] {
        let _ = std::fs::remove_dir_all(workspace.cache_dir());
        let mut child = workspace
            .command(&["run", "slow.yaml", "--out", "out"])
            .spawn()
            .expect("spawn");
        std::thread::sleep(Duration::from_millis(delay_ms));
        child.kill().expect("SIGKILL");
        child.wait().expect("reap");
        workspace.run_ok(&["run", "slow.yaml", "--out", "out"]);
        assert_eq!(statuses(&workspace.path().join("out")).len(), 3);
        let verify = workspace.squeal(&["cache", "verify", "--cache", ".squeal/cache"]);
        let stdout = String::from_utf8_lossy(&verify.stdout);
        assert!(
            verify.status.success(),
            "after a kill at {delay_ms} ms: {stdout}"
        );
        assert!(stdout.contains(": 0 problems"), "{stdout}");
    }
}

#[test]
fn a_flipped_byte_is_detected_recomputed_and_reported_with_the_stage() {
    let workspace = Workspace::new();
    workspace.write("chain.yaml", CHAIN);
    workspace.run_ok(&["run", "chain.yaml", "--out", "out"]);
    let manifest = read_parquet(&workspace.path().join("out/manifest.parquet"));
    let outputs: Vec<String> = strings(&manifest, "outputs_json");
    let stages = strings(&manifest, "stage");
    let shift = stages
        .iter()
        .position(|stage| stage == "shift")
        .expect("shift row");
    let output: serde_json::Value = serde_json::from_str(&outputs[shift]).unwrap();
    let digest = output["table"].as_str().unwrap();
    let object = workspace
        .cache_dir()
        .join("objects")
        .join(&digest[..2])
        .join(digest);
    let flip_a_byte = || {
        let mut bytes = std::fs::read(&object).unwrap();
        let middle = bytes.len() / 2;
        bytes[middle] ^= 0x40;
        // Entries are read-only: replace the file, as a disk fault would change it.
        std::fs::remove_file(&object).unwrap();
        std::fs::write(&object, bytes).unwrap();
    };

    flip_a_byte();
    let stderr = workspace.run_ok(&["run", "chain.yaml", "--out", "fresh"]);
    assert!(
        stderr.contains("ran     shift (cache entry corrupt"),
        "{stderr}"
    );
    assert_eq!(ran(&workspace.path().join("fresh")), ["shift"]);

    // The planner finds it too (and discards the entry, so the next run recomputes it).
    flip_a_byte();
    let plan = workspace.squeal(&["plan", "chain.yaml"]);
    let plan = String::from_utf8_lossy(&plan.stdout);
    assert!(plan.contains("shift   runs: cache entry corrupt"), "{plan}");
    workspace.run_ok(&["run", "chain.yaml", "--out", "fresh"]);
    assert_eq!(ran(&workspace.path().join("fresh")), ["shift"]);
    let verify = workspace.squeal(&["cache", "verify", "--cache", ".squeal/cache"]);
    assert!(
        verify.status.success(),
        "{}",
        String::from_utf8_lossy(&verify.stdout)
    );
}

#[test]
fn two_concurrent_runs_on_one_cache_both_succeed_with_identical_outputs() {
    let workspace = Workspace::new();
    let study = "\
stages:
  source:
    kind: test.constant
    params: { value: 3.0, rows: 200000 }
  slow:
    kind: test.sleep
    inputs: { table: source.table }
    params: { seconds: 0.2 }
  sweep:
    kind: test.affine
    inputs: { table: slow.table }
    matrix: { scale: [1, 2, 3, 4, 5, 6] }
  gathered:
    kind: table.gather
    inputs: { tables: sweep.table }
";
    workspace.write("sweep.yaml", study);
    let children: Vec<_> = ["out_a", "out_b"]
        .iter()
        .map(|out| {
            workspace
                .command(&["run", "sweep.yaml", "--out", out])
                .spawn()
                .expect("spawn")
        })
        .collect();
    for child in children {
        let output = child.wait_with_output().expect("wait");
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let digests = |out: &str| {
        let manifest = read_parquet(&workspace.path().join(out).join("manifest.parquet"));
        strings(&manifest, "stage")
            .into_iter()
            .zip(strings(&manifest, "outputs_json"))
            .collect::<Vec<_>>()
    };
    assert_eq!(digests("out_a"), digests("out_b"));
    assert_eq!(digests("out_a").len(), 9);
    let a = std::fs::read(workspace.path().join("out_a/gathered/gathered.parquet")).unwrap();
    let b = std::fs::read(workspace.path().join("out_b/gathered/gathered.parquet")).unwrap();
    assert_eq!(a, b);
    let verify = workspace.squeal(&["cache", "verify", "--cache", ".squeal/cache"]);
    assert!(verify.status.success());
}

#[test]
fn a_failing_stage_stops_its_dependents_while_other_branches_finish() {
    let workspace = Workspace::new();
    let study = common::FAILING_STUDY;
    workspace.write("fail.yaml", study);
    let output = workspace.squeal(&["run", "fail.yaml", "--out", "out", "-v"]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(
            "FAILED  broken: solver did not converge after 50 iterations (residual 3.2e-2)"
        ),
        "{stderr}"
    );
    assert_eq!(
        stderr.matches("solver did not converge").count(),
        1,
        "the failure is printed once: {stderr}"
    );
    // Written to a pipe, the log carries no colour codes.
    assert!(!stderr.contains('\x1b'), "{stderr:?}");
    assert!(
        stderr.contains("skipped after_broken: `broken` did not complete"),
        "{stderr}"
    );
    let statuses = statuses(&workspace.path().join("out"));
    assert_eq!(statuses["healthy"], "ran");
    assert_eq!(statuses["after_broken"], "skipped");
    // The healthy branch is cached: a rerun only retries the failure.
    workspace.squeal(&["run", "fail.yaml", "--out", "out"]);
    assert_eq!(ran(&workspace.path().join("out")), Vec::<String>::new());
    assert_eq!(
        common::statuses(&workspace.path().join("out"))["healthy"],
        "cached"
    );
}

#[test]
fn gc_keeps_what_a_study_references() {
    let workspace = Workspace::new();
    workspace.write("chain.yaml", CHAIN);
    workspace.run_ok(&["run", "chain.yaml", "--out", "out"]);
    workspace.run_ok(&["run", "chain.yaml", "--out", "out", "--set", "last.scale=5"]);
    let gc = workspace.squeal(&["cache", "gc", "chain.yaml"]);
    let stdout = String::from_utf8_lossy(&gc.stdout);
    assert!(gc.status.success(), "{stdout}");
    assert!(
        stdout.starts_with("removed 1 actions and 1 objects"),
        "{stdout}"
    );
    workspace.run_ok(&["run", "chain.yaml", "--out", "out"]);
    assert_eq!(ran(&workspace.path().join("out")), Vec::<String>::new());
    let gc = workspace.squeal(&["cache", "gc", "--cache", ".squeal/cache", "--max-size", "0"]);
    assert!(gc.status.success());
    workspace.run_ok(&["run", "chain.yaml", "--out", "out"]);
    assert_eq!(ran(&workspace.path().join("out")).len(), 5);
}

/// A list input takes one artifact from each stage listed, in order; a swept one fans the
/// consumer out, and editing one listed stage reruns the consumer only.
#[test]
fn a_list_input_joins_each_listed_stage_and_fans_out_over_a_sweep() {
    let workspace = Workspace::new();
    workspace.write(
        "list.yaml",
        "\
study: list
stages:
  a:
    kind: test.constant
    params: { value: 1.0, rows: 2 }
  b:
    kind: test.constant
    params: { rows: 2 }
    matrix: { value: [10.0, 20.0] }
  c:
    kind: test.constant
    params: { value: 100.0, rows: 2 }
  total:
    kind: test.total
    inputs: { tables: [a.table, b.table, c.table] }
    params: { offset: 0.5 }
",
    );
    workspace.run_ok(&["run", "list.yaml", "--out", "out"]);
    let out = workspace.path().join("out");
    assert_eq!(
        ran(&out),
        [
            "a",
            "b[value=10]",
            "b[value=20]",
            "c",
            "total[value=10]",
            "total[value=20]"
        ]
    );
    for (value, expected) in [(10, 111.5), (20, 121.5)] {
        let table = read_parquet(&out.join(format!("total/value={value}/table.parquet")));
        assert_eq!(floats(&table, "x"), [expected, expected]);
    }
    workspace.run_ok(&["run", "list.yaml", "--out", "out", "--set", "c.value=200"]);
    assert_eq!(ran(&out), ["c", "total[value=10]", "total[value=20]"]);
}
