//! Faults: runs killed at random points, a full disk, a read-only cache, truncated and garbage
//! entries in the store. Each ends in a clear error or a recomputation, never in a corrupt
//! entry or a lost result. The tests that mount small file systems need root and are ignored
//! by default; `.ci/run` runs them.

mod common;

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use common::{Workspace, outputs_but_the_manifest, statuses};

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
      scale: [2.0, 3.0, 4.0]
  slow:
    kind: test.sleep
    inputs: { table: scaled.table }
    params: { seconds: 0.05 }
  gathered:
    kind: table.gather
    inputs: { tables: slow.table }
";

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
    // The kills are spread over the fastest of three uncached runs: the first, from a cold
    // start, can take a third longer than the trials, whose kills would then land late.
    let full = (0..3)
        .map(|_| {
            let _ = std::fs::remove_dir_all(reference.path().join(".squeal"));
            let started = Instant::now();
            reference.run_ok(&["run", "study.yaml", "--out", "out"]);
            started.elapsed()
        })
        .min()
        .expect("three runs");
    let expected = outputs_but_the_manifest(&reference.path().join("out"));
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
        let got = outputs_but_the_manifest(&workspace.path().join("out"));
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
    eprintln!("{killed_running} of 50 kills hit a running run (uninterrupted: {full:?})");
    assert!(
        killed_running >= 35,
        "{killed_running} of 50 kills hit a running run"
    );
}

/// The object file of output `output` of instance `instance`, from the manifest.
fn object_of(workspace: &Workspace, out: &str, instance: &str, output: &str) -> PathBuf {
    let manifest = common::read_parquet(&workspace.path().join(out).join("manifest.parquet"));
    let row = common::strings(&manifest, "stage")
        .iter()
        .position(|stage| stage == instance)
        .unwrap_or_else(|| panic!("no instance {instance}"));
    let outputs: serde_json::Value =
        serde_json::from_str(&common::strings(&manifest, "outputs_json")[row]).unwrap();
    let digest = outputs[output].as_str().unwrap().to_string();
    workspace
        .cache_dir()
        .join("objects")
        .join(&digest[..2])
        .join(digest)
}

#[test]
fn truncated_emptied_and_garbage_entries_are_recomputed_and_reported() {
    let reference = Workspace::new();
    reference.write("study.yaml", STUDY);
    reference.run_ok(&["run", "study.yaml", "--out", "out"]);
    let expected = outputs_but_the_manifest(&reference.path().join("out"));

    let workspace = Workspace::new();
    workspace.write("study.yaml", STUDY);
    workspace.run_ok(&["run", "study.yaml", "--out", "out"]);
    // Cut in half, emptied (what a crash leaves on a file system that reorders writes), and
    // the same length of garbage.
    let truncated = object_of(&workspace, "out", "scaled[scale=2]", "table");
    let bytes = std::fs::read(&truncated).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(
        object_of(&workspace, "out", "scaled[scale=3]", "table"),
        b"",
    )
    .unwrap();
    let garbage = object_of(&workspace, "out", "gathered", "gathered");
    let length = std::fs::metadata(&garbage).unwrap().len() as usize;
    let mut state = 7;
    let noise: Vec<u8> = (0..length)
        .map(|_| (uniform(&mut state) * 256.0) as u8)
        .collect();
    std::fs::write(&garbage, noise).unwrap();
    // An action record overwritten, and files that are no entry at all.
    let manifest = common::read_parquet(&workspace.path().join("out/manifest.parquet"));
    let row = common::strings(&manifest, "stage")
        .iter()
        .position(|stage| stage == "scaled[scale=4]")
        .unwrap();
    let key = common::strings(&manifest, "key")[row].clone();
    let record = workspace
        .cache_dir()
        .join("actions")
        .join(&key[..2])
        .join(&key);
    assert!(record.exists());
    std::fs::remove_file(&record).unwrap();
    std::fs::write(&record, b"{\"stage\": \"not a record\"").unwrap();
    std::fs::write(workspace.cache_dir().join("objects/zz"), b"not a folder").unwrap();
    std::fs::write(
        workspace.cache_dir().join("tmp/12345-left-behind"),
        b"partial",
    )
    .unwrap();

    let stderr = workspace.run_ok(&["run", "study.yaml", "--out", "again"]);
    for instance in [
        "scaled[scale=2]",
        "scaled[scale=3]",
        "scaled[scale=4]",
        "gathered",
    ] {
        assert!(
            stderr.contains(&format!("ran     {instance} (cache entry corrupt")),
            "{instance}: {stderr}"
        );
    }
    let got = outputs_but_the_manifest(&workspace.path().join("again"));
    assert_eq!(got.len(), expected.len());
    for ((path, bytes), (_, reference)) in got.iter().zip(&expected) {
        assert!(bytes == reference, "{} differs", path.display());
    }
    // Recomputed to the same bytes, the products leave their dependents cached.
    let status = statuses(&workspace.path().join("again"));
    assert_eq!(status.len(), 8);
    for instance in ["source", "slow[scale=2]", "slow[scale=3]", "slow[scale=4]"] {
        assert_eq!(status[instance], "cached", "{instance}");
    }
    verify_is_clean(&workspace, ".squeal/cache", "after the rerun");
    // What is no entry stays out of the way: gc takes the temporary.
    let stats = workspace.squeal(&["--cache", ".squeal/cache", "cache", "stats"]);
    assert!(String::from_utf8_lossy(&stats.stdout).contains("temporaries 1"));
    workspace.run_ok(&["--cache", ".squeal/cache", "cache", "gc"]);
    let stats = workspace.squeal(&["--cache", ".squeal/cache", "cache", "stats"]);
    assert!(String::from_utf8_lossy(&stats.stdout).contains("temporaries 0"));
}

/// A tmpfs of `size` mounted on `dir` for the duration of a test (root only).
struct Mount {
    dir: PathBuf,
}

impl Mount {
    fn new(dir: PathBuf, size: &str) -> Mount {
        std::fs::create_dir_all(&dir).unwrap();
        let status = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(&dir)
            .status()
            .expect("mount");
        assert!(status.success(), "mounting a tmpfs needs root");
        Mount { dir }
    }

    fn remount(&self, options: &str) {
        let status = Command::new("mount")
            .args(["-o", &format!("remount,{options}")])
            .arg(&self.dir)
            .status()
            .expect("mount");
        assert!(status.success());
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.dir).status();
    }
}

#[test]
#[ignore = "mounts file systems: needs root; run by .ci/run"]
fn fault_full_disk_and_read_only_cache_give_clear_errors_and_lose_nothing() {
    let reference = Workspace::new();
    reference.write("study.yaml", STUDY);
    reference.run_ok(&["run", "study.yaml", "--out", "out"]);
    let expected = outputs_but_the_manifest(&reference.path().join("out"));

    // A cache on a 3 MB file system: the source table (2.4 MB) fits, its first product does
    // not.
    let workspace = Workspace::new();
    workspace.write("study.yaml", STUDY);
    let disk = Mount::new(workspace.path().join("disk"), "3m");
    let output = workspace.squeal(&["--cache", "disk/cache", "run", "study.yaml", "--out", "out"]);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("storing output `table` in the cache: cache ")
            && stderr.contains("No space left on device"),
        "{stderr}"
    );
    let status = statuses(&workspace.path().join("out"));
    assert_eq!(status["source"], "ran");
    assert!(
        status.values().any(|status| status == "failed"),
        "{status:?}"
    );
    verify_is_clean(&workspace, "disk/cache", "on a full disk");

    // With room again, what was stored is kept and the rest computed.
    disk.remount("size=64m");
    let stderr = workspace.run_ok(&["--cache", "disk/cache", "run", "study.yaml", "--out", "out"]);
    assert_eq!(
        statuses(&workspace.path().join("out"))["source"],
        "cached",
        "{stderr}"
    );
    let got = outputs_but_the_manifest(&workspace.path().join("out"));
    assert_eq!(got.len(), expected.len());
    for ((path, bytes), (_, reference)) in got.iter().zip(&expected) {
        assert!(bytes == reference, "{} differs", path.display());
    }

    // Read-only: what the cache holds is served; what it lacks fails with the reason.
    disk.remount("ro");
    workspace.run_ok(&[
        "--cache",
        "disk/cache",
        "run",
        "study.yaml",
        "--out",
        "read_only",
    ]);
    assert!(
        statuses(&workspace.path().join("read_only"))
            .values()
            .all(|status| status == "cached")
    );
    let output = workspace.squeal(&[
        "--cache",
        "disk/cache",
        "run",
        "study.yaml",
        "--out",
        "edited",
        "--set",
        "slow.seconds=0.06",
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    // The pass-through stage's output object exists already; its record cannot be written.
    assert!(
        stderr.contains(
            "FAILED  slow[scale=2]: recording the outputs in the cache: cache disk/cache/tmp: \
             Read-only file system"
        ),
        "{stderr}"
    );
    assert!(!stderr.contains("WARN"), "{stderr}");
    disk.remount("rw");
    verify_is_clean(&workspace, "disk/cache", "after the read-only runs");
}
