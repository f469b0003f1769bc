//! `lobe compare`: its metrics against OpenImageIO, and non-finite pixels refused.

use super::common::*;
use std::process::Command;

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
