//! The run record: what each stage instance of a study last ran with, kept beside the study
//! (`.squeal/record/<study>.json`), separate from the spec, so the planner can say *why* a
//! stage runs ("parameter `mu` changed 0.3 → 0.38").

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use squeal_cache::Digest;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InstanceRecord {
    pub kind: String,
    pub version: u32,
    pub key: Digest,
    /// Parameter values as displayed.
    pub params: BTreeMap<String, String>,
    /// Input port → (`upstream.output`, digest) per artifact.
    pub inputs: BTreeMap<String, Vec<(String, Digest)>>,
    pub outputs: BTreeMap<String, Digest>,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct RunRecord {
    pub instances: BTreeMap<String, InstanceRecord>,
}

impl RunRecord {
    pub fn path_for(study: &Path, record_dir: &Path) -> PathBuf {
        let stem = study
            .file_stem()
            .map_or("study".into(), |stem| stem.to_string_lossy().into_owned());
        record_dir.join(format!("{stem}.json"))
    }

    /// A missing or unreadable record is an empty one: it only explains, never decides.
    pub fn load(path: &Path) -> RunRecord {
        std::fs::read(path)
            .ok()
            .and_then(|bytes| serde_json::from_slice(&bytes).ok())
            .unwrap_or_default()
    }

    /// Written atomically, like everything the engine leaves behind.
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let json = serde_json::to_vec_pretty(self).expect("records serialise");
        crate::output::write_if_changed(path, &json)
    }
}
