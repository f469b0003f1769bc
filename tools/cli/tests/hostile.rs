//! Hostile input, third round (docs/robustness.md): cases that once crashed, passed
//! silently or lost a user's work, each ending now in a one-line error or a right answer.

use std::path::Path;
use std::process::{Command, Output};

fn lobe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    lobe().current_dir(dir).args(args).output().unwrap()
}

/// `args` fails with one line on stderr holding every needle, and no panic or abort.
fn refused(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let o = run_in(dir, args);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {err} lacks {n:?}");
    }
    err
}

use lobe_tests::listing;

const SCENE: &str = r#"{
  "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
  "film": {"width": 16, "height": 12},
  "sampler": {"spp": 4},
  "shapes": [{"type": "sphere", "material": "m"}],
  "materials": {"m": MATERIAL},
  "lights": [{"type": "envmap", "file": "builtin:studio"}]
}"#;

/// A fit report whose ward model is `material`.
fn report(material: serde_json::Value) -> String {
    serde_json::json!({
        "format_version": 3, "material": "m", "source": "m.binary", "resolution_deg": 1.0,
        "samples": 100, "max_albedo": 0.5,
        "models": {"ward": {"material": material, "error": 0.1, "error_normalized": 0.2,
                            "starts": 1, "starts_agreeing": 1, "evaluations": 10, "seconds": 0.1}}
    })
    .to_string()
}

#[test]
fn fit_reports_that_name_themselves_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fit = |file: &str| serde_json::json!({"type": "fit", "file": file, "model": "ward"});
    std::fs::write(d.join("self.fit.json"), report(fit("self.fit.json"))).unwrap();
    std::fs::write(d.join("a.fit.json"), report(fit("b.fit.json"))).unwrap();
    std::fs::write(d.join("b.fit.json"), report(fit("a.fit.json"))).unwrap();
    for file in ["self.fit.json", "a.fit.json"] {
        let m = fit(file).to_string();
        let scene = SCENE.replace("MATERIAL", &m);
        std::fs::write(d.join("s.json"), scene).unwrap();
        let cases: [&[&str]; 4] = [
            &["tabulate", "--material", &m, "-o", "t.binary"],
            &["render", "s.json", "-o", "r.exr"],
            &["eval", "--material", &m, "--grid", "30,0,30,180"],
            &[
                "figure",
                "polar",
                "--material",
                &m,
                "--report",
                file,
                "-o",
                "p.png",
            ],
        ];
        for args in cases {
            refused(d, args, &["expected an analytic model or a composite"]);
        }
        let before = listing(d);
        assert!(
            !before
                .iter()
                .any(|f| f.starts_with("t.") || f.starts_with("r."))
        );
    }
}

/// Writes an RGB OpenEXR image of `size` whose data window starts at `origin` (its
/// display window is the data window unless `display` is given).
fn write_exr_at(
    path: &Path,
    size: (usize, usize),
    origin: (i32, i32),
    display: Option<((i32, i32), (usize, usize))>,
) {
    use exr::prelude::*;
    let channels =
        SpecificChannels::rgb(|p: Vec2<usize>| (p.x() as f32 * 0.1, p.y() as f32 * 0.05, 0.5));
    let mut layer = Layer::new(
        size,
        LayerAttributes::named("rgb"),
        Encoding::FAST_LOSSLESS,
        channels,
    );
    layer.attributes.layer_position = Vec2(origin.0, origin.1);
    let mut image = Image::from_layer(layer);
    image.attributes.display_window = match display {
        Some((o, s)) => IntegerBounds::new(o, s),
        None => IntegerBounds::new(origin, size),
    };
    image.write().to_file(path).unwrap();
}

#[test]
fn images_whose_windows_differ_are_not_compared_and_crops_are_no_environment_maps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_exr_at(&d.join("at0.exr"), (32, 32), (0, 0), None);
    write_exr_at(&d.join("at57.exr"), (32, 32), (5, 7), None);
    refused(
        d,
        &["compare", "at57.exr", "at0.exr"],
        &["at57.exr", "data window (5,7)-(36,38)", "(0,0)-(31,31)"],
    );
    // The same pixels over the same windows compare equal.
    write_exr_at(&d.join("again57.exr"), (32, 32), (5, 7), None);
    let o = run_in(d, &["compare", "at57.exr", "again57.exr", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["rmse"], 0.0);
    // A crop of a larger frame is no environment map.
    write_exr_at(
        &d.join("crop.exr"),
        (32, 16),
        (0, 0),
        Some(((0, 0), (64, 32))),
    );
    let scene = SCENE
        .replace("MATERIAL", r#"{"type": "lambert"}"#)
        .replace("builtin:studio", "crop.exr");
    std::fs::write(d.join("s.json"), scene).unwrap();
    refused(
        d,
        &["render", "s.json", "-o", "r.exr"],
        &[
            "crop.exr",
            "differs from display window",
            "expected a whole image",
        ],
    );
}

#[test]
fn a_variance_image_of_another_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for f in ["t", "r"] {
        write_exr_at(&d.join(format!("{f}.exr")), (32, 32), (0, 0), None);
    }
    write_exr_at(&d.join("r.var.exr"), (32, 32), (0, 0), None);
    for size in [(1, 1), (64, 64), (32, 31)] {
        write_exr_at(&d.join("t.var.exr"), size, (0, 0), None);
        refused(
            d,
            &["compare", "t.exr", "r.exr", "--z-test", "0.01"],
            &["t.var.exr", "expected the size of t.exr, 32x32"],
        );
    }
    write_exr_at(&d.join("t.var.exr"), (32, 32), (0, 0), None);
    let o = run_in(d, &["compare", "t.exr", "r.exr", "--z-test", "0.01"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Sends `signal` to `child`.
fn signal(child: &std::process::Child, signal: libc::c_int) {
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    // SAFETY: kill(2) has no memory-safety preconditions.
    assert_eq!(unsafe { libc::kill(pid, signal) }, 0);
}

/// Renders `s.json` to out.exr with its variance, PNG and statistics.
fn render_args<'a>() -> [&'a str; 5] {
    ["render", "s.json", "-o", "out.exr", "--variance"]
}

fn write_scene(d: &Path, spp: u32, size: u32) {
    let scene = SCENE
        .replace("MATERIAL", r#"{"type": "lambert"}"#)
        .replace("\"spp\": 4", &format!("\"spp\": {spp}"))
        .replace(
            "\"width\": 16, \"height\": 12",
            &format!("\"width\": {size}, \"height\": {size}"),
        );
    std::fs::write(d.join("s.json"), scene).unwrap();
}

const OUTPUTS: [&str; 4] = ["out.exr", "out.png", "out.stats.json", "out.var.exr"];

/// The bytes of every output of a render, in [`OUTPUTS`] order.
fn outputs(d: &Path) -> Vec<Vec<u8>> {
    OUTPUTS
        .iter()
        .map(|f| std::fs::read(d.join(f)).unwrap())
        .collect()
}

#[test]
fn sigterm_stops_a_render_like_ctrl_c_and_keeps_the_old_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_scene(d, 4, 16);
    assert!(run_in(d, &render_args()).status.success());
    let old = outputs(d);
    write_scene(d, 400_000, 16);
    let child = lobe()
        .current_dir(d)
        .args(render_args())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Sent once lobe handles SIGTERM (its handler is installed before the scene loads),
    // long before the render of 400,000 spp can end.
    assert!(
        lobe_tests::wait_for_signal_handler(child.id(), libc::SIGTERM),
        "lobe never installed a SIGTERM handler"
    );
    signal(&child, libc::SIGTERM);
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("nothing is written"), "{err}");
    assert_eq!(outputs(d), old, "the old outputs changed");
    let mut expected: Vec<&str> = OUTPUTS.to_vec();
    expected.push("s.json");
    assert_eq!(listing(d), expected);
}

/// A render killed (SIGKILL) at any moment leaves either the old set of outputs or the
/// whole new one, and no temporary file: the outputs are staged unnamed and moved into
/// place together.
#[test]
fn a_killed_render_leaves_the_old_set_or_the_new_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_scene(d, 1, 16);
    assert!(run_in(d, &render_args()).status.success());
    let mut expected: Vec<&str> = OUTPUTS.to_vec();
    expected.push("s.json");
    // A film large enough that writing it takes a while, at few samples.
    write_scene(d, 2, 1500);
    for delay_ms in [150, 300, 450, 600, 800, 1000, 1300] {
        let old = outputs(d);
        let seed = delay_ms.to_string();
        let mut child = lobe()
            .current_dir(d)
            .args(render_args())
            .args(["--seed", &seed])
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        signal(&child, libc::SIGKILL);
        let _ = child.wait();
        assert_eq!(listing(d), expected, "killed after {delay_ms} ms");
        let now = outputs(d);
        let changed: Vec<bool> = now.iter().zip(&old).map(|(a, b)| a != b).collect();
        // The first render was 16x16, so the new set differs in every file.
        assert!(
            changed.iter().all(|&c| c) || changed.iter().all(|&c| !c),
            "killed after {delay_ms} ms: a mixed set {changed:?} of {OUTPUTS:?}"
        );
    }
}

/// Binned isotropic data (5-degree bins to 80 degrees) of value `f(wi, wo)` in every bin.
fn write_binned(path: &Path, f: impl Fn(glam::Vec3, glam::Vec3) -> [f32; 3]) {
    use lobe_materials::measured::binned::{Axis, Binned};
    let mut b = Binned::empty(
        false,
        vec![
            Axis::new(16, 0.0, 80.0),
            Axis::new(16, 0.0, 80.0),
            Axis::new(36, 0.0, 180.0),
        ],
    );
    for i in 0..b.len() {
        let (wi, wo) = b.directions(i);
        b.values[i] = Some(f(wi, wo));
    }
    b.write(path).unwrap();
}

fn ward_data(wi: glam::Vec3, wo: glam::Vec3) -> [f32; 3] {
    let ward = lobe_materials::registry::Registry::builtin()
        .create(
            &serde_json::json!({"type": "ward", "diffuse": 0.3, "specular": 0.2, "alpha": 0.2}),
            "m",
        )
        .unwrap();
    ward.eval(wo, wi).to_array()
}

/// A quick study of `data` into `s` under the studio map.
const STUDY: &[&str] = &[
    "study",
    "data",
    "--quick",
    "-o",
    "s",
    "--env",
    "builtin:studio",
];

#[test]
fn a_study_goes_on_past_a_corrupt_file_and_lists_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("data")).unwrap();
    write_binned(&d.join("data/good.bin"), ward_data);
    std::fs::write(d.join("data/broken.bsdf"), b"tensor_file\0garbage").unwrap();
    let o = run_in(d, STUDY);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("broken failed")
            && err.contains("broken.bsdf")
            && err.contains("1 of 2 materials failed"),
        "{err}"
    );
    let index = std::fs::read_to_string(d.join("s/index.html")).unwrap();
    assert!(
        index.contains("Materials that failed") && index.contains("broken"),
        "no failure list"
    );
    assert!(d.join("s/materials/good.html").exists());
    assert!(!d.join("s/materials/broken.html").exists());
    assert!(
        err.lines()
            .any(|l| l.starts_with("FAIL: 1 of 2 materials failed")),
        "no verdict: {err}"
    );
    // Without the broken file the study ends with a PASS line naming the targets of its
    // one material-map.
    std::fs::remove_file(d.join("data/broken.bsdf")).unwrap();
    let o = run_in(d, STUDY);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("PASS: 1 material done; of 1 material-map, "),
        "{err}"
    );
}

#[cfg(unix)]
#[test]
fn devices_pipes_and_oversized_files_are_refused_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    for special in ["/dev/zero", "fifo"] {
        let shape = |s: &str| {
            SCENE
                .replace("MATERIAL", r#"{"type": "lambert"}"#)
                .replace(r#"{"type": "sphere", "material": "m"}"#, s)
        };
        std::fs::write(
            d.join("obj.json"),
            shape(&format!(
                r#"{{"type": "obj", "file": "{special}", "material": "m"}}"#
            )),
        )
        .unwrap();
        std::fs::write(
            d.join("gltf.json"),
            shape(&format!(
                r#"{{"type": "gltf", "file": "{special}", "material": "m"}}"#
            )),
        )
        .unwrap();
        let fit = serde_json::json!({"type": "fit", "file": special, "model": "ward"}).to_string();
        let merl = serde_json::json!({"type": "merl", "file": special}).to_string();
        let at = format!("@{special}");
        let cases: [&[&str]; 7] = [
            &["render", special, "-o", "r.exr"],
            &["render", "obj.json", "-o", "r.exr"],
            &["render", "gltf.json", "-o", "r.exr"],
            &["tabulate", "--material", &at, "-o", "t.binary"],
            &["tabulate", "--material", &fit, "-o", "t.binary"],
            &["tabulate", "--material", &merl, "-o", "t.binary"],
            &["compare", special, special],
        ];
        for args in cases {
            let t0 = std::time::Instant::now();
            refused(d, args, &[special, "not a regular file"]);
            assert!(
                t0.elapsed().as_secs() < 20,
                "{args:?} took {:?}",
                t0.elapsed()
            );
        }
    }
}

#[test]
fn fits_that_would_not_load_are_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 0.5 1/sr everywhere reflects pi / 2 of the light: no diffuse colour in [0, 1] fits.
    write_binned(&d.join("bright.bin"), |_, _| [0.5; 3]);
    refused(
        d,
        &[
            "fit",
            "bright.bin",
            "--models",
            "ward",
            "-o",
            "b.fit.json",
            "-q",
        ],
        &[
            "bright.bin",
            "ward",
            "diffuse",
            "would not load",
            "largest albedo",
        ],
    );
    write_binned(&d.join("black.bin"), |_, _| [0.0; 3]);
    refused(
        d,
        &[
            "fit",
            "black.bin",
            "--models",
            "ward",
            "-o",
            "k.fit.json",
            "-q",
        ],
        &["black.bin", "is zero"],
    );
    assert!(!d.join("b.fit.json").exists() && !d.join("k.fit.json").exists());
}

#[test]
fn far_away_geometry_is_refused_where_f32_cannot_hold_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lambert = SCENE.replace("MATERIAL", r#"{"type": "lambert"}"#);
    let cases = [
        // A sphere of radius 1e9 whose surface is 4.5 in front of the camera.
        (
            lambert.replace(
                r#"{"type": "sphere", "material": "m"}"#,
                r#"{"type": "sphere", "center": [0, 0, -1000000000], "radius": 1000000000, "material": "m"}"#,
            ),
            "expected within 1e9",
        ),
        // A huge sphere that f32 holds, but not 4.5 from its surface.
        (
            lambert.replace(
                r#"{"type": "sphere", "material": "m"}"#,
                r#"{"type": "sphere", "center": [0, 0, -100000000], "radius": 100000000, "material": "m"}"#,
            ),
            "distance from the camera to the surface",
        ),
        // A camera 1e7 from a unit sphere.
        (
            lambert.replace("[0, 0, 4]", "[0, 0, 10000000]"),
            "radius is 1e0, below 64 single-precision steps",
        ),
        (
            lambert.replace("[0, 0, 4]", "[0, 0, 1e30]"),
            "camera.origin: is",
        ),
    ];
    for (scene, needle) in cases {
        std::fs::write(d.join("s.json"), scene).unwrap();
        refused(d, &["render", "s.json", "-o", "r.exr"], &["s.json", needle]);
    }
    // A camera 1e4 from a unit sphere is resolved, and renders it.
    std::fs::write(
        d.join("s.json"),
        lambert
            .replace("[0, 0, 4]", "[0, 0, 10000]")
            .replace("\"fov\": 40", "\"fov\": 0.02"),
    )
    .unwrap();
    let o = run_in(d, &["render", "s.json", "-o", "r.exr"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn renders_that_drop_samples_fail_with_status_3() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = SCENE.replace("MATERIAL", r#"{"type": "lambert"}"#).replace(
        r#""file": "builtin:studio""#,
        r#""file": "builtin:studio", "scale": 1e38"#,
    );
    std::fs::write(d.join("s.json"), scene).unwrap();
    let o = run_in(d, &["render", "s.json", "-o", "r.exr"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("were NaN or infinite and were dropped") && err.contains("biased"),
        "{err}"
    );
    // The biased image is written, for inspection, with its statistics.
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("r.stats.json")).unwrap()).unwrap();
    assert!(stats["nonfinite_dropped"].as_u64().unwrap() > 0);
}

#[test]
fn small_things() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let lambert = SCENE.replace("MATERIAL", r#"{"type": "lambert"}"#);
    std::fs::write(d.join("s.json"), &lambert).unwrap();
    // Names that CSV and Markdown must quote or escape.
    std::fs::create_dir(d.join("reports")).unwrap();
    let ward = serde_json::json!({"type": "ward", "alpha": 0.1, "specular": 0.5});
    for (k, name) in ["a,b", "say \"hi\"", "x|y", "two\nlines"]
        .iter()
        .enumerate()
    {
        let mut r: serde_json::Value = serde_json::from_str(&report(ward.clone())).unwrap();
        r["material"] = (*name).into();
        std::fs::write(d.join(format!("reports/{k}.fit.json")), r.to_string()).unwrap();
    }
    let o = run_in(d, &["fit", "merge", "reports", "-o", "merged"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(d.join("merged.csv")).unwrap();
    for quoted in ["\"a,b\"", "\"say \"\"hi\"\"\"", "\"two\nlines\""] {
        assert!(csv.contains(quoted), "{quoted} not quoted in {csv}");
    }
    let md = std::fs::read_to_string(d.join("merged.md")).unwrap();
    assert!(md.contains("x\\|y") && md.contains("two lines"), "{md}");
    let rows = md.lines().filter(|l| l.starts_with('|')).count();
    assert_eq!(rows, 6, "{md}");
    // Options out of range, with messages that say what is wrong.
    let ward_m = ward.to_string();
    refused(
        d,
        &[
            "tabulate",
            "--material",
            &ward_m,
            "--empty-fraction",
            "1",
            "-o",
            "t.binary",
        ],
        &["no bin would hold a value"],
    );
    assert!(!d.join("t.binary").exists());
    refused(
        d,
        &["render", "s.json", "--bench", "--runs", "0"],
        &["--runs"],
    );
    refused(
        d,
        &["render", "s.json", "--spp", "16777217"],
        &["--spp", "16777216"],
    );
    // (clap's own error format: its usage hint follows, and the status is 2.)
    let o = run_in(d, &["render", "s.json", "--exposure", "1e308"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--exposure") && err.contains("beyond the option's precision"),
        "{err}"
    );
    std::fs::write(
        d.join("far.json"),
        lambert.replace("\"fov\": 40", "\"fov\": 40, \"near_clip\": 1e300"),
    )
    .unwrap();
    refused(
        d,
        &["render", "far.json", "-o", "r.exr"],
        &["near_clip", "beyond single precision"],
    );
    // A data file whose stem is ".." cannot name the study's files.
    std::fs::create_dir(d.join("dots")).unwrap();
    write_binned(&d.join("dots/...binary"), ward_data);
    refused(
        d,
        &["study", "dots/...binary", "--quick", "-o", "st"],
        &["...binary", "cannot name the study's files"],
    );
    assert!(!d.join("renders").exists() && !d.join("st/renders").exists());
}
