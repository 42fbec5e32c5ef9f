//! What the Slurm executor costs over a local run, on a single-node cluster on the loopback
//! interface (`tests/slurm/cluster.sh`; needs Debian's slurm-wlm and munge, and root):
//! the coarse brake's μ sweep (`pipelines/mu_sweep.yaml`: its `stability`, an array of 7
//! tasks) local and on Slurm, back to back; the cost of a job, from a 20-task array of trivial stages and from a
//! chain of 5 dependent jobs; and what a 1,000-point sweep submits (a dry run).
//! Run with `cargo bench --bench slurm_overhead`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

const REPEATS: usize = 3;
/// Seconds between two `squeue`: a run ends at most this late after its last job.
const POLL: &str = "0.5";

fn squeal(dir: &Path, conf: &Path, args: &[&str]) -> (Duration, String) {
    let started = Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_squeal"))
        .args(args)
        .current_dir(dir)
        .env("SQUEAL_TEST_KINDS", "1")
        .env("SLURM_CONF", conf)
        .env_remove("SQUEAL_CACHE")
        .output()
        .expect("run squeal");
    let elapsed = started.elapsed();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "squeal {args:?}: {stderr}");
    (
        elapsed,
        String::from_utf8_lossy(&output.stdout).into_owned(),
    )
}

/// Median wall time of a cold run (fresh folder and cache) of `study`, locally or on Slurm.
fn cold_run(study: &str, text: &str, conf: &Path, slurm: bool) -> Duration {
    let mut times: Vec<Duration> = (0..REPEATS)
        .map(|_| {
            let dir = tempfile::tempdir().expect("temporary folder");
            std::fs::write(dir.path().join(study), text).expect("write study");
            let mut args = vec!["run", study];
            if slurm {
                args.extend(["--executor", "slurm", "--poll", POLL]);
            }
            squeal(dir.path(), conf, &args).0
        })
        .collect();
    times.sort();
    times[REPEATS / 2]
}

fn compare(label: &str, study: &str, text: &str, conf: &Path, jobs: usize) {
    // Back to back, local first, so that the machine's drift touches both alike.
    let local = cold_run(study, text, conf, false);
    let slurm = cold_run(study, text, conf, true);
    println!(
        "{label:<34} local {:>7.2} s   slurm {:>7.2} s   ×{:.2}   {:+.2} s per job",
        local.as_secs_f64(),
        slurm.as_secs_f64(),
        slurm.as_secs_f64() / local.as_secs_f64(),
        (slurm.as_secs_f64() - local.as_secs_f64()) / jobs as f64
    );
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let cluster = tempfile::tempdir().expect("temporary folder");
    let script = root.join("tests/slurm/cluster.sh");
    let started = Command::new(&script)
        .arg("start")
        .arg(cluster.path())
        .status()
        .expect("run cluster.sh");
    if !started.success() {
        eprintln!(
            "slurm_overhead needs a Slurm cluster: tests/slurm/cluster.sh could not start one"
        );
        std::process::exit(1);
    }
    let conf = cluster.path().join("slurm.conf");

    let mu_sweep = std::fs::read_to_string(root.join("pipelines/mu_sweep.yaml")).expect("study");
    compare(
        "mu_sweep (7 tasks, one array)",
        "mu_sweep.yaml",
        &mu_sweep,
        &conf,
        7,
    );

    let mut array =
        String::from("stages:\n  points:\n    kind: test.constant\n    matrix:\n      value: [");
    array += &(0..20)
        .map(|k| k.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    array += "]\n    resources: { placement: job, cpus_per_task: 1, mem: 100M }\n";
    compare(
        "20 trivial tasks, one array",
        "array.yaml",
        &array,
        &conf,
        20,
    );

    let mut chain = String::from(
        "stages:\n  s0:\n    kind: test.constant\n    resources: { placement: job, mem: 100M }\n",
    );
    for step in 1..5 {
        chain += &format!(
            "  s{step}:\n    kind: test.affine\n    inputs: {{ table: s{}.table }}\n    \
             resources: {{ placement: job, mem: 100M }}\n",
            step - 1
        );
    }
    compare("5 dependent trivial jobs", "chain.yaml", &chain, &conf, 5);

    let dir = tempfile::tempdir().expect("temporary folder");
    let big = mu_sweep.replace("num: 7", "num: 1000");
    assert_ne!(big, mu_sweep, "the sweep's size is `num: 7`");
    std::fs::write(dir.path().join("big.yaml"), big).expect("write study");
    let (elapsed, printed) = squeal(
        dir.path(),
        &conf,
        &["run", "big.yaml", "--executor", "slurm", "--dry-run"],
    );
    let submissions = printed
        .lines()
        .filter(|line| line.contains("=$(sbatch "))
        .count();
    let tasks = printed
        .lines()
        .find(|line| line.starts_with("# then submit "))
        .unwrap_or_default()
        .to_string();
    println!(
        "mu_sweep with 1,000 points: {submissions} sbatch calls ({}); dry run {:.2} s",
        tasks
            .trim_start_matches("# then submit ")
            .split(", which")
            .next()
            .unwrap_or(""),
        elapsed.as_secs_f64()
    );

    let _ = Command::new(&script)
        .arg("stop")
        .arg(cluster.path())
        .status();
}
