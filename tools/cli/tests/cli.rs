//! The `lobe` binary as a user meets it: a render writes EXR, PNG and JSON atomically;
//! bad input gives one line on stderr and a non-zero exit, and leaves nothing behind.

use std::path::Path;
use std::process::Command;

fn lobe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
}

const SCENE: &str = r#"{
  "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
  "film": {"width": 16, "height": 12},
  "sampler": {"spp": 4},
  "shapes": [{"type": "sphere"}],
  "lights": [{"type": "envmap", "file": "builtin:studio"}]
}"#;

#[test]
fn render_writes_exr_png_and_stats() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.path().join("img.exr");
    let o = lobe()
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--threads",
            "2",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("16x12 at 4 spp")
            && stderr.contains("Msamples/s")
            && stderr.contains("0 non-finite"),
        "{stderr}"
    );
    assert!(out.exists() && dir.path().join("img.png").exists());
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("img.stats.json")).unwrap())
            .unwrap();
    assert_eq!(stats["spp"], 4);
    assert_eq!(stats["nonfinite_dropped"], 0);
    let img = lobe_renderer::image_io::read_exr(&out).unwrap();
    assert_eq!((img.width, img.height), (16, 12));
    assert!(img.pixels.iter().all(|p| p.is_finite()) && img.mean().max_component() > 0.0);
    // No temporary files are left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
}

fn fails(args: &[&str], needle: &str) {
    let o = lobe().args(args).output().unwrap();
    assert!(!o.status.success(), "{args:?} succeeded");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains(needle), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"));
}

#[test]
fn bad_input_is_one_line_and_non_zero() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let s = scene.to_str().unwrap();
    fails(&["render", "/nonexistent/scene.json"], "does not exist");
    fails(&["render", dir.path().to_str().unwrap()], "is a directory");
    let missing_dir = dir.path().join("no/such/dir/out.exr");
    fails(
        &["render", s, "-o", missing_dir.to_str().unwrap()],
        "output folder",
    );
    fails(&["render", s, "--spp", "0"], "--spp");
    fails(&["render", s, "--threads", "0"], "--threads");
    let empty = dir.path().join("empty.json");
    std::fs::write(&empty, "").unwrap();
    fails(&["render", empty.to_str().unwrap()], "is empty");
}

#[test]
fn the_scene_file_is_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("x.json");
    std::fs::write(&scene, SCENE).unwrap();
    // The statistics go to x.stats.json, not x.json.
    let o = lobe()
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            dir.path().join("x.exr").to_str().unwrap(),
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), SCENE);
    assert!(dir.path().join("x.stats.json").exists());
    // Naming the scene itself as an output is refused.
    let copy = dir.path().join("y.png");
    std::fs::write(&copy, SCENE).unwrap();
    let o = lobe()
        .args([
            "render",
            copy.to_str().unwrap(),
            "-o",
            dir.path().join("y.exr").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("(the scene file), an input"));
    assert_eq!(std::fs::read_to_string(&copy).unwrap(), SCENE);
}

#[test]
fn a_failed_render_does_not_clobber_an_existing_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("keep.exr");
    std::fs::write(&out, b"precious").unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        r#"{"camera": {"type": "perspective"}, "shapes": [{"type": "sphere", "radius": -1}]}"#,
    )
    .unwrap();
    let o = lobe()
        .args(["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert_eq!(std::fs::read(&out).unwrap(), b"precious");
    assert!(!Path::new(&dir.path().join("keep.png")).exists());
}

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

#[test]
fn compare_agrees_with_openimageio_idiff() {
    let idiff =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../mitsuba/.venv/bin/idiff");
    if !idiff.exists() {
        lobe_tests::skip_on_this_machine(&format!(
            "the idiff cross-check: {} is absent (run tools/mitsuba/setup.sh to create the venv)",
            idiff.display()
        ));
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    for (out, seed) in [(&a, "1"), (&b, "2")] {
        let o = lobe()
            .args([
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--seed",
                seed,
                "-q",
            ])
            .output()
            .unwrap();
        assert!(o.status.success());
    }
    let o = lobe()
        .args([
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    let ours: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let o = Command::new(&idiff)
        .args(["-a", a.to_str().unwrap(), b.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    let field = |name: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.contains(name))
            .unwrap_or_else(|| panic!("idiff printed no {name}: {text}"));
        line.split('=').nth(1).unwrap().trim().parse().unwrap()
    };
    let (rmse, psnr) = (field("RMS error"), field("Peak SNR"));
    assert!(
        (ours["rmse"].as_f64().unwrap() - rmse).abs() <= 1e-5 * rmse.max(1e-12),
        "RMSE {} vs idiff {rmse}",
        ours["rmse"]
    );
    assert!(
        (ours["psnr"].as_f64().unwrap() - psnr).abs() <= 1e-3,
        "PSNR {} vs idiff {psnr}",
        ours["psnr"]
    );
}

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

/// Writes isotropic binned data of `material` (no acquisition noise, every bin filled):
/// `n_theta` bins of theta_i and theta_o over 0-80 degrees, `n_phi` of phi_d over 0-180.
fn write_binned(material: serde_json::Value, (n_theta, n_phi): (usize, usize), path: &Path) {
    use lobe_materials::measured::binned::{Axis, Binned};
    let mat = lobe_materials::registry::Registry::builtin()
        .create(&material, "m")
        .unwrap();
    let mut b = Binned::empty(
        false,
        vec![
            Axis::new(n_theta, 0.0, 80.0),
            Axis::new(n_theta, 0.0, 80.0),
            Axis::new(n_phi, 0.0, 180.0),
        ],
    );
    for i in 0..b.len() {
        let (wi, wo) = b.directions(i);
        b.values[i] = Some(mat.eval(wo, wi).to_array());
    }
    b.write(path).unwrap();
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
fn microfacet_synth_and_estimate_write_tables_plots_and_materials() {
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

/// `lobe fit compare-metrics`: every metric's fit of every model, rendered under the
/// held-out map against the data's own render; a model fits its own data best; the fits
/// are kept and reused when rerun; bad options are one-line errors.
#[test]
fn fit_compare_metrics_renders_each_metrics_fits_against_the_data() {
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
            // Eq. (1) error (column 4) near zero for the data's own model; its render
            // closer to the data's (RMSE, column 5) than the other model's.
            assert!(value(material, own, metric, 4) < 1e-3, "{csv}");
            assert!(value(material, other, metric, 4) > 1e-2, "{csv}");
            assert!(
                value(material, own, metric, 5) < value(material, other, metric, 5),
                "{csv}"
            );
        }
    }
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
fn resource_limits_are_one_line_errors_not_aborts() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let s = scene.to_str().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // Far more threads than any machine: refused at once (it ran for minutes).
    fails(
        &["render", s, "-o", &out("t.exr"), "--threads", "10000"],
        "expected 1 to 1024",
    );
    // Threads beyond the tile count are not started, and never change the image.
    let (a, b) = (out("one.exr"), out("many.exr"));
    for (o, t) in [(&a, "1"), (&b, "1000")] {
        let r = lobe()
            .args(["render", s, "-o", o, "--threads", t])
            .output()
            .unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    }
    let (ia, ib) = (
        lobe_renderer::image_io::read_exr(Path::new(&a)).unwrap(),
        lobe_renderer::image_io::read_exr(Path::new(&b)).unwrap(),
    );
    assert!(ia.pixels == ib.pixels);
    // A 16384^2 film (6 GiB) under a 2 GiB address-space limit: a clean error, no abort.
    let big = dir.path().join("big.json");
    std::fs::write(
        &big,
        SCENE.replace(
            r#""width": 16, "height": 12"#,
            r#""width": 16384, "height": 16384"#,
        ),
    )
    .unwrap();
    match Command::new("prlimit")
        .arg("--as=2147483648")
        .arg(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "render",
            big.to_str().unwrap(),
            "-o",
            &out("big.exr"),
            "--spp",
            "1",
        ])
        .output()
    {
        Ok(r) => {
            let stderr = String::from_utf8_lossy(&r.stderr);
            assert_eq!(r.status.signal(), None, "killed by a signal: {stderr}");
            assert_eq!(r.status.code(), Some(1), "{stderr}");
            assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
            assert!(
                stderr.contains("16384x16384 film") && stderr.contains("memory"),
                "{stderr}"
            );
            assert!(!dir.path().join("big.exr").exists());
        }
        Err(e) => eprintln!("prlimit unavailable ({e}): memory-limit case skipped"),
    }
}

/// Files in `dir` (names), sorted.
use lobe_tests::listing;

/// Sends SIGINT (what Ctrl-C sends) to `child`.
fn sigint(child: &std::process::Child) {
    #[cfg(unix)]
    {
        let pid = libc::pid_t::try_from(child.id()).unwrap();
        // SAFETY: kill(2) has no memory-safety preconditions.
        let ok = unsafe { libc::kill(pid, libc::SIGINT) } == 0;
        assert!(ok, "kill -INT {pid} failed");
    }
    #[cfg(not(unix))]
    {
        let ok = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok, "kill -INT failed");
    }
}

#[test]
fn ctrl_c_stops_a_render_without_output_and_a_batch_fit_without_losing_reports() {
    let dir = tempfile::tempdir().unwrap();
    // A render long enough to be interrupted.
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE.replace("\"spp\": 4", "\"spp\": 200000")).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let child = lobe()
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(out.join("img.exr"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Interrupted once lobe handles SIGINT (installed before the scene loads), long before
    // 200,000 spp can end: no guessed delay.
    assert!(lobe_tests::wait_for_signal_handler(
        child.id(),
        libc::SIGINT
    ));
    sigint(&child);
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("interrupted"), "{err}");
    assert!(err.contains("Ctrl-C again to abort"), "{err}");
    assert!(listing(&out).is_empty(), "{:?}", listing(&out));
    // A batch fit: interrupt after the first report, then resume.
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    for k in 0..6 {
        write_binned(
            serde_json::json!({"type": "ward", "diffuse": 0.1, "specular": 0.4, "alpha": 0.1 + 0.05 * k as f64}),
            (20, 45),
            &data.join(format!("m{k}.bin")),
        );
    }
    let reports = dir.path().join("reports");
    let args = [
        "fit",
        data.to_str().unwrap(),
        "-o",
        reports.to_str().unwrap(),
        "--models",
        "ward,he",
    ];
    let args = &args[..];
    let child = lobe()
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !reports.is_dir() || listing(&reports).iter().all(|f| !f.ends_with(".fit.json")) {
        assert!(t0.elapsed().as_secs() < 120, "no report appeared");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    sigint(&child);
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert!(
        err.contains("stopping the running fits now") && err.contains("Ctrl-C again to abort"),
        "{err}"
    );
    let kept = listing(&reports);
    assert!(!kept.is_empty() && kept.len() < 6, "{kept:?}");
    for f in &kept {
        assert!(f.ends_with(".fit.json"), "partial output left: {f}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(reports.join(f)).unwrap()).unwrap();
        assert!(v["models"]["he"]["error"].is_number(), "{f} is incomplete");
    }
    // The rerun resumes: the kept reports are untouched and the rest appear.
    let o = lobe().args(args).arg("-q").output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(listing(&reports).len(), 6);
}

#[test]
fn read_only_folders_and_full_disks_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    // A read-only output folder (root ignores permissions: then the case is skipped).
    let ro = dir.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(ro.join("probe"), b"x").is_ok() {
        lobe_tests::skip_on_this_machine(
            "the read-only folder case: permissions are not enforced (running as root)",
        );
        std::fs::remove_file(ro.join("probe")).unwrap();
    } else {
        fails(
            &[
                "render",
                scene.to_str().unwrap(),
                "-o",
                ro.join("x.exr").to_str().unwrap(),
            ],
            "x.exr",
        );
        assert!(listing(&ro).is_empty());
    }
    // An unreadable input (skipped as root too).
    let secret = dir.path().join("secret.json");
    std::fs::write(&secret, SCENE).unwrap();
    std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o000)).unwrap();
    if std::fs::read(&secret).is_err() {
        fails(&["render", secret.to_str().unwrap()], "secret.json");
    }
    // A full disk: a 64 KiB tmpfs, where mounting is allowed.
    let small = dir.path().join("small");
    std::fs::create_dir(&small).unwrap();
    let mounted = Command::new("mount")
        .args([
            "-t",
            "tmpfs",
            "-o",
            "size=64k",
            "tmpfs",
            small.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        lobe_tests::skip_on_this_machine("the full-disk case: cannot mount a tmpfs here");
        return;
    }
    let big = SCENE.replace(
        "\"width\": 16, \"height\": 12",
        "\"width\": 256, \"height\": 256",
    );
    std::fs::write(&scene, big).unwrap();
    let out = small.join("big.exr");
    let o = lobe()
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    let left = listing(&small);
    let _ = Command::new("umount").arg(&small).status();
    assert!(!o.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("big.exr"), "{err}");
    assert!(
        left.is_empty(),
        "partial output left on the full disk: {left:?}"
    );
}

/// Runs lobe in `dir`.
fn lobe_in(dir: &Path, args: &[&str]) -> std::process::Output {
    lobe().current_dir(dir).args(args).output().unwrap()
}

/// Runs lobe in `dir` and checks that it fails with one line holding every needle.
fn refused_in(dir: &Path, args: &[&str], needles: &[&str]) {
    let o = lobe_in(dir, args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{args:?} succeeded: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: no \"{n}\" in {stderr}");
    }
}

/// A small linear EXR of `w` x `h` pixels of value `v`.
fn write_exr(path: &Path, (w, h): (u32, u32), v: f32) {
    let px = vec![lobe_renderer::Rgb::splat(v); (w * h) as usize];
    lobe_renderer::image_io::write_exr(path, w, h, &px).unwrap();
}

const WARD: &str = r#"{"type": "ward", "diffuse": 0.1, "specular": 0.2, "alpha": 0.2}"#;

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("sub")).unwrap();
    write_binned(
        serde_json::from_str(WARD).unwrap(),
        (12, 24),
        &d.join("p.bin"),
    );
    let data = std::fs::read(d.join("p.bin")).unwrap();
    for out in ["p.bin", "./p.bin", "sub/../p.bin"] {
        refused_in(
            d,
            &["fit", "p.bin", "--models", "ward", "-o", out],
            &["would overwrite", "p.bin (the measured data)"],
        );
    }
    assert_eq!(std::fs::read(d.join("p.bin")).unwrap(), data);
    // A table read by the material, named directly or through a symlink.
    write_merl(&d.join("n.binary"));
    let merl = std::fs::read(d.join("n.binary")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(d.join("n.binary"), d.join("link.binary")).unwrap();
    for out in ["n.binary", "link.binary"] {
        let m = r#"{"type": "merl", "file": "n.binary"}"#;
        refused_in(
            d,
            &["tabulate", "--material", m, "-o", out],
            &["the table would overwrite", "n.binary"],
        );
    }
    assert!(std::fs::read(d.join("n.binary")).unwrap() == merl);
    // The heat map over the test image.
    write_exr(&d.join("t.exr"), (8, 8), 0.5);
    write_exr(&d.join("r.exr"), (8, 8), 0.4);
    let t = std::fs::read(d.join("t.exr")).unwrap();
    refused_in(
        d,
        &["compare", "t.exr", "r.exr", "--heatmap", "t.exr"],
        &["heat map would overwrite t.exr (the test image)"],
    );
    assert_eq!(std::fs::read(d.join("t.exr")).unwrap(), t);
    // Figures over their report.
    let o = lobe_in(
        d,
        &[
            "fit",
            "p.bin",
            "--models",
            "ward",
            "-o",
            "pw.fit.json",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = std::fs::read(d.join("pw.fit.json")).unwrap();
    let m = r#"{"type": "binned", "file": "p.bin"}"#;
    refused_in(
        d,
        &[
            "figure",
            "polar",
            "--material",
            m,
            "--report",
            "pw.fit.json",
            "-o",
            "pw.fit.json",
        ],
        &["figure would overwrite pw.fit.json (the fit report)"],
    );
    refused_in(
        d,
        &["figure", "errors", ".", "-o", "pw.fit.json"],
        &["figure would overwrite", "pw.fit.json (a fit report)"],
    );
    assert_eq!(std::fs::read(d.join("pw.fit.json")).unwrap(), report);
    // Merged tables over a report.
    std::fs::write(d.join("t.md"), &report).unwrap();
    refused_in(
        d,
        &["fit", "merge", "t.md", "-o", "t"],
        &["Markdown table would overwrite t.md (a fit report)"],
    );
    assert_eq!(std::fs::read(d.join("t.md")).unwrap(), report);
}

#[test]
fn render_never_writes_over_what_its_scene_reads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("envmaps")).unwrap();
    write_exr(&d.join("envmaps/e.exr"), (8, 4), 1.0);
    let env = std::fs::read(d.join("envmaps/e.exr")).unwrap();
    std::fs::write(
        d.join("s.json"),
        SCENE.replace("builtin:studio", "envmaps/e.exr"),
    )
    .unwrap();
    refused_in(
        d,
        &["render", "s.json", "-o", "envmaps/e.exr"],
        &["rendered EXR would overwrite", "lights[0].file of s.json"],
    );
    // Through another spelling of the folder, and from elsewhere.
    refused_in(
        d,
        &["render", "s.json", "-o", "./envmaps/../envmaps/e.png"],
        &["lights[0].file"],
    );
    assert_eq!(std::fs::read(d.join("envmaps/e.exr")).unwrap(), env);
    assert!(!d.join("envmaps/e.png").exists() && !d.join("envmaps/e.stats.json").exists());
    // A trade-off scene whose material reads a file the trade-off would write.
    write_binned(
        serde_json::from_str(WARD).unwrap(),
        (8, 12),
        &d.join("p.bin"),
    );
    let scene = serde_json::json!({
        "camera": {"type": "perspective", "origin": [0, 0, 4]},
        "materials": {
            "subject": {"type": "lambert"},
            "other": {"type": "sampled-microfacet", "distribution": "t-microfacet.exr"}
        },
        "shapes": [{"type": "sphere", "material": "subject"}]
    });
    std::fs::write(d.join("t.json"), scene.to_string()).unwrap();
    write_exr(&d.join("t-microfacet.exr"), (9, 9), 1.0);
    refused_in(
        d,
        &["tradeoff", "p.bin", "--scene", "t.json", "-o", "t"],
        &[
            "estimated distribution would overwrite",
            "materials.other of t.json",
        ],
    );
}

#[test]
fn render_outputs_follow_the_extension_of_o_and_never_collide() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), SCENE).unwrap();
    let o = lobe_in(d, &["render", "s.json", "-o", "x.png"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("wrote x.exr, x.png, x.stats.json"),
        "{stderr}"
    );
    assert!(
        std::fs::read(d.join("x.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    assert!(
        std::fs::read(d.join("x.exr"))
            .unwrap()
            .starts_with(&[0x76, 0x2f, 0x31, 0x01])
    );
    assert!(d.join("x.stats.json").exists());
    refused_in(
        d,
        &["render", "s.json", "-o", "y.jpg"],
        &["y.jpg", ".exr (or .png)"],
    );
    refused_in(d, &["render", "s.json", "-o", "y"], &["has no extension"]);
    refused_in(
        d,
        &["render", "s.json", "-o", "y.png", "--no-png"],
        &["--no-png writes none"],
    );
    assert_eq!(listing(d), ["s.json", "x.exr", "x.png", "x.stats.json"]);
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

#[test]
fn comparisons_fail_on_non_finite_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_exr(&d.join("a.exr"), (16, 16), 0.5);
    write_exr(&d.join("a.var.exr"), (16, 16), 1e-4);
    write_exr(&d.join("b.var.exr"), (16, 16), 1e-4);
    let mut px = vec![lobe_renderer::Rgb::splat(0.5); 256];
    px[3] = lobe_renderer::Rgb::splat(f32::NAN);
    px[200].b = f32::INFINITY;
    lobe_renderer::image_io::write_exr(&d.join("b.exr"), 16, 16, &px).unwrap();
    write_exr(&d.join("all.exr"), (16, 16), f32::NAN);
    let needle = "b.exr: 2 of 256 pixels are non-finite";
    refused_in(
        d,
        &["compare", "b.exr", "a.exr", "--fail-above", "rmse=0.01"],
        &[needle],
    );
    refused_in(
        d,
        &["compare", "a.exr", "b.exr", "--fail-below", "psnr=30"],
        &[needle],
    );
    refused_in(
        d,
        &["compare", "a.exr", "b.exr", "--z-test", "0.01"],
        &[needle],
    );
    refused_in(
        d,
        &["compare", "all.exr", "a.exr"],
        &["all.exr: 256 of 256 pixels"],
    );
    // NaN variances fail the z-test too, naming their file.
    write_exr(&d.join("c.exr"), (16, 16), 0.5);
    write_exr(&d.join("c.var.exr"), (16, 16), f32::NAN);
    refused_in(
        d,
        &["compare", "c.exr", "a.exr", "--z-test", "0.01"],
        &["c.var.exr: 256 of 256 pixels are non-finite"],
    );
    // SSIM is undefined under 8x8 pixels: a threshold on it fails rather than passes.
    write_exr(&d.join("s1.exr"), (4, 4), 0.5);
    write_exr(&d.join("s2.exr"), (4, 4), 0.5);
    refused_in(
        d,
        &["compare", "s1.exr", "s2.exr", "--fail-below", "ssim=0.5"],
        &["ssim is undefined"],
    );
}

#[test]
fn numeric_options_refuse_nan_and_infinity() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), SCENE).unwrap();
    for args in [
        &["render", "s.json", "--exposure", "nan"][..],
        &["compare", "a.exr", "b.exr", "--exposure=-inf"],
        &[
            "tabulate",
            "--material",
            WARD,
            "--noise",
            "NaN",
            "-o",
            "t.binary",
        ],
        &["fit", "x.bin", "--resolution", "inf", "-o", "r.fit.json"],
    ] {
        let o = lobe_in(d, args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            stderr.contains("expected a finite number"),
            "{args:?}: {stderr}"
        );
    }
    refused_in(
        d,
        &["eval", "--material", WARD, "--grid", "nan,0,0,0"],
        &["--grid: theta_i"],
    );
    assert_eq!(listing(d), ["s.json"]);
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

#[test]
fn json_mistakes_name_the_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("big.json"),
        SCENE.replace("\"fov\": 40", "\"fov\": 1e400"),
    )
    .unwrap();
    std::fs::write(
        d.join("nan.json"),
        SCENE.replace("\"fov\": 40", "\"fov\": NaN"),
    )
    .unwrap();
    for (f, token) in [("big.json", "1e400"), ("nan.json", "NaN")] {
        refused_in(
            d,
            &["render", f],
            &[
                &format!("{f}: line 2, column"),
                token,
                "JSON numbers must be finite",
            ],
        );
    }
    refused_in(
        d,
        &[
            "eval",
            "--material",
            r#"{"type": "ward", "alpha": NaN}"#,
            "--grid",
            "0,0,0,0",
        ],
        &["--material: line 1, column", "must be finite"],
    );
    let dup = SCENE.replacen(
        "{",
        r#"{"materials": {"m": {"type": "lambert"}, "m": {"type": "ward"}},"#,
        1,
    );
    std::fs::write(d.join("dup.json"), dup).unwrap();
    refused_in(
        d,
        &["render", "dup.json"],
        &["dup.json", "materials.m", "given twice"],
    );
    assert_eq!(listing(d), ["big.json", "dup.json", "nan.json"]);
}

#[test]
fn the_showcase_labels_its_models() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = lobe_in(d, &["render", "--spp", "1", "-o", "x.exr"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("cook-torrance, ashikhmin-shirley, ward-anisotropic, he, lafortune"),
        "{stderr}"
    );
    // The PNG is the tonemapped EXR plus the labels.
    let exr = lobe_renderer::image_io::read_exr(&d.join("x.exr")).unwrap();
    let tonemapped = lobe_renderer::film::tonemap(&exr.pixels, 0.0);
    let png = image::open(d.join("x.png")).unwrap().to_rgb8().into_raw();
    assert_eq!(png.len(), tonemapped.len());
    let changed = png
        .chunks(3)
        .zip(tonemapped.chunks(3))
        .filter(|(a, b)| a != b)
        .count();
    assert!(changed > 500, "{changed} labelled pixels");
    assert!(changed < png.len() / 3 / 10, "{changed} labelled pixels");
}

#[test]
fn help_texts_name_real_files_and_every_output() {
    let help = |args: &[&str]| {
        let o = lobe().args(args).arg("--help").output().unwrap();
        assert!(o.status.success());
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let render = help(&["render"]);
    assert!(
        render.contains("out/showcase.exr, .png, .stats.json"),
        "{render}"
    );
    assert!(!render.contains("showcase.{exr,png,json}"));
    let compare = help(&["compare"]);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut named = 0;
    for word in compare.split_whitespace() {
        if word.starts_with("reference-images/") {
            assert!(root.join(word).exists(), "compare --help names {word}");
            named += 1;
        }
    }
    assert!(named >= 2, "{compare}");
    for fig in ["errors", "multilobe", "polar", "spheres", "lobes"] {
        let h = help(&["figure", fig]);
        let line = h
            .lines()
            .find(|l| l.trim_start().starts_with("-o, --output"))
            .unwrap();
        assert!(line.contains("Output PNG file"), "figure {fig}: {line}");
    }
}

/// A full MERL table (35 MB) of the Ward material [`WARD`].
fn write_merl(path: &Path) {
    let ward = lobe_materials::registry::Registry::builtin()
        .create(&serde_json::from_str(WARD).unwrap(), "m")
        .unwrap();
    lobe_materials::measured::tabulate::merl_from(&|wo, wi| ward.eval(wo, wi), &Default::default())
        .write(path)
        .unwrap();
}

/// A second Ctrl-C exits at once, even while the first waits for work that cannot stop
/// (reading and binning a MERL table, about half a second). The first Ctrl-C is sent
/// once the batch says it reads the table: sent earlier, the batch would stop before
/// reading and exit before the second one.
#[test]
fn a_second_ctrl_c_exits_at_once() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    write_merl(&data.join("m.binary"));
    let reports = dir.path().join("reports");
    let mut child = lobe()
        .args([
            "fit",
            data.to_str().unwrap(),
            "-o",
            reports.to_str().unwrap(),
        ])
        .args(["--models", "he"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut err = String::new();
    while !err.contains("m: reading the data") {
        let n = stderr.read_line(&mut err).unwrap();
        assert!(n > 0, "the batch ended before reading its data: {err}");
    }
    sigint(&child);
    while !err.contains("Ctrl-C again to abort") {
        let n = stderr.read_line(&mut err).unwrap();
        assert!(n > 0, "the first Ctrl-C was not acknowledged: {err}");
    }
    sigint(&child);
    let status = child.wait().unwrap();
    std::io::Read::read_to_string(&mut stderr, &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(
        err.contains("Ctrl-C again to abort") && err.contains("lobe: aborted"),
        "{err}"
    );
    assert!(listing(&reports).is_empty(), "{:?}", listing(&reports));
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

/// The README's "Other commands" are consistent as written, without running them (together
/// they take minutes): the binary is installed first (the text says how), every output
/// goes under out/, and every file a command reads is in the repository, in
/// ../shared/data, or written by an earlier line.
#[test]
fn readme_commands_read_existing_files_and_write_under_out() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let section = readme
        .split("## Other commands")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("an Other commands section");
    assert!(
        section.contains("cargo install --path tools/cli"),
        "{section}"
    );
    let block = section.split("```").nth(1).expect("a code block");
    let mut written: Vec<String> = Vec::new();
    for line in block.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let cmd = line.split("  #").next().unwrap().trim();
        let words: Vec<&str> = cmd.split_whitespace().collect();
        let first = words.iter().position(|w| *w == "lobe").unwrap_or(0);
        let known = ["lobe", "mkdir", "tools/mitsuba/bench.sh", "scripts/fuzz.sh"];
        assert!(known.contains(&words[first]), "{line}");
        if words[first] != "lobe" {
            continue;
        }
        // Outputs: after -o and --heatmap, all under out/.
        let mut outputs = Vec::new();
        for w in words.windows(2) {
            if ["-o", "--heatmap"].contains(&w[0]) {
                assert!(w[1].starts_with("out/"), "{line}: writes {}", w[1]);
                outputs.push(w[1].trim_end_matches('/').to_string());
            }
        }
        // Inputs: path-like words and the "file" of JSON descriptions.
        let mut inputs: Vec<String> = words
            .windows(2)
            .filter(|w| !["-o", "--heatmap"].contains(&w[0]))
            .map(|w| w[1].trim_matches(['\'', '"', ',', '}']).to_string())
            .filter(|w| w.contains('/') && !w.starts_with("docs/") && !w.contains(".."))
            .chain(
                cmd.split("\"file\": \"")
                    .skip(1)
                    .map(|s| s.split('"').next().unwrap().to_string()),
            )
            .collect();
        inputs.extend(
            words
                .iter()
                .filter(|w| w.starts_with("../shared/data"))
                .map(|w| w.to_string()),
        );
        for i in inputs {
            let shared = i.starts_with("../shared/data");
            let made = written
                .iter()
                .any(|o| i == *o || i.starts_with(&format!("{o}/")));
            assert!(
                made || shared || root.join(&i).exists(),
                "{line}: reads {i}, which is neither in the repository nor written before"
            );
            if shared && shared_data().is_some() {
                assert!(
                    root.join(&i).exists(),
                    "{line}: {i} is not in ../shared/data"
                );
            }
        }
        written.extend(outputs);
    }
    assert!(written.len() >= 10, "{written:?}");
}

/// ../shared/data next to the repository, if present.
fn shared_data() -> Option<std::path::PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    p.is_dir().then_some(p)
}

/// `lobe study` refuses, in one line naming the problem, missing data, a bad shard, data
/// inside the study folder and a study folder made with other settings.
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

/// Output piped into a reader that has gone (`lobe models | head -1`) ends the process
/// quietly, as Unix tools end (by SIGPIPE), instead of with a panic in `println!`.
#[cfg(unix)]
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

#[test]
fn a_closed_stdout_ends_the_process_without_a_panic() {
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    // A pipe whose reading end is closed before the process starts: every write fails,
    // however fast the process is (closing it after the spawn raced with the writes).
    let mut fds = [0; 2];
    // SAFETY: pipe(2) fills the two descriptors it is given.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    // SAFETY: both descriptors were just created and are owned here alone.
    let (read_end, write_end) =
        unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
    drop(read_end);
    let child = lobe()
        .arg("models")
        .stdout(Stdio::from(write_end))
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {err}",
        out.status
    );
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

/// `--samples A:B` writes a partial render and `render merge` joins parts of disjoint
/// ranges into the whole render's image (to within one f32 step per pixel); a merge of
/// parts that miss samples is refused and writes nothing.
#[test]
fn partial_renders_merge_into_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), SCENE.replace("\"spp\": 4", "\"spp\": 8")).unwrap();
    let run = |args: &[&str]| {
        let o = lobe_in(d, args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    run(&["render", "s.json", "-o", "whole.exr", "-q"]);
    run(&[
        "render",
        "s.json",
        "--samples",
        "3:8",
        "-o",
        "b.lobepart",
        "-q",
    ]);
    run(&[
        "render",
        "s.json",
        "--samples",
        "0:3",
        "-o",
        "a.lobepart",
        "-q",
    ]);
    refused_in(
        d,
        &["render", "merge", "b.lobepart", "-o", "m.exr"],
        &["expected every sample"],
    );
    assert!(!d.join("m.exr").exists());
    run(&[
        "render",
        "merge",
        "b.lobepart",
        "a.lobepart",
        "-o",
        "m.exr",
        "-q",
    ]);
    let read = |f: &str| lobe_renderer::image_io::read_exr(&d.join(f)).unwrap();
    let (w, m) = (read("whole.exr"), read("m.exr"));
    for (a, b) in w.pixels.iter().zip(&m.pixels) {
        for (x, y) in a.to_array().iter().zip(b.to_array()) {
            assert!((x - y).abs() <= 1e-6 * x.abs().max(1e-30), "{x} vs {y}");
        }
    }
    refused_in(
        d,
        &["render", "s.json", "--samples", "4:9", "-o", "c.lobepart"],
        &["samples 4:9", "expected a range"],
    );
    refused_in(
        d,
        &["render", "s.json", "--samples", "0:4", "-o", "c.exr"],
        &["expected -o NAME.lobepart"],
    );
}
