//! The fitter recovers known parameters from synthetic data: data tabulated from a
//! Cook-Torrance material is fitted by Cook-Torrance with (almost) zero error and the true
//! parameters, while a model that cannot represent it (Ward) is left with a larger error.

use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::{builtin_specs, fit};
use lobe_materials::registry::Registry;
use serde_json::json;

#[test]
fn cook_torrance_data_is_recovered_by_cook_torrance() {
    let truth = Registry::builtin()
        .create(&json!({"type": "cook-torrance", "diffuse": [0.2, 0.1, 0.05], "specular": [0.3, 0.35, 0.4], "m": 0.15, "f0": 0.1}), "t")
        .unwrap();
    let data = Dataset::isotropic(&|wi, wo| Some(truth.eval(wo, wi)), 4.0);
    assert!(data.samples.len() > 10_000);
    let specs = builtin_specs();
    let ct = specs.iter().find(|s| s.label == "cook-torrance").unwrap();
    let r = fit(&data, ct, 200);
    eprintln!(
        "{} -> error {:.3e} (normalized {:.3e}), {} of {} starts agree, {} evaluations, {:.1} s",
        r.material,
        r.error,
        r.error_normalized,
        r.starts_agreeing,
        r.starts,
        r.evaluations,
        r.seconds
    );
    let m = r.material["m"].as_f64().unwrap();
    let f0 = r.material["f0"].as_f64().unwrap();
    assert!((m - 0.15).abs() < 0.15 * 0.02, "m = {m}");
    assert!((f0 - 0.1).abs() < 0.1 * 0.05, "f0 = {f0}");
    for (c, want) in [0.2, 0.1, 0.05].iter().enumerate() {
        let got = r.material["diffuse"][c].as_f64().unwrap();
        assert!((got - want).abs() < 0.02 * want, "diffuse {c}: {got}");
    }
    assert!(r.error_normalized < 1e-3, "{}", r.error_normalized);
    assert!(r.starts_agreeing >= 2);
    let ward = specs.iter().find(|s| s.label == "ward").unwrap();
    let w = fit(&data, ward, 100);
    eprintln!("ward: error {:.3e}", w.error);
    assert!(
        w.error > 10.0 * r.error.max(1e-6),
        "ward {} vs cook-torrance {}",
        w.error,
        r.error
    );
    // The fitted material loads as a material.
    Registry::builtin().create(&r.material, "fit").unwrap();
}
