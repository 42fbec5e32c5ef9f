//! The fuzz campaign on the study parser and validator: a million inputs (structured mutations
//! of the pipelines and the malformed-study tests, and random text), each accepted or rejected
//! in one line with a location; anything else is a finding.
//!
//! ```text
//! cargo bench -p squeal-engine --bench fuzz_study
//! SQUEAL_FUZZ_INPUTS=5000000 SQUEAL_FUZZ_SEED=7 cargo bench -p squeal-engine --bench fuzz_study
//! ```
//!
//! Findings are written to `target/fuzz_findings/` (the input), and printed with what was
//! wrong; once fixed, an input belongs in `engine/tests/fuzz_regressions/`. Exit code 1 when
//! anything was found.

#[path = "../tests/support/fuzz.rs"]
mod fuzz;

use std::time::Instant;

use rayon::prelude::*;

/// Inputs per task: tasks are seeded by their index, so the inputs do not depend on threads.
const CHUNK: usize = 10_000;

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
    let registry = fuzz::registry();
    let started = Instant::now();
    let chunks = inputs.div_ceil(CHUNK);
    let results: Vec<fuzz::Campaign> = (0..chunks)
        .into_par_iter()
        .map(|chunk| {
            let count = CHUNK.min(inputs - chunk * CHUNK);
            let chunk_seed = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ chunk as u64;
            fuzz::campaign(&registry, chunk_seed, count)
        })
        .collect();
    let _ = std::panic::take_hook();
    let seconds = started.elapsed().as_secs_f64();
    let total: usize = results.iter().map(|result| result.inputs).sum();
    let accepted: usize = results.iter().map(|result| result.accepted).sum();
    let rejected: usize = results.iter().map(|result| result.rejected).sum();
    let findings: Vec<&(String, String)> =
        results.iter().flat_map(|result| &result.findings).collect();
    println!(
        "fuzz_study: {total} inputs (seed {seed}) in {seconds:.1} s ({:.0} a second): {accepted} accepted, {rejected} rejected in one located line, {} findings",
        total as f64 / seconds,
        findings.len()
    );
    if findings.is_empty() {
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fuzz_findings");
    std::fs::create_dir_all(&dir).expect("findings folder");
    for (idx, (input, what)) in findings.iter().enumerate() {
        println!("finding {idx}: {what}");
        std::fs::write(dir.join(format!("finding_{idx:04}.yaml")), input).expect("finding");
    }
    println!("inputs in {}", dir.display());
    std::process::exit(1);
}
