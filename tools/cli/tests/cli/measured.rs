//! `lobe tabulate` and measured files: tables that render, files told apart by content.

use super::common::*;

#[test]
fn tabulate_writes_tables_that_render() {
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("ct.binary");
    let mat = r#"{"type": "cook-torrance", "diffuse": 0.2, "specular": 0.3, "m": 0.2}"#;
    let o = lobe()
        .args([
            "tabulate",
            "--material",
            mat,
            "-o",
            table.to_str().unwrap(),
            "--retro-exclusion",
            "3",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let binned = dir.path().join("ct.bin");
    let merl_mat = format!(r#"{{"type": "merl", "file": "{}"}}"#, table.display());
    let o = lobe()
        .args([
            "tabulate",
            "--material",
            &merl_mat,
            "--format",
            "binned",
            "--empty-fraction",
            "0.2",
            "--seed",
            "3",
            "-o",
            binned.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bins hold a value"));
    // Both render.
    for m in [
        format!(r#"{{"type": "merl", "file": "{}"}}"#, table.display()),
        format!(r#"{{"type": "binned", "file": "{}"}}"#, binned.display()),
    ] {
        let scene = dir.path().join("s.json");
        std::fs::write(
            &scene,
            SCENE.replace(
                r#""shapes": [{"type": "sphere"}]"#,
                &format!(r#""shapes": [{{"type": "sphere", "material": {m}}}]"#),
            ),
        )
        .unwrap();
        let o = lobe()
            .args([
                "render",
                scene.to_str().unwrap(),
                "-o",
                dir.path().join("r.exr").to_str().unwrap(),
                "-q",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    fails(
        &[
            "tabulate",
            "--material",
            mat,
            "-o",
            "/nonexistent/dir/x.binary",
        ],
        "output folder",
    );
    fails(
        &[
            "tabulate",
            "--material",
            mat,
            "--empty-fraction",
            "2",
            "-o",
            table.to_str().unwrap(),
        ],
        "--empty-fraction",
    );
    fails(
        &[
            "tabulate",
            "--material",
            mat,
            "--anisotropic",
            "-o",
            table.to_str().unwrap(),
        ],
        "--anisotropic",
    );
}

#[test]
fn measured_files_are_told_apart_by_content() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Binned data named like a MERL table loads as binned.
    write_binned(
        serde_json::from_str(WARD).unwrap(),
        (12, 24),
        &d.join("b.binary"),
    );
    let o = lobe_in(
        d,
        &[
            "fit",
            "b.binary",
            "--models",
            "ward",
            "-o",
            "b.fit.json",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A MERL table named like binned data loads as MERL.
    write_merl(&d.join("m.bin"));
    let o = lobe_in(
        d,
        &[
            "fit",
            "m.bin",
            "--models",
            "ward",
            "--resolution",
            "5",
            "-o",
            "m.fit.json",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("m.fit.json")).unwrap()).unwrap();
    let alpha = r["models"]["ward"]["material"]["alpha"].as_f64().unwrap();
    assert!((alpha - 0.2).abs() < 0.02, "{alpha}");
    // Unknown content, and a material type that does not match the content.
    std::fs::write(d.join("junk.bsdf"), b"PK\x03\x04 not a BRDF").unwrap();
    refused_in(
        d,
        &["fit", "junk.bsdf", "-o", "j.fit.json"],
        &["junk.bsdf: unknown content", "expected a MERL table"],
    );
    refused_in(
        d,
        &[
            "tabulate",
            "--material",
            r#"{"type": "merl", "file": "b.binary"}"#,
            "-o",
            "x.binary",
        ],
        &["b.binary: holds binned data", "{\"type\": \"binned\"}"],
    );
}
