//! Image-difference tests against Mitsuba 3: every reference of reference-images/manifest.json
//! is re-rendered with lobe and compared with the noise-aware multi-scale z-test of
//! `lobe_renderer::compare::z_test` (per pixel and over 4x4, 16x16, 64x64 blocks, two-sided
//! normal p-values, Sidak-corrected to a 1 % false-alarm rate per image). Each scene is
//! also rendered with every material's colours 5 % too bright, and the test must then fail:
//! proof that each comparison can see a wrong material.
//!
//! A reference whose scene file changed since it was rendered fails with the command that
//! re-renders it (`tools/mitsuba/reference.sh NAME`).

use lobe_renderer::compare::z_test;
use lobe_renderer::film::Image;
use lobe_renderer::image_io::read_exr;
use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value};
use serde_json::Value;
use sha2::{Digest, Sha256};
use std::path::Path;

/// The false-alarm rate of the whole family of reference comparisons: each image's z-test
/// runs at the Sidak share of it (with 11 references, 9.1e-4 each), so that the suite, not
/// each image, fails by chance once in a hundred runs.
const FAMILY_ALPHA: f64 = 0.01;

fn per_image_alpha(images: usize) -> f64 {
    1.0 - (1.0 - FAMILY_ALPHA).powf(1.0 / images.max(1) as f64)
}

fn manifest() -> Vec<(String, Value)> {
    let path = lobe_tests::workspace().join("reference-images/manifest.json");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&path).expect("manifest"))
        .expect("manifest JSON");
    v.as_object()
        .expect("object")
        .iter()
        .map(|(k, e)| (k.clone(), e.clone()))
        .collect()
}

fn reference(entry: &Value) -> Image {
    let root = lobe_tests::workspace();
    let mut img = read_exr(&root.join(entry["image"].as_str().unwrap())).unwrap();
    img.variance = read_exr(&root.join(entry["variance"].as_str().unwrap()))
        .unwrap()
        .pixels;
    img.variance_dof = (entry["runs"].as_u64().unwrap().max(2) - 1) as f64;
    img
}

/// Every diffuse / specular / reflectance colour multiplied by `k` (Ngan fits expanded
/// into their model descriptions first).
fn brighten(v: &mut Value, k: f64, base: &Path) {
    match v {
        Value::Object(m) => {
            if m.get("type").and_then(Value::as_str) == Some("ngan-fit") {
                let model = m
                    .get("model")
                    .and_then(Value::as_str)
                    .unwrap_or("cook-torrance")
                    .to_string();
                let dir = lobe_materials::ngan_fit::locate_fits("", base).expect("fits");
                let file = lobe_materials::ngan_fit::MODELS
                    .iter()
                    .find(|(n, _, _)| *n == model)
                    .unwrap()
                    .1;
                let fits = lobe_materials::ngan_fit::read_fits(&dir.join(file)).unwrap();
                let fit = fits
                    .iter()
                    .find(|f| {
                        Some(f.material.as_str()) == m.get("material").and_then(Value::as_str)
                    })
                    .unwrap();
                *v = lobe_materials::ngan_fit::description(
                    fit,
                    &model,
                    lobe_materials::ngan_fit::MERL_CHANNEL_SCALE,
                )
                .unwrap();
                return brighten(v, k, base);
            }
            if m.get("type").and_then(Value::as_str) == Some("rgl") {
                // A measured file has no colour parameter: brighten it through a composite
                // is not possible, so scale the table by swapping in a 5 % brighter copy is
                // not either; instead the scene's lights are brightened (see below).
                return;
            }
            for (key, val) in m.iter_mut() {
                if ["reflectance", "diffuse", "specular"].contains(&key.as_str()) {
                    match val {
                        Value::Number(n) => *val = serde_json::json!(n.as_f64().unwrap() * k),
                        Value::Array(a) => a
                            .iter_mut()
                            .for_each(|x| *x = serde_json::json!(x.as_f64().unwrap() * k)),
                        _ => {}
                    }
                } else {
                    brighten(val, k, base);
                }
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| brighten(x, k, base)),
        _ => {}
    }
}

/// lobe's per-pixel variance comes from its own samples, which are correlated (Owen-
/// scrambled Sobol'): their spread cannot show a contribution rarer than one in `spp`
/// (a glossy reflection of a small bright light through two bounces), and at such pixels
/// it underestimates the error, so the z-test would flag a correct render. The variance
/// of the reference, made with Mitsuba's independent sampler, is an honest per-sample
/// variance of the same estimator (lobe's is within 12 % of it with random samples,
/// docs/validation.md); scaled to lobe's spp (`ratio` = reference spp / lobe spp), it
/// floors lobe's own estimate.
fn floor_variance(img: &mut Image, reference: &Image, ratio: f32) {
    for (v, r) in img.variance.iter_mut().zip(&reference.variance) {
        v.r = v.r.max(r.r * ratio);
        v.g = v.g.max(r.g * ratio);
        v.b = v.b.max(r.b * ratio);
    }
}

fn render_lobe(desc: &Value, file: &str, base: &Path, spp: u32) -> Image {
    let mut scene = from_value(desc, file, base, &LoadOptions::with_builtins())
        .unwrap_or_else(|e| panic!("{e}"));
    scene.settings.spp = spp;
    let (img, stats) = render(&scene, &RenderOptions::default()).unwrap();
    assert_eq!(stats.nonfinite_dropped, 0, "{file}: non-finite samples");
    img
}

#[test]
fn lobe_matches_every_mitsuba_reference_and_sees_wrong_materials() {
    let root = lobe_tests::workspace();
    let mut compared = 0;
    let mut failures = Vec::new();
    let references = manifest();
    let alpha = per_image_alpha(references.len());
    for (name, entry) in references {
        let scene_path = root.join(entry["scene"].as_str().unwrap());
        let bytes = std::fs::read(&scene_path).unwrap();
        let digest = format!("{:x}", Sha256::digest(&bytes));
        assert_eq!(
            digest,
            entry["scene_sha256"].as_str().unwrap(),
            "{name}: {} changed since its reference was rendered; rerun `{}`",
            scene_path.display(),
            entry["command"].as_str().unwrap()
        );
        let text = String::from_utf8(bytes).unwrap();
        if text.contains("\"ngan-fit\"") && lobe_tests::shared_data().is_none() {
            lobe_tests::skip_without_data(&format!("the Mitsuba reference {name} (Ngan fits)"));
            continue;
        }
        if text.contains("shared/data/") && !root.join("../shared/data").is_dir() {
            lobe_tests::skip_without_data(&format!(
                "the Mitsuba reference {name} (reads ../shared/data next to the checkout)"
            ));
            continue;
        }
        let desc: Value = serde_json::from_str(&text).unwrap();
        let base = scene_path.parent().unwrap();
        let spp = entry["lobe_spp"].as_u64().unwrap() as u32;
        let reference = reference(&entry);
        let ref_spp =
            (entry["spp_per_run"].as_u64().unwrap() * entry["runs"].as_u64().unwrap()) as f32;
        let mut img = render_lobe(&desc, &scene_path.display().to_string(), base, spp);
        floor_variance(&mut img, &reference, ref_spp / spp as f32);
        let z = z_test(&img, &reference, alpha).unwrap();
        eprintln!(
            "{name}: min p {:.2e} (threshold {:.2e}), worst z {:.2} ({}x{} block at {}, {})",
            z.min_p, z.threshold, z.worst.3, z.worst.2, z.worst.2, z.worst.0, z.worst.1
        );
        if !z.passed() {
            failures.push(format!(
                "{name}: {} significant tests, worst z {:.2} for the {}x{} block at ({}, {})",
                z.failures, z.worst.3, z.worst.2, z.worst.2, z.worst.0, z.worst.1
            ));
        }
        let mut wrong = desc.clone();
        brighten(&mut wrong, 1.05, base);
        if text.contains("\"rgl\"") {
            // Measured tables have no colour to scale: scale the environment instead, which
            // has the same effect on every reflected pixel.
            for l in wrong["lights"].as_array_mut().into_iter().flatten() {
                let s = l.get("scale").and_then(Value::as_f64).unwrap_or(1.0);
                l["scale"] = serde_json::json!(s * 1.05);
            }
        }
        let mut bad = render_lobe(&wrong, &scene_path.display().to_string(), base, spp);
        floor_variance(&mut bad, &reference, ref_spp / spp as f32);
        let zb = z_test(&bad, &reference, alpha).unwrap();
        eprintln!("{name} with colours x1.05: worst z {:.2}", zb.worst.3);
        if zb.passed() {
            failures.push(format!(
                "{name}: colours 5 % too bright were NOT detected (worst z {:.2})",
                zb.worst.3
            ));
        }
        compared += 1;
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(compared >= 8, "{compared} references compared");
}
