//! `lobe stability`: sweeps that find no non-finite or negative values, and what they show.

use super::common::*;

#[test]
fn stability_sweep_finds_no_nonfinite_or_negative_values() {
    let o = lobe().args(["stability", "--quick"]).output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for m in [
        "| ward |",
        "| cook-torrance |",
        "| he |",
        "| poulin-fournier |",
        "| sampled-microfacet |",
        "| merl |",
    ] {
        assert!(out.contains(m), "{m} missing:\n{out}");
    }
    // The verdict comes last; columns 5 and 6 (non-finite, negative) are zero on every
    // row.
    let last = out.lines().last().unwrap_or("");
    assert!(
        last.starts_with("PASS: no non-finite or negative value in "),
        "{last}"
    );
    for row in out.lines().skip(2).filter(|l| l.starts_with('|')) {
        let cols: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!((cols[5], cols[6]), ("0", "0"), "{row}");
        assert!(
            cols[2].parse::<usize>().unwrap() > 0 || cols[1] == "rgl",
            "{row}"
        );
    }
}

/// `--verbose` shows the first case of each kind found; `--rgl` sweeps the files of a folder
/// and refuses one without any, rather than passing on nothing.
#[test]
fn stability_shows_its_cases_and_sweeps_the_rgl_folder_given() {
    // Ashikhmin-Shirley's f32 and f64 evaluations disagree at grazing angles (a finding).
    let o = lobe()
        .args([
            "stability",
            "--quick",
            "--models",
            "ashikhmin-shirley",
            "--verbose",
        ])
        .output()
        .unwrap();
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{out}{err}");
    let findings: usize = out
        .lines()
        .find(|l| l.starts_with("| ashikhmin-shirley |"))
        .map(|row| row.split('|').nth(9).unwrap().trim().parse().unwrap())
        .unwrap();
    assert!(findings > 0, "{out}");
    assert!(
        err.contains("\"ashikhmin-shirley\"") && err.contains(": f32 ["),
        "{err}"
    );
    let quiet = lobe()
        .args(["stability", "--quick", "--models", "ashikhmin-shirley"])
        .output()
        .unwrap();
    assert!(!String::from_utf8_lossy(&quiet.stderr).contains(": f32 ["));
    // A folder without .bsdf files is an error, not a pass over nothing.
    let dir = tempfile::tempdir().unwrap();
    fails(
        &[
            "stability",
            "--quick",
            "--models",
            "rgl",
            "--rgl",
            dir.path().to_str().unwrap(),
        ],
        "no .bsdf file",
    );
    let Some(data) = lobe_tests::shared_data_or_skip("stability --rgl over the shared RGL files")
    else {
        return;
    };
    let rgl = data.join("rgl");
    let count = std::fs::read_dir(&rgl)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "bsdf")
        })
        .count();
    let o = lobe()
        .args(["stability", "--quick", "--models", "rgl", "--rgl"])
        .arg(&rgl)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}");
    let row = out.lines().find(|l| l.starts_with("| rgl |")).unwrap();
    let cols: Vec<&str> = row.split('|').map(str::trim).collect();
    assert_eq!(cols[2], count.to_string(), "{row}");
    assert!(cols[4].parse::<usize>().unwrap() > 0, "{row}");
}
