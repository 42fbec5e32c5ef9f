//! Where a line of an input deck came from, and why a deck could not be read: shared by the
//! Abaqus and Nastran readers, whose every error names its `file:line`.

use std::fmt;
use std::sync::Arc;

/// Where a line came from: its file (as the deck or its include named it) and 1-based line.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    pub file: Arc<str>,
    pub line: usize,
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}

/// Why a deck could not be read: where (a line, or a whole file) and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct DeckError {
    pub at: String,
    pub message: String,
}

impl DeckError {
    pub fn at(source: &Source, message: impl Into<String>) -> Self {
        DeckError {
            at: source.to_string(),
            message: message.into(),
        }
    }

    pub fn file(file: &str, message: impl Into<String>) -> Self {
        DeckError {
            at: file.to_string(),
            message: message.into(),
        }
    }

    /// The message a stage gives: located at its line, or at the deck `path` for a problem of
    /// the deck as a whole.
    pub fn in_file(&self, path: &std::path::Path) -> String {
        if self.at.is_empty() {
            format!("{}: {}", path.display(), self.message)
        } else {
            self.to_string()
        }
    }

    /// A problem of the deck as a whole (its sets, parts, contact), placed at no line.
    pub fn whole(message: impl Into<String>) -> Self {
        DeckError {
            at: String::new(),
            message: message.into(),
        }
    }
}

impl fmt::Display for DeckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.at.is_empty() {
            f.write_str(&self.message)
        } else {
            write!(f, "{}: {}", self.at, self.message)
        }
    }
}
