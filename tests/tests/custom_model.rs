//! A model declared outside lobe (here, in the test) is a first-class model once it is
//! registered: the fitter fits it from its own declaration (fit range, starts), the fit
//! report names it, and a `{"type": "fit", ...}` material loads that report through the
//! caller's registry (the `fit` material builds what a report names with the registry of
//! its build context, not with the builtin one). Through the builtin registry the same
//! report is a clear "unknown model" error naming the report's field.

use glam::Vec3;
use lobe_materials::analytic::common::{DIFFUSE, SPECULAR, lobe_param};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{fit, model_specs};
use lobe_materials::lobe::{GenericLobe, Lobe};
use lobe_materials::math::{Num, V3, gt, maximum, powf, select};
use lobe_materials::registry::{BuildContext, Registry};
use lobe_materials::sampling::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use lobe_materials::schema::{
    Bounds, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params,
};
use lobe_materials::{Flags, ParamError};
use serde_json::json;
use std::f64::consts::PI;
use std::sync::Arc;

/// A normalized Phong lobe about the retro-reflection direction,
/// (n + 2) / (2 pi) max(0, wo . wi)^n: a shape no builtin model has.
#[derive(Debug)]
struct RetroPhong {
    n: f64,
}

/// The model's formulas, each written once over `Num` (f64 for the fitter, f32 and lanes
/// for the renderer): branches are masks and `select`.
impl GenericLobe for RetroPhong {
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        let v = T::of((self.n + 2.0) / (2.0 * PI)) * powf(maximum(wo.dot(wi), zero), T::of(self.n));
        select(gt(wo.z, zero) & gt(wi.z, zero), v, zero)
    }
    /// Cosine-weighted: any density covering the lobe is a valid sampler.
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        select(gt(wo.z, zero), cosine_hemisphere_pdf(wi.z), zero)
    }
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, _uc: T) -> (V3<T>, T::Mask) {
        let [x, y, z] = cosine_hemisphere(ux, uy);
        (V3::new(x, y, z), gt(wo.z, T::of(0.0)) & gt(z, T::of(0.0)))
    }
}

impl Lobe for RetroPhong {
    fn model(&self) -> &'static str {
        "retro-phong"
    }
    // eval, eval_f64, pdf, sample and their lane forms, from the formulas above.
    lobe_materials::impl_lobe_forms!();
    fn flags(&self) -> Flags {
        Flags::ISOTROPIC | Flags::RECIPROCAL | Flags::GLOSSY
    }
}

fn retro_lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    Ok(Arc::new(RetroPhong { n: p.scalar("n") }))
}

/// The model's whole declaration: schema, fit range and starts, fit variant.
const RETRO_PHONG: LobeModel = LobeModel {
    schema: ModelSchema {
        name: "retro-phong",
        summary: "Phong lobe about the retro-reflection direction",
        params: &[
            DIFFUSE,
            SPECULAR,
            lobe_param("n", Bounds::closed(0.0, 1e6), 10.0, "exponent of wo . wi")
                .fitted(FitRange::log(1.0, 1e4, &[5.0, 50.0])),
        ],
    },
    lobe: retro_lobe,
    fits: &[FitVariant::single("retro-phong", FitGroup::Isotropic)],
    published: None,
};

#[test]
fn a_model_registered_by_the_caller_is_fitted_and_loaded_from_its_report() {
    let mut registry = Registry::builtin();
    registry.register_model(&RETRO_PHONG);
    let truth = registry
        .create(
            &json!({"type": "retro-phong", "diffuse": [0.2, 0.15, 0.1], "specular": [0.3, 0.3, 0.35], "n": 25}),
            "truth",
        )
        .unwrap();
    let data = Dataset::isotropic(&|wi, wo| Some(truth.eval(wo, wi)), 4.0);
    let specs = model_specs(&RETRO_PHONG);
    assert_eq!(specs.len(), 1);
    assert_eq!(specs[0].params.len(), 1);
    let r = fit(&registry, &data, &specs[0], 300).unwrap();
    assert_eq!(r.material["type"], "retro-phong");
    let n = r.material["n"].as_f64().unwrap();
    assert!((n - 25.0).abs() < 0.01 * 25.0, "fitted n = {n}");
    assert!(r.error_normalized < 1e-3, "{}", r.error_normalized);

    let dir = tempfile::tempdir().unwrap();
    let report = FitReport::new("retro", "synthetic data", 4.0, &data, &[r]);
    report::write(&dir.path().join("retro.fit.json"), &report).unwrap();
    let desc = json!({"type": "fit", "file": "retro.fit.json", "model": "retro-phong"});

    let loaded = registry
        .create_with(
            &desc,
            "materials.x",
            &BuildContext::new(dir.path(), &registry),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    for (wo, wi) in [
        (Vec3::new(0.3, 0.1, 0.95), Vec3::new(0.35, 0.05, 0.93)),
        (Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.5, 0.2, 0.84)),
        (Vec3::new(0.0, 0.0, 1.0), Vec3::new(-0.7, 0.0, 0.71)),
    ] {
        let (wo, wi) = (wo.normalize(), wi.normalize());
        let (a, b) = (
            loaded.eval(wo, wi).to_array(),
            truth.eval(wo, wi).to_array(),
        );
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 0.01 * b[c], "{a:?} vs {b:?}");
        }
    }

    let builtin = Registry::builtin();
    let ctx = BuildContext::new(dir.path(), &builtin);
    let Err(e) = builtin.create_with(&desc, "materials.x", &ctx) else {
        panic!("the builtin registry built a report naming retro-phong");
    };
    assert!(e.path.ends_with(".type"), "{e}");
    assert!(
        e.message.contains("unknown model \"retro-phong\"") && e.message.contains("ward"),
        "{e}"
    );
}

/// The formulas written once give lane entry points equal to the scalar ones, bit for bit.
#[test]
fn the_lane_forms_of_a_model_written_once_equal_its_scalar_forms() {
    use glam::Vec2;
    use lobe_materials::simd::{LANES, Vec3xN, lanes};
    let lobe = RetroPhong { n: 25.0 };
    let dir = |k: usize, s: f32| {
        let a = 0.37 * k as f32 + s;
        Vec3::new(a.cos() * 0.6, a.sin() * 0.6, 0.8 - 0.1 * (k % 3) as f32 - s).normalize()
    };
    let wo: [Vec3; LANES] = lanes(|k| dir(k, 0.0));
    let wi: [Vec3; LANES] = lanes(|k| dir(k, if k % 4 == 0 { 0.9 } else { 0.1 }));
    let (f, p) = lobe.eval_pdf_xn(Vec3xN::from_array(&wo), Vec3xN::from_array(&wi));
    let u: [Vec2; LANES] = lanes(|k| Vec2::new(k as f32 / LANES as f32, 0.77 - 0.04 * k as f32));
    let uc = [0.5; LANES];
    let (d, ok) = lobe.sample_xn(
        Vec3xN::from_array(&wo),
        lobe_materials::Vec2s::from(&u[..]).cols().load(0),
        lobe_materials::simd::f32xn::new(uc),
    );
    let (ok, d) = (lobe_materials::simd::mask_bits(ok), d.to_array());
    let drawn: [Option<Vec3>; LANES] = lanes(|k| (ok >> k & 1 != 0).then_some(d[k]));
    let (f, p) = (f.to_array(), p.to_array());
    let mut lit = 0;
    for k in 0..LANES {
        let bits = |c: [f32; 3]| c.map(f32::to_bits);
        let one = lobe.eval(wo[k], wi[k]).to_array();
        assert_eq!(bits(f[k].to_array()), bits(one), "lane {k}");
        assert_eq!(p[k].to_bits(), lobe.pdf(wo[k], wi[k]).to_bits(), "lane {k}");
        let dir_bits = |d: Option<Vec3>| d.map(|d| d.to_array().map(f32::to_bits));
        let one = lobe.sample(wo[k], u[k], uc[k]);
        assert_eq!(dir_bits(drawn[k]), dir_bits(one), "lane {k}");
        lit += (f[k].to_array()[0] > 0.0) as usize;
    }
    assert!(
        lit > 0,
        "every lane below the surface: the test would check nothing"
    );
}
