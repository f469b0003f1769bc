//! The one rule every command follows for the files it writes: an output path that is one
//! of the command's inputs, or that another output of the same command will write, is
//! refused with a one-line error naming both, before any work starts. Paths are compared
//! after canonicalization (symlinks, `.` and `..` resolved; a path that does not exist
//! yet by its canonical folder and its name), so `./x`, `dir/../x` and a symlink to `x` are
//! all `x`. Writes themselves stay atomic ([`crate::film::atomic_write`]).
//!
//! A command lists what it reads and writes in a [`FilePlan`] and calls
//! [`FilePlan::check`]: scene files contribute everything they reference
//! ([`crate::scene::inputs`]), materials the tables and reports they read
//! ([`lobe_materials::registry::Registry::inputs`]).

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// The canonical form of `path` used to tell whether two paths name one file: the
/// canonical path when it exists, else its folder's canonical path joined with its name,
/// else the absolute path.
pub fn canonical(path: &Path) -> PathBuf {
    if let Ok(c) = path.canonicalize() {
        return c;
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (parent.canonicalize(), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf()),
    }
}

/// An output path whose folder exists and which is not itself a folder.
fn writable(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::file(
            path.display(),
            format!("output folder {} does not exist", dir.display()),
        ));
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(Error::file(
            path.display(),
            "is a directory; expected an output file path",
        )),
        // A device, pipe or socket would be replaced by the renamed file (/dev/null!).
        Ok(m) if !m.is_file() => Err(Error::file(
            path.display(),
            "is not a regular file (a device, pipe or socket); expected an output file path",
        )),
        _ => Ok(()),
    }
}

/// One file of a plan: the path as the user gave it, its canonical form, and what it is
/// ("the measured data", "lights[0].file of scenes/x.json").
#[derive(Clone, Debug)]
struct Planned {
    shown: PathBuf,
    key: PathBuf,
    role: String,
}

impl Planned {
    fn new(path: &Path, role: String) -> Self {
        Self {
            shown: path.to_path_buf(),
            key: canonical(path),
            role,
        }
    }
}

/// The files one command reads and writes.
#[derive(Clone, Debug, Default)]
pub struct FilePlan {
    inputs: Vec<Planned>,
    outputs: Vec<Planned>,
}

impl FilePlan {
    pub fn new() -> Self {
        Self::default()
    }

    /// A file the command reads; `role` says what it is.
    pub fn input(&mut self, path: impl AsRef<Path>, role: impl Into<String>) -> &mut Self {
        self.inputs.push(Planned::new(path.as_ref(), role.into()));
        self
    }

    /// A file the command writes; `role` says what it is.
    pub fn output(&mut self, path: impl AsRef<Path>, role: impl Into<String>) -> &mut Self {
        self.outputs.push(Planned::new(path.as_ref(), role.into()));
        self
    }

    /// Every input of a scene file, the scene itself included.
    pub fn scene(&mut self, scene: &Path) -> Result<&mut Self> {
        for i in crate::scene::inputs::inputs(scene)? {
            self.input(&i.path, i.role);
        }
        Ok(self)
    }

    /// Refuses an output that is an input or another output, or that cannot be written
    /// (its folder is missing, or it is a folder).
    pub fn check(&self) -> Result<()> {
        self.check_overlaps()?;
        self.outputs.iter().try_for_each(|o| writable(&o.shown))
    }

    /// Refuses an output that is an input or another output (for a command that creates
    /// its output folder after this check and before [`FilePlan::check`]).
    pub fn check_overlaps(&self) -> Result<()> {
        for (k, out) in self.outputs.iter().enumerate() {
            if let Some(inp) = self.inputs.iter().find(|i| i.key == out.key) {
                return Err(Error::file(
                    out.shown.display(),
                    format!(
                        "the {} would overwrite {} ({}), an input of this command; expected a different output path",
                        out.role,
                        inp.shown.display(),
                        inp.role
                    ),
                ));
            }
            if let Some(other) = self.outputs[..k].iter().find(|o| o.key == out.key) {
                return Err(Error::file(
                    out.shown.display(),
                    format!(
                        "the {} and the {} ({}) would both be written to this path; expected different output paths",
                        out.role,
                        other.role,
                        other.shown.display()
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The files `lobe render` writes for one output path, side by side with one stem: the
/// linear EXR, the tonemapped PNG (unless disabled), the statistics JSON and, if asked,
/// the variance EXR. The path names either the EXR (`x.exr`) or the PNG (`x.png`); any
/// other extension is refused, as is a `.png` path when no PNG is written.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderFiles {
    pub exr: PathBuf,
    pub png: Option<PathBuf>,
    pub stats: PathBuf,
    pub variance: Option<PathBuf>,
}

impl RenderFiles {
    pub fn new(output: &Path, png: bool, variance: bool) -> Result<Self> {
        let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("");
        let bad = |why: &str| {
            Err(Error::file(
                output.display(),
                format!(
                    "{why}; expected an output path ending in .exr (or .png): the render writes NAME.exr, NAME.png and NAME.stats.json"
                ),
            ))
        };
        let ext = ext.to_ascii_lowercase();
        match ext.as_str() {
            "exr" => {}
            "png" if png => {}
            "png" => return bad("names a PNG, but --no-png writes none"),
            "" => return bad("has no extension"),
            other => return bad(&format!("has the extension .{other}")),
        }
        // The named file keeps its spelling (x.EXR stays x.EXR).
        let sibling = |e: &str| {
            if ext == e {
                output.to_path_buf()
            } else {
                output.with_extension(e)
            }
        };
        Ok(Self {
            exr: sibling("exr"),
            png: png.then(|| sibling("png")),
            stats: output.with_extension("stats.json"),
            variance: variance.then(|| output.with_extension("var.exr")),
        })
    }

    /// Adds every file to `plan` as an output.
    pub fn plan(&self, plan: &mut FilePlan) {
        plan.output(&self.exr, "rendered EXR");
        if let Some(p) = &self.png {
            plan.output(p, "tonemapped PNG");
        }
        plan.output(&self.stats, "statistics JSON");
        if let Some(v) = &self.variance {
            plan.output(v, "variance EXR");
        }
    }

    /// The paths, in writing order.
    pub fn all(&self) -> Vec<&Path> {
        let mut v = vec![self.exr.as_path()];
        v.extend(self.variance.as_deref());
        v.extend(self.png.as_deref());
        v.push(&self.stats);
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_of_one_file_are_one_file() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        std::fs::write(d.join("a.exr"), b"x").unwrap();
        let a = canonical(&d.join("a.exr"));
        assert_eq!(canonical(&d.join("sub/../a.exr")), a);
        assert_eq!(canonical(&d.join("./a.exr")), a);
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("a.exr"), d.join("link.exr")).unwrap();
            assert_eq!(canonical(&d.join("link.exr")), a);
        }
        // Not there yet: its folder's canonical path and its name.
        assert_eq!(
            canonical(&d.join("sub/../new.png")),
            d.canonicalize().unwrap().join("new.png")
        );
    }

    #[test]
    fn render_files_follow_the_extension_of_the_output() {
        let f = RenderFiles::new(Path::new("o/x.png"), true, true).unwrap();
        assert_eq!(f.exr, Path::new("o/x.exr"));
        assert_eq!(f.png.as_deref(), Some(Path::new("o/x.png")));
        assert_eq!(f.stats, Path::new("o/x.stats.json"));
        assert_eq!(f.variance.as_deref(), Some(Path::new("o/x.var.exr")));
        let f = RenderFiles::new(Path::new("x.EXR"), false, false).unwrap();
        assert_eq!((f.exr.as_path(), f.png), (Path::new("x.EXR"), None));
        for bad in ["x", "x.jpg", "x.stats.json"] {
            assert!(
                RenderFiles::new(Path::new(bad), true, false).is_err(),
                "{bad}"
            );
        }
        assert!(RenderFiles::new(Path::new("x.png"), false, false).is_err());
    }

    #[test]
    fn outputs_over_inputs_or_each_other_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("in.exr"), b"x").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        let mut plan = FilePlan::new();
        plan.input(d.join("in.exr"), "test image")
            .output(d.join("heat.png"), "heat map");
        assert!(plan.check().is_ok());
        let e = plan
            .clone()
            .output(d.join("sub/../in.exr"), "report")
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("test image") && e.contains("in.exr") && e.contains("report"));
        let e = plan
            .output(d.join("./heat.png"), "plot")
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("heat map") && e.contains("plot"), "{e}");
    }

    #[test]
    fn outputs_must_be_regular_files_in_existing_folders() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let check = |p: &Path| FilePlan::new().output(p, "image").check();
        assert!(check(&d.join("new.exr")).is_ok());
        let e = check(&d.join("missing/x.exr")).unwrap_err().to_string();
        assert!(
            e.contains("output folder") && e.contains("does not exist"),
            "{e}"
        );
        assert!(check(d).unwrap_err().to_string().contains("is a directory"));
        #[cfg(unix)]
        {
            let sock = d.join("s.exr");
            let _l = std::os::unix::net::UnixListener::bind(&sock).unwrap();
            let e = check(&sock).unwrap_err().to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
    }
}
