//! A short fuzz campaign on the three mesh readers, run by `cargo test`: 150 mutants of each
//! file of `model/tests/data/elements/` (every element kind, as Gmsh, Abaqus and Nastran files), each
//! read or refused with a one-line message, none panicking. The million-mutant campaign is
//! `cargo bench -p squeal-stages --bench fuzz_readers`.

mod support;

use support::mutate::{Lcg, Outcome, corpus, mutate, try_read};

#[test]
fn mutated_gmsh_abaqus_and_nastran_files_are_read_or_refused_in_one_line() {
    for (index, (name, text, read)) in corpus().iter().enumerate() {
        let mut rng = Lcg(0x5eed_0000 + index as u64);
        let mut refused = 0;
        for _ in 0..150 {
            let mutant = mutate(text, &mut rng);
            match try_read(&mutant, read) {
                Outcome::Read => {}
                Outcome::Refused => refused += 1,
                Outcome::Finding(finding) => panic!("{name}: {finding}:\n{mutant}"),
            }
        }
        assert!(
            refused > 0,
            "{name}: no mutant was refused: the mutations do nothing"
        );
    }
}
