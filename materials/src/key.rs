//! Content keys: what names a result by what made it, so that a rerun recomputes exactly
//! what is missing or changed and outputs made on different machines can be merged and
//! checked. A key is the BLAKE3 hash (hex) of the bytes of a step's inputs (data files,
//! environment maps) and of the settings that shape it, with every field length-prefixed
//! and named so that no two different inputs hash alike, and with lobe's version mixed in
//! (a new version recomputes).

use crate::error::FileError;
use crate::io::{MAX_DATA_BYTES, open_regular};
use serde_json::Value;
use std::path::Path;

/// Builds a key from named fields, in order.
#[derive(Clone)]
pub struct KeyBuilder(blake3::Hasher);

impl KeyBuilder {
    /// A key of results of `kind` (a fit, a render, a study step).
    pub fn new(kind: &str) -> Self {
        let mut h = blake3::Hasher::new();
        h.update(b"lobe-content-key/1\0");
        h.update(env!("CARGO_PKG_VERSION").as_bytes());
        let b = Self(h);
        b.text("kind", kind)
    }

    fn field(mut self, name: &str, bytes: &[u8]) -> Self {
        for part in [name.as_bytes(), bytes] {
            self.0.update(&(part.len() as u64).to_le_bytes());
            self.0.update(part);
        }
        self
    }

    /// A text field.
    pub fn text(self, name: &str, v: &str) -> Self {
        self.field(name, v.as_bytes())
    }

    /// A number, by its exact bits.
    pub fn number(self, name: &str, v: f64) -> Self {
        self.field(name, &v.to_bits().to_le_bytes())
    }

    /// A JSON value, in serde_json's canonical form (object keys sorted).
    pub fn json(self, name: &str, v: &Value) -> Self {
        self.text(name, &v.to_string())
    }

    /// The hex digest.
    pub fn finish(&self) -> String {
        self.0.finalize().to_hex().to_string()
    }
}

/// The hex BLAKE3 digest of a file's bytes, read in blocks (a regular file of at most
/// [`MAX_DATA_BYTES`]; `what` completes "expected ...").
pub fn file_digest(path: &Path, what: &str) -> Result<String, FileError> {
    let (file, _) = open_regular(path, MAX_DATA_BYTES, what)?;
    let mut h = blake3::Hasher::new();
    h.update_reader(std::io::Read::take(file, MAX_DATA_BYTES))
        .map_err(|e| FileError::new(path.display(), format!("cannot read: {e}")))?;
    Ok(h.finalize().to_hex().to_string())
}

/// The digest of an input given as text: a file's digest, or for `builtin:NAME` the name
/// itself (built-in inputs change only with lobe's version, which every key holds).
pub fn input_digest(spec: &str, what: &str) -> Result<String, FileError> {
    match spec.starts_with("builtin:") {
        true => Ok(spec.to_string()),
        false => file_digest(Path::new(spec), what),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_separated_and_ordered() {
        let a = KeyBuilder::new("k").text("a", "bc").finish();
        let b = KeyBuilder::new("k").text("ab", "c").finish();
        let c = KeyBuilder::new("k")
            .text("a", "bc")
            .number("x", 1.0)
            .finish();
        let d = KeyBuilder::new("j").text("a", "bc").finish();
        assert_ne!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
        assert_eq!(a, KeyBuilder::new("k").text("a", "bc").finish());
        assert_eq!(a.len(), 64);
    }

    #[test]
    fn file_digest_follows_content() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.bin");
        std::fs::write(&p, b"one").unwrap();
        let one = file_digest(&p, "data").unwrap();
        std::fs::write(&p, b"two").unwrap();
        assert_ne!(one, file_digest(&p, "data").unwrap());
        let e = file_digest(dir.path(), "data").unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        assert_eq!(
            input_digest("builtin:studio", "map").unwrap(),
            "builtin:studio"
        );
    }
}
