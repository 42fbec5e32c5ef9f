//! Shared helpers for tests that drive the `squeal` binary on real study files.

#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use arrow_array::RecordBatch;
use arrow_array::{Array, BooleanArray, Float64Array, StringArray};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// `pareto` over a swept error with one reference time: inputs of both arities, declared in
/// an order other than their names'.
pub const PARETO_STUDY: &str = "\
stages:
  reference:
    kind: test.constant
    params: { value: 1.0 }
  error:
    kind: test.constant
    matrix:
      value: [0.5, 0.25]
  front:
    kind: pareto
    inputs:
      errors: error.table
      run_times: error.compute_s
      reference_time: reference.compute_s
    params: { errors: x }
";

/// A stage that fails (with the message of a solver that did not converge), one that depends
/// on it, and an independent branch.
pub const FAILING_STUDY: &str = "\
stages:
  source:
    kind: test.constant
  broken:
    kind: test.fail
    inputs: { table: source.table }
    params: { message: solver did not converge after 50 iterations (residual 3.2e-2) }
  after_broken:
    kind: test.affine
    inputs: { table: broken.table }
  healthy:
    kind: test.affine
    inputs: { table: source.table }
";

/// A scratch folder holding a study, its `.squeal/` state and its outputs.
pub struct Workspace {
    pub dir: tempfile::TempDir,
}

impl Workspace {
    pub fn new() -> Workspace {
        Workspace {
            dir: tempfile::tempdir().expect("temporary folder"),
        }
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.path().join(name);
        std::fs::write(&path, text).expect("write study");
        path
    }

    /// `squeal ARGS` run inside the workspace, with the engine's test stage kinds enabled.
    pub fn squeal(&self, args: &[&str]) -> Output {
        self.command(args).output().expect("run squeal")
    }

    pub fn command(&self, args: &[&str]) -> Command {
        let mut command = Command::new(env!("CARGO_BIN_EXE_squeal"));
        command
            .args(args)
            .current_dir(self.path())
            .env("SQUEAL_TEST_KINDS", "1")
            .env_remove("SQUEAL_CACHE");
        command
    }

    /// Runs and asserts success, returning stderr.
    pub fn run_ok(&self, args: &[&str]) -> String {
        let output = self.squeal(args);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "squeal {args:?} failed:\n{stderr}");
        stderr
    }

    pub fn cache_dir(&self) -> PathBuf {
        self.path().join(".squeal/cache")
    }
}

/// The path of a study of the repository's `pipelines/`.
pub fn pipeline(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("pipelines")
        .join(name)
        .display()
        .to_string()
}

pub fn read_parquet(path: &Path) -> RecordBatch {
    let file = std::fs::File::open(path).unwrap_or_else(|err| panic!("{}: {err}", path.display()));
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .expect("parquet")
        .build()
        .expect("reader");
    let batches: Vec<RecordBatch> = reader.map(|batch| batch.expect("batch")).collect();
    arrow_select::concat::concat_batches(&batches[0].schema(), &batches).expect("same schema")
}

/// The column `name` of `batch`, as the array type `A`.
fn column<'a, A: Array + 'static>(batch: &'a RecordBatch, name: &str) -> &'a A {
    batch
        .column_by_name(name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .as_any()
        .downcast_ref::<A>()
        .unwrap_or_else(|| panic!("column {name} is not a {}", std::any::type_name::<A>()))
}

pub fn strings(batch: &RecordBatch, name: &str) -> Vec<String> {
    let array = column::<StringArray>(batch, name);
    (0..array.len())
        .map(|idx| array.value(idx).to_string())
        .collect()
}

pub fn floats(batch: &RecordBatch, name: &str) -> Vec<f64> {
    column::<Float64Array>(batch, name).values().to_vec()
}

pub fn booleans(batch: &RecordBatch, name: &str) -> Vec<bool> {
    let array = column::<BooleanArray>(batch, name);
    (0..array.len()).map(|idx| array.value(idx)).collect()
}

/// `manifest.parquet` as stage instance → status.
pub fn statuses(out: &Path) -> BTreeMap<String, String> {
    let manifest = read_parquet(&out.join("manifest.parquet"));
    strings(&manifest, "stage")
        .into_iter()
        .zip(strings(&manifest, "status"))
        .collect()
}

/// The instances a run executed (status `ran`), sorted.
pub fn ran(out: &Path) -> Vec<String> {
    statuses(out)
        .into_iter()
        .filter(|(_, status)| status == "ran")
        .map(|(stage, _)| stage)
        .collect()
}

/// Every file under `dir` but the manifest (which holds times), relative, with its bytes,
/// sorted: what two runs must write identically.
pub fn outputs_but_the_manifest(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.file_name() != Some("manifest.parquet".as_ref()) {
                files.push((
                    path.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&path).unwrap(),
                ));
            }
        }
    }
    files.sort();
    files
}
