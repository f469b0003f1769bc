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
    let img = lobe_renderer::film::read_exr(&out).unwrap();
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
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("mitsuba/.venv/bin/idiff");
    if !idiff.exists() {
        eprintln!(
            "SKIPPED: {} is absent (run tools/mitsuba/setup.sh to create the venv)",
            idiff.display()
        );
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
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(&out), vec!["ct0.fit.json", "ct2.fit.json"]);
    run(&["--shard", "1/2"]);
    assert_eq!(names(&out).len(), 3);
    // A rerun skips what is done (the files are untouched).
    let before = std::fs::metadata(out.join("ct1.fit.json"))
        .unwrap()
        .modified()
        .unwrap();
    run(&[]);
    assert_eq!(
        std::fs::metadata(out.join("ct1.fit.json"))
            .unwrap()
            .modified()
            .unwrap(),
        before
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
    assert!(
        csv.starts_with("material,max_albedo,cook-torrance error,cook-torrance normalized error")
    );
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
        let want = if name == "s.png" {
            // Three spheres (the material, ward, lafortune) in one row with labels.
            (3 * 48, 48 + 30)
        } else {
            (1000, 600)
        };
        assert_eq!(img.dimensions(), want);
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
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = String::from_utf8_lossy(&o.stdout).to_string();
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
    // Any tolerance: the pick is the cheapest measured model.
    let s = run("1e12");
    let costs = s["costs"].as_object().unwrap();
    let total =
        |m: &str| costs[m]["eval_ns"].as_f64().unwrap() + costs[m]["sample_ns"].as_f64().unwrap();
    let cheapest = costs
        .keys()
        .min_by(|a, b| total(a).total_cmp(&total(b)))
        .unwrap();
    assert_eq!(s["model"].as_str().unwrap(), cheapest);
    assert!(
        total("he") > total("ward"),
        "He is measured costlier than Ward"
    );
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
            .take(9)
            .map(|x| x.parse().unwrap())
            .collect();
        assert!(f.iter().all(|x| x.is_finite() && *x >= 0.0), "{row}");
    }
    // Cook-Torrance data: the Cook-Torrance fit's BRDF error is below Ward's, and the
    // measured table holds far more memory than an analytic model.
    let col = |r: &str, k: usize| r.split(',').nth(k).unwrap().parse::<f64>().unwrap();
    assert!(col(rows[3], 1) < col(rows[2], 1));
    assert!(col(rows[0], 7) > 100.0 * col(rows[3], 7));
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
    // Columns 5 and 6 (non-finite, negative) are zero on every row.
    for row in out.lines().skip(2) {
        let cols: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!((cols[5], cols[6]), ("0", "0"), "{row}");
        assert!(
            cols[2].parse::<usize>().unwrap() > 0 || cols[1] == "rgl",
            "{row}"
        );
    }
}

/// Files in `dir` (names), sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

fn sigint(child: &std::process::Child) {
    let ok = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -INT failed");
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
    std::thread::sleep(std::time::Duration::from_millis(1500));
    sigint(&child);
    let o = child.wait_with_output().unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("interrupted"), "{err}");
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
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("interrupted"), "{err}");
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
        eprintln!("SKIPPED read-only folder case: permissions are not enforced (running as root)");
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
        eprintln!("SKIPPED full-disk case: cannot mount a tmpfs here");
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
