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

/// A file that cannot be read, parsed or written: the file and what went wrong, including
/// what was expected and what was found.
#[derive(Debug, Clone, Error, PartialEq)]
#[error("{file}: {message}")]
pub struct FileError {
    pub file: String,
    pub message: String,
}

impl FileError {
    pub fn new(file: impl std::fmt::Display, message: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            message: message.into(),
        }
    }
}
