//! Study files: YAML → a raw, located syntax tree, and the error type every spec problem uses.
//!
//! Parsing is strict (unknown keys, duplicate keys and wrong shapes are errors); meaning
//! (kinds, parameters, references, cycles) is checked in [`crate::study`]. Every error names
//! `file:line:col` and the field path.

use std::fmt;

use serde::Deserialize;
use serde::de::{MapAccess, SeqAccess, Visitor};
use serde_saphyr::Spanned;

/// Where a spec problem is.
#[derive(Debug, Clone, PartialEq)]
pub enum Location {
    File {
        file: String,
        line: u64,
        col: u64,
    },
    /// An argument on the command line, e.g. `--set stage.param=value`.
    CommandLine(String),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File { file, line, col } => write!(f, "{file}:{line}:{col}"),
            Location::CommandLine(arg) => f.write_str(arg),
        }
    }
}

/// A one-line problem with a study: location, field path, message. Names echoed from the
/// study may hold line breaks (a quoted key, a multi-line scalar): they print escaped, so the
/// error stays one line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{location}: {}: {}", one_line(path), one_line(message))]
pub struct SpecError {
    pub location: Location,
    pub path: String,
    pub message: String,
}

impl SpecError {
    /// A problem with a command-line argument: `arg` as written (`--target mesh`), `option`
    /// the option it belongs to (`--target`).
    pub fn command_line(
        arg: impl Into<String>,
        option: &str,
        message: impl Into<String>,
    ) -> SpecError {
        SpecError {
            location: Location::CommandLine(arg.into()),
            path: option.into(),
            message: message.into(),
        }
    }
}

/// `text` with its control characters escaped (`\n`, `\r`, `\t`, `\u{..}`).
fn one_line(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return text.into();
    }
    text.chars()
        .map(|character| match character {
            '\n' => "\\n".to_string(),
            '\r' => "\\r".to_string(),
            '\t' => "\\t".to_string(),
            other if other.is_control() => other.escape_unicode().to_string(),
            other => other.to_string(),
        })
        .collect::<String>()
        .into()
}

/// A value with where it was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Located<T> {
    pub value: T,
    pub location: Location,
}

impl<T> Located<T> {
    pub fn error(&self, path: impl Into<String>, message: impl Into<String>) -> SpecError {
        SpecError {
            location: self.location.clone(),
            path: path.into(),
            message: message.into(),
        }
    }
}

/// A value as written in YAML (or on the command line), before it meets its declaration: a
/// scalar, or a list of them for a list parameter.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum RawValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    List(Vec<RawValue>),
}

impl fmt::Display for RawValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RawValue::Bool(value) => write!(f, "{value}"),
            RawValue::Int(value) => write!(f, "{value}"),
            RawValue::Float(value) => write!(f, "{value}"),
            RawValue::Str(value) => write!(f, "\"{value}\""),
            RawValue::List(items) => {
                let items: Vec<String> = items.iter().map(ToString::to_string).collect();
                write!(f, "[{}]", items.join(", "))
            }
        }
    }
}

/// The values a `matrix:` entry sweeps: a list, or an evenly spaced range.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum RawSweep {
    List(Vec<RawValue>),
    Range(RawRange),
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRange {
    pub start: f64,
    pub stop: f64,
    /// Number of points, both ends included.
    pub num: usize,
}

/// A YAML mapping kept in file order. (Keys are plain strings so that error paths can name
/// them; errors about an entry point at its value.)
#[derive(Debug, Clone, PartialEq)]
pub struct OrderedMap<V>(pub Vec<(String, V)>);

impl<V> Default for OrderedMap<V> {
    fn default() -> Self {
        OrderedMap(Vec::new())
    }
}

impl<'de, V: Deserialize<'de>> Deserialize<'de> for OrderedMap<V> {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct MapVisitor<V>(std::marker::PhantomData<V>);
        impl<'de, V: Deserialize<'de>> Visitor<'de> for MapVisitor<V> {
            type Value = OrderedMap<V>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a mapping")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
                let mut entries = Vec::new();
                while let Some(key) = map.next_key::<String>()? {
                    entries.push((key, map.next_value()?));
                }
                Ok(OrderedMap(entries))
            }
        }
        deserializer.deserialize_map(MapVisitor(std::marker::PhantomData))
    }
}

/// What an input port is connected to: one `stage.output`, or a list of them (each located).
#[derive(Debug, Clone, PartialEq)]
pub enum RawInput {
    One(String),
    List(Vec<Spanned<String>>),
}

impl<'de> Deserialize<'de> for RawInput {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct InputVisitor;
        impl<'de> Visitor<'de> for InputVisitor {
            type Value = RawInput;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("`stage.output` or a list of them")
            }
            fn visit_str<E: serde::de::Error>(self, value: &str) -> Result<RawInput, E> {
                Ok(RawInput::One(value.to_string()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<RawInput, A::Error> {
                let mut references = Vec::new();
                while let Some(reference) = seq.next_element()? {
                    references.push(reference);
                }
                Ok(RawInput::List(references))
            }
        }
        deserializer.deserialize_any(InputVisitor)
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStudy {
    /// The study's name (defaults to the file stem).
    pub study: Option<String>,
    #[serde(default)]
    pub description: String,
    /// Stages whose outputs are wanted; all stages when absent.
    pub targets: Option<Vec<Spanned<String>>>,
    pub stages: OrderedMap<RawStage>,
    /// Defaults for the Slurm executor's jobs.
    pub slurm: Option<RawSlurm>,
}

/// The `slurm:` section: what every job asks for unless the command line or a stage says
/// otherwise.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSlurm {
    pub partition: Option<Spanned<String>>,
    pub account: Option<Spanned<String>>,
    pub time: Option<Spanned<String>>,
    pub mem: Option<Spanned<String>>,
    pub cpus_per_task: Option<Spanned<u32>>,
    #[serde(default)]
    pub sbatch_args: Vec<Spanned<String>>,
}

/// A stage's `resources:`: where a cluster executor runs it and what its jobs ask for.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawResources {
    /// `driver` or `job`.
    pub placement: Option<Spanned<String>>,
    pub cpus_per_task: Option<Spanned<u32>>,
    pub mem: Option<Spanned<String>>,
    pub time: Option<Spanned<String>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStage {
    pub kind: Spanned<String>,
    #[serde(default)]
    pub params: OrderedMap<Spanned<RawValue>>,
    /// Input port → `stage.output`, or a list of them for a list port.
    #[serde(default)]
    pub inputs: OrderedMap<Spanned<RawInput>>,
    /// Swept parameter → values; several entries sweep their cartesian product.
    #[serde(default)]
    pub matrix: OrderedMap<Spanned<RawSweep>>,
    /// Placement and requests for a cluster executor.
    pub resources: Option<RawResources>,
}

pub fn located<T>(file: &str, spanned: Spanned<T>) -> Located<T> {
    Located {
        location: file_location(file, &spanned.referenced),
        value: spanned.value,
    }
}

pub fn file_location(file: &str, location: &serde_saphyr::Location) -> Location {
    Location::File {
        file: file.to_string(),
        line: location.line(),
        col: location.column(),
    }
}

/// Parses a study. `file` is the name used in error messages. Booleans are YAML 1.2's, `true`
/// and `false` only: `[x, y]` is two names, not a name and `true`, and `no` is not `false`.
pub fn parse(file: &str, text: &str) -> Result<RawStudy, SpecError> {
    let options = serde_saphyr::options! { with_snippet: false, strict_booleans: true };
    let mut path = String::new();
    let result = serde_saphyr::with_deserializer_from_str_with_options(text, options, |de| {
        serde_path_to_error::deserialize(de).map_err(|err| {
            path = err.path().to_string();
            err.into_inner()
        })
    });
    result.map_err(|err| {
        let location = err.location().map_or(
            Location::File {
                file: file.to_string(),
                line: 1,
                col: 1,
            },
            |location| file_location(file, &location),
        );
        SpecError {
            location,
            path: clean_path(&path),
            message: plain_message(&err.without_snippet().to_string()),
        }
    })
}

/// Parses one `--set` value as YAML: a scalar, or a list (`[35, 36]`).
pub fn parse_value(text: &str) -> Option<RawValue> {
    let options = serde_saphyr::options! { strict_booleans: true };
    serde_saphyr::from_str_with_options(text, options).ok()
}

/// The path as a user wrote it: without the `.value` that `Spanned` fields add, and without
/// the `?` of keys not yet read.
fn clean_path(path: &str) -> String {
    let mut segments: Vec<&str> = path
        .split('.')
        .filter(|segment| !segment.is_empty() && *segment != "?")
        .collect();
    let spanned_leaf = match segments.as_slice() {
        ["stages", _, "params" | "matrix" | "inputs", _, "value"]
        | ["stages", _, "kind", "value"] => true,
        [.., last] => last.starts_with("targets[") && last.ends_with("].value"),
        _ => false,
    };
    if spanned_leaf {
        let last = segments.pop().expect("matched a non-empty path");
        if let Some(target) = last.strip_suffix(".value") {
            segments.push(target);
        }
    }
    if segments.is_empty() {
        "(study)".into()
    } else {
        segments.join(".")
    }
}

/// One line, location removed (we print it first), serde's wording made plain.
fn plain_message(message: &str) -> String {
    let first = message.lines().next().unwrap_or(message).trim();
    let first = match first.rfind(" at line ") {
        Some(idx) => &first[..idx],
        None => first,
    };
    let first = first.trim_end_matches('.').trim_end_matches(':');
    if let Some(rest) = first.strip_prefix("duplicate mapping key: ") {
        let key = rest
            .split(", set DuplicateKeyPolicy")
            .next()
            .unwrap_or(rest);
        return format!("duplicate key `{key}`");
    }
    if first.contains("untagged enum RawSweep") {
        return "expected a list of values or {start, stop, num}".into();
    }
    if first.contains("untagged enum RawValue") {
        return "expected a number, string, bool or list".into();
    }
    first
        .replace("expected mapping start", "expected a mapping")
        .replace("expected sequence start", "expected a list")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error(text: &str) -> String {
        parse("s.yaml", text).unwrap_err().to_string()
    }

    #[test]
    fn keeps_stage_order_and_locations() {
        let text = "stages:\n  b:\n    kind: x\n  a:\n    kind: y\n    params: { mu: 0.38 }\n";
        let study = parse("s.yaml", text).unwrap();
        let names: Vec<&str> = study
            .stages
            .0
            .iter()
            .map(|(name, _)| name.as_str())
            .collect();
        assert_eq!(names, ["b", "a"]);
        let (_, a) = &study.stages.0[1];
        assert_eq!(a.kind.referenced.line(), 5);
        let (_, mu) = &a.params.0[0];
        assert_eq!(mu.value, RawValue::Float(0.38));
        assert_eq!((mu.referenced.line(), mu.referenced.column()), (6, 19));
    }

    #[test]
    fn unknown_key_names_location_and_path() {
        let message = error("stages:\n  a:\n    kind: x\n    parms: {}\n");
        assert!(
            message.starts_with("s.yaml:4:5: stages.a.parms: unknown field `parms`"),
            "{message}"
        );
    }

    #[test]
    fn syntax_and_duplicates_are_located() {
        let message = error("stages:\n  a:\n    kind: [x\n");
        assert!(message.starts_with("s.yaml:"), "{message}");
        let message = error("stages:\n  a:\n    kind: x\n  a:\n    kind: y\n");
        assert!(message.starts_with("s.yaml:4:"), "{message}");
        assert!(message.contains("duplicate"), "{message}");
    }

    #[test]
    fn values_parse_like_yaml() {
        assert_eq!(parse_value("0.38"), Some(RawValue::Float(0.38)));
        assert_eq!(parse_value("12"), Some(RawValue::Int(12)));
        assert_eq!(parse_value("true"), Some(RawValue::Bool(true)));
        assert_eq!(parse_value("y"), Some(RawValue::Str("y".into())));
        assert_eq!(parse_value("no"), Some(RawValue::Str("no".into())));
        assert_eq!(parse_value("40 mm"), Some(RawValue::Str("40 mm".into())));
        assert_eq!(
            parse_value("[35, hub]"),
            Some(RawValue::List(vec![
                RawValue::Int(35),
                RawValue::Str("hub".into())
            ]))
        );
    }
}
