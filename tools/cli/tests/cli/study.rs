//! `lobe study`: bad inputs refused in one line.

use super::common::*;

/// `lobe study` refuses, in one line naming the problem, missing data, a bad shard, a
/// budget out of the estimate's range (and makes no folder), data inside the study folder
/// and a study folder made with other settings.
#[test]
fn study_refuses_bad_inputs_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let o = out.to_str().unwrap();
    let missing = dir.path().join("missing.bsdf");
    fails(
        &["study", missing.to_str().unwrap(), "-o", o],
        "missing.bsdf: does not exist",
    );
    let data = dir.path().join("a.bsdf");
    std::fs::write(&data, b"not read before the checks").unwrap();
    let d = data.to_str().unwrap();
    fails(&["study", d, "--shard", "2/2", "-o", o], "--shard");
    for (n, found) in [("8", "found 8"), ("100000", "found 100000")] {
        fails(
            &["study", d, "--error-spp", n, "-o", o],
            &format!("--error-spp: expected a mean of 32 to 16384 samples per pixel, {found}"),
        );
        assert!(!out.exists(), "--error-spp {n}: the study folder was made");
    }
    let inside = out.join("b.bsdf");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(&inside, b"x").unwrap();
    fails(
        &["study", inside.to_str().unwrap(), "-o", o],
        "is inside the study folder",
    );
    std::fs::write(
        out.join("study.json"),
        r#"{"settings": {}, "environments": []}"#,
    )
    .unwrap();
    fails(
        &["study", d, "--quick", "-o", o],
        "made with other settings",
    );
}
