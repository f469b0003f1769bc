//! Shared helpers of lobe's integration tests: chi-square goodness-of-fit with pooling of
//! low-expected-count cells (as Mitsuba 3's `chi2.py` and pbrt-v4's `bsdfs_test.cpp` do),
//! and locating the shared data folder.

pub mod bsdf_checks;
pub mod fuzz;

use std::path::PathBuf;

/// Pearson's chi-square test of observed against expected counts. Cells whose expected
/// count is below `min_expected` are pooled into one cell (Mitsuba's chi2.py rule).
/// Returns (statistic, degrees of freedom, p-value).
pub fn chi2_test(observed: &[f64], expected: &[f64], min_expected: f64) -> (f64, usize, f64) {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    assert_eq!(observed.len(), expected.len());
    let mut stat = 0.0;
    let mut dof = 0usize;
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < min_expected {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    } else if pool_o > 0.0 {
        // Samples where the density says none can fall: an outright failure.
        return (f64::INFINITY, dof.max(1), 0.0);
    }
    let dof = dof.saturating_sub(1).max(1);
    let p = 1.0 - ChiSquared::new(dof as f64).expect("dof > 0").cdf(stat);
    (stat, dof, p)
}

/// The shared data folder (`LOBE_DATA`, or `../shared/data` from the workspace), if any.
pub fn shared_data() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("LOBE_DATA") {
        let p = PathBuf::from(p);
        if p.is_dir() {
            return Some(p);
        }
    }
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let p = here.join("../../shared/data");
    p.is_dir().then_some(p)
}

/// Where skipped checks are listed, one line each: scripts/test.sh clears it first and
/// prints a summary of it last (`cargo test` hides the stderr of passing tests).
pub fn skip_log() -> PathBuf {
    workspace().join("target/skipped-checks.log")
}

fn record_skip(line: &str) {
    use std::io::Write;
    eprintln!("SKIPPED {line}");
    let log = skip_log();
    if let Some(dir) = log.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    if let Ok(mut f) = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log)
    {
        let _ = writeln!(f, "{line}");
    }
}

/// Records a check that could not run because `../shared/data` (or `LOBE_DATA`) is absent.
/// With `LOBE_REQUIRE_DATA=1` (CI sets it: CI has the data) it fails the test instead.
pub fn skip_without_data(what: &str) {
    if std::env::var("LOBE_REQUIRE_DATA").is_ok_and(|v| v == "1") {
        panic!("LOBE_REQUIRE_DATA=1 but ../shared/data (or LOBE_DATA) is absent: {what}");
    }
    record_skip(&format!("(no shared data) {what}"));
}

/// The shared data folder, or `None` with the skipped check recorded
/// ([`skip_without_data`]).
pub fn shared_data_or_skip(what: &str) -> Option<PathBuf> {
    let d = shared_data();
    if d.is_none() {
        skip_without_data(what);
    }
    d
}

/// Records a check that could not run on this machine for another reason (a missing
/// program, permissions not enforced as root); never fatal.
pub fn skip_on_this_machine(what: &str) {
    record_skip(&format!("(this machine) {what}"));
}

/// Waits until process `pid` catches `signal` (its handler is installed: Linux's
/// /proc/PID/status `SigCgt` mask), so that a test can interrupt a child at a known
/// point of its life instead of after a guessed delay. Returns false if the process ended
/// first or the mask cannot be read (then a test should skip, not guess).
pub fn wait_for_signal_handler(pid: u32, signal: i32) -> bool {
    let status = format!("/proc/{pid}/status");
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_secs(60) {
        let Ok(text) = std::fs::read_to_string(&status) else {
            return false;
        };
        let caught = text
            .lines()
            .find_map(|l| l.strip_prefix("SigCgt:"))
            .and_then(|m| u64::from_str_radix(m.trim(), 16).ok());
        match caught {
            Some(mask) if mask & (1 << (signal - 1)) != 0 => return true,
            Some(_) => std::thread::sleep(std::time::Duration::from_millis(5)),
            None => return false,
        }
    }
    false
}

/// The names in a folder, sorted (what a test expects to find there, or not).
pub fn listing(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

/// The workspace root.
pub fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}
