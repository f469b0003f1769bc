//! A model declared outside lobe (here, in the test) is a first-class model once it is
//! registered: the fitter fits it from its own declaration (fit range, starts), the fit
//! report names it, and a `{"type": "fit", ...}` material loads that report through the
//! caller's registry (the `fit` material builds what a report names with the registry of
//! its build context, not with the builtin one). Through the builtin registry the same
//! report is a clear "unknown model" error naming the report's field.

use glam::{DVec3, Vec2, Vec3};
use lobe_materials::analytic::common::{DIFFUSE, SPECULAR, lobe_param};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{fit, model_specs};
use lobe_materials::lobe::Lobe;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_materials::schema::{
    Bounds, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params,
};
use lobe_materials::{Flags, ParamError, Rgb};
use serde_json::json;
use std::f64::consts::PI;
use std::sync::Arc;

/// A normalized Phong lobe about the retro-reflection direction,
/// (n + 2) / (2 pi) max(0, wo . wi)^n: a shape no builtin model has.
#[derive(Debug)]
struct RetroPhong {
    n: f64,
}

impl RetroPhong {
    fn value(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (self.n + 2.0) / (2.0 * PI) * wo.dot(wi).max(0.0).powf(self.n)
    }
}

impl Lobe for RetroPhong {
    fn model(&self) -> &'static str {
        "retro-phong"
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        Rgb::splat(self.value(wo.as_dvec3(), wi.as_dvec3()) as f32)
    }
    fn eval_f64(&self, wo: DVec3, wi: DVec3) -> [f64; 3] {
        [self.value(wo, wi); 3]
    }
    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<Vec3> {
        // Cosine-weighted: any density covering the lobe is a valid sampler.
        if wo.z <= 0.0 {
            return None;
        }
        let r = u.x.sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.y;
        Some(Vec3::new(
            r * phi.cos(),
            r * phi.sin(),
            (1.0 - u.x).max(0.0).sqrt(),
        ))
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            0.0
        } else {
            wi.z / std::f32::consts::PI
        }
    }
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
