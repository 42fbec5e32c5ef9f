//! A short fuzz campaign on the three mesh readers: files of every element kind written by
//! other tools, mutated line by line and byte by byte. Each mutant is read or refused with a
//! one-line message; none panics. (The million-mutation campaign the readers still lack would
//! share this generator.)

use std::path::Path;

use crate::mesh::{abaqus, gmsh, nastran};

/// A small deterministic generator (64-bit LCG): the same campaign on every run.
struct Lcg(u64);

impl Lcg {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) as usize) % n.max(1)
    }
}

/// Characters that change a number, a field or a card: digits, signs, separators, markers.
const NOISE: &[u8] = b"0123456789.-+eE, *$\n\"";

fn mutate(text: &str, rng: &mut Lcg) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for _ in 0..1 + rng.below(3) {
        if lines.is_empty() {
            break;
        }
        let at = rng.below(lines.len());
        match rng.below(5) {
            0 => {
                lines.remove(at);
            }
            1 => {
                let copy = lines[at].clone();
                lines.insert(rng.below(lines.len()), copy);
            }
            2 => {
                let other = rng.below(lines.len());
                lines.swap(at, other);
            }
            3 => {
                let mut bytes = lines[at].clone().into_bytes();
                if !bytes.is_empty() {
                    let position = rng.below(bytes.len());
                    bytes[position] = NOISE[rng.below(NOISE.len())];
                }
                lines[at] = String::from_utf8_lossy(&bytes).into_owned();
            }
            _ => {
                let keep = rng.below(lines[at].len() + 1);
                lines[at] = lines[at].chars().take(keep).collect();
            }
        }
    }
    lines.join("\n")
}

fn data(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/elements")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|err| panic!("{}: {err}", path.display()))
}

/// Reads `mutants` mutants of `text` with `read`, which returns the error message of a refused
/// one: none may panic, every message is one line.
fn campaign(name: &str, text: &str, mutants: usize, read: &dyn Fn(&str) -> Option<String>) {
    let mut rng = Lcg(0x5eed_0000 + name.len() as u64);
    let mut refused = 0;
    for _ in 0..mutants {
        let mutant = mutate(text, &mut rng);
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(&mutant)));
        match outcome {
            Ok(None) => {}
            Ok(Some(message)) => {
                assert!(
                    !message.is_empty() && !message.contains('\n'),
                    "{name}: `{message}`"
                );
                refused += 1;
            }
            Err(_) => panic!("{name}: a mutant panicked the reader:\n{mutant}"),
        }
    }
    assert!(
        refused > 0,
        "{name}: no mutant was refused: the mutations do nothing"
    );
}

#[test]
fn mutated_gmsh_abaqus_and_nastran_files_are_read_or_refused_in_one_line() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/elements");
    for stem in ["tet1", "wedge2", "hex2"] {
        campaign(
            &format!("{stem}.msh"),
            &data(&format!("{stem}.msh")),
            300,
            &|text| {
                gmsh::read_msh(text, &gmsh::ReadOptions::default())
                    .err()
                    .map(|err| err.to_string())
            },
        );
        let parts = abaqus::ReadOptions {
            parts: vec!["disc".into()],
            contact: None,
        };
        campaign(
            &format!("{stem}.inp"),
            &data(&format!("{stem}.inp")),
            300,
            &|text| {
                abaqus::read_inp_text(text, "deck.inp", &dir, &parts)
                    .err()
                    .map(|err| err.to_string())
            },
        );
        campaign(
            &format!("{stem}.bdf"),
            &data(&format!("{stem}.bdf")),
            300,
            &|text| {
                nastran::read_bdf_text(text, "deck.bdf", &dir, &nastran::ReadOptions::default())
                    .err()
                    .map(|err| err.to_string())
            },
        );
    }
}
