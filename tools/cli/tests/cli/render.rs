//! `lobe render`: EXR, PNG and statistics written atomically, outputs that never overwrite the scene or its inputs, partial renders that merge.

use super::common::*;
use std::path::Path;

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
