//! The study fuzzer, shared by `tests/fuzz.rs` (a short campaign in every test run) and
//! `benches/fuzz_study.rs` (the million-input campaign): structured mutations of valid and
//! malformed studies, and random bytes, each validated as `squeal validate` would; every input
//! must be accepted, or rejected with one line that has a location in the file. A panic or any
//! other rejection is a finding.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use squeal_engine::Location;
use squeal_engine::{Instances, Registry, Study};

/// xorshift64*: the same inputs on every machine for a given seed.
pub struct Rng(pub u64);

impl Rng {
    pub fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 33) as usize % n.max(1)
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Scalars and fragments a mutation writes in place of a value or a key.
const FRAGMENTS: &[&str] = &[
    "",
    "~",
    "null",
    "-1",
    "0",
    "1",
    "2.5",
    "1e309",
    "-1e309",
    ".nan",
    ".inf",
    "-.inf",
    "99999999999999999999",
    "1 mm",
    "1 kHz",
    "40 GPa",
    "3 furlongs",
    "abc",
    "true",
    "no",
    "[1, 2]",
    "[]",
    "{}",
    "{a: 1}",
    "'quoted'",
    "\"unterminated",
    "&anchor 1",
    "*anchor",
    "!!binary AAAA",
    "!custom 1",
    "[",
    "]",
    "{",
    "}",
    "- - -",
    ":",
    "? x",
    "<<: *a",
    "{ start: 0, stop: 1, num: 0 }",
    "{ start: 0, stop: 1, num: 3 }",
    "{ start: 0, stop: 1, num: 1000000000 }",
    "[0.1, 0.1]",
    "µ∞ ünïcödé",
    "\t1",
    "%YAML 1.2",
    "---",
    "...",
    "#",
    "mesh.mesh",
    "model.",
    ".model",
    "nosuch.table",
    "source.table",
    "test.affine",
    "test.constant",
    "table.gather",
    "stability",
    "1 m/s",
    "5e-324",
];

const KEYS: &[&str] = &[
    "stages",
    "kind",
    "params",
    "inputs",
    "matrix",
    "targets",
    "study",
    "description",
    "value",
    "offset",
    "scale",
    "mu",
    "unknown_key",
    "table",
    "tables",
    "x",
    "",
];

/// Valid and malformed studies to start from: the pipelines and the malformed-study tests.
pub fn seeds() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files: Vec<PathBuf> = Vec::new();
    for dir in ["pipelines", "tests/malformed"] {
        let mut found: Vec<PathBuf> = std::fs::read_dir(root.join(dir))
            .unwrap()
            .map(|entry| entry.unwrap().path())
            .filter(|path| path.extension().is_some_and(|ext| ext == "yaml"))
            .collect();
        found.sort();
        files.extend(found);
    }
    files.push(PathBuf::new());
    files
        .into_iter()
        .map(|path| {
            if path.as_os_str().is_empty() {
                // A study of the test kinds, with a sweep and a gather.
                return (
                    "chain.yaml".to_string(),
                    "stages:\n  source:\n    kind: test.constant\n    matrix:\n      value: [1, 2]\n  scaled:\n    kind: test.affine\n    inputs: { table: source.table }\n    params: { scale: 2, offset: 1 }\n  all:\n    kind: table.gather\n    inputs: { tables: scaled.table }\n".to_string(),
                );
            }
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&path).unwrap())
        })
        .collect()
}

/// One mutation of `text`.
pub fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let line = rng.below(lines.len());
    match rng.below(12) {
        0 => {
            lines.remove(line);
        }
        1 => {
            let copy = lines[line].clone();
            lines.insert(line, copy);
        }
        2 => {
            let other = rng.below(lines.len());
            lines.swap(line, other);
        }
        3 => {
            let indent = *rng.pick(&["", " ", "  ", "\t", "      "]);
            let trimmed = lines[line].trim_start().to_string();
            lines[line] = format!("{indent}{trimmed}");
        }
        4 | 5 => {
            // A value after `:` replaced.
            if let Some(colon) = lines[line].find(':') {
                let head = lines[line][..=colon].to_string();
                lines[line] = format!("{head} {}", rng.pick(FRAGMENTS));
            }
        }
        6 => {
            // A key replaced.
            if let Some(colon) = lines[line].find(':') {
                let indent = lines[line].len() - lines[line].trim_start().len();
                let tail = lines[line][colon..].to_string();
                lines[line] = format!("{}{}{tail}", " ".repeat(indent), rng.pick(KEYS));
            }
        }
        7 => {
            // A word anywhere replaced by a fragment.
            let words: Vec<&str> = lines[line].split(' ').collect();
            let word = rng.below(words.len());
            let replaced: Vec<&str> = words
                .iter()
                .enumerate()
                .map(|(idx, w)| {
                    if idx == word {
                        *rng.pick(FRAGMENTS)
                    } else {
                        *w
                    }
                })
                .collect();
            lines[line] = replaced.join(" ");
        }
        8 => {
            let indent = " ".repeat(2 * rng.below(4));
            let key = rng.pick(KEYS);
            let value = rng.pick(FRAGMENTS);
            lines.insert(line, format!("{indent}{key}: {value}"));
        }
        9 => {
            // Truncated at a character boundary.
            let joined = lines.join("\n");
            let mut cut = rng.below(joined.len() + 1);
            while !joined.is_char_boundary(cut) {
                cut -= 1;
            }
            return joined[..cut].to_string();
        }
        10 => {
            // Characters inserted, control characters included.
            let joined = lines.join("\n");
            let mut at = rng.below(joined.len() + 1);
            while !joined.is_char_boundary(at) {
                at -= 1;
            }
            let inserted: String = (0..1 + rng.below(6))
                .map(|_| {
                    *rng.pick(&[
                        '\0', '\t', '\r', '\n', ':', '-', '{', '[', '"', '\'', '&', '*', '!', '#',
                        '|', '>', '%', '@', '`', 'é', '\u{feff}', '\u{2028}',
                    ])
                })
                .collect();
            return format!("{}{inserted}{}", &joined[..at], &joined[at..]);
        }
        _ => {
            // A line's text repeated into a long one.
            let long = lines[line].repeat(1 + rng.below(200));
            lines[line] = long;
        }
    }
    lines.join("\n")
}

/// Random characters: printable, YAML punctuation, whitespace, control and non-ASCII.
pub fn random_text(rng: &mut Rng) -> String {
    const ALPHABET: &[char] = &[
        'a', 'k', 's', ' ', ' ', '\n', '\n', '\t', ':', '-', '{', '}', '[', ']', ',', '"', '\'',
        '&', '*', '!', '#', '|', '>', '?', '%', '@', '0', '1', '.', 'e', '\0', '\r', 'µ',
        '\u{feff}',
    ];
    (0..rng.below(300)).map(|_| *rng.pick(ALPHABET)).collect()
}

/// What validating one input gave.
pub enum Verdict {
    Accepted,
    Rejected,
    /// A panic, or a rejection that is not one line with a location: the message says which.
    Finding(String),
}

/// Validates `text` as the file `file` and expands its instances, as `squeal validate` does.
pub fn check(registry: &Registry, file: &str, text: &str) -> Verdict {
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        Study::from_text(file, "fuzz", text, Path::new("."), registry, &[])
            .map(|study| Instances::expand(&study, &study.targets).list.len())
    }));
    match outcome {
        Err(payload) => {
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Verdict::Finding(format!("panic: {message}"))
        }
        Ok(Ok(_)) => Verdict::Accepted,
        Ok(Err(err)) => {
            let message = err.to_string();
            if message.contains('\n') || message.contains('\r') {
                return Verdict::Finding(format!("a rejection of several lines: {message:?}"));
            }
            match &err.location {
                Location::File {
                    file: named,
                    line,
                    col,
                } if named == file
                    && *line >= 1
                    && *col >= 1
                    && *line as usize <= line_breaks(text) + 2 =>
                {
                    Verdict::Rejected
                }
                other => Verdict::Finding(format!(
                    "a rejection without a location in the file ({other}): {message}"
                )),
            }
        }
    }
}

/// Line breaks as YAML counts them: `\n`, `\r\n` and a lone `\r`.
fn line_breaks(text: &str) -> usize {
    text.matches('\n').count() + text.matches('\r').count()
}

/// Counts of a campaign, and its findings (input, what was wrong).
#[derive(Default)]
pub struct Campaign {
    pub inputs: usize,
    pub accepted: usize,
    pub rejected: usize,
    pub findings: Vec<(String, String)>,
}

/// `inputs` inputs from `seed`: one in eight random text, the rest mutations (one to three
/// in a row) of a seed study.
pub fn campaign(registry: &Registry, seed: u64, inputs: usize) -> Campaign {
    let seeds = seeds();
    // splitmix64 of the seed: neighbouring seeds give unrelated sequences.
    let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    let mut rng = Rng((z ^ (z >> 31)) | 1);
    let mut result = Campaign::default();
    for _ in 0..inputs {
        let text = if rng.below(8) == 0 {
            random_text(&mut rng)
        } else {
            let (_, mut text) = rng.pick(&seeds).clone();
            for _ in 0..1 + rng.below(3) {
                text = mutate(&mut rng, &text);
            }
            text
        };
        result.inputs += 1;
        match check(registry, "fuzz.yaml", &text) {
            Verdict::Accepted => result.accepted += 1,
            Verdict::Rejected => result.rejected += 1,
            Verdict::Finding(what) => result.findings.push((text, what)),
        }
    }
    result
}

/// The registry of `squeal` with the test kinds.
pub fn registry() -> Registry {
    let mut kinds = squeal_stages::all_kinds();
    kinds.extend(squeal_stages::test_kinds());
    Registry::new(kinds)
}
