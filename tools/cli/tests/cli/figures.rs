//! `lobe figure`, `lobe microfacet` and `lobe tradeoff`: figures drawn from fit reports and what they must name.

use super::common::*;

#[test]
fn figures_draw_pngs_from_fit_reports() {
    let dir = tempfile::tempdir().unwrap();
    let mat = r#"{"type": "ward", "diffuse": 0.1, "specular": 0.2, "alpha": 0.2}"#;
    let report = dir.path().join("w.fit.json");
    let o = lobe()
        .args([
            "fit",
            "--material",
            mat,
            "--models",
            "ward,lafortune",
            "--resolution",
            "4",
            "-o",
            report.to_str().unwrap(),
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (args, name) in [
        (vec!["figure", "errors", report.to_str().unwrap()], "e.png"),
        (
            vec![
                "figure",
                "polar",
                "--material",
                mat,
                "--report",
                report.to_str().unwrap(),
            ],
            "p.png",
        ),
        (
            vec![
                "figure",
                "spheres",
                "--material",
                mat,
                "--report",
                report.to_str().unwrap(),
                "--spp",
                "4",
                "--tile",
                "48",
            ],
            "s.png",
        ),
        (
            vec!["figure", "lobes", "--theta-i", "45", "--exponent", "20"],
            "l.png",
        ),
    ] {
        let out = dir.path().join(name);
        let o = lobe()
            .args(&args)
            .args(["-o", out.to_str().unwrap(), "-q"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = image::open(&out).unwrap().to_rgb8();
        let svg = out.with_extension("svg");
        if name == "s.png" {
            // Three spheres (the material, ward, lafortune) in one row with labels, each
            // with its FLIP map under it.
            assert!(
                img.width() >= 3 * 48 && img.height() >= 2 * 48 + 60,
                "{:?}",
                img.dimensions()
            );
            assert!(!svg.exists(), "a raster figure has no SVG");
        } else {
            // A chart: at least chart-sized, and the same drawing as SVG beside it.
            assert!(img.width() >= 1000 && img.height() >= 500, "{name}");
            let text = std::fs::read_to_string(&svg).unwrap();
            assert!(
                text.starts_with("<svg") && text.contains(&format!("width=\"{}\"", img.width()))
            );
        }
        // Something coloured (a plotted curve) was drawn, not just a blank canvas.
        assert!(img.pixels().any(|p| p[0] != p[1] || p[1] != p[2]));
    }
    fails(
        &[
            "figure",
            "polar",
            "--material",
            mat,
            "--theta-i",
            "95",
            "-o",
            dir.path().join("x.png").to_str().unwrap(),
        ],
        "--theta-i",
    );
}

#[test]
fn microfacet_synth_writes_its_table_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("velvet");
    let o = lobe()
        .args([
            "microfacet",
            "synth",
            "velvet",
            "-o",
            out.to_str().unwrap(),
            "--nodes",
            "33",
            "--resolution",
            "8",
            "--f0",
            "1",
            "--filled",
            "0.1",
            "--iterations",
            "2",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The options reach the estimate: a tenth of the bins filled, two alternations (one
    // change between them).
    let table = String::from_utf8_lossy(&o.stdout).to_string();
    let summary = table.lines().find(|l| l.starts_with("velvet: ")).unwrap();
    assert!(summary.contains("10 % filled"), "{summary}");
    let changes = summary.split("p change per iteration").nth(1).unwrap();
    assert_eq!(
        changes.matches("e-").count() + changes.matches("e+").count(),
        1,
        "{summary}"
    );
    assert_eq!(
        table.lines().filter(|l| l.starts_with("| ")).count(),
        5,
        "{table}"
    );
    for f in [
        "velvet-truth.exr",
        "velvet-truth.png",
        "velvet-estimate.exr",
        "velvet-estimate.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // The table printed is also written into the folder.
    let written = std::fs::read_to_string(out.join("velvet.md")).unwrap();
    assert_eq!(written, table);
}

#[test]
fn microfacet_estimate_writes_a_material_that_renders() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("velvet");
    // Estimate from a MERL table tabulated from the generator itself.
    let data = dir.path().join("beckmann.binary");
    let o = lobe()
        .args([
            "tabulate",
            "--material",
            r#"{"type": "sampled-microfacet", "distribution": "beckmann", "alpha_x": 0.2, "alpha_y": 0.2, "specular": 0.5, "resolution": 65}"#,
            "-o",
            data.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stem = dir.path().join("p");
    let o = lobe()
        .args([
            "microfacet",
            "estimate",
            data.to_str().unwrap(),
            "-o",
            stem.to_str().unwrap(),
            "--nodes",
            "33",
            "--f0",
            "1",
            "--resolution",
            "5",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("p.json")).unwrap()).unwrap();
    assert_eq!(v["material"]["distribution"], "p.exr");
    assert!(v["changes"].as_array().unwrap().len() <= 4);
    // The written material renders through `lobe eval` next to its table.
    let mat = serde_json::json!({"type": "sampled-microfacet", "distribution": dir.path().join("p.exr").to_str().unwrap(), "specular": 0.5});
    let o = lobe()
        .args([
            "eval",
            "--material",
            &mat.to_string(),
            "--grid",
            "30,0,30,180",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    fails(
        &[
            "microfacet",
            "synth",
            "corduroy",
            "-o",
            out.to_str().unwrap(),
        ],
        "expected brushed, satin or velvet",
    );
    fails(
        &[
            "microfacet",
            "estimate",
            "/nonexistent.bin",
            "-o",
            stem.to_str().unwrap(),
        ],
        "does not exist",
    );
}

#[test]
fn tradeoff_reports_every_representation() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("ct.binary");
    let o = lobe()
        .args([
            "tabulate",
            "--material",
            r#"{"type": "cook-torrance", "diffuse": 0.1, "specular": 0.5, "m": 0.2}"#,
            "-o",
            data.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stem = dir.path().join("to");
    let o = lobe()
        .args([
            "tradeoff",
            data.to_str().unwrap(),
            "--models",
            "ward,cook-torrance",
            "--resolution",
            "6",
            "--size",
            "24",
            "--spp",
            "16",
            "--reference-spp",
            "64",
            "-o",
            stem.to_str().unwrap(),
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.path().join("to.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    for (row, name) in rows
        .iter()
        .zip(["measured", "sampled-microfacet", "ward", "cook-torrance"])
    {
        assert!(row.starts_with(name), "{row}");
        let f: Vec<f64> = row
            .split(',')
            .skip(1)
            .take(12)
            .map(|x| x.parse().unwrap())
            .collect();
        assert!(f.iter().all(|x| x.is_finite() && *x >= 0.0), "{row}");
    }
    // Cook-Torrance data: the Cook-Torrance fit's BRDF error is below Ward's, and the
    // measured table holds far more memory than an analytic model.
    let col = |r: &str, k: usize| r.split(',').nth(k).unwrap().parse::<f64>().unwrap();
    assert!(col(rows[3], 1) < col(rows[2], 1));
    assert!(col(rows[0], 9) > 100.0 * col(rows[3], 9));
    assert!(dir.path().join("to.png").is_file() && dir.path().join("to.md").is_file());
    assert!(dir.path().join("to-microfacet.exr").is_file());
    fails(
        &[
            "tradeoff",
            data.to_str().unwrap(),
            "-o",
            "/nonexistent/dir/x",
        ],
        "does not exist",
    );
}

#[test]
fn figure_models_must_be_in_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = lobe_in(
        d,
        &[
            "fit",
            "--material",
            WARD,
            "--models",
            "ward,he",
            "--resolution",
            "5",
            "-o",
            "r.fit.json",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for kind in ["polar", "spheres"] {
        refused_in(
            d,
            &[
                "figure",
                kind,
                "--material",
                WARD,
                "--report",
                "r.fit.json",
                "--models",
                "ward,cook-torrance",
                "-o",
                "f.png",
            ],
            &[
                "no model \"cook-torrance\" in r.fit.json",
                "expected one of: he, ward",
            ],
        );
    }
    refused_in(
        d,
        &["stability", "--models", "ward,nope"],
        &["unknown model \"nope\""],
    );
    assert!(!d.join("f.png").exists());
}
