//! Atomic file writes, shared by every writer of lobe (tables, images, reports): the data
//! goes to a temporary file in the destination folder, is flushed and synced, then renamed
//! over the destination, so a failed or interrupted write never leaves a truncated file
//! nor clobbers an existing good one.

use crate::error::FileError;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes `path` atomically with `fill`; on any error nothing at `path` changes.
pub fn atomic_write(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let shown = path.display().to_string();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(FileError::new(
            &shown,
            format!("output folder {} does not exist", dir.display()),
        ));
    }
    if path.is_dir() {
        return Err(FileError::new(
            &shown,
            "is a directory; expected a file path to write",
        ));
    }
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| {
            FileError::new(
                &shown,
                format!("cannot create a file in {}: {e}", dir.display()),
            )
        })?;
    {
        let file = tmp.as_file();
        let mut w = BufWriter::new(file);
        fill(&mut w)
            .and_then(|_| w.flush())
            .map_err(|e| FileError::new(&shown, format!("write failed: {e}")))?;
        drop(w);
        file.sync_all()
            .map_err(|e| FileError::new(&shown, format!("write failed: {e}")))?;
        // Temporary files are created private (0600); a finished output is an ordinary
        // file (0644).
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = file.set_permissions(std::fs::Permissions::from_mode(0o644));
        }
    }
    tmp.persist(path).map_err(|e| {
        FileError::new(
            &shown,
            format!("cannot move the finished file into place: {}", e.error),
        )
    })?;
    Ok(())
}

/// Largest image (in pixels) lobe reads: 2^27 (e.g. 16384 x 8192), about 1.6 GB as RGB f32.
pub const MAX_IMAGE_PIXELS: usize = 1 << 27;

/// Checks an OpenEXR file's declared layer sizes before its pixels are allocated (a header
/// can declare any size; found by fuzzing).
pub fn check_exr_size(path: &Path) -> Result<(), String> {
    let meta = crate::guard::third_party("OpenEXR", || {
        exr::meta::MetaData::read_from_file(path, false)
    })?
    .map_err(|e| format!("cannot read OpenEXR header: {e}"))?;
    for h in &meta.headers {
        let (w, hh) = (h.layer_size.width(), h.layer_size.height());
        if w.checked_mul(hh).is_none_or(|n| n > MAX_IMAGE_PIXELS) {
            return Err(format!(
                "declares {w} x {hh} pixels; expected at most {MAX_IMAGE_PIXELS} pixels"
            ));
        }
    }
    Ok(())
}
