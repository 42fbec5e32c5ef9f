//! Reading a case's `reference_values/<case>.json`: `{ "case", "source", "values" }`, the
//! values in the case's own typed struct (unknown or missing fields are errors).

use std::path::PathBuf;

use serde::Deserialize;
use serde::de::DeserializeOwned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File<T> {
    // What is verified, in a sentence, and where the reference values come from: for the
    // reader of the file, required so that every file says it.
    #[allow(dead_code)]
    case: String,
    #[allow(dead_code)]
    source: String,
    values: T,
}

/// The values of `reference_values/<case>.json`.
pub fn load<T: DeserializeOwned>(case: &str) -> T {
    let path: PathBuf = [
        env!("CARGO_MANIFEST_DIR"),
        "tests",
        "verification",
        "reference_values",
        &format!("{case}.json"),
    ]
    .iter()
    .collect();
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|err| panic!("cannot read {}: {err}", path.display()));
    serde_json::from_str::<File<T>>(&text)
        .unwrap_or_else(|err| panic!("{}: {err}", path.display()))
        .values
}
