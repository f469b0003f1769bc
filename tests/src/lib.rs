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

/// The workspace root.
pub fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}
