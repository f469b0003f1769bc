//! The renderer's error type. Every message names the file, the JSON path or field of the
//! offending value, what was found and what was expected, on one line.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum Error {
    /// A value in a scene description that cannot be accepted.
    #[error("{file}: {path}: {message}")]
    Scene {
        file: String,
        path: String,
        message: String,
    },
    /// A file that cannot be read, parsed or written.
    #[error("{file}: {message}")]
    File { file: String, message: String },
    /// Anything else, already phrased for the user.
    #[error("{0}")]
    Other(String),
    /// Outputs were written but are biased: more than
    /// [`crate::render::MAX_DROPPED_SHARE`] of the samples were non-finite and dropped.
    /// `lobe` exits with status 3 (docs/robustness.md).
    #[error("{0}")]
    Biased(String),
}

impl Error {
    pub fn scene(file: impl Into<String>, path: impl Into<String>, msg: impl Into<String>) -> Self {
        Error::Scene {
            file: file.into(),
            path: path.into(),
            message: msg.into(),
        }
    }
    pub fn file(file: impl std::fmt::Display, msg: impl Into<String>) -> Self {
        Error::File {
            file: file.to_string(),
            message: msg.into(),
        }
    }
}

impl From<lobe_materials::FileError> for Error {
    fn from(e: lobe_materials::FileError) -> Self {
        Error::File {
            file: e.file,
            message: e.message,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;
