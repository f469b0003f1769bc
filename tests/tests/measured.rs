//! Measured tables: the MERL format (round trip, rejection of wrong dimensions, truncated
//! and too-long files), lookups against the analytic model a table was made from, the
//! binned format, acquisition emulation, the tabulated sampler (pdf normalization,
//! chi-square, variance against cosine sampling on a specular table), and lazy, shared
//! loading in scenes.

use glam::{Vec2, Vec3};
use lobe_materials::Bsdf;
use lobe_materials::measured::binned::Binned;
use lobe_materials::measured::merl::{Merl, SAMPLES};
use lobe_materials::measured::tabulate::{Acquisition, binned_from, merl_from};
use lobe_materials::registry::Registry;
use lobe_tests::bsdf_checks::*;
use serde_json::json;
use std::sync::Arc;

fn model(desc: serde_json::Value) -> Arc<dyn Bsdf> {
    Registry::builtin().create(&desc, "m").unwrap()
}

fn glossy() -> Arc<dyn Bsdf> {
    model(json!({"type": "cook-torrance", "diffuse": [0.1, 0.2, 0.3], "specular": 0.5, "m": 0.2}))
}

fn write_merl(
    dir: &std::path::Path,
    name: &str,
    m: &dyn Bsdf,
    acq: &Acquisition,
) -> std::path::PathBuf {
    let p = dir.join(name);
    merl_from(&|wo, wi| m.eval(wo, wi), acq).write(&p).unwrap();
    p
}

#[test]
fn merl_round_trip_and_lookups() {
    let dir = tempfile::tempdir().unwrap();
    let m = glossy();
    let path = write_merl(dir.path(), "ct.binary", m.as_ref(), &Acquisition::default());
    assert_eq!(
        std::fs::metadata(&path).unwrap().len() as usize,
        12 + 3 * SAMPLES * 8
    );
    let t = Merl::read(&path).unwrap();
    // Interpolated lookups follow the smooth model; the nearest bin is coarser.
    let (mut err_lin, mut err_near, mut n) = (0.0f64, 0.0f64, 0);
    for k in 0..2000 {
        let wo = dir_deg(5.0 + 70.0 * ((k * 37 % 100) as f64 / 100.0), 0.0);
        let wi = dir_deg(
            5.0 + 70.0 * ((k * 53 % 100) as f64 / 100.0),
            (k * 7919 % 360) as f64,
        );
        let truth = m.eval(wo, wi).g as f64;
        err_lin += (t.lookup(wi, wo).g as f64 - truth).abs() / truth;
        err_near += (t.lookup_nearest(wi, wo).g as f64 - truth).abs() / truth;
        n += 1;
    }
    let (err_lin, err_near) = (err_lin / n as f64, err_near / n as f64);
    eprintln!("mean relative error of MERL lookups: trilinear {err_lin:.4}, nearest {err_near:.4}");
    assert!(
        err_lin < 0.02 && err_lin < err_near,
        "trilinear {err_lin}, nearest {err_near}"
    );
    // Writing what was read gives the same bytes.
    let again = dir.path().join("again.binary");
    t.write(&again).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        std::fs::read(&again).unwrap()
    );
}

#[test]
fn bad_merl_files_are_rejected_with_what_was_expected() {
    let dir = tempfile::tempdir().unwrap();
    let good = write_merl(
        dir.path(),
        "g.binary",
        glossy().as_ref(),
        &Acquisition::default(),
    );
    let bytes = std::fs::read(&good).unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "truncated.binary",
            bytes[..bytes.len() - 8].to_vec(),
            "truncated",
        ),
        (
            "long.binary",
            [bytes.clone(), vec![0u8; 8]].concat(),
            "too long",
        ),
        (
            "dims.binary",
            {
                let mut b = bytes.clone();
                b[0..4].copy_from_slice(&45i32.to_le_bytes());
                b
            },
            "expected [90, 90, 180]",
        ),
        ("tiny.binary", vec![1, 2, 3], "12-byte header"),
    ];
    for (name, data, needle) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, data).unwrap();
        let e = Merl::read(&p).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(needle), "{e}");
    }
    // Through the registry the error names the parameter.
    let reg = Registry::builtin();
    let e = reg
        .create_with(
            &json!({"type": "merl", "file": "tiny.binary"}),
            "materials.x",
            &lobe_materials::registry::BuildContext::new(dir.path(), &reg),
        )
        .unwrap_err();
    assert_eq!(e.path, "materials.x.file");
}

#[test]
fn acquisition_emulation_is_seeded_and_does_what_it_says() {
    let m = glossy();
    let f = |wo: Vec3, wi: Vec3| m.eval(wo, wi);
    let acq = Acquisition {
        noise: 0.05,
        retro_exclusion_deg: 3.0,
        grazing_cutoff_deg: 80.0,
        empty_fraction: 0.25,
        seed: 7,
    };
    let a = binned_from(&f, false, &acq);
    let b = binned_from(&f, false, &acq);
    assert_eq!(a.to_bytes(), b.to_bytes(), "same options, same file");
    let c = binned_from(&f, false, &Acquisition { seed: 8, ..acq });
    assert_ne!(a.to_bytes(), c.to_bytes());
    // Nothing past 80 degrees, nothing within 3 degrees of retro-reflection.
    for k in 0..a.len() {
        if a.values[k].is_some() {
            let (wi, wo) = a.directions(k);
            assert!(
                wi.z >= 80f32.to_radians().cos() - 1e-3 && wo.z >= 80f32.to_radians().cos() - 1e-3
            );
        }
    }
    let near_retro = a.bin_of(dir_deg(30.5, 0.0), dir_deg(30.5, 0.5));
    assert!(a.values[near_retro].is_none());
    // About 25 % of the bins left empty at random (besides the cut-offs).
    let full = binned_from(
        &f,
        false,
        &Acquisition {
            empty_fraction: 0.0,
            ..acq
        },
    );
    let kept = a.filled() as f64 / full.filled() as f64;
    assert!((kept - 0.75).abs() < 0.01, "kept {kept}");
}

#[test]
fn binned_round_trip_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let m = glossy();
    let t = binned_from(
        &|wo, wi| m.eval(wo, wi),
        false,
        &Acquisition {
            empty_fraction: 0.15,
            seed: 1,
            ..Default::default()
        },
    );
    let p = dir.path().join("t.bin");
    t.write(&p).unwrap();
    let r = Binned::read(&p).unwrap();
    assert_eq!(r.values, t.values);
    assert_eq!(r.axes, t.axes);
    let bytes = std::fs::read(&p).unwrap();
    for (name, data, needle) in [
        ("short.bin", bytes[..bytes.len() - 1].to_vec(), "truncated"),
        (
            "long.bin",
            [bytes.clone(), vec![0u8; 12]].concat(),
            "too long",
        ),
        (
            "magic.bin",
            [b"NOTLOBE!".to_vec(), bytes[8..].to_vec()].concat(),
            "LOBEBIN1",
        ),
    ] {
        let q = dir.path().join(name);
        std::fs::write(&q, data).unwrap();
        let e = Binned::read(&q).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(needle), "{e}");
    }
    // An anisotropic layout round-trips too (sparse).
    let a = binned_from(
        &|wo, wi| m.eval(wo, wi),
        true,
        &Acquisition {
            empty_fraction: 0.75,
            grazing_cutoff_deg: 80.0,
            ..Default::default()
        },
    );
    assert_eq!(a.len(), 45 * 45 * 180 * 180);
    let pa = dir.path().join("a.bin");
    a.write(&pa).unwrap();
    assert_eq!(Binned::read(&pa).unwrap().filled(), a.filled());
}

#[test]
fn tabulated_sampling_is_exact_and_beats_cosine_sampling() {
    let dir = tempfile::tempdir().unwrap();
    // A specular table: Cook-Torrance m = 0.05 with a dark diffuse.
    let spec = model(json!({"type": "cook-torrance", "diffuse": 0.02, "specular": 0.8, "m": 0.05}));
    let path = write_merl(
        dir.path(),
        "spec.binary",
        spec.as_ref(),
        &Acquisition::default(),
    );
    let mat = Registry::builtin()
        .create(
            &json!({"type": "merl", "file": path.to_str().unwrap()}),
            "m",
        )
        .unwrap();
    check_finite_nonnegative("merl", mat.as_ref());
    check_sample_consistency("merl", mat.as_ref());
    for wo in [
        dir_deg(10.0, 0.0),
        dir_deg(45.0, 30.0),
        dir_deg(70.0, 200.0),
    ] {
        let integral = pdf_integral(mat.as_ref(), wo, 600);
        assert!(
            (integral - 1.0).abs() < 0.01,
            "pdf integrates to {integral}"
        );
        let p = chi2_pvalue_sub(mat.as_ref(), wo, 24, 200_000, 5, 48);
        assert!(p > 1e-3, "chi-square p = {p}");
    }
    // Variance of the directional-albedo estimator: tabulated vs cosine sampling.
    #[derive(Debug)]
    struct Cos(Arc<dyn Bsdf>);
    impl Bsdf for Cos {
        fn eval(&self, wo: Vec3, wi: Vec3) -> lobe_materials::Rgb {
            self.0.eval(wo, wi)
        }
        fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<lobe_materials::BsdfSample> {
            let wi = lobe_materials::sampling::warp::square_to_cosine_hemisphere(u);
            let pdf = wi.z / std::f32::consts::PI;
            (wo.z > 0.0 && pdf > 0.0).then(|| lobe_materials::BsdfSample {
                wi,
                weight: self.0.eval(wo, wi) * (wi.z / pdf),
                pdf,
            })
        }
        fn pdf(&self, _wo: Vec3, wi: Vec3) -> f32 {
            wi.z.max(0.0) / std::f32::consts::PI
        }
        fn flags(&self) -> lobe_materials::Flags {
            self.0.flags()
        }
        fn name(&self) -> &str {
            "cos"
        }
    }
    let mut ratios = Vec::new();
    for wo in [dir_deg(0.0, 0.0), dir_deg(30.0, 0.0), dir_deg(60.0, 0.0)] {
        let ours = weight_variance(mat.as_ref(), wo, 256);
        let cosine = weight_variance(&Cos(mat.clone()), wo, 256);
        ratios.push(cosine / ours);
    }
    eprintln!(
        "variance of cosine sampling / tabulated sampling on a specular MERL table: {ratios:?}"
    );
    assert!(ratios.iter().all(|&r| r > 20.0), "{ratios:?}");
}

#[test]
fn scenes_load_tables_lazily() {
    let dir = tempfile::tempdir().unwrap();
    write_merl(
        dir.path(),
        "t.binary",
        glossy().as_ref(),
        &Acquisition::default(),
    );
    let scene = |shapes: serde_json::Value| {
        json!({
            "camera": {"type": "perspective", "origin": [0, 0, 5], "target": [0, 0, 0]},
            "film": {"width": 8, "height": 8},
            "materials": {"table": {"type": "merl", "file": "t.binary"}, "unused": {"type": "merl", "file": "missing.binary"}},
            "shapes": shapes,
            "lights": [{"type": "constant"}]
        })
    };
    let load = |v: serde_json::Value| {
        lobe_renderer::scene::from_value(&v, "s.json", dir.path(), &Default::default())
    };
    // An unused material's missing file is never read: the scene loads. (That the two
    // shapes, one named and one inline, share one table is counted in lazy_build.rs, whose
    // process-wide build counter no other test moves.)
    let s = load(scene(json!([{"type": "sphere", "material": "table"}, {"type": "sphere", "center": [2, 0, 0], "material": {"type": "merl", "file": "t.binary"}}]))).unwrap();
    assert_eq!(s.world.shapes.len(), 2);
    let e = match load(scene(json!([{"type": "sphere", "material": "unused"}]))) {
        Ok(_) => panic!("a missing table was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("materials.unused.file") && e.contains("missing.binary"),
        "{e}"
    );
}
