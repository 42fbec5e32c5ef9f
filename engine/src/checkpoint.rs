//! Checkpoints of long stages in the cache, so that a killed run resumes.
//!
//! The latest checkpoint of a stage instance is an object of the cache named by an action
//! record under a key derived from the instance's cache key (same kind, version, parameters and
//! input bytes): written like every entry (object, then record, each atomically), verified on
//! read (a corrupt one is a miss), and removed once the stage has finished, so that `gc`
//! collects its bytes.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use squeal_cache::{ActionRecord, Cache, Digest};
use squeal_contract::Checkpoints;

/// The output name of a checkpoint's object in its record.
const STATE: &str = "checkpoint";
/// Default time between checkpoints; `SQUEAL_CHECKPOINT_SECONDS` overrides it.
const DEFAULT_INTERVAL: Duration = Duration::from_secs(30);

/// The key of the checkpoint record of the instance whose cache key is `key`.
pub fn checkpoint_key(key: &Digest) -> Digest {
    let mut bytes = b"squeal checkpoint of ".to_vec();
    bytes.extend_from_slice(key.hex().as_bytes());
    Digest::of(&bytes)
}

/// Checkpoints of one stage instance.
pub struct CacheCheckpoints<'a> {
    cache: &'a Cache,
    key: Digest,
    stage: String,
    kind: String,
    interval: Duration,
    last: Mutex<Instant>,
}

impl<'a> CacheCheckpoints<'a> {
    pub fn new(cache: &'a Cache, instance_key: &Digest, stage: &str, kind: &str) -> Self {
        let interval = std::env::var("SQUEAL_CHECKPOINT_SECONDS")
            .ok()
            .and_then(|value| value.parse::<f64>().ok())
            .filter(|seconds| seconds.is_finite() && *seconds >= 0.0)
            .map_or(DEFAULT_INTERVAL, Duration::from_secs_f64);
        CacheCheckpoints {
            cache,
            key: checkpoint_key(instance_key),
            stage: stage.to_string(),
            kind: kind.to_string(),
            interval,
            last: Mutex::new(Instant::now()),
        }
    }

    /// Forgets the checkpoint (the stage finished, or failed for good).
    pub fn discard(&self) {
        if let Err(err) = self.cache.remove_action(&self.key) {
            tracing::warn!(stage = %self.stage, "could not discard its checkpoint: {err}");
        }
    }
}

impl Checkpoints for CacheCheckpoints<'_> {
    fn load(&self) -> Option<Vec<u8>> {
        let record = match self.cache.get_action(&self.key) {
            Ok(record) => record?,
            Err(err) => {
                tracing::warn!(stage = %self.stage, "checkpoint unusable: {err}");
                return None;
            }
        };
        let digest = record.outputs.get(STATE)?;
        match self.cache.get_object(digest) {
            Ok(bytes) => {
                tracing::info!(stage = %self.stage, "resuming from its checkpoint");
                Some(bytes)
            }
            Err(err) => {
                tracing::warn!(stage = %self.stage, "checkpoint unusable: {err}");
                None
            }
        }
    }

    fn due(&self) -> bool {
        self.last.lock().expect("checkpoint clock").elapsed() >= self.interval
    }

    fn save(&self, state: &[u8]) {
        let saved = self.cache.put_object(state).and_then(|digest| {
            let record = ActionRecord {
                stage: self.stage.clone(),
                kind: self.kind.clone(),
                outputs: BTreeMap::from([(STATE.to_string(), digest)]),
                wall_s: 0.0,
            };
            self.cache.put_action(&self.key, &record)
        });
        match saved {
            Ok(()) => *self.last.lock().expect("checkpoint clock") = Instant::now(),
            Err(err) => tracing::warn!(stage = %self.stage, "checkpoint not kept: {err}"),
        }
    }
}
