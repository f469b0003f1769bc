//! `lobe eval` and `lobe models`: CSV values of a material, and the model reference.

use super::common::*;

#[test]
fn eval_prints_csv_for_stdin_pairs_and_grids() {
    use std::io::Write;
    let mut child = lobe()
        .args([
            "eval",
            "--material",
            r#"{"type": "ward", "specular": 0.1, "alpha": 0.2}"#,
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"30 0 30 180\n# comment\n\n20,0,40,180\n")
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "theta_i,phi_i,theta_o,phi_o,f_r,f_g,f_b,pdf");
    assert_eq!(lines.len(), 3);
    // Ward at the mirror direction: specular / (4 pi alpha^2 cos 30).
    let f: f64 = lines[1].split(',').nth(4).unwrap().parse().unwrap();
    let expected = 0.1 / (4.0 * std::f64::consts::PI * 0.04 * 30f64.to_radians().cos());
    assert!((f - expected).abs() < 1e-5 * expected, "{f} vs {expected}");
    let o = lobe()
        .args([
            "eval",
            "--material",
            r#"{"type": "lambert", "reflectance": 0.5}"#,
            "--grid",
            "0..80..40,0,10,0..180..90",
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(
        String::from_utf8(o.stdout).unwrap().lines().count(),
        1 + 3 * 3
    );
    fails(
        &[
            "eval",
            "--material",
            r#"{"type": "ward", "alpha": -1}"#,
            "--grid",
            "0,0,0,0",
        ],
        "material.alpha",
    );
    fails(
        &[
            "eval",
            "--material",
            r#"{"type": "lambert"}"#,
            "--grid",
            "0,0,0",
        ],
        "--grid",
    );
    fails(&["eval", "--material", "{not json"], "invalid JSON");
}

/// `lobe models` prints the registry's reference (the text docs/models.md holds, checked
/// in tests/scene_files.rs) and `--names` one name per line, every model once.
#[test]
fn models_prints_the_reference_and_the_names() {
    let reg = lobe_materials::registry::Registry::builtin();
    let o = lobe().arg("models").output().unwrap();
    assert!(o.status.success());
    assert_eq!(
        String::from_utf8(o.stdout).unwrap(),
        reg.reference_markdown()
    );
    let o = lobe().args(["models", "--names"]).output().unwrap();
    let out = String::from_utf8(o.stdout).unwrap();
    let names: Vec<&str> = out.lines().collect();
    assert_eq!(names, reg.names().collect::<Vec<_>>());
    for m in [
        "lambert",
        "ward",
        "he",
        "sampled-microfacet",
        "merl",
        "rgl",
        "composite",
    ] {
        assert_eq!(
            names.iter().filter(|n| **n == m).count(),
            1,
            "{m}: {names:?}"
        );
    }
}
