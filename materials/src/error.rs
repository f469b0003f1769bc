//! Errors of the materials crate: one type, whose message names the JSON path of the
//! offending value, what was found and what was expected. The caller (scene loading, the
//! CLI) prefixes the file name.

use thiserror::Error;

/// A parameter that could not be accepted. `path` is the JSON path of the value
/// (for example `materials.gold.roughness`).
#[derive(Debug, Clone, Error, PartialEq)]
#[error("{path}: {message}")]
pub struct ParamError {
    pub path: String,
    pub message: String,
}

impl ParamError {
    pub fn new(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            message: message.into(),
        }
    }
}
