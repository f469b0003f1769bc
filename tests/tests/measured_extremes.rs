//! Measured tables and fit reports with values that make a BRDF non-finite in f32 are
//! refused by their readers, naming the file and the first bad entry; extreme values that
//! are accepted (up to lobe_materials::measured::MAX_VALUE, tiny, zero, negative where the
//! format allows) evaluate and sample to finite numbers.

use lobe_materials::measured::binned::{Axis, Binned};
use lobe_materials::measured::merl::{Merl, SAMPLES, SCALE};
use lobe_materials::registry::{BuildContext, Registry};
use serde_json::json;
use std::path::Path;

/// A MERL file whose stored (unscaled) values are all `v`.
fn merl_bytes(v: f64) -> Vec<u8> {
    let mut b = Vec::with_capacity(12 + 24 * SAMPLES);
    for d in [90i32, 90, 180] {
        b.extend_from_slice(&d.to_le_bytes());
    }
    for _ in 0..3 * SAMPLES {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b
}

/// Builds `desc` (relative to `dir`) and checks every value, density and sample weight on
/// a grid is finite.
fn all_finite(dir: &Path, desc: serde_json::Value) {
    let reg = Registry::builtin();
    let b = reg
        .create_with(&desc, "m", &BuildContext::new(dir, &reg))
        .unwrap_or_else(|e| panic!("{desc} refused: {e}"));
    assert_eq!(
        lobe_materials::bsdf::first_nonfinite(b.as_ref()),
        None,
        "{desc}"
    );
}

#[test]
fn merl_values_that_overflow_after_the_channel_scale_are_refused() {
    // 1e300 was accepted: eval printed inf and a render lost a fifth of its samples.
    let e = Merl::from_bytes(&merl_bytes(1e300), "n.binary")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("n.binary")
            && e.contains("sample 0 (theta_h bin 0, theta_d bin 0, phi_d bin 0) of channel 0"),
        "{e}"
    );
    // Finite in f64, infinite in f32 after the red scale (1/1500).
    let e = Merl::from_bytes(&merl_bytes(1e42), "n.binary")
        .unwrap_err()
        .to_string();
    assert!(e.contains("expected a finite value up to 1e12"), "{e}");
    // One bad value deep in the blue channel is named by its bins.
    let mut b = merl_bytes(1.0);
    let i = 2 * SAMPLES + 5 * 180 * 90 + 7 * 180 + 11;
    b[12 + 8 * i..20 + 8 * i].copy_from_slice(&1e20f64.to_le_bytes());
    let e = Merl::from_bytes(&b, "n.binary").unwrap_err().to_string();
    assert!(
        e.contains("(theta_h bin 5, theta_d bin 7, phi_d bin 11) of channel 2"),
        "{e}"
    );
}

#[test]
fn accepted_extreme_tables_evaluate_and_sample_finitely() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The largest accepted MERL value, a denormal one and zeros.
    for (k, v) in [1e12 / SCALE[2], 1e-41, 0.0].into_iter().enumerate() {
        let f = d.join(format!("m{k}.binary"));
        std::fs::write(&f, merl_bytes(v)).unwrap();
        all_finite(
            d,
            json!({"type": "merl", "file": f.file_name().unwrap().to_str().unwrap()}),
        );
    }
    // Binned: the largest value in one bin of each row, negative bins (rendered as zero),
    // denormals and zeros.
    let mut t = Binned::empty(
        false,
        vec![
            Axis::new(9, 0.0, 90.0),
            Axis::new(9, 0.0, 90.0),
            Axis::new(18, 0.0, 180.0),
        ],
    );
    for k in 0..t.len() {
        t.values[k] = Some(match k % 4 {
            0 => [1e12; 3],
            1 => [-1e12, -1.0, -1e-30],
            2 => [1e-44; 3],
            _ => [0.0; 3],
        });
    }
    t.write(&d.join("t.bin")).unwrap();
    all_finite(d, json!({"type": "binned", "file": "t.bin"}));
    let reg = Registry::builtin();
    let b = reg
        .create_with(
            &json!({"type": "binned", "file": "t.bin"}),
            "m",
            &BuildContext::new(d, &reg),
        )
        .unwrap();
    for k in (1..t.len()).step_by(4) {
        let (wi, wo) = t.directions(k);
        assert_eq!(b.eval(wo, wi).to_array(), [0.0; 3], "negative bin {k}");
    }
}

#[test]
fn binned_values_beyond_the_limit_are_refused_naming_the_bin() {
    let mut t = Binned::empty(
        false,
        vec![
            Axis::new(3, 0.0, 90.0),
            Axis::new(3, 0.0, 90.0),
            Axis::new(2, 0.0, 180.0),
        ],
    );
    for k in 0..t.len() {
        t.values[k] = Some([0.5; 3]);
    }
    t.values[7] = Some([0.1, 3e38, 0.1]);
    let e = Binned::from_bytes(&t.to_bytes(), "b.bin")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("b.bin")
            && e.contains("bin 7 (centre at [45, 15, 135] degrees)")
            && e.contains("1e12"),
        "{e}"
    );
}

#[test]
fn rgl_fields_that_overflow_are_refused() {
    let Some(data) = lobe_tests::shared_data_or_skip("RGL fields that overflow") else {
        return;
    };
    let src = data.join("rgl/paper_white_rgb.bsdf");
    let bytes = std::fs::read(&src).unwrap();
    let t = lobe_materials::measured::tensor::TensorFile::from_bytes(&bytes, "x").unwrap();
    let offset_of = |field: &str| {
        let f = &t.fields[field].bytes;
        bytes
            .windows(f.len())
            .position(|w| w == &f[..])
            .expect("field bytes")
    };
    let dir = tempfile::tempdir().unwrap();
    let read = |b: &[u8]| {
        let p = dir.path().join("f_rgb.bsdf");
        std::fs::write(&p, b).unwrap();
        lobe_materials::measured::rgl::Rgl::read(&p)
            .map(|_| ())
            .unwrap_err()
            .to_string()
    };
    // One rgb value at f32::MAX.
    let mut b = bytes.clone();
    let o = offset_of("rgb") + 4 * 10;
    b[o..o + 4].copy_from_slice(&f32::MAX.to_le_bytes());
    let e = read(&b);
    assert!(
        e.contains("f_rgb.bsdf") && e.contains("field \"rgb\": value 10"),
        "{e}"
    );
    // A negative ndf value.
    let mut b = bytes.clone();
    let o = offset_of("ndf");
    b[o..o + 4].copy_from_slice(&(-1.0f32).to_le_bytes());
    assert!(read(&b).contains("field \"ndf\": value 0"));
    // A luminance table of denormals: within range, but normalizing it overflows f32.
    let mut b = bytes.clone();
    let o = offset_of("luminance");
    for k in 0..t.fields["luminance"].bytes.len() / 4 {
        b[o + 4 * k..o + 4 * k + 4].copy_from_slice(&1e-44f32.to_le_bytes());
    }
    let e = read(&b);
    assert!(
        e.contains("expected finite values") && e.contains("theta_o"),
        "{e}"
    );
}

#[test]
fn fit_reports_hold_analytic_models_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("r.fit.json"),
        {
            let fit = |m: serde_json::Value| {
                json!({"material": m, "error": 0, "error_normalized": 0,
                "starts": 1, "starts_agreeing": 1, "evaluations": 1, "seconds": 0})
            };
            json!({"material": "r", "source": "r.binary", "resolution_deg": 1, "samples": 1,
                "max_albedo": 1, "models": {
                "self": fit(json!({"type": "fit", "file": "r.fit.json", "model": "self"})),
                "table": fit(json!({"type": "merl", "file": "x.binary"})),
                "ward": fit(json!({"type": "ward", "specular": 1e12, "alpha": 1e-4}))
            }})
        }
        .to_string(),
    )
    .unwrap();
    let reg = Registry::builtin();
    let ctx = BuildContext::new(d, &reg);
    // A report naming itself recursed until the stack overflowed.
    for model in ["self", "table"] {
        let e = reg
            .create_with(
                &json!({"type": "fit", "file": "r.fit.json", "model": model}),
                "m",
                &ctx,
            )
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.fit.json") && e.contains("expected an analytic model or a composite"),
            "{e}"
        );
    }
    all_finite(
        d,
        json!({"type": "fit", "file": "r.fit.json", "model": "ward"}),
    );
}
