//! `pipelines/stress.yaml`: every verdict of the stress study holds, and what must stop
//! instead stops with its reason.

mod common;

use std::path::Path;

use common::{Workspace, booleans, floats, pipeline, read_parquet, strings};

/// The rows of a stress table: case, point, quantity, observed, holds.
fn verdicts(out: &Path) -> Vec<(String, String, String, f64, bool)> {
    let table = read_parquet(&out.join("verdicts/gathered.parquet"));
    let holds = booleans(&table, "holds");
    let (case, point, quantity) = (
        strings(&table, "case"),
        strings(&table, "point"),
        strings(&table, "quantity"),
    );
    let observed = floats(&table, "observed");
    (0..table.num_rows())
        .map(|row| {
            (
                case[row].clone(),
                point[row].clone(),
                quantity[row].clone(),
                observed[row],
                holds[row],
            )
        })
        .collect()
}

/// Prints the stress table under `out` and checks it has `rows` verdicts, every one holding.
fn assert_every_verdict_holds(out: &Path, rows: usize) {
    let found = verdicts(out);
    for (case, point, quantity, observed, holds) in &found {
        eprintln!("{case:<58} {point:<32} {quantity:<22} {observed:>10.3e} {holds}");
    }
    assert_eq!(found.len(), rows);
    let failing: Vec<_> = found.iter().filter(|verdict| !verdict.4).collect();
    assert!(failing.is_empty(), "{failing:?}");
}

#[test]
fn every_stress_verdict_holds_and_what_cannot_be_solved_says_why() {
    let workspace = Workspace::new();
    let study = pipeline("stress.yaml");
    let stderr = workspace.run_ok(&["run", &study, "--out", "out", "--cache", "cache"]);
    // The millimetre interference is solved, and warned about.
    assert!(
        stderr.contains("beyond the small strains (1 %)"),
        "{stderr}"
    );
    // 14 Hoffmann points, 7 × 2 brake points, 2 contrasts, 2 puck checks, 5 single cases.
    assert_every_verdict_holds(&workspace.path().join("out"), 37);

    // Beyond what has a solution: a clear reason, nothing downstream.
    for (set, reason) in [
        (
            "slow_sliding.mu=5",
            "the sliding equilibrium is not unique, or does not exist, at this friction coefficient",
        ),
        ("slow_sliding.omega=0", "has no sliding direction"),
    ] {
        let output = workspace.squeal(&[
            "run",
            &study,
            "--out",
            "out_fail",
            "--cache",
            "cache",
            "--target",
            "slow_check",
            "--set",
            set,
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{set}: {stderr}");
        assert!(
            stderr.contains("FAILED  slow_sliding: ") && stderr.contains(reason),
            "{set}: {stderr}"
        );
        assert!(stderr.contains("skipped slow_check"), "{stderr}");
    }
}

/// The μ sweep of the stress study on the coarse brake (`pipelines/stress_coarse_brake.yaml`):
/// every point's Krylov band against the dense solve.
#[test]
#[ignore = "about 2.5 min: run by .ci/run with the slow tests"]
fn the_coarse_brake_from_mu_0_to_1_5_matches_the_dense_solve_at_every_point() {
    let workspace = Workspace::new();
    let study = pipeline("stress_coarse_brake.yaml");
    workspace.run_ok(&["run", &study, "--out", "out", "--cache", "cache"]);
    assert_every_verdict_holds(&workspace.path().join("out"), 14);
}
