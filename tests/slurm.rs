//! The Slurm executor. Without a cluster: what `--dry-run` would submit (arrays, dependencies,
//! requests) and the checks on Slurm settings. On a real single-node cluster
//! (`tests/slurm/cluster.sh`, ignored by default, run by `.ci/run` when Debian's slurm-wlm and
//! munge install): the coarse brake's μ sweep gives the bytes of a local run, and a failed
//! stage, a job cancelled with scancel, a job past its time limit and an interrupted driver
//! each end as documented, a rerun submitting only what is missing.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{Workspace, outputs_but_the_manifest, pipeline, statuses};

fn stdout(output: &std::process::Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn stderr(output: &std::process::Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// The `#SBATCH` value of `option` in each script of a dry run, in order.
fn directives(text: &str, option: &str) -> Vec<String> {
    let prefix = format!("#SBATCH --{option}=");
    text.lines()
        .filter_map(|line| line.strip_prefix(&prefix).map(str::to_string))
        .collect()
}

fn sbatch_lines(text: &str) -> Vec<String> {
    text.lines()
        .filter(|line| line.contains("=$(sbatch "))
        .map(str::to_string)
        .collect()
}

#[test]
fn a_dry_run_of_the_mu_sweep_submits_its_stability_as_one_array() {
    let workspace = Workspace::new();
    let study = workspace.path().join("mu_sweep.yaml");
    std::fs::copy(pipeline("mu_sweep.yaml"), &study).unwrap();
    let output = workspace.squeal(&["run", "mu_sweep.yaml", "--executor", "slurm", "--dry-run"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    let equilibria: Vec<String> = ["0", "0.1", "0.2", "0.3", "0.4", "0.5", "0.6"]
        .map(|mu| format!("equilibrium[mu={mu}]"))
        .to_vec();
    assert!(
        text.contains(&format!(
            "# squeal would run in the driver first: mesh, model, {}\n\
             # then submit 1 job (7 tasks), which also run: nothing\n\
             # then run in the driver: eigenvalues, tracked\n",
            equilibria.join(", ")
        )),
        "{text}"
    );
    let sbatch = sbatch_lines(&text);
    assert_eq!(sbatch.len(), 1, "{text}");
    assert!(
        sbatch[0].starts_with("job1=$(sbatch --parsable /"),
        "{}",
        sbatch[0]
    );
    assert_eq!(directives(&text, "array"), ["0-6"]);
    // The stage kind's own request.
    assert_eq!(directives(&text, "cpus-per-task"), ["4"]);
    assert_eq!(directives(&text, "mem"), ["4096M"]);
    assert!(directives(&text, "time").is_empty());
    assert!(text.contains("\nstability[mu=0.3]\n"), "{text}");
    // Nothing ran, nothing was written.
    assert!(!workspace.path().join("out").exists());
    assert!(!workspace.path().join(".squeal/slurm").exists());
}

/// A sweep followed through a job stage, crossed with a second sweep behind a driver stage,
/// then gathered.
const GROUPING_STUDY: &str = "\
slurm:
  partition: batch
  time: \"2:00:00\"
  sbatch_args: [--qos=normal]
stages:
  source:
    kind: test.constant
    matrix:
      value: [1.0, 2.0, 3.0]
    resources: { placement: job, cpus_per_task: 1, mem: 100M }
  scaled:
    kind: test.affine
    inputs: { table: source.table }
    resources: { placement: job, time: \"10\" }
  rounded:
    kind: test.round
    inputs: { table: scaled.table }
  crossed:
    kind: test.affine
    inputs: { table: rounded.table }
    matrix:
      offset: [0.0, 1.0]
    resources: { placement: job }
  gathered:
    kind: table.gather
    inputs: { tables: crossed.table }
    resources: { placement: job }
";

#[test]
fn submissions_follow_the_dependencies_and_the_requests_their_sources() {
    let workspace = Workspace::new();
    workspace.write("grouping.yaml", GROUPING_STUDY);
    let output = workspace.squeal(&[
        "run",
        "grouping.yaml",
        "--executor",
        "slurm",
        "--dry-run",
        "--mem",
        "2G",
        "--sbatch-arg=--exclusive",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(
        text.contains(
            "# then submit 6 jobs (13 tasks), which also run: rounded[value=1], \
             rounded[value=2], rounded[value=3]\n# then run in the driver: nothing\n"
        ),
        "{text}"
    );
    let sbatch = sbatch_lines(&text);
    let dependency = |line: &str| {
        line.split_whitespace()
            .find_map(|word| word.strip_prefix("\"--dependency="))
            .map(|value| value.trim_end_matches('"').to_string())
    };
    let dependencies: Vec<Option<String>> = sbatch.iter().map(|line| dependency(line)).collect();
    assert_eq!(
        dependencies,
        [
            None,
            Some("aftercorr:$job1".into()),
            // Each point of `scaled`, through the driver stage `rounded` (which runs in the
            // job), feeds two instances of `crossed`: three arrays, each after its own task.
            Some("afterok:$job2_0".into()),
            Some("afterok:$job2_1".into()),
            Some("afterok:$job2_2".into()),
            // The gather needs every task of the three arrays: their whole jobs.
            Some("afterok:$job3:$job4:$job5".into()),
        ],
        "{text}"
    );
    assert_eq!(
        directives(&text, "array"),
        ["0-2", "0-2", "0-1", "0-1", "0-1"]
    );
    // A stage's `resources:` over the command line, over the study's `slurm:`, over the kind.
    assert_eq!(
        directives(&text, "cpus-per-task"),
        ["1", "1", "1", "1", "1", "1"]
    );
    assert_eq!(
        directives(&text, "mem"),
        ["100M", "2G", "2G", "2G", "2G", "2G"]
    );
    assert_eq!(
        directives(&text, "time"),
        ["2:00:00", "10", "2:00:00", "2:00:00", "2:00:00", "2:00:00"]
    );
    assert_eq!(directives(&text, "partition"), vec!["batch"; 6]);
    assert!(
        sbatch
            .iter()
            .all(|line| line.contains(" --qos=normal --exclusive ")),
        "{text}"
    );
}

#[test]
fn slurm_settings_are_checked_before_anything_runs() {
    let workspace = Workspace::new();
    workspace.write("grouping.yaml", GROUPING_STUDY);
    let refused = |args: &[&str], expected: &str| {
        let output = workspace.squeal(args);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{args:?}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains(expected),
            "{args:?}: expected `{expected}` in:\n{}",
            stderr(&output)
        );
    };
    let base = ["run", "grouping.yaml", "--executor", "slurm", "--dry-run"];
    refused(
        &[&base[..], &["--time", "1h"]].concat(),
        "--time: `1h` is not a time limit for Slurm",
    );
    refused(
        &[&base[..], &["--mem", "16GB"]].concat(),
        "--mem: `16GB` is not a memory size for Slurm",
    );
    refused(
        &[&base[..], &["--cpus-per-task", "0"]].concat(),
        "a job needs at least one CPU",
    );
    refused(
        &["run", "grouping.yaml", "--dry-run"],
        "--dry-run: needs --executor slurm",
    );
    for (edit, expected) in [
        (
            ("placement: job, time", "placement: cloud, time"),
            "edited.yaml:14:29: stages.scaled.resources.placement: `cloud` is not a placement: \
             use `driver` or `job`",
        ),
        (
            ("time: \"2:00:00\"", "time: 2 hours"),
            "edited.yaml:3:9: slurm.time: `2 hours` is not a time limit for Slurm",
        ),
        (
            ("mem: 100M", "memory: 100M"),
            "edited.yaml:10:52: stages.source.resources.memory: unknown field `memory`",
        ),
    ] {
        workspace.write("edited.yaml", &GROUPING_STUDY.replace(edit.0, edit.1));
        refused(
            &["run", "edited.yaml", "--executor", "slurm", "--dry-run"],
            expected,
        );
    }
}

/// A single-node Slurm cluster for the duration of a test, stopped when dropped.
struct Cluster {
    dir: tempfile::TempDir,
}

impl Cluster {
    fn start() -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slurm/cluster.sh");
        let output = Command::new(&script)
            .arg("start")
            .arg(dir.path())
            .output()
            .expect("run cluster.sh");
        assert!(
            output.status.success(),
            "the test cluster did not start:\n{}{}",
            stdout(&output),
            stderr(&output)
        );
        Cluster { dir }
    }

    fn conf(&self) -> PathBuf {
        self.dir.path().join("slurm.conf")
    }

    /// `squeal ARGS` in the workspace, on this cluster.
    fn squeal(&self, workspace: &Workspace, args: &[&str]) -> std::process::Output {
        self.squeal_command(workspace, args)
            .output()
            .expect("run squeal")
    }

    fn squeal_command(&self, workspace: &Workspace, args: &[&str]) -> Command {
        let mut command = workspace.command(args);
        command.env("SLURM_CONF", self.conf());
        command
    }

    /// The state of the job named `name` once it is running (waits up to a minute).
    fn wait_running(&self, name: &str) -> String {
        let started = Instant::now();
        while started.elapsed() < Duration::from_secs(60) {
            let output = Command::new("squeue")
                .args(["--noheader", "--format=%i|%j|%T"])
                .env("SLURM_CONF", self.conf())
                .output()
                .expect("squeue");
            for line in stdout(&output).lines() {
                let fields: Vec<&str> = line.trim().split('|').collect();
                if fields.len() == 3 && fields[1] == name && fields[2] == "RUNNING" {
                    return fields[0].to_string();
                }
            }
            std::thread::sleep(Duration::from_millis(250));
        }
        panic!("job {name} did not start within a minute");
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slurm/cluster.sh");
        let _ = Command::new(script)
            .arg("stop")
            .arg(self.dir.path())
            .status();
    }
}

/// The `submitted N jobs (M tasks)` figure of a run.
fn submitted(stderr: &str) -> (usize, usize) {
    let line = stderr
        .lines()
        .find(|line| line.starts_with("slurm: submitted "))
        .unwrap_or_else(|| panic!("no submission line in:\n{stderr}"));
    let numbers: Vec<usize> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter(|word| !word.is_empty())
        .take(2)
        .map(|word| word.parse().unwrap())
        .collect();
    (numbers[0], numbers[1])
}

const FAULTS_STUDY: &str = "\
stages:
  source:
    kind: test.constant
  ok:
    kind: test.affine
    inputs: { table: source.table }
    resources: { placement: job }
  bad:
    kind: test.fail
    inputs: { table: source.table }
    params: { message: solver did not converge after 50 iterations }
    resources: { placement: job }
  after_bad:
    kind: test.affine
    inputs: { table: bad.table }
    resources: { placement: job }
  slow:
    kind: test.sleep
    inputs: { table: ok.table }
    params: { seconds: 600 }
    resources: { placement: job, time: \"1\" }
";

#[test]
#[ignore = "needs a Slurm cluster: run by .ci/run, which starts one with tests/slurm/cluster.sh"]
fn slurm_cluster_runs_studies_and_reports_failed_cancelled_timed_out_and_interrupted_jobs() {
    let cluster = Cluster::start();

    // The μ sweep: the bytes of a local run, then a rerun that submits nothing.
    let local = Workspace::new();
    let remote = Workspace::new();
    for workspace in [&local, &remote] {
        std::fs::copy(
            pipeline("mu_sweep.yaml"),
            workspace.path().join("mu_sweep.yaml"),
        )
        .unwrap();
    }
    local.run_ok(&["run", "mu_sweep.yaml"]);
    let output = cluster.squeal(
        &remote,
        &[
            "run",
            "mu_sweep.yaml",
            "--executor",
            "slurm",
            "--poll",
            "0.5",
        ],
    );
    let text = stderr(&output);
    assert!(output.status.success(), "{text}");
    assert_eq!(submitted(&text), (1, 7), "{text}");
    assert!(
        text.contains("ran     stability[mu=0.3] (in Slurm job "),
        "{text}"
    );
    let outputs =
        |workspace: &Workspace| outputs_but_the_manifest(&workspace.path().join("out/mu_sweep"));
    let (local_files, remote_files) = (outputs(&local), outputs(&remote));
    assert!(local_files.len() > 20);
    assert_eq!(
        local_files.iter().map(|(path, _)| path).collect::<Vec<_>>(),
        remote_files
            .iter()
            .map(|(path, _)| path)
            .collect::<Vec<_>>()
    );
    for ((path, local_bytes), (_, remote_bytes)) in local_files.iter().zip(&remote_files) {
        assert!(local_bytes == remote_bytes, "{} differs", path.display());
    }
    assert_eq!(
        statuses(&remote.path().join("out/mu_sweep")),
        statuses(&local.path().join("out/mu_sweep"))
    );
    let output = cluster.squeal(
        &remote,
        &[
            "run",
            "mu_sweep.yaml",
            "--executor",
            "slurm",
            "--poll",
            "0.5",
        ],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(submitted(&stderr(&output)), (0, 0));

    // A failed stage and a job past its time limit: both named with their Slurm state and
    // stderr; the dependent skipped, the independent branch finished.
    let faults = Workspace::new();
    faults.write("faults.yaml", FAULTS_STUDY);
    let output = cluster.squeal(
        &faults,
        &["run", "faults.yaml", "--executor", "slurm", "--poll", "0.5"],
    );
    let text = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{text}");
    assert_eq!(submitted(&text), (4, 4), "{text}");
    let line = |start: &str| {
        text.lines()
            .find(|line| line.starts_with(start))
            .unwrap_or_else(|| panic!("no line `{start}` in:\n{text}"))
            .to_string()
    };
    assert!(
        line("FAILED  bad: Slurm job ")
            .contains(" FAILED: solver did not converge after 50 iterations; stderr ends:")
    );
    assert!(text.contains("    error: bad failed: solver did not converge after 50 iterations"));
    assert_eq!(
        line("skipped after_bad"),
        "skipped after_bad: `bad` did not complete"
    );
    assert!(
        line("FAILED  slow: Slurm job ")
            .contains(" TIMEOUT: it ran past its time limit (--time=1); stderr ends:"),
        "{text}"
    );
    assert!(text.contains("DUE TO TIME LIMIT"), "{text}");
    assert!(line("ran     ok (in Slurm job ").ends_with(" s"));
    let out = faults.path().join("out/faults");
    let status = statuses(&out);
    assert_eq!(status["ok"], "ran");
    assert_eq!(status["bad"], "failed");
    assert_eq!(status["after_bad"], "skipped");
    assert_eq!(status["slow"], "failed");
    assert!(out.join("ok/table.parquet").exists());

    // The rerun would submit only what did not complete.
    let dry_run = |workspace: &Workspace, extra: &[&str]| {
        let output = cluster.squeal(
            workspace,
            &[
                &["run", "faults.yaml", "--executor", "slurm", "--dry-run"][..],
                extra,
            ]
            .concat(),
        );
        assert!(output.status.success(), "{}", stderr(&output));
        let text = stdout(&output);
        text.lines()
            .filter_map(|line| {
                line.strip_prefix("# ")
                    .and_then(|rest| rest.strip_suffix(": one job"))
            })
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert_eq!(dry_run(&faults, &[]), ["bad", "after_bad", "slow"]);

    // The slow stage alone, stopped by `stop(job id, driver pid)` once its job runs: the job's
    // id and the run's stderr.
    let stopped = |seconds: &str, stop: &dyn Fn(&str, u32) -> std::process::ExitStatus| {
        let set = format!("slow.seconds={seconds}");
        let child = cluster
            .squeal_command(
                &faults,
                &[
                    "run",
                    "faults.yaml",
                    "--executor",
                    "slurm",
                    "--poll",
                    "0.5",
                    "--target",
                    "slow",
                    "--set",
                    &set,
                ],
            )
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let id = cluster.wait_running("squeal.faults.slow");
        assert!(stop(&id, child.id()).success());
        let output = child.wait_with_output().unwrap();
        let text = stderr(&output);
        assert_eq!(output.status.code(), Some(1), "{text}");
        (id, text)
    };

    // A job cancelled with scancel: CANCELLED, and only it is resubmitted.
    let (id, text) = stopped("601", &|id, _| {
        Command::new("scancel")
            .arg(id)
            .env("SLURM_CONF", cluster.conf())
            .status()
            .unwrap()
    });
    assert!(
        text.contains(&format!(
            "FAILED  slow: Slurm job {id} CANCELLED: cancelled (scancel, or an administrator)"
        )),
        "{text}"
    );
    assert_eq!(
        dry_run(&faults, &["--target", "slow", "--set", "slow.seconds=601"]),
        ["slow"]
    );

    // An interrupted driver (Ctrl-C) cancels its jobs and writes what finished.
    let (id, text) = stopped("602", &|_, pid| {
        Command::new("kill")
            .args(["-INT", &pid.to_string()])
            .status()
            .unwrap()
    });
    assert!(
        text.contains(&format!("interrupted: cancelled Slurm jobs {id}")),
        "{text}"
    );
    assert!(
        text.contains(&format!(
            "FAILED  slow: Slurm job {id} cancelled: the run was interrupted"
        )),
        "{text}"
    );
    assert_eq!(statuses(&out)["ok"], "cached");
    // Slurm cancelled it: the queue no longer runs it.
    let started = Instant::now();
    loop {
        let output = Command::new("squeue")
            .args([
                "--noheader",
                "--states=all",
                "--format=%i|%T",
                "--jobs",
                &id,
            ])
            .env("SLURM_CONF", cluster.conf())
            .output()
            .unwrap();
        if stdout(&output).contains("CANCELLED") {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "{}",
            stdout(&output)
        );
        std::thread::sleep(Duration::from_millis(250));
    }
}
