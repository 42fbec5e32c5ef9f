//! Mutated mesh files for fuzzing the Gmsh, Abaqus and Nastran readers: files of every element
//! kind written by other tools (`model/tests/data/elements/`), changed line by line and byte by
//! byte by a deterministic generator. Shared by the short campaign `cargo test` runs
//! (`tests/fuzz_readers.rs`) and the million-mutant one (`benches/fuzz_readers.rs`).

use std::path::{Path, PathBuf};

use squeal_stages::mesh::{abaqus, gmsh, nastran};

/// A small deterministic generator (64-bit LCG): the same campaign on every run.
pub struct Lcg(pub u64);

impl Lcg {
    pub fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) as usize) % n.max(1)
    }
}

/// Characters that change a number, a field or a card: digits, signs, separators, markers.
const NOISE: &[u8] = b"0123456789.-+eE, *$\n\"";

/// One to three edits of `text`: a line removed, repeated, swapped or cut short, or one of its
/// bytes replaced by noise.
pub fn mutate(text: &str, rng: &mut Lcg) -> String {
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

/// A reader: the error message of a refused file, `None` for one read.
pub type Reader = Box<dyn Fn(&str) -> Option<String> + Sync>;

/// The folder of the files written by other tools.
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/tests/data/elements")
}

/// Every file of `model/tests/data/elements/` with the reader of its format: each element kind of
/// first and second order, as Gmsh MSH, Abaqus INP and Nastran bulk data.
pub fn corpus() -> Vec<(String, String, Reader)> {
    let mut corpus: Vec<(String, String, Reader)> = Vec::new();
    for stem in ["tet1", "tet2", "wedge1", "wedge2", "hex1", "hex2"] {
        let read = |name: &str| {
            let path = data_dir().join(name);
            std::fs::read_to_string(&path).unwrap_or_else(|err| panic!("{}: {err}", path.display()))
        };
        let msh = format!("{stem}.msh");
        corpus.push((
            msh.clone(),
            read(&msh),
            Box::new(|text| {
                gmsh::read_msh(text, &gmsh::ReadOptions::default())
                    .err()
                    .map(|err| err.to_string())
            }),
        ));
        let inp = format!("{stem}.inp");
        corpus.push((
            inp.clone(),
            read(&inp),
            Box::new(|text| {
                let parts = abaqus::ReadOptions {
                    parts: vec!["disc".into()],
                    contact: None,
                };
                abaqus::read_inp_text(text, "deck.inp", &data_dir(), &parts)
                    .err()
                    .map(|err| err.to_string())
            }),
        ));
        let bdf = format!("{stem}.bdf");
        corpus.push((
            bdf.clone(),
            read(&bdf),
            Box::new(|text| {
                nastran::read_bdf_text(
                    text,
                    "deck.bdf",
                    &data_dir(),
                    &nastran::ReadOptions::default(),
                )
                .err()
                .map(|err| err.to_string())
            }),
        ));
    }
    corpus
}

/// How one mutant went.
pub enum Outcome {
    Read,
    Refused,
    /// A panic, or a message that is empty or longer than a line.
    Finding(String),
}

/// Reads `mutant` with `read`, a panic caught.
pub fn try_read(mutant: &str, read: &Reader) -> Outcome {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read(mutant))) {
        Ok(None) => Outcome::Read,
        Ok(Some(message)) if !message.is_empty() && !message.contains('\n') => Outcome::Refused,
        Ok(Some(message)) => Outcome::Finding(format!("a message not on one line: `{message}`")),
        Err(_) => Outcome::Finding("the reader panicked".into()),
    }
}
