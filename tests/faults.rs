//! Faults: runs killed at random points, a full disk, a read-only cache, truncated and garbage
//! entries in the store. Each ends in a clear error or a recomputation, never in a corrupt
//! entry or a lost result. The tests that mount small file systems need root and are ignored
//! by default; `.ci/run` runs them.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::{Workspace, statuses};

/// A sweep of three points over a 300,000-row table, each point through a short sleep, then
/// gathered: stages computing, objects written, outputs exported, all take a noticeable time.
const STUDY: &str = "\
stages:
  source:
    kind: test.constant
    params: { rows: 300000 }
  scaled:
    kind: test.affine
    inputs: { table: source.table }
    matrix:
      scale: [1.0, 2.0, 3.0]
  slow:
    kind: test.sleep
    inputs: { table: scaled.table }
    params: { seconds: 0.05 }
  gathered:
    kind: table.gather
    inputs: { tables: slow.table }
";

/// Every file under `dir` but the manifest (which holds times), relative, with its bytes.
fn outputs(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.file_name() != Some("manifest.parquet".as_ref()) {
                files.push((
                    path.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&path).unwrap(),
                ));
            }
        }
    }
    files.sort();
    files
}

fn verify_is_clean(workspace: &Workspace, cache: &str, when: &str) {
    let verify = workspace.squeal(&["--cache", cache, "cache", "verify"]);
    let stdout = String::from_utf8_lossy(&verify.stdout);
    assert!(verify.status.success(), "{when}: {stdout}");
    assert!(stdout.contains(": 0 problems"), "{when}: {stdout}");
}

/// SplitMix64: the kill times, the same on every machine.
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn a_run_killed_at_50_random_points_reruns_to_the_bytes_of_an_uninterrupted_run() {
    let reference = Workspace::new();
    reference.write("study.yaml", STUDY);
    let started = Instant::now();
    reference.run_ok(&["run", "study.yaml", "--out", "out"]);
    let full = started.elapsed();
    let expected = outputs(&reference.path().join("out"));
    assert_eq!(statuses(&reference.path().join("out")).len(), 8);

    let workspace = Workspace::new();
    workspace.write("study.yaml", STUDY);
    let mut state = 2024;
    let mut killed_running = 0;
    for trial in 0..50 {
        let _ = std::fs::remove_dir_all(workspace.path().join(".squeal"));
        let _ = std::fs::remove_dir_all(workspace.path().join("out"));
        let delay = full.mul_f64(1.1 * uniform(&mut state));
        let mut child = workspace
            .command(&["run", "study.yaml", "--out", "out"])
            .spawn()
            .expect("spawn");
        std::thread::sleep(delay);
        if child.try_wait().expect("poll").is_none() {
            killed_running += 1;
        }
        child.kill().expect("SIGKILL");
        child.wait().expect("reap");
        let when = format!("trial {trial}, killed after {delay:?}");
        verify_is_clean(&workspace, ".squeal/cache", &when);
        workspace.run_ok(&["run", "study.yaml", "--out", "out"]);
        let got = outputs(&workspace.path().join("out"));
        assert_eq!(
            got.iter().map(|(path, _)| path).collect::<Vec<_>>(),
            expected.iter().map(|(path, _)| path).collect::<Vec<_>>(),
            "{when}"
        );
        for ((path, bytes), (_, reference)) in got.iter().zip(&expected) {
            assert!(bytes == reference, "{when}: {} differs", path.display());
        }
        verify_is_clean(&workspace, ".squeal/cache", &when);
    }
    // Most kills landed while the run was working, not after it ended.
    assert!(killed_running >= 35, "{killed_running} of 50 kills hit a running run");
}
