//! Command-line options that no other test exercised, each checked by its effect: what
//! changes in the output when the option is given.

use std::path::Path;
use std::process::{Command, Output};

fn lobe_in(dir: &Path, args: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

const SCENE: &str = r#"{
  "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
  "film": {"width": 16, "height": 12},
  "sampler": {"spp": 4},
  "materials": {"red": {"type": "ward", "diffuse": [0.6, 0.1, 0.05], "specular": [0.3, 0.05, 0.02], "alpha": 0.2}},
  "shapes": [{"type": "sphere", "material": "red"}],
  "lights": [{"type": "envmap", "file": "builtin:studio"}]
}"#;

/// A folder holding two renders of [`SCENE`] with seeds 1 and 2 (a.exr, b.exr; with
/// their variances when `variance`).
fn two_renders(variance: bool) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), SCENE).unwrap();
    for (name, seed) in [("a", "1"), ("b", "2")] {
        let out = format!("{name}.exr");
        let mut args = vec!["render", "s.json", "-o", &out, "--seed", seed];
        if variance {
            args.push("--variance");
        }
        lobe_in(d, &args);
    }
    dir
}

#[test]
fn models_lists_every_registered_model_with_its_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let reg = lobe_materials::registry::Registry::builtin();
    let mut want: Vec<String> = reg.names().map(str::to_string).collect();
    want.sort();
    let names = lobe_in(dir.path(), &["models", "--names"]);
    let mut got: Vec<String> = String::from_utf8(names.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    got.sort();
    assert_eq!(got, want);
    let full = String::from_utf8(lobe_in(dir.path(), &["models"]).stdout).unwrap();
    assert_eq!(full, reg.reference_markdown());
    assert!(
        full.contains("| `alpha` | number | lobe shape | (0, 10] |"),
        "{full}"
    );
}

#[test]
fn bench_times_the_runs_it_is_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.json"), SCENE).unwrap();
    for runs in ["1", "3"] {
        let o = lobe_in(dir.path(), &["render", "s.json", "--bench", "--runs", runs]);
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains(&format!("over {runs} runs")), "{out}");
        let err = String::from_utf8_lossy(&o.stderr);
        let timed = err.lines().filter(|l| l.starts_with("run ")).count();
        assert_eq!(timed.to_string(), runs, "{err}");
    }
}

#[test]
fn the_degrees_of_freedom_of_variances_change_the_z_test() {
    let dir = two_renders(true);
    let d = dir.path();
    let min_p = |extra: &[&str]| {
        let mut args = vec!["compare", "a.exr", "b.exr", "--z-test", "0.01", "--json"];
        args.extend_from_slice(extra);
        let v: serde_json::Value = serde_json::from_slice(&lobe_in(d, &args).stdout).unwrap();
        v["z_test"]["min_p"].as_f64().unwrap()
    };
    let normal = min_p(&[]);
    // Variances from 3 samples (4 spp) are uncertain: Student's t with few degrees of
    // freedom has heavier tails than the normal, so the smallest p-value grows.
    let t = min_p(&["--test-dof", "3", "--reference-dof", "3"]);
    assert!(t > normal, "dof 3: {t} vs normal {normal}");
    let one_side = min_p(&["--test-dof", "3"]);
    assert!(
        one_side > normal && one_side <= t * 1.0001,
        "{one_side} {normal} {t}"
    );
}

#[test]
fn a_scene_material_is_taken_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.json"), SCENE).unwrap();
    let by_name = lobe_in(
        d,
        &[
            "eval",
            "--scene",
            "s.json",
            "--name",
            "red",
            "--grid",
            "30,0,30,180",
        ],
    );
    let desc = r#"{"type": "ward", "diffuse": [0.6, 0.1, 0.05], "specular": [0.3, 0.05, 0.02], "alpha": 0.2}"#;
    let direct = lobe_in(d, &["eval", "--material", desc, "--grid", "30,0,30,180"]);
    assert_eq!(by_name.stdout, direct.stdout);
    assert!(!by_name.stdout.is_empty());
}

#[test]
fn figure_channels_draw_the_channel_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let red = r#"{"type": "ward", "diffuse": [0.6, 0.1, 0.05], "specular": [0.3, 0.05, 0.02], "alpha": 0.2}"#;
    let grey = r#"{"type": "ward", "diffuse": 0.6, "specular": 0.3, "alpha": 0.2}"#;
    let svg = |material: &str, channel: &str, name: &str| {
        lobe_in(
            d,
            &[
                "figure",
                "polar",
                "--material",
                material,
                "--channel",
                channel,
                "-o",
                name,
            ],
        );
        std::fs::read_to_string(d.join(name).with_extension("svg")).unwrap()
    };
    // A red material drawn in red is the grey one of the same red channel; in blue, not.
    assert_eq!(svg(red, "0", "r0.png"), svg(grey, "0", "g0.png"));
    assert_ne!(svg(red, "2", "r2.png"), svg(grey, "2", "g2.png"));
}

#[test]
fn ngan_fits_are_named_by_material_and_model() {
    let Some(_) = lobe_tests::shared_data_or_skip("eval --ngan (the Ngan et al. fits)") else {
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let grid = "45,0,0..80..20,180";
    let a = lobe_in(
        &root,
        &[
            "eval",
            "--ngan",
            "nickel",
            "--model",
            "cook-torrance",
            "--grid",
            grid,
        ],
    );
    let b = lobe_in(
        &root,
        &[
            "eval", "--ngan", "nickel", "--model", "ward", "--grid", grid,
        ],
    );
    let c = lobe_in(
        &root,
        &[
            "eval",
            "--ngan",
            "gold-paint",
            "--model",
            "cook-torrance",
            "--grid",
            grid,
        ],
    );
    assert!(!a.stdout.is_empty() && a.stdout != b.stdout && a.stdout != c.stdout);
}

#[test]
fn compare_takes_the_noise_out_of_the_rmse_of_two_renders_of_one_scene() {
    // Two seeds of one scene differ only by noise: the RMSE without noise is compatible
    // with zero, and the noise floor is at least the plain RMSE (a Sobol' render's
    // per-pixel sample variance overstates the variance of its mean, so the floor is an
    // upper bound).
    let dir = two_renders(true);
    let d = dir.path();
    let args = ["compare", "a.exr", "b.exr", "--z-test", "0.01", "--json"];
    let v: serde_json::Value = serde_json::from_slice(&lobe_in(d, &args).stdout).unwrap();
    let (plain, n) = (v["rmse"].as_f64().unwrap(), &v["noise"]);
    let floor = n["noise_floor"].as_f64().unwrap();
    assert!(floor > 0.9 * plain, "{plain} vs {n}");
    assert_eq!(n["ci95"][0].as_f64(), Some(0.0), "{n}");
    assert!(
        n["rmse_without_noise"].as_f64().unwrap() < 0.5 * plain,
        "{n}"
    );
    // Without --json the last line is the verdict.
    let o = lobe_in(d, &["compare", "a.exr", "b.exr", "--z-test", "0.01"]);
    let out = String::from_utf8_lossy(&o.stdout);
    let last = out.lines().last().unwrap_or("");
    assert!(last.starts_with("PASS: 0 of "), "{out}");
}

#[test]
fn the_flip_heat_map_carries_its_colour_bar_and_scale() {
    let dir = two_renders(false);
    let d = dir.path();
    lobe_in(d, &["compare", "a.exr", "b.exr", "--heatmap", "h.png"]);
    let png = std::fs::read(d.join("h.png")).unwrap();
    // IHDR: width and height, big-endian, at bytes 16..24.
    let (w, h) = (
        u32::from_be_bytes(png[16..20].try_into().unwrap()),
        u32::from_be_bytes(png[20..24].try_into().unwrap()),
    );
    // The 16 x 12 map, widened to hold the bar's scale, with 48 rows of bar under it.
    assert_eq!((w, h), (220, 12 + 48));
}

#[test]
fn a_comparison_with_thresholds_ends_with_its_verdict() {
    let dir = two_renders(false);
    let d = dir.path();
    let last = |o: &Output| {
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        out.lines().last().unwrap_or("").to_string()
    };
    let o = lobe_in(d, &["compare", "a.exr", "b.exr", "--fail-above", "rmse=10"]);
    assert_eq!(last(&o), "PASS: all 1 thresholds met");
    let o = Command::new(env!("CARGO_BIN_EXE_lobe"))
        .current_dir(d)
        .args(["compare", "a.exr", "b.exr", "--fail-above", "rmse=0"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(last(&o).starts_with("FAIL: missed: rmse "), "{}", last(&o));
}
