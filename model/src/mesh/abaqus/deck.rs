//! An Abaqus input deck as keyword blocks: `*INCLUDE` expanded in place, comments (`**`) and
//! blank lines dropped, keywords and parameter names upper-cased, data lines split on commas.

use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use crate::mesh::deck_error::{DeckError, Source};

/// Includes nested deeper than this are refused (an include cycle would never end).
const MAX_INCLUDE_DEPTH: usize = 16;

/// A keyword line and the data lines under it.
#[derive(Debug, Clone)]
pub struct Block {
    /// Upper case, single spaces: `ELEMENT`, `END PART`.
    pub keyword: String,
    /// Parameter names upper case; values as written, unquoted (`""` for a flag).
    pub params: Vec<(String, String)>,
    pub at: Source,
    pub data: Vec<DataLine>,
}

#[derive(Debug, Clone)]
pub struct DataLine {
    pub fields: Vec<String>,
    pub at: Source,
}

impl Block {
    pub fn param(&self, name: &str) -> Option<&str> {
        self.params
            .iter()
            .find(|(key, _)| key == name)
            .map(|(_, value)| value.as_str())
    }

    /// The parameter, required.
    pub fn required(&self, name: &str) -> Result<&str, DeckError> {
        self.param(name).ok_or_else(|| {
            DeckError::at(
                &self.at,
                format!("*{} needs its {name}= parameter", self.keyword),
            )
        })
    }

    /// Refuses parameters outside `known`: one this reader ignored could change the mesh
    /// (`*NODE, SYSTEM=C` gives cylindrical coordinates).
    pub fn only_params(&self, known: &[&str]) -> Result<(), DeckError> {
        match self
            .params
            .iter()
            .find(|(key, _)| !known.contains(&key.as_str()))
        {
            Some((key, _)) => Err(DeckError::at(
                &self.at,
                format!(
                    "*{} parameter {key} is not supported (supported: {})",
                    self.keyword,
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                ),
            )),
            None => Ok(()),
        }
    }
}

/// Reads the deck at `path` with its includes (paths relative to the including file).
pub fn read_deck(path: &Path) -> Result<Vec<Block>, DeckError> {
    let mut blocks = Vec::new();
    read_into(path, &path.display().to_string(), 0, &mut blocks)?;
    Ok(blocks)
}

/// Reads the deck text of `file` (its name in messages); `*INCLUDE` is resolved in `dir`.
pub fn parse_deck(text: &str, file: &str, dir: &Path) -> Result<Vec<Block>, DeckError> {
    let mut blocks = Vec::new();
    parse_into(text, file, dir, 0, &mut blocks)?;
    Ok(blocks)
}

/// Reads `path` in place: its data lines continue the block before the `*INCLUDE` (a file of
/// node lines can follow a `*NODE`).
fn read_into(
    path: &Path,
    name: &str,
    depth: usize,
    blocks: &mut Vec<Block>,
) -> Result<(), DeckError> {
    let bytes = std::fs::read(path).map_err(|err| DeckError::file(name, err.to_string()))?;
    let text = String::from_utf8(bytes)
        .map_err(|_| DeckError::file(name, "not UTF-8 text: is this an Abaqus input file?"))?;
    let dir = path.parent().map_or_else(PathBuf::new, Path::to_path_buf);
    parse_into(&text, name, &dir, depth, blocks)
}

fn parse_into(
    text: &str,
    file: &str,
    dir: &Path,
    depth: usize,
    blocks: &mut Vec<Block>,
) -> Result<(), DeckError> {
    let file: Arc<str> = file.into();
    for (idx, raw) in text.lines().enumerate() {
        let at = Source {
            file: file.clone(),
            line: idx + 1,
        };
        let line = raw.trim();
        if line.is_empty() || line.starts_with("**") {
            continue;
        }
        if let Some(keyword_line) = line.strip_prefix('*') {
            let block = keyword_block(keyword_line, at)?;
            if block.keyword == "INCLUDE" {
                block.only_params(&["INPUT"])?;
                let input = block.required("INPUT")?;
                if depth + 1 > MAX_INCLUDE_DEPTH {
                    return Err(DeckError::at(
                        &block.at,
                        format!(
                            "includes nest deeper than {MAX_INCLUDE_DEPTH}: do they include each other?"
                        ),
                    ));
                }
                let path = dir.join(input);
                let name = path.display().to_string();
                if !path.is_file() {
                    return Err(DeckError::at(
                        &block.at,
                        format!("*INCLUDE: {name} is not a readable file"),
                    ));
                }
                read_into(&path, &name, depth + 1, blocks)?;
            } else {
                blocks.push(block);
            }
            continue;
        }
        let fields: Vec<String> = line
            .split(',')
            .map(|field| field.trim().to_string())
            .collect();
        match blocks.last_mut() {
            Some(block) => block.data.push(DataLine { fields, at }),
            None => {
                return Err(DeckError::at(
                    &at,
                    "a data line outside any keyword: is a `*` missing above it?",
                ));
            }
        }
    }
    Ok(())
}

fn keyword_block(keyword_line: &str, at: Source) -> Result<Block, DeckError> {
    let mut tokens = keyword_line.split(',');
    let keyword = tokens
        .next()
        .unwrap_or_default()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_uppercase();
    if keyword.is_empty() {
        return Err(DeckError::at(&at, "a `*` without a keyword"));
    }
    let mut params = Vec::new();
    for token in tokens {
        let token = token.trim();
        if token.is_empty() {
            continue;
        }
        let (key, value) = token.split_once('=').unwrap_or((token, ""));
        let value = value.trim().trim_matches('"').to_string();
        params.push((key.trim().to_uppercase(), value));
    }
    Ok(Block {
        keyword,
        params,
        at,
        data: Vec::new(),
    })
}

/// A number as Abaqus writes it (Fortran's `1.5D+00` too).
pub fn number(field: &str, at: &Source, what: &str) -> Result<f64, DeckError> {
    field
        .replace(['D', 'd'], "e")
        .parse::<f64>()
        .ok()
        .filter(|value| value.is_finite())
        .ok_or_else(|| DeckError::at(at, format!("{what}: `{field}` is not a number")))
}

/// A positive integer label (node, element).
pub fn label(field: &str, at: &Source, what: &str) -> Result<u64, DeckError> {
    field
        .parse::<u64>()
        .ok()
        .filter(|label| *label > 0)
        .ok_or_else(|| DeckError::at(at, format!("{what}: `{field}` is not a positive integer")))
}
