//! Cache keys: blake3 of a canonical encoding of what determines a stage's outputs — the
//! artifacts' encoding version, kind, implementation version, every declared parameter, the
//! digests of its inputs, and the numeric platform (architecture and vector instruction set:
//! results are bit-identical on any
//! thread count, but not across instruction sets, so machines that share a cache and differ
//! there keep their own entries).
//!
//! Inputs enter by the digest of the upstream *output* bytes, not the upstream key, so a rerun
//! that reproduces identical bytes leaves every dependent's key unchanged (early cutoff).

use std::collections::BTreeMap;

use squeal_cache::Digest;
use squeal_contract::{Coords, Value};

/// The resolved inputs of one instance: port → (coordinates, digest) per upstream artifact.
pub type InputDigests = BTreeMap<String, Vec<(Coords, Digest)>>;

/// Length-prefixed, type-tagged fields: no two different inputs encode to the same bytes.
struct Canonical(blake3::Hasher);

impl Canonical {
    fn bytes(&mut self, bytes: &[u8]) {
        self.0.update(&(bytes.len() as u64).to_le_bytes());
        self.0.update(bytes);
    }

    fn str(&mut self, text: &str) {
        self.bytes(text.as_bytes());
    }

    fn count(&mut self, count: usize) {
        self.0.update(&(count as u64).to_le_bytes());
    }

    fn value(&mut self, value: &Value) {
        match value {
            Value::Bool(value) => self.0.update(&[1, *value as u8]),
            Value::Int(value) => self.0.update(&[2]).update(&value.to_le_bytes()),
            // -0.0 and 0.0 are the same parameter value.
            Value::Float(value) => self
                .0
                .update(&[3])
                .update(&(value + 0.0).to_bits().to_le_bytes()),
            Value::Str(text) => {
                self.0.update(&[4]);
                self.str(text);
                &mut self.0
            }
        };
    }
}

/// The key of a stage instance on this machine.
pub fn cache_key(
    kind: &str,
    version: u32,
    params: &BTreeMap<String, Value>,
    inputs: &InputDigests,
) -> Digest {
    cache_key_on(
        squeal_linalg::numeric_platform(),
        kind,
        version,
        params,
        inputs,
    )
}

/// The key of a stage instance on the numeric platform `platform`.
pub fn cache_key_on(
    platform: &str,
    kind: &str,
    version: u32,
    params: &BTreeMap<String, Value>,
    inputs: &InputDigests,
) -> Digest {
    let mut canonical = Canonical(blake3::Hasher::new());
    canonical.str("squeal cache key v2");
    canonical
        .0
        .update(&squeal_contract::artifact::ENCODING_VERSION.to_le_bytes());
    canonical.str(platform);
    canonical.str(kind);
    canonical.0.update(&version.to_le_bytes());
    canonical.count(params.len());
    for (name, value) in params {
        canonical.str(name);
        canonical.value(value);
    }
    canonical.count(inputs.len());
    for (port, artifacts) in inputs {
        canonical.str(port);
        canonical.count(artifacts.len());
        for (coords, digest) in artifacts {
            canonical.count(coords.len());
            for (label, value) in coords {
                canonical.str(label);
                canonical.value(value);
            }
            canonical.0.update(&digest.0);
        }
    }
    canonical.0.finalize().into()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(entries: &[(&str, Value)]) -> BTreeMap<String, Value> {
        entries
            .iter()
            .map(|(name, value)| (name.to_string(), value.clone()))
            .collect()
    }

    #[test]
    fn keys_change_with_every_ingredient_and_only_with_them() {
        let base_params = params(&[("mu", Value::Float(0.38)), ("n", Value::Int(3))]);
        let digest = Digest::of(b"model");
        let inputs = InputDigests::from([("model".into(), vec![(Vec::new(), digest)])]);
        let base = cache_key("stability", 1, &base_params, &inputs);
        assert_eq!(
            base,
            cache_key("stability", 1, &base_params.clone(), &inputs.clone())
        );
        assert_ne!(base, cache_key("modes", 1, &base_params, &inputs));
        let platform = squeal_linalg::numeric_platform();
        assert_eq!(
            base,
            cache_key_on(platform, "stability", 1, &base_params, &inputs)
        );
        let elsewhere = if platform == "x86_64+avx2" {
            "x86_64+avx512"
        } else {
            "x86_64+avx2"
        };
        assert_ne!(
            base,
            cache_key_on(elsewhere, "stability", 1, &base_params, &inputs),
            "machines whose results may differ keep their own entries"
        );
        assert_ne!(base, cache_key("stability", 2, &base_params, &inputs));
        let other_mu = params(&[("mu", Value::Float(0.3)), ("n", Value::Int(3))]);
        assert_ne!(base, cache_key("stability", 1, &other_mu, &inputs));
        let float_n = params(&[("mu", Value::Float(0.38)), ("n", Value::Float(3.0))]);
        assert_ne!(
            base,
            cache_key("stability", 1, &float_n, &inputs),
            "types are tagged"
        );
        let other_input =
            InputDigests::from([("model".into(), vec![(Vec::new(), Digest::of(b"x"))])]);
        assert_ne!(base, cache_key("stability", 1, &base_params, &other_input));
        let zero = params(&[("x", Value::Float(0.0))]);
        let negative_zero = params(&[("x", Value::Float(-0.0))]);
        assert_eq!(
            cache_key("k", 1, &zero, &inputs),
            cache_key("k", 1, &negative_zero, &inputs)
        );
    }
}
