//! A set of outputs is written whole or not at all ([`lobe_materials::io::OutputSet`]):
//! nothing appears in the destination folder while files are staged, a dropped set leaves
//! the old files as they were, and once the process is interrupted no set is committed.
//! (The interrupt state is process-wide: this file is its own test process.)

use lobe_materials::io::{OutputSet, interrupt_outputs};
use std::io::Write;

use lobe_tests::listing;

#[test]
fn a_set_is_committed_whole_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("a.stats.json"));
    std::fs::write(&a, "old a").unwrap();
    std::fs::write(&b, "old b").unwrap();

    // Staged files are invisible, and a set dropped uncommitted changes nothing.
    let mut set = OutputSet::new();
    set.stage(&a, |w| w.write_all(b"new a")).unwrap();
    assert_eq!(listing(dir.path()), ["a.exr", "a.stats.json"]);
    let failed = set.stage(&b, |_| Err(std::io::Error::other("disk full")));
    assert!(failed.unwrap_err().to_string().contains("disk full"));
    drop(set);
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "old b");
    assert_eq!(listing(dir.path()), ["a.exr", "a.stats.json"]);

    // A committed set replaces every file, leaves no temporary file, and its files are
    // ordinary readable files.
    let mut set = OutputSet::new();
    set.stage(&a, |w| w.write_all(b"new a")).unwrap();
    set.stage(&b, |w| w.write_all(b"new b")).unwrap();
    set.commit().unwrap();
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
    assert_eq!(listing(dir.path()), ["a.exr", "a.stats.json"]);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&a).unwrap().permissions().mode();
        assert_ne!(mode & 0o044, 0, "mode {mode:o}: not readable by others");
    }

    // After an interrupt, no set is committed any more: the staged files vanish.
    let mut set = OutputSet::new();
    set.stage(&a, |w| w.write_all(b"late a")).unwrap();
    set.stage(&b, |w| w.write_all(b"late b")).unwrap();
    assert!(!interrupt_outputs(), "no commit was under way");
    let e = set.commit().unwrap_err().to_string();
    assert!(
        e.contains("interrupted") && e.contains("nothing is written"),
        "{e}"
    );
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
    assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
    assert_eq!(listing(dir.path()), ["a.exr", "a.stats.json"]);
}
