//! A transient killed part-way resumes from its checkpoint on the next run and writes the same
//! bytes as an uninterrupted run; no checkpoint outlives the stage.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::Workspace;

const STUDY: &str = r#"
study: resume
stages:
  mesh:
    kind: mesh.brake
    params: { n_radial: 4, n_theta: 48, n_thick: 2, pucks_radial: 1, pucks_angular: 2, puck_cells: 2, puck_layers: 2, thickness: 45 mm }
  model:
    kind: assemble
    inputs: { mesh: mesh.mesh }
  equilibrium:
    kind: equilibrium
    inputs: { model: model.model }
    params: { mu: 0.38, omega: 4, interference: 50 um }
  stability:
    kind: stability
    inputs: { model: model.model, equilibrium: equilibrium.equilibrium }
    params: { f_max_hz: 8 kHz }
  transient:
    kind: transient
    inputs: { model: model.model, equilibrium: equilibrium.equilibrium, complex_modes: stability.modes }
    params: { tau: 2 us, duration: 30 ms, amplitude: 1 nm, output_every: 5 }
"#;

/// Whether the cache holds a checkpoint record.
fn has_checkpoint(cache: &Path) -> bool {
    let Ok(folders) = std::fs::read_dir(cache.join("actions")) else {
        return false;
    };
    folders.flatten().any(|folder| {
        std::fs::read_dir(folder.path()).is_ok_and(|records| {
            records.flatten().any(|record| {
                std::fs::read_to_string(record.path())
                    .is_ok_and(|text| text.contains("\"checkpoint\""))
            })
        })
    })
}

fn outputs(workspace: &Workspace) -> Vec<(String, Vec<u8>)> {
    let dir = workspace.path().join("out/study/transient");
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .expect("transient outputs")
        .flatten()
        .filter(|entry| entry.path().extension().is_some_and(|ext| ext == "parquet"))
        .map(|entry| {
            (
                entry.file_name().to_string_lossy().into_owned(),
                std::fs::read(entry.path()).expect("read output"),
            )
        })
        .collect();
    files.sort();
    files
}

#[test]
fn a_killed_transient_resumes_to_the_same_bytes() {
    let reference = Workspace::new();
    reference.write("study.yaml", STUDY);
    reference.run_ok(&["run", "study.yaml"]);
    let expected = outputs(&reference);
    assert!(expected.len() >= 5, "{expected:?}");

    let workspace = Workspace::new();
    workspace.write("study.yaml", STUDY);
    let mut child = workspace
        .command(&["run", "study.yaml"])
        .env("SQUEAL_CHECKPOINT_SECONDS", "0.2")
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start squeal");
    let started = Instant::now();
    while !has_checkpoint(&workspace.cache_dir()) {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no checkpoint was written"
        );
        assert!(
            child.try_wait().expect("poll").is_none(),
            "the run ended before a checkpoint"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    child.kill().expect("kill squeal");
    child.wait().expect("reap squeal");
    assert!(
        has_checkpoint(&workspace.cache_dir()),
        "the killed run left its checkpoint"
    );

    let output = workspace
        .command(&["run", "study.yaml"])
        .env("SQUEAL_LOG", "info")
        .output()
        .expect("rerun squeal");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("resuming from its checkpoint"), "{stderr}");
    assert!(
        outputs(&workspace) == expected,
        "the resumed run wrote other bytes"
    );
    assert!(
        !has_checkpoint(&workspace.cache_dir()),
        "a checkpoint outlived its stage"
    );
}
