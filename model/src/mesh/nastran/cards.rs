//! Nastran bulk data as cards: `INCLUDE` read in place, comments (`$`) dropped, the executive
//! and case control before `BEGIN BULK` skipped, and each card's fields gathered over its
//! continuation lines, whatever their format.
//!
//! Formats of a line: small field (ten fields of 8 columns: the name, eight data fields, a
//! continuation marker), large field (a name ending in `*`, then four data fields of 16
//! columns, the marker; its continuation lines start with `*`), and free field (fields
//! separated by commas; a name ending in `*` takes four data fields per line). A line whose
//! first field is blank or starts with `+` or `*` continues the card above. A free-field line
//! holds a name and at most eight data fields (four for a large card): the rest of a card is
//! on continuation lines, as in the fixed formats.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::mesh::deck_error::{DeckError, Source};

/// Includes nested deeper than this are refused (an include cycle would never end).
const MAX_INCLUDE_DEPTH: usize = 16;

/// A bulk data card: its name (upper case, without `*`), its data fields in order (trimmed,
/// blank ones empty) and the line it starts on.
#[derive(Debug, Clone)]
pub struct Card {
    pub name: String,
    pub fields: Vec<String>,
    pub at: Source,
    /// Comments right above the card (`$` removed), where decks name properties.
    pub comments: Vec<String>,
}

impl Card {
    /// Data field `index` (0-based: field 2 of the card is 0), blank if absent.
    pub fn field(&self, index: usize) -> &str {
        self.fields.get(index).map_or("", String::as_str)
    }

    /// An integer field; `what` names it in the error.
    pub fn int(&self, index: usize, what: &str) -> Result<i64, DeckError> {
        let text = self.field(index);
        text.parse().map_err(|_| {
            DeckError::at(
                &self.at,
                format!("{}: {what} must be an integer, found `{text}`", self.name),
            )
        })
    }

    /// An integer field that may be blank (then `default`).
    pub fn int_or(&self, index: usize, default: i64, what: &str) -> Result<i64, DeckError> {
        if self.field(index).is_empty() {
            Ok(default)
        } else {
            self.int(index, what)
        }
    }

    /// A real field (Nastran's forms: `1.5`, `1.5E3`, `1.5+3`, `1.5D3`, `-2.-4`); blank is 0.
    pub fn real(&self, index: usize, what: &str) -> Result<f64, DeckError> {
        let text = self.field(index);
        if text.is_empty() {
            return Ok(0.0);
        }
        parse_real(text).ok_or_else(|| {
            DeckError::at(
                &self.at,
                format!("{}: {what} must be a number, found `{text}`", self.name),
            )
        })
    }
}

/// A Nastran real: an optional sign, digits with a point, and an exponent written with `E`,
/// `D` or only its sign.
pub fn parse_real(text: &str) -> Option<f64> {
    let upper = text.trim().to_ascii_uppercase().replace('D', "E");
    if let Ok(value) = upper.parse::<f64>() {
        return value.is_finite().then_some(value);
    }
    // `1.5+3`, `-2.-4`: an exponent sign after the first character and not after an `E`.
    let bytes = upper.as_bytes();
    let split = (1..bytes.len())
        .find(|&i| (bytes[i] == b'+' || bytes[i] == b'-') && bytes[i - 1] != b'E')?;
    let value: f64 = format!("{}E{}", &upper[..split], &upper[split..])
        .parse()
        .ok()?;
    value.is_finite().then_some(value)
}

/// The cards of the deck at `path` (with its includes).
pub fn read_cards(path: &Path) -> Result<Vec<Card>, DeckError> {
    let mut reader = Reader::default();
    reader.read_file(path, &path.display().to_string(), 0)?;
    reader.finish()
}

/// The cards of deck text (`file` names it in messages; includes resolve in `dir`).
pub fn parse_cards(text: &str, file: &str, dir: &Path) -> Result<Vec<Card>, DeckError> {
    let mut reader = Reader::default();
    reader.parse(text, file, dir, 0)?;
    reader.finish()
}

#[derive(Default)]
struct Reader {
    cards: Vec<Card>,
    /// Whether `BEGIN BULK` was met (before it, lines are executive and case control).
    in_bulk: bool,
    /// Whether some file had a `BEGIN BULK` at all: a file without one is all bulk data.
    saw_begin: bool,
    ended: bool,
    comments: Vec<String>,
}

impl Reader {
    fn read_file(&mut self, path: &Path, name: &str, depth: usize) -> Result<(), DeckError> {
        let bytes = std::fs::read(path).map_err(|err| DeckError::file(name, err.to_string()))?;
        let text = String::from_utf8(bytes).map_err(|_| {
            DeckError::file(name, "not UTF-8 text: is this a Nastran bulk data file?")
        })?;
        let dir = path.parent().map_or_else(PathBuf::new, Path::to_path_buf);
        self.parse(&text, name, &dir, depth)
    }

    fn parse(&mut self, text: &str, file: &str, dir: &Path, depth: usize) -> Result<(), DeckError> {
        let file: Arc<str> = Arc::from(file);
        // A deck without `BEGIN BULK` (an included file, a bulk-only deck) is bulk data.
        let has_begin = text.lines().any(is_begin_bulk);
        if depth == 0 {
            self.saw_begin = has_begin;
            self.in_bulk = !has_begin;
        }
        let mut lines = text.lines().enumerate().peekable();
        while let Some((idx, raw)) = lines.next() {
            if self.ended {
                break;
            }
            let at = Source {
                file: file.clone(),
                line: idx + 1,
            };
            let line = raw.trim_end_matches(['\r', '\n']);
            if !self.in_bulk {
                if is_begin_bulk(line) {
                    self.in_bulk = true;
                }
                continue;
            }
            let (content, comment) = match line.find('$') {
                Some(dollar) => (&line[..dollar], Some(line[dollar + 1..].trim())),
                None => (line, None),
            };
            if content.trim().is_empty() {
                if let Some(comment) = comment {
                    self.comments.push(comment.to_string());
                }
                continue;
            }
            let upper = content.trim_start().to_ascii_uppercase();
            if upper.starts_with("ENDDATA") {
                self.ended = true;
                break;
            }
            if upper.starts_with("INCLUDE") {
                let mut spec = content.trim_start()[7..].trim().to_string();
                // A quoted name may continue on the next lines until its closing quote.
                while spec.starts_with('\'') && spec.matches('\'').count() < 2 {
                    match lines.next() {
                        Some((_, more)) => spec.push_str(more.trim()),
                        None => break,
                    }
                }
                let name = spec.trim().trim_matches('\'').trim();
                if name.is_empty() {
                    return Err(DeckError::at(&at, "INCLUDE names no file"));
                }
                if depth + 1 > MAX_INCLUDE_DEPTH {
                    return Err(DeckError::at(
                        &at,
                        format!(
                            "INCLUDE nested more than {MAX_INCLUDE_DEPTH} deep: is there a cycle?"
                        ),
                    ));
                }
                let path = dir.join(name);
                self.read_file(&path, &path.display().to_string(), depth + 1)
                    .map_err(|err| {
                        if err.at == path.display().to_string() {
                            DeckError::at(&at, format!("INCLUDE '{name}': {}", err.message))
                        } else {
                            err
                        }
                    })?;
                continue;
            }
            self.card_line(content, at)?;
        }
        Ok(())
    }

    /// One non-blank, non-comment line of bulk data.
    fn card_line(&mut self, content: &str, at: Source) -> Result<(), DeckError> {
        let first = content.chars().next().unwrap_or(' ');
        let free = content.contains(',');
        let head: String = if free {
            content.split(',').next().unwrap_or("").trim().to_string()
        } else {
            content
                .chars()
                .take(8)
                .collect::<String>()
                .trim()
                .to_string()
        };
        let continues = first == '+' || first == '*' || head.is_empty();
        let large = if continues {
            first == '*' || self.last_is_large()
        } else {
            head.ends_with('*')
        };
        let data = if free {
            split_free(content, large)
        } else {
            split_fixed(content, large)
        };
        if continues {
            let Some(card) = self.cards.last_mut() else {
                return Err(DeckError::at(
                    &at,
                    "a continuation line with no card before it",
                ));
            };
            card.fields.extend(data);
            return Ok(());
        }
        let name = head.trim_end_matches('*').to_ascii_uppercase();
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(DeckError::at(&at, format!("`{head}` is not a card name")));
        }
        self.cards.push(Card {
            name: if large { format!("{name}*") } else { name },
            fields: data,
            at,
            comments: std::mem::take(&mut self.comments),
        });
        Ok(())
    }

    fn last_is_large(&self) -> bool {
        self.cards
            .last()
            .is_some_and(|card| card.name.ends_with('*'))
    }

    fn finish(mut self) -> Result<Vec<Card>, DeckError> {
        if self.saw_begin && !self.in_bulk {
            return Err(DeckError::whole(
                "the deck has no bulk data after BEGIN BULK",
            ));
        }
        for card in &mut self.cards {
            if let Some(name) = card.name.strip_suffix('*') {
                card.name = name.to_string();
            }
        }
        Ok(self.cards)
    }
}

fn is_begin_bulk(line: &str) -> bool {
    let upper = line.trim().to_ascii_uppercase();
    upper.starts_with("BEGIN") && upper.contains("BULK")
}

/// A fixed-format line's data fields: 8 of 8 columns, or 4 of 16 (large field).
fn split_fixed(line: &str, large: bool) -> Vec<String> {
    let chars: Vec<char> = line.chars().collect();
    let field = |start: usize, width: usize| -> String {
        chars
            .iter()
            .skip(start)
            .take(width)
            .collect::<String>()
            .trim()
            .to_string()
    };
    let (width, count) = if large { (16, 4) } else { (8, 8) };
    (0..count).map(|k| field(8 + k * width, width)).collect()
}

/// A free-field line's data fields: up to 8, or 4 for a large card, after its first field.
fn split_free(line: &str, large: bool) -> Vec<String> {
    let mut fields: Vec<String> = line
        .split(',')
        .skip(1)
        .map(|f| f.trim().to_string())
        .collect();
    fields.truncate(if large { 4 } else { 8 });
    fields
}
