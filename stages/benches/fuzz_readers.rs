//! The fuzz campaign on the Gmsh, Abaqus and Nastran readers: a million mutants (by default)
//! of the files of `model/tests/data/elements/` (every element kind, first and second order, as
//! written by Gmsh and pyNastran), spread evenly over the files. Each must be read or refused
//! with a one-line message; a panic, a message on several lines, a mutant that takes more than
//! a second (a hang) is a finding. At the end: the counts, the slowest mutant and the peak
//! resident memory, against the largest file.
//!
//! ```text
//! cargo bench -p squeal-stages --bench fuzz_readers
//! SQUEAL_FUZZ_INPUTS=5000000 SQUEAL_FUZZ_SEED=7 cargo bench -p squeal-stages --bench fuzz_readers
//! ```
//!
//! Findings are written to `target/fuzz_findings/readers/` (the mutant, named after its file);
//! exit code 1 when anything was found.

#[path = "../tests/support/mutate.rs"]
mod mutate;

use std::time::{Duration, Instant};

use mutate::{Lcg, Outcome, corpus, mutate, try_read};
use rayon::prelude::*;

/// Mutants per task: tasks are seeded by their index, so the mutants do not depend on threads.
const CHUNK: usize = 5_000;

/// A mutant read slower than this is a hang (the files are read in milliseconds).
const HANG: Duration = Duration::from_secs(1);

#[derive(Default)]
struct Tally {
    read: usize,
    refused: usize,
    findings: Vec<(String, String, String)>,
    slowest: Duration,
}

/// Peak resident memory of this process (kB), from `/proc/self/status`.
fn peak_rss_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|line| line.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn main() {
    let inputs: usize = std::env::var("SQUEAL_FUZZ_INPUTS")
        .ok()
        .and_then(|value| value.parse().ok())
        .unwrap_or(1_000_000);
    let seed: u64 = std::env::var("SQUEAL_FUZZ_SEED")
        .ok()
        .and_then(|value| value.parse().ok())
        .unwrap_or(1);
    std::panic::set_hook(Box::new(|_| {}));
    let corpus = corpus();
    let rss_before = peak_rss_kb();
    let started = Instant::now();
    let per_file = inputs.div_ceil(corpus.len());
    let chunks = per_file.div_ceil(CHUNK);
    let tallies: Vec<Tally> = (0..corpus.len() * chunks)
        .into_par_iter()
        .map(|task| {
            let (file, chunk) = (task / chunks, task % chunks);
            let (name, text, read) = &corpus[file];
            let mut rng = Lcg(seed
                .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                .wrapping_add(task as u64));
            let mut tally = Tally::default();
            for _ in 0..CHUNK.min(per_file - chunk * CHUNK) {
                let mutant = mutate(text, &mut rng);
                let began = Instant::now();
                let outcome = try_read(&mutant, read);
                let took = began.elapsed();
                tally.slowest = tally.slowest.max(took);
                match outcome {
                    _ if took > HANG => {
                        tally
                            .findings
                            .push((name.clone(), format!("took {took:.1?}"), mutant))
                    }
                    Outcome::Read => tally.read += 1,
                    Outcome::Refused => tally.refused += 1,
                    Outcome::Finding(finding) => {
                        tally.findings.push((name.clone(), finding, mutant))
                    }
                }
            }
            tally
        })
        .collect();
    let seconds = started.elapsed().as_secs_f64();
    let read: usize = tallies.iter().map(|tally| tally.read).sum();
    let refused: usize = tallies.iter().map(|tally| tally.refused).sum();
    let slowest = tallies
        .iter()
        .map(|tally| tally.slowest)
        .max()
        .unwrap_or_default();
    let findings: Vec<&(String, String, String)> =
        tallies.iter().flat_map(|tally| &tally.findings).collect();
    let largest_file = corpus
        .iter()
        .map(|(_, text, _)| text.len())
        .max()
        .unwrap_or(0);
    println!(
        "{} mutants of {} files in {seconds:.1} s ({:.0}/s): {read} read, {refused} refused, {} findings",
        read + refused + findings.len(),
        corpus.len(),
        (read + refused + findings.len()) as f64 / seconds,
        findings.len()
    );
    println!(
        "slowest mutant {:.2} ms; peak resident memory {} kB (before the campaign {} kB; largest file {} kB)",
        slowest.as_secs_f64() * 1e3,
        peak_rss_kb().map_or("?".into(), |kb| kb.to_string()),
        rss_before.map_or("?".into(), |kb| kb.to_string()),
        largest_file.div_ceil(1024)
    );
    if findings.is_empty() {
        return;
    }
    let folder =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fuzz_findings/readers");
    let _ = std::fs::create_dir_all(&folder);
    for (index, (name, finding, mutant)) in findings.iter().enumerate() {
        println!("{name}: {finding}");
        let _ = std::fs::write(folder.join(format!("{index}-{name}")), mutant);
    }
    std::process::exit(1);
}
