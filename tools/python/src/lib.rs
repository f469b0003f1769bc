//! `lobe._lobe`: lobe from Python (pyo3), the compiled half of the `lobe` package
//! (`tools/python/python/lobe` adds the typed wrappers, docstrings and `lobe.mitsuba`).
//!
//! It is a thin boundary over the libraries, as the CLI is: materials are built by
//! lobe-materials' registry from the same JSON as scene files, fit reports and Ngan fits
//! ([`material`]); measured files are read and written by lobe-materials' readers
//! ([`data`]); fits go through lobe-analysis ([`fit`]); renders and image metrics through
//! lobe-renderer ([`images`]); the study through lobe-analysis, whole or step by step
//! ([`study`]). Every entry point runs under [`guarded`]: lobe's errors
//! become `ValueError` or `FileNotFoundError` carrying the CLI's one-line message, and a
//! panic becomes a `RuntimeError` instead of reaching Python. Array work releases the GIL
//! and runs on rayon's pool in fixed chunks, so results do not depend on the thread count.
//! Renders and fits run on a thread of their own while the calling thread shows their
//! progress and watches for Ctrl-C ([`interrupt`]).

mod data;
mod fit;

/// Rust allocations of the extension go to mimalloc rather than the host's malloc, whose
/// tuning is the host's: Dask's workers set `MALLOC_TRIM_THRESHOLD_=65536`, with which
/// glibc returned and refaulted a fit's buffers on every objective evaluation (twice the
/// time, most of it in the kernel; docs/distributed.md).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

mod images;
mod interrupt;
mod material;
mod study;

use pyo3::exceptions::{PyFileNotFoundError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

/// A lobe error as the Python exception the package documents: `FileNotFoundError` when
/// the file it is about does not exist (a file error's file; for an error in a
/// description, the file its message starts with, as in `material.file: PATH: cannot
/// read: ...`), `ValueError` otherwise; the message is the CLI's.
pub(crate) fn to_py(e: lobe_renderer::Error) -> PyErr {
    // Names in angle brackets (`<scene dict>`) are descriptions given as values, not files.
    let missing = |f: &str| !f.is_empty() && !f.starts_with('<') && !Path::new(f).exists();
    let not_found = match &e {
        lobe_renderer::Error::File { file, .. } => missing(file),
        lobe_renderer::Error::Scene { message, .. } => message
            .split_once(": ")
            .is_some_and(|(f, _)| Path::new(f).is_absolute() && missing(f)),
        lobe_renderer::Error::Other(_) | lobe_renderer::Error::Biased(_) => false,
    };
    if not_found {
        PyFileNotFoundError::new_err(e.to_string())
    } else {
        PyValueError::new_err(e.to_string())
    }
}

/// `From` for the materials crate's file errors, through the renderer's error type.
pub(crate) fn file_err(e: lobe_materials::FileError) -> PyErr {
    to_py(e.into())
}

/// Runs `work` on a pool of `threads` threads (a Dask worker's share of the cores), or on
/// rayon's global pool (all cores) for None.
pub(crate) fn on_threads<T: Send>(
    threads: Option<usize>,
    work: impl FnOnce() -> Result<T, lobe_renderer::Error> + Send,
) -> Result<T, lobe_renderer::Error> {
    match threads {
        None => work(),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.clamp(1, lobe_renderer::limits::MAX_THREADS))
            .build()
            .map_err(|e| lobe_renderer::Error::Other(format!("cannot start {n} threads: {e}")))?
            .install(work),
    }
}

/// Runs `f`, turning a panic into a `RuntimeError` (a bug in lobe, said as such).
pub(crate) fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        let what = p
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| p.downcast_ref::<&str>().copied())
            .unwrap_or("unknown panic");
        Err(PyRuntimeError::new_err(format!(
            "internal error in lobe (a bug; please report it): {what}"
        )))
    })
}

#[pymodule]
fn _lobe(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    material::register(m)?;
    data::register(m)?;
    fit::register(m)?;
    images::register(m)?;
    study::register(m)?;
    Ok(())
}
