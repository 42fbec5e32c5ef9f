//! A short fuzz campaign on the study parser and validator in every test run (the long one is
//! `cargo bench -p squeal-engine --bench fuzz_study`), and the inputs earlier campaigns found,
//! kept as regression tests in `tests/fuzz_regressions/`.

mod support;

use std::path::Path;

use support::fuzz::{Verdict, campaign, check, registry};

#[test]
fn twenty_thousand_mutated_studies_are_accepted_or_rejected_in_one_located_line() {
    // Quiet the default hook: panics are caught and reported as findings.
    std::panic::set_hook(Box::new(|_| {}));
    let result = campaign(&registry(), 0x0515_7ea1, 20_000);
    let _ = std::panic::take_hook();
    for (_, what) in &result.findings {
        eprintln!("finding: {what}");
    }
    assert!(
        result.findings.is_empty(),
        "{} findings, the first: {}\ninput:\n{}",
        result.findings.len(),
        result.findings[0].1,
        result.findings[0].0
    );
    // The mutations reach both sides of validation.
    assert!(
        result.accepted > 200 && result.rejected > 15_000,
        "{} accepted, {} rejected",
        result.accepted,
        result.rejected
    );
}

#[test]
fn inputs_that_earlier_campaigns_found_are_rejected_in_one_located_line() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    let registry = registry();
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match check(&registry, &name, &text) {
            Verdict::Finding(what) => panic!("{name}: {what}"),
            Verdict::Accepted | Verdict::Rejected => checked += 1,
        }
    }
    assert!(checked > 0);
}
