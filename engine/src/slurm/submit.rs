//! The jobs a run submits: which instances share a job array, what each waits for, and the
//! batch script that runs them.
//!
//! The instances of one stage that wait for the same jobs form one submission: one job, or a
//! job array when there are several. A submission whose tasks each wait for the task of the
//! same index in one upstream array (a sweep followed through two stages) waits with
//! `aftercorr`, so a failed point stops its own chain only. Any other waits with `afterok`, on a
//! whole upstream job when it needs all of it (a gather), else on the tasks it needs.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::instances::Instances;

/// One `sbatch`.
#[derive(Debug, Clone, PartialEq)]
pub struct Submission {
    pub stage: usize,
    /// Instance indices; task `t` of an array runs `instances[t]`.
    pub instances: Vec<usize>,
    pub after: After,
}

impl Submission {
    pub fn is_array(&self) -> bool {
        self.instances.len() > 1
    }
}

/// What a submission waits for, by submission index.
#[derive(Debug, Clone, PartialEq)]
pub enum After {
    Nothing,
    /// Task `t` waits for task `t` of this array (`aftercorr`).
    Corresponding(usize),
    /// Every listed job or task must succeed first (`afterok`).
    All(Vec<Wait>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Wait {
    Whole(usize),
    Task(usize, usize),
}

/// Groups the instances marked `job` into submissions, upstream first. An instance waits for
/// its nearest upstream instances that are jobs; instances in between run inside its job.
pub fn group(instances: &Instances, job: &[bool]) -> Vec<Submission> {
    let n = instances.list.len();
    // The job instances each instance needs first, through instances that are not jobs.
    let mut waits: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
    for (idx, instance) in instances.list.iter().enumerate() {
        for input in &instance.inputs {
            for &up in &input.from {
                if job[up] {
                    waits[idx].insert(up);
                } else {
                    let inherited = waits[up].clone();
                    waits[idx].extend(inherited);
                }
            }
        }
    }
    let mut submissions: Vec<Submission> = Vec::new();
    // Instance → (submission, task).
    let mut placed: BTreeMap<usize, (usize, usize)> = BTreeMap::new();
    for of_stage in &instances.of_stage {
        let members: Vec<usize> = of_stage.iter().copied().filter(|&idx| job[idx]).collect();
        let Some(&first) = members.first() else {
            continue;
        };
        let stage = instances.list[first].stage;
        let mut new = Vec::new();
        if let Some(upstream) = corresponding(&members, &waits, &placed, &submissions) {
            new.push(Submission {
                stage,
                instances: members.clone(),
                after: After::Corresponding(upstream),
            });
        } else {
            // Classes of identical waits, in order of first appearance.
            let mut classes: Vec<(&BTreeSet<usize>, Vec<usize>)> = Vec::new();
            for &idx in &members {
                match classes.iter_mut().find(|(set, _)| **set == waits[idx]) {
                    Some((_, class)) => class.push(idx),
                    None => classes.push((&waits[idx], vec![idx])),
                }
            }
            for (set, class) in classes {
                new.push(Submission {
                    stage,
                    instances: class,
                    after: after_all(set, &placed, &submissions),
                });
            }
        }
        for submission in new {
            let index = submissions.len();
            for (task, &idx) in submission.instances.iter().enumerate() {
                placed.insert(idx, (index, task));
            }
            submissions.push(submission);
        }
    }
    submissions
}

/// The upstream array whose task `t` alone feeds `members[t]`, for every `t`.
fn corresponding(
    members: &[usize],
    waits: &[BTreeSet<usize>],
    placed: &BTreeMap<usize, (usize, usize)>,
    submissions: &[Submission],
) -> Option<usize> {
    if members.len() < 2 {
        return None;
    }
    let mut upstream = None;
    for (task, &idx) in members.iter().enumerate() {
        let mut set = waits[idx].iter();
        let (Some(up), None) = (set.next(), set.next()) else {
            return None;
        };
        let (submission, up_task) = placed[up];
        if up_task != task || *upstream.get_or_insert(submission) != submission {
            return None;
        }
    }
    upstream.filter(|&submission| submissions[submission].instances.len() == members.len())
}

fn after_all(
    set: &BTreeSet<usize>,
    placed: &BTreeMap<usize, (usize, usize)>,
    submissions: &[Submission],
) -> After {
    if set.is_empty() {
        return After::Nothing;
    }
    let mut by_submission: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for up in set {
        let (submission, task) = placed[up];
        by_submission.entry(submission).or_default().push(task);
    }
    let mut waits = Vec::new();
    for (submission, tasks) in by_submission {
        if tasks.len() == submissions[submission].instances.len() {
            waits.push(Wait::Whole(submission));
        } else {
            waits.extend(tasks.into_iter().map(|task| Wait::Task(submission, task)));
        }
    }
    After::All(waits)
}

/// The `--dependency` value, given the job id of each earlier submission.
pub fn dependency(after: &After, ids: &[String]) -> Option<String> {
    match after {
        After::Nothing => None,
        After::Corresponding(upstream) => Some(format!("aftercorr:{}", ids[*upstream])),
        After::All(waits) => {
            let mut text = String::from("afterok");
            for wait in waits {
                match *wait {
                    Wait::Whole(submission) => write!(text, ":{}", ids[submission]),
                    Wait::Task(submission, task) => write!(text, ":{}_{task}", ids[submission]),
                }
                .expect("writing to a String");
            }
            Some(text)
        }
    }
}

/// Files of one submission, in the run's Slurm folder.
pub struct Files {
    pub script: PathBuf,
    /// The instance names, one per line: task `t` runs line `t + 1`.
    pub instances: PathBuf,
    /// `%A_%a` (array) or `%j`, expanded by Slurm.
    pub stdout: PathBuf,
    pub stderr: PathBuf,
    /// `{task}` is replaced by the task index.
    pub status: PathBuf,
}

impl Files {
    pub fn new(dir: &Path, number: usize, stage: &str, array: bool) -> Files {
        let stem = format!("{number:03}-{}", file_safe(stage));
        let job = if array { "%A_%a" } else { "%j" };
        Files {
            script: dir.join(format!("{stem}.sh")),
            instances: dir.join(format!("{stem}.instances")),
            stdout: dir.join(format!("{stem}-{job}.out")),
            stderr: dir.join(format!("{stem}-{job}.err")),
            status: dir.join(format!("{stem}-{{task}}.json")),
        }
    }

    /// The stderr file of a job (`job` its id, `task` its array index).
    pub fn stderr_of(&self, job: &str, task: Option<usize>) -> PathBuf {
        let name = self.stderr.to_string_lossy();
        PathBuf::from(match task {
            Some(task) => name.replace("%A_%a", &format!("{job}_{task}")),
            None => name.replace("%j", job),
        })
    }

    pub fn status_of(&self, task: usize) -> PathBuf {
        PathBuf::from(
            self.status
                .to_string_lossy()
                .replace("{task}", &task.to_string()),
        )
    }
}

/// A stage name as a file name: letters, digits, `-`, `_` and `.` kept, the rest `_`.
fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// What a job's script needs to know.
pub struct ScriptInput<'a> {
    pub job_name: &'a str,
    pub files: &'a Files,
    pub tasks: usize,
    pub request: &'a super::requests::JobRequest,
    /// The command that runs the task's instance: `squeal … worker …`.
    pub worker: &'a [String],
}

/// The batch script: `#SBATCH` lines, then the worker on the task's instance.
pub fn script(input: &ScriptInput) -> String {
    let request = input.request;
    let mut text = String::from("#!/bin/bash\n");
    let mut directive = |option: &str, value: &str| {
        writeln!(text, "#SBATCH --{option}={}", value).expect("writing to a String")
    };
    directive("job-name", input.job_name);
    directive("output", &input.files.stdout.to_string_lossy());
    directive("error", &input.files.stderr.to_string_lossy());
    directive("cpus-per-task", &request.cpus_per_task.to_string());
    directive("mem", &request.mem);
    if let Some(time) = &request.time {
        directive("time", time);
    }
    if let Some(partition) = &request.partition {
        directive("partition", partition);
    }
    if let Some(account) = &request.account {
        directive("account", account);
    }
    if input.tasks > 1 {
        directive("array", &format!("0-{}", input.tasks - 1));
    }
    let words: Vec<String> = input.worker.iter().map(|word| quote(word)).collect();
    writeln!(text, "exec {}", words.join(" ")).expect("writing to a String");
    text
}

/// `word` quoted for bash.
pub fn quote(word: &str) -> String {
    if !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:+,@%".contains(c))
    {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}
