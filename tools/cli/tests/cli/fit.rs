//! `lobe fit`: reports that load as materials, metrics, batches (sharded, resumable, keyed by content), selection and metric comparisons.

use super::common::*;
use std::path::Path;
use std::process::Command;

#[test]
fn fit_writes_a_report_that_loads_as_a_material() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("r.fit.json");
    let mat = r#"{"type": "cook-torrance", "diffuse": 0.1, "specular": 0.4, "m": 0.2, "f0": 0.2}"#;
    let o = lobe()
        .args([
            "fit",
            "--material",
            mat,
            "--models",
            "cook-torrance,ward",
            "--resolution",
            "5",
            "-o",
            report.to_str().unwrap(),
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let ct = &v["models"]["cook-torrance"];
    assert!(ct["error_normalized"].as_f64().unwrap() < 1e-3);
    assert!(v["models"]["ward"]["error"].as_f64().unwrap() > ct["error"].as_f64().unwrap());
    assert!((ct["material"]["m"].as_f64().unwrap() - 0.2).abs() < 0.004);
    let fit_mat = format!(
        r#"{{"type": "fit", "file": "{}", "model": "cook-torrance"}}"#,
        report.display()
    );
    let o = lobe()
        .args(["eval", "--material", &fit_mat, "--grid", "30,0,30,180"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    fails(
        &[
            "fit",
            "--material",
            mat,
            "--models",
            "nonsense",
            "-o",
            report.to_str().unwrap(),
        ],
        "unknown model",
    );
    fails(
        &["fit", "/nonexistent.binary", "-o", report.to_str().unwrap()],
        "does not exist",
    );
    // A MERL table with every bin missing, and an empty file.
    let missing = dir.path().join("missing.binary");
    lobe_materials::measured::merl::Merl::from_fn(|_, _, _| None)
        .write(&missing)
        .unwrap();
    fails(
        &[
            "fit",
            missing.to_str().unwrap(),
            "-o",
            report.to_str().unwrap(),
        ],
        "no measured values",
    );
    let empty = dir.path().join("empty.binary");
    std::fs::write(&empty, b"").unwrap();
    fails(
        &[
            "fit",
            empty.to_str().unwrap(),
            "-o",
            report.to_str().unwrap(),
        ],
        "empty.binary",
    );
    let bad = format!(
        r#"{{"type": "fit", "file": "{}", "model": "he"}}"#,
        report.display()
    );
    fails(
        &["eval", "--material", &bad, "--grid", "0,0,0,0"],
        "no model \"he\"",
    );
}

#[test]
fn fit_metric_is_chosen_recorded_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let mat = r#"{"type": "cook-torrance", "diffuse": 0.1, "specular": 0.4, "m": 0.2, "f0": 0.2}"#;
    let fit = |metric: &str, extra: &[&str]| {
        let report = dir.path().join(format!("{metric}.fit.json"));
        let mut args = vec![
            "fit",
            "--material",
            mat,
            "--models",
            "ward",
            "--resolution",
            "10",
            "--metric",
            metric,
            "-o",
            report.to_str().unwrap(),
            "-q",
        ];
        args.extend(extra);
        let o = lobe().args(&args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        v
    };
    let eq1 = fit("ngan2005", &[]);
    assert_eq!(eq1["metric"], "eq1");
    assert!(eq1["models"]["ward"].get("metric_error").is_none());
    for (metric, extra) in [
        ("cube-root", &[][..]),
        ("image", &["--env", "builtin:studio"][..]),
    ] {
        let v = fit(metric, extra);
        assert_eq!(v["metric"], metric);
        let w = &v["models"]["ward"];
        // Another metric's optimum is not Eq. (1)'s: its Eq. (1) error is larger.
        let e = w["error"].as_f64().unwrap();
        let e1 = eq1["models"]["ward"]["error"].as_f64().unwrap();
        assert!(e > e1 * (1.0 + 1e-6), "{metric}: {e} vs {e1}");
        assert!(w["metric_error"].as_f64().unwrap() > 0.0);
    }
    let out = dir.path().join("x.fit.json");
    let out = out.to_str().unwrap();
    fails(
        &["fit", "--material", mat, "--metric", "l2", "-o", out],
        "unknown metric \"l2\"",
    );
    fails(
        &[
            "fit",
            "--material",
            mat,
            "--env",
            "builtin:studio",
            "-o",
            out,
        ],
        "--env: only for --metric image",
    );
    fails(
        &[
            "fit",
            "--material",
            mat,
            "--metric",
            "image",
            "--env",
            "/nonexistent.exr",
            "-o",
            out,
        ],
        "/nonexistent.exr",
    );
}

#[test]
fn batch_fits_are_sharded_resumable_and_merge_into_tables() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    // Three coarse binned tables of Cook-Torrance materials.
    for (k, m) in [0.1, 0.2, 0.3].iter().enumerate() {
        write_binned(
            serde_json::json!({"type": "cook-torrance", "diffuse": 0.1, "specular": 0.5, "m": m}),
            (16, 36),
            &data.join(format!("ct{k}.bin")),
        );
    }
    std::fs::write(data.join("notes.txt"), "ignored").unwrap();
    let out = dir.path().join("reports");
    let run = |extra: &[&str]| {
        let mut a = vec![
            "fit",
            data.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--models",
            "cook-torrance",
            "-q",
        ];
        a.extend_from_slice(extra);
        let o = lobe().args(&a).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&["--shard", "0/2"]);
    let names = |d: &Path| listing(d);
    assert_eq!(names(&out), vec!["ct0.fit.json", "ct2.fit.json"]);
    run(&["--shard", "1/2"]);
    assert_eq!(names(&out).len(), 3);
    // A rerun skips what is done: the file is untouched, the same inode (a rewrite
    // renames a new file into place) with the same bytes.
    let identity = |p: &Path| {
        use std::os::unix::fs::MetadataExt;
        let m = std::fs::metadata(p).unwrap();
        (m.ino(), m.dev(), std::fs::read(p).unwrap())
    };
    let before = identity(&out.join("ct1.fit.json"));
    run(&[]);
    assert!(
        identity(&out.join("ct1.fit.json")) == before,
        "ct1.fit.json was rewritten"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("ct1.fit.json")).unwrap()).unwrap();
    assert!(
        (v["models"]["cook-torrance"]["material"]["m"]
            .as_f64()
            .unwrap()
            - 0.2)
            .abs()
            < 0.01
    );
    let table = dir.path().join("table");
    let o = lobe()
        .args([
            "fit",
            "merge",
            out.to_str().unwrap(),
            "-o",
            table.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(dir.path().join("table.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4, "{csv}");
    assert!(csv.starts_with(
        "material,max_albedo,metric,cook-torrance error,cook-torrance normalized error"
    ));
    assert!(
        std::fs::read_to_string(dir.path().join("table.md"))
            .unwrap()
            .contains("| ct2 |")
    );
    fails(
        &[
            "fit",
            data.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--shard",
            "2/2",
        ],
        "--shard",
    );
    fails(
        &[
            "fit",
            "merge",
            dir.path().join("nothing").to_str().unwrap(),
            "-o",
            table.to_str().unwrap(),
        ],
        "nothing",
    );
    // A broken file fails alone: the batch fits the others, exits non-zero naming it, and
    // a rerun (after the file is fixed or removed) finds the finished reports in place.
    std::fs::remove_file(out.join("ct0.fit.json")).unwrap();
    std::fs::write(data.join("broken.bin"), b"not a binned file").unwrap();
    fails(
        &[
            "fit",
            data.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--models",
            "cook-torrance",
            "-q",
        ],
        "broken.bin",
    );
    assert_eq!(
        names(&out),
        vec!["ct0.fit.json", "ct1.fit.json", "ct2.fit.json"]
    );
}

#[test]
fn fit_select_picks_the_cheapest_model_within_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("sel.fit.json");
    let run = |tol: &str| {
        let o = lobe()
            .args([
                "fit",
                "--material",
                r#"{"type": "ward", "diffuse": 0.2, "specular": 0.3, "alpha": 0.15}"#,
                "--models",
                "ward,cook-torrance,he",
                "--resolution",
                "6",
                "--select",
                "--tolerance",
                tol,
                "-o",
                report.to_str().unwrap(),
                "-q",
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        v["selected"].clone()
    };
    // Tolerance 0: only the best fit (Ward fits its own data exactly) qualifies.
    assert_eq!(run("0")["model"], "ward");
    // Any tolerance: the pick is the cheapest model of the committed cost table (the same
    // on every run), whatever this run measured; the measured costs are recorded beside.
    let s = run("1e12");
    let costs = s["costs"].as_object().unwrap();
    assert_eq!(costs.len(), 3);
    let table = |m: &str| lobe_analysis::cost::reference_cost(m).unwrap().total();
    let cheapest = costs
        .keys()
        .min_by(|a, b| table(a).total_cmp(&table(b)))
        .unwrap();
    assert_eq!(s["model"].as_str().unwrap(), cheapest);
    assert_eq!(
        run("1e12")["model"],
        s["model"],
        "a second run chose otherwise"
    );
    assert!(table("he") > table("ward"), "He is costlier than Ward");
    fails(
        &[
            "fit",
            "--material",
            "{\"type\": \"ward\"}",
            "--select",
            "--tolerance=-1",
            "-o",
            report.to_str().unwrap(),
        ],
        "--tolerance",
    );
}

/// `fit compare-metrics`' metrics.csv of the Ward and Blinn-Phong data ("w", "b") under
/// sunset, both models, metrics eq1 and log: each data's own model has a vanishing Eq. (1)
/// error and an image error whose interval lies below the other model's; every interval
/// holds its estimate; the own model's noise and the noise floor are positive and below
/// the other model's error.
fn assert_each_data_fits_its_own_model_best(csv: &str) {
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    // 2 materials x 2 metrics x 2 models under 1 map.
    assert_eq!(rows.len(), 8, "{csv}");
    let value = |material: &str, model: &str, metric: &str, col: usize| -> f64 {
        let r = rows
            .iter()
            .find(|r| r[0] == material && r[1] == model && r[2] == metric && r[3] == "sunset")
            .unwrap_or_else(|| panic!("{material} {model} {metric} missing: {csv}"));
        r[col].parse().unwrap()
    };
    for metric in ["eq1", "log"] {
        for (material, own, other) in [("w", "ward", "blinn-phong"), ("b", "blinn-phong", "ward")] {
            // Eq. (1) error (column 4) near zero for the data's own model; its image
            // closer to the data's (RMSE, column 5) than the other model's, the intervals
            // (columns 6, 7) apart; its noise (column 9) and the map's noise floor (column
            // 10) positive and below the other model's error.
            assert!(value(material, own, metric, 4) < 1e-3, "{csv}");
            assert!(value(material, other, metric, 4) > 1e-2, "{csv}");
            assert!(
                value(material, own, metric, 7) < value(material, other, metric, 6),
                "{csv}"
            );
            for model in [own, other] {
                let (lo, e, hi) = (
                    value(material, model, metric, 6),
                    value(material, model, metric, 5),
                    value(material, model, metric, 7),
                );
                assert!(lo <= e && e <= hi, "{csv}");
            }
            for col in [9, 10] {
                let noise = value(material, own, metric, col);
                assert!(
                    noise > 0.0 && noise < value(material, other, metric, 5),
                    "column {col}: {csv}"
                );
            }
        }
    }
}

/// `lobe fit compare-metrics`: every metric's fit of every model, its image error under the
/// held-out map against the data's image with an interval and the noise floor; a model fits
/// its own data best, with intervals that separate; the fits are kept and reused when
/// rerun; bad options are one-line errors.
#[test]
fn fit_compare_metrics_estimates_each_fits_image_error_against_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let ward = dir.path().join("w.bin");
    let blinn = dir.path().join("b.bin");
    write_binned(
        serde_json::json!({"type": "ward", "diffuse": 0.1, "specular": 0.3, "alpha": 0.15}),
        (20, 45),
        &ward,
    );
    write_binned(
        serde_json::json!({"type": "blinn-phong", "diffuse": 0.2, "specular": 0.2, "n": 30}),
        (20, 45),
        &blinn,
    );
    let out = dir.path().join("out");
    let args = |metrics: &str, test_env: &str| -> Vec<String> {
        [
            "fit",
            "compare-metrics",
            ward.to_str().unwrap(),
            blinn.to_str().unwrap(),
            "--models",
            "ward,blinn-phong",
            "--metrics",
            metrics,
            "--test-env",
            test_env,
            "--resolution",
            "6",
            "--size",
            "24",
            "--spp",
            "8",
            "-o",
            out.to_str().unwrap(),
            "-q",
        ]
        .map(String::from)
        .to_vec()
    };
    let o = lobe()
        .args(args("eq1,log", "builtin:sunset"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_each_data_fits_its_own_model_best(&csv);
    let md = std::fs::read_to_string(out.join("metrics.md")).unwrap();
    assert!(
        md.contains("| eq1 | 1.000 |") && md.contains("| log |"),
        "{md}"
    );
    // A rerun reuses the fits: each report untouched (same inode, same bytes).
    let identity = |p: &Path| {
        use std::os::unix::fs::MetadataExt;
        let m = std::fs::metadata(p).unwrap();
        (m.ino(), std::fs::read(p).unwrap())
    };
    let fits = out.join("fits");
    let reports = listing(&fits);
    assert_eq!(reports.len(), 4, "{reports:?}");
    let before: Vec<_> = reports.iter().map(|f| identity(&fits.join(f))).collect();
    let o = lobe()
        .args(args("eq1,log", "builtin:sunset"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let after: Vec<_> = reports.iter().map(|f| identity(&fits.join(f))).collect();
    assert!(before == after, "a rerun fitted again");
    assert_eq!(
        std::fs::read_to_string(out.join("metrics.csv")).unwrap(),
        csv
    );
    // Bad options.
    let bad = |metrics: &str, env: &str, needle: &str| {
        let a = args(metrics, env);
        fails(&a.iter().map(String::as_str).collect::<Vec<_>>(), needle);
    };
    bad("eq1,nope", "builtin:sunset", "--metrics");
    // The image metric fits under studio and sunset by default: neither is held out.
    bad("eq1,image", "builtin:sunset", "--test-env builtin:sunset");
    bad("eq1", dir.path().join("no.exr").to_str().unwrap(), "no.exr");
}

#[test]
fn batch_fits_refuse_clashing_reports_and_file_like_folders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("data")).unwrap();
    for name in ["a.bin", "a.binary"] {
        write_binned(
            serde_json::from_str(WARD).unwrap(),
            (8, 12),
            &d.join("data").join(name),
        );
    }
    refused_in(
        d,
        &["fit", "data", "-o", "reports"],
        &[
            "reports/a.fit.json",
            "report of data/a.binary",
            "report of data/a.bin",
        ],
    );
    refused_in(
        d,
        &["fit", "data", "-o", "x.fit.json"],
        &["x.fit.json", "looks like a file name", "folder of reports"],
    );
    std::fs::write(d.join("file"), "").unwrap();
    refused_in(d, &["fit", "data", "-o", "file"], &["is a file"]);
    assert_eq!(listing(d), ["data", "file"]);
}

/// The batch progress bar (drawn when stderr is a terminal: `script` provides one) counts
/// fitted models, files x models, so it moves as soon as the first model is fitted.
#[test]
fn the_batch_progress_bar_counts_models() {
    if Command::new("script").arg("--version").output().is_err() {
        lobe_tests::skip_on_this_machine(
            "the batch progress bar: no `script` command to run lobe on a pseudo-terminal",
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    for k in 0..3 {
        write_binned(
            serde_json::from_str(WARD).unwrap(),
            (8, 12),
            &data.join(format!("m{k}.bin")),
        );
    }
    let cmd = format!(
        "{} fit {} -o {} --models ward,blinn-phong",
        env!("CARGO_BIN_EXE_lobe"),
        data.display(),
        dir.path().join("reports").display()
    );
    let o = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .output()
        .unwrap();
    let shown = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{shown}");
    assert!(shown.contains("/6 models"), "{shown}");
    assert!(!shown.contains("/3 "), "{shown}");
}

/// A batch's reports are keyed by content: a rerun with more models adds them to the
/// report (keeping the models it had, bit for bit), and one with another metric, another
/// bin size, or other data under the same file name redoes the report (before keys each
/// of these said "already done" and kept the stale report). Reports of one name and
/// settings from different data do not merge.
#[test]
fn batch_fits_are_keyed_by_content() {
    let dir = tempfile::tempdir().unwrap();
    let (data, out) = (dir.path().join("data"), dir.path().join("reports"));
    std::fs::create_dir(&data).unwrap();
    let ward = |alpha: f64| serde_json::json!({"type": "ward", "diffuse": 0.1, "specular": 0.2, "alpha": alpha});
    write_binned(ward(0.1), (16, 36), &data.join("paint.bin"));
    let report = out.join("paint.fit.json");
    let fit = |extra: &[&str]| -> (String, serde_json::Value) {
        let mut a = vec!["fit", data.to_str().unwrap(), "-o", out.to_str().unwrap()];
        a.extend_from_slice(extra);
        let o = lobe().args(&a).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{err}");
        let v = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (err, v)
    };
    let (_, first) = fit(&["--models", "ward"]);
    assert_eq!(first["key"]["data"].as_str().unwrap().len(), 64);
    let (err, v) = fit(&["--models", "ward"]);
    assert!(err.contains("fitted 0 materials, 1 already done"), "{err}");
    assert_eq!(v, first);
    // More models: added, the old fit kept as it was.
    let (err, v) = fit(&["--models", "ward,lafortune"]);
    assert!(err.contains("fitted 1 materials, 0 already done"), "{err}");
    assert_eq!(v["models"]["ward"], first["models"]["ward"]);
    assert!(v["models"]["lafortune"]["error"].as_f64().unwrap() > 0.0);
    assert_eq!(v["key"], first["key"]);
    // Another metric or bin size: redone under another key.
    let (_, v) = fit(&["--models", "ward", "--metric", "log"]);
    assert_eq!(v["metric"], "log");
    assert_ne!(v["key"]["settings"], first["key"]["settings"]);
    assert!(v["models"].get("lafortune").is_none());
    let (_, v) = fit(&["--models", "ward", "--resolution", "6"]);
    assert_eq!(v["resolution_deg"], 6.0);
    // Other data under the same name: redone.
    let (_, before) = fit(&["--models", "ward"]);
    let old = dir.path().join("old");
    std::fs::create_dir(&old).unwrap();
    std::fs::copy(&report, old.join("paint.fit.json")).unwrap();
    write_binned(ward(0.3), (16, 36), &data.join("paint.bin"));
    let (_, v) = fit(&["--models", "ward"]);
    assert_ne!(v["key"]["data"], before["key"]["data"]);
    let alpha = v["models"]["ward"]["material"]["alpha"].as_f64().unwrap();
    assert!((alpha - 0.3).abs() < 0.03, "{alpha}");
    let o = lobe()
        .args(["fit", "merge", out.to_str().unwrap(), old.to_str().unwrap()])
        .args(["-o", dir.path().join("t").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("from different data"), "{err}");
}
