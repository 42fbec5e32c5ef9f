//! Engine overhead on studies of trivial stages, measured on whole `squeal` invocations:
//! a 200-stage study (10 chains of 20) — first run, no-op rerun, plan — and the plan of a
//! 10,000-point sweep. Run with `cargo bench --bench engine_overhead`.
//!
//! Reference figures for the same 200-stage shape on this kind of machine: Snakemake 9.27
//! no-op rerun 1.03 s, DVC 3.67 `repro` 8.74 s. Goals: no-op rerun ≤ 20 ms; 10k-sweep plan < 1 s.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

fn squeal(dir: &Path, args: &[&str]) -> Duration {
    let started = Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_squeal"))
        .args(args)
        .current_dir(dir)
        .env("SQUEAL_TEST_KINDS", "1")
        .env_remove("SQUEAL_CACHE")
        .output()
        .expect("run squeal");
    let elapsed = started.elapsed();
    assert!(
        output.status.success(),
        "squeal {args:?}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    elapsed
}

/// Best of `repeats` runs, the usual estimate of a command's own cost.
fn best_of(repeats: usize, dir: &Path, args: &[&str]) -> Duration {
    (0..repeats)
        .map(|_| squeal(dir, args))
        .min()
        .expect("at least one run")
}

fn chains_study(n_chains: usize, chain_length: usize) -> String {
    let mut study = String::from("study: chains\nstages:\n");
    for chain in 0..n_chains {
        study.push_str(&format!(
            "  c{chain}_s0:\n    kind: test.constant\n    params: {{ value: {chain} }}\n"
        ));
        for step in 1..chain_length {
            study.push_str(&format!(
                "  c{chain}_s{step}:\n    kind: test.affine\n    inputs: {{ table: c{chain}_s{}.table }}\n    params: {{ offset: 1 }}\n",
                step - 1
            ));
        }
    }
    study
}

fn report(label: &str, duration: Duration) {
    println!("{label:<44} {:>9.1} ms", duration.as_secs_f64() * 1e3);
}

fn main() {
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::write(dir.path().join("chains.yaml"), chains_study(10, 20)).expect("write study");
    let run = ["run", "chains.yaml", "--out", "out"];
    println!("200 trivial stages (10 chains of 20)");
    report("first run", squeal(dir.path(), &run));
    report("no-op rerun (best of 20)", best_of(20, dir.path(), &run));
    report(
        "plan (best of 20)",
        best_of(20, dir.path(), &["plan", "chains.yaml"]),
    );
    let edit = [
        "run",
        "chains.yaml",
        "--out",
        "out",
        "--set",
        "c3_s10.offset=2",
    ];
    report(
        "rerun after one edit (10 stages rerun)",
        squeal(dir.path(), &edit),
    );

    let sweep = "study: sweep\nstages:\n  point:\n    kind: test.constant\n    matrix:\n      value: { start: 0.0, stop: 1.0, num: 10000 }\n";
    std::fs::write(dir.path().join("sweep.yaml"), sweep).expect("write study");
    println!("10,000-instance sweep");
    report(
        "plan, nothing cached (best of 5)",
        best_of(5, dir.path(), &["plan", "sweep.yaml"]),
    );
    report(
        "first run",
        squeal(dir.path(), &["run", "sweep.yaml", "--out", "out_sweep"]),
    );
    report(
        "plan, all cached (best of 5)",
        best_of(5, dir.path(), &["plan", "sweep.yaml"]),
    );
    report(
        "no-op rerun (best of 5)",
        best_of(5, dir.path(), &["run", "sweep.yaml", "--out", "out_sweep"]),
    );
}
