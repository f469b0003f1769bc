//! Atomic file writes, shared by every writer of lobe (tables, images, reports): the data
//! goes to a temporary file in the destination folder, is flushed and synced, then renamed
//! over the destination, so a failed or interrupted write never leaves a truncated file
//! nor clobbers an existing good one. Files that belong together (a render's outputs) are
//! staged and committed as one set ([`OutputSet`]), and an interrupt never splits a set.

use crate::error::FileError;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes `path` atomically with `fill`; on any error nothing at `path` changes.
pub fn atomic_write(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let shown = path.display().to_string();
    let dir = output_folder(path)?;
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
        fill_and_sync(file, &shown, fill)?;
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
    let (file, _) =
        open_regular(path, MAX_DATA_BYTES, "an OpenEXR image").map_err(|e| e.message)?;
    let meta = crate::guard::third_party("OpenEXR", || {
        exr::meta::MetaData::read_from_buffered(std::io::BufReader::new(file), false)
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

/// Files written together or not at all: a render's EXR, variance, PNG and statistics.
///
/// Each file is staged first ([`OutputSet::stage`]): written in full to a temporary file
/// of its destination folder and synced. On Linux that file is unnamed (`O_TMPFILE`), so a
/// process killed while staging (`kill -9`, a full disk) leaves nothing behind. Nothing at
/// a destination changes until [`OutputSet::commit`], which names every staged file and
/// then renames each over its destination: the only window in which a set can be seen
/// half replaced is those renames (microseconds), and an interrupt that arrives then
/// ([`interrupt_outputs`]) waits for them. A set dropped without a commit (an error, an
/// interrupt) deletes what it staged.
#[derive(Default)]
pub struct OutputSet {
    staged: Vec<Staged>,
}

struct Staged {
    dest: std::path::PathBuf,
    dir: std::path::PathBuf,
    file: StagedFile,
}

enum StagedFile {
    /// An `O_TMPFILE` file, named at the commit.
    #[cfg(target_os = "linux")]
    Unnamed(std::fs::File),
    Named(tempfile::NamedTempFile),
}

impl OutputSet {
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `fill` into a staged file for `path` (flushed and synced); `path` itself is
    /// untouched until [`OutputSet::commit`].
    pub fn stage(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> std::io::Result<()>,
    ) -> Result<(), FileError> {
        let shown = path.display().to_string();
        let dir = output_folder(path)?;
        let file = stage_file(&dir).map_err(|e| {
            FileError::new(
                &shown,
                format!("cannot create a file in {}: {e}", dir.display()),
            )
        })?;
        let f = match &file {
            #[cfg(target_os = "linux")]
            StagedFile::Unnamed(f) => f,
            StagedFile::Named(t) => t.as_file(),
        };
        fill_and_sync(f, &shown, fill)?;
        self.staged.push(Staged {
            dest: path.to_path_buf(),
            dir,
            file,
        });
        Ok(())
    }

    /// Moves every staged file into place. Refused, with nothing written, once the process
    /// was interrupted ([`interrupt_outputs`]).
    pub fn commit(self) -> Result<(), FileError> {
        let Some(first) = self.staged.first() else {
            return Ok(());
        };
        let _commit = Commit::begin().ok_or_else(|| {
            FileError::new(
                first.dest.display().to_string(),
                "interrupted before the outputs were moved into place: nothing is written",
            )
        })?;
        // Every file gets a temporary name first; a failure here leaves every
        // destination as it was (the named files are deleted when dropped).
        let mut named = Vec::with_capacity(self.staged.len());
        for s in self.staged {
            let shown = s.dest.display().to_string();
            let tmp = name_staged(s.file, &s.dir, &s.dest).map_err(|e| {
                FileError::new(&shown, format!("cannot name the finished file: {e}"))
            })?;
            named.push((tmp, s.dest));
        }
        for (k, (tmp, dest)) in named.into_iter().enumerate() {
            tmp.persist(&dest).map_err(|e| {
                FileError::new(
                    dest.display().to_string(),
                    format!(
                        "cannot move the finished file into place ({k} of the set's files were): {}",
                        e.error
                    ),
                )
            })?;
        }
        Ok(())
    }
}

/// Writes `fill` into `file` through a buffer, flushes it and syncs it to disk; `shown`
/// names the destination in the error.
fn fill_and_sync(
    file: &std::fs::File,
    shown: &str,
    fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let mut w = BufWriter::new(file);
    fill(&mut w)
        .and_then(|_| w.flush())
        .map_err(|e| FileError::new(shown, format!("write failed: {e}")))?;
    drop(w);
    file.sync_all()
        .map_err(|e| FileError::new(shown, format!("write failed: {e}")))
}

/// The folder `path` is written in: it must exist, and `path` must not be a folder.
fn output_folder(path: &Path) -> Result<std::path::PathBuf, FileError> {
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
    Ok(dir)
}

/// A file to stage into: unnamed where the file system allows it (Linux `O_TMPFILE`),
/// else a named temporary file (deleted when dropped).
fn stage_file(dir: &Path) -> std::io::Result<StagedFile> {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::OpenOptionsExt;
        let unnamed = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .mode(0o644)
            .custom_flags(libc::O_TMPFILE)
            .open(dir);
        if let Ok(f) = unnamed {
            return Ok(StagedFile::Unnamed(f));
        }
    }
    let tmp = tempfile::Builder::new()
        .prefix(".lobe-output.")
        .suffix(".tmp")
        .tempfile_in(dir)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    Ok(StagedFile::Named(tmp))
}

/// Gives a staged file a hidden temporary name beside `dest` (deleted if dropped).
fn name_staged(
    file: StagedFile,
    dir: &Path,
    dest: &Path,
) -> std::io::Result<tempfile::NamedTempFile<()>> {
    let name = dest.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    match file {
        #[cfg(target_os = "linux")]
        StagedFile::Unnamed(f) => builder.make_in(dir, |p| link_unnamed(&f, p)),
        StagedFile::Named(t) => {
            let (f, path) = t.into_parts();
            drop(f);
            Ok(tempfile::NamedTempFile::from_parts((), path))
        }
    }
}

/// Links an `O_TMPFILE` file at `path` (through /proc/self/fd, as open(2) documents);
/// where /proc is not mounted, copies it to `path` instead.
#[cfg(target_os = "linux")]
fn link_unnamed(f: &std::fs::File, path: &Path) -> std::io::Result<()> {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::io::AsRawFd;
    let src = CString::new(format!("/proc/self/fd/{}", f.as_raw_fd()))?;
    let dst = CString::new(path.as_os_str().as_bytes())?;
    // SAFETY: both arguments are NUL-terminated strings that outlive the call.
    let r = unsafe {
        libc::linkat(
            libc::AT_FDCWD,
            src.as_ptr(),
            libc::AT_FDCWD,
            dst.as_ptr(),
            libc::AT_SYMLINK_FOLLOW,
        )
    };
    if r == 0 {
        return Ok(());
    }
    let e = std::io::Error::last_os_error();
    if e.kind() == std::io::ErrorKind::AlreadyExists {
        return Err(e);
    }
    use std::io::{Seek, SeekFrom};
    let mut out = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)?;
    let mut src = f;
    src.seek(SeekFrom::Start(0))?;
    std::io::copy(&mut src, &mut out)?;
    out.sync_all()
}

/// The process's output commit state: idle, inside an [`OutputSet::commit`], or
/// interrupted (no commit starts any more).
static COMMIT_STATE: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(IDLE);
const IDLE: u8 = 0;
const COMMITTING: u8 = 1;
const INTERRUPTED: u8 = 2;

/// Marks the process as inside a commit while alive.
struct Commit;

impl Commit {
    fn begin() -> Option<Self> {
        use std::sync::atomic::Ordering::SeqCst;
        loop {
            match COMMIT_STATE.compare_exchange(IDLE, COMMITTING, SeqCst, SeqCst) {
                Ok(_) => return Some(Commit),
                Err(INTERRUPTED) => return None,
                // Another thread's commit: wait for it.
                Err(_) => std::thread::yield_now(),
            }
        }
    }
}

impl Drop for Commit {
    fn drop(&mut self) {
        use std::sync::atomic::Ordering::SeqCst;
        let _ = COMMIT_STATE.compare_exchange(COMMITTING, IDLE, SeqCst, SeqCst);
    }
}

/// Called by an interrupt handler (Ctrl-C, SIGTERM): from now on no [`OutputSet`] is
/// committed. Returns true when a commit is under way: it completes (a set is never left
/// half replaced), and [`wait_for_commit`] waits for it.
pub fn interrupt_outputs() -> bool {
    use std::sync::atomic::Ordering::SeqCst;
    let mut found_commit = false;
    loop {
        match COMMIT_STATE.compare_exchange(IDLE, INTERRUPTED, SeqCst, SeqCst) {
            Ok(_) | Err(INTERRUPTED) => return found_commit,
            Err(_) => {
                found_commit = true;
                wait_for_commit();
            }
        }
    }
}

/// Waits until no [`OutputSet::commit`] is under way.
pub fn wait_for_commit() {
    while COMMIT_STATE.load(std::sync::atomic::Ordering::SeqCst) == COMMITTING {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// Largest text input lobe reads (a scene, material, fit report, Ngan `.fit` or glTF JSON
/// file): 256 MiB.
pub const MAX_TEXT_BYTES: u64 = 1 << 28;
/// Largest binary input (a measured table, mesh, image): 4 GiB.
pub const MAX_DATA_BYTES: u64 = 1 << 32;

/// Opens `path` for reading if it is a regular file of at most `max_bytes`; `what`
/// completes "expected ...". A device (`/dev/zero` would be read until memory runs out), a
/// pipe (which blocks) or a socket is refused, as is a file beyond the limit, before
/// anything is read. Returns the file and its size.
pub fn open_regular(
    path: &Path,
    max_bytes: u64,
    what: &str,
) -> Result<(std::fs::File, u64), FileError> {
    let shown = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|e| {
        let m = match e.kind() {
            std::io::ErrorKind::NotFound => format!("does not exist; expected {what}"),
            _ => format!("cannot read: {e}; expected {what}"),
        };
        FileError::new(&shown, m)
    })?;
    let check = |meta: &std::fs::Metadata| -> Result<u64, FileError> {
        if meta.is_dir() {
            return Err(FileError::new(
                &shown,
                format!("is a directory; expected {what}"),
            ));
        }
        if !meta.is_file() {
            return Err(FileError::new(
                &shown,
                format!("is not a regular file (a device, pipe or socket); expected {what}"),
            ));
        }
        if meta.len() > max_bytes {
            return Err(FileError::new(
                &shown,
                format!(
                    "is {} bytes; expected {what} of at most {max_bytes} bytes",
                    meta.len()
                ),
            ));
        }
        Ok(meta.len())
    };
    check(&meta)?;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    // Should a pipe replace the file between the check and the open, the open must not
    // block (the check below then refuses it).
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options
        .open(path)
        .map_err(|e| FileError::new(&shown, format!("cannot read: {e}; expected {what}")))?;
    let len = file
        .metadata()
        .map_err(|e| FileError::new(&shown, format!("cannot read: {e}")))
        .and_then(|m| check(&m))?;
    Ok((file, len))
}

/// The bytes of `path`, a regular file of at most `max_bytes` ([`open_regular`]).
pub fn read_regular(path: &Path, max_bytes: u64, what: &str) -> Result<Vec<u8>, FileError> {
    use std::io::Read;
    let (file, len) = open_regular(path, max_bytes, what)?;
    let shown = path.display().to_string();
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(len as usize)
        .map_err(|_| FileError::new(&shown, format!("cannot allocate {len} bytes to read it")))?;
    // At most the limit, should the file grow while it is read.
    file.take(max_bytes)
        .read_to_end(&mut bytes)
        .map_err(|e| FileError::new(&shown, format!("cannot read: {e}")))?;
    Ok(bytes)
}

/// The text of `path`, a regular UTF-8 file of at most `max_bytes` ([`open_regular`]).
pub fn read_regular_to_string(
    path: &Path,
    max_bytes: u64,
    what: &str,
) -> Result<String, FileError> {
    let bytes = read_regular(path, max_bytes, what)?;
    String::from_utf8(bytes).map_err(|e| {
        FileError::new(
            path.display().to_string(),
            format!(
                "is not UTF-8 text (invalid byte at offset {}); expected {what}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}
