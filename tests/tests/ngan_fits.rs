//! The published Ngan et al. 2005 fits (../shared/data/ngan-fits) load for every material
//! and model, evaluate finite and non-negative, and agree with each other: under the
//! conventions lobe uses, the directional albedos of a material's Ward, Ward-Duer,
//! Blinn-Phong, Ashikhmin-Shirley, He and Cook-Torrance fits are close (they were fitted to
//! the same data), which a wrong normalization would break.

use lobe_materials::ngan_fit::{MODELS, read_fits};
use lobe_materials::registry::Registry;
use lobe_tests::bsdf_checks::{albedo, dir_deg};
use serde_json::json;

fn fits_dir() -> Option<std::path::PathBuf> {
    lobe_tests::shared_data_or_skip("the published Ngan et al. fits").map(|d| d.join("ngan-fits"))
}

#[test]
fn every_published_fit_loads_and_is_finite() {
    let Some(dir) = fits_dir() else { return };
    let reg = Registry::builtin();
    let mut n = 0;
    for (model, file, _) in MODELS {
        let fits = read_fits(&dir.join(file)).unwrap();
        assert!(fits.len() >= 80, "{file}: {} fits", fits.len());
        for f in &fits {
            let desc = json!({"type": "ngan-fit", "material": f.material, "model": model, "fits": dir.to_str().unwrap()});
            let m = reg
                .create(&desc, "m")
                .unwrap_or_else(|e| panic!("{desc}: {e}"));
            // A coarser grid than the battery's: 7 models x ~86 materials.
            for t in [0.0, 30.0, 60.0, 85.0, 89.99] {
                let wo = dir_deg(t, 10.0);
                for t2 in [0.0, 20.0, 45.0, 70.0, 89.99] {
                    for p in [0.0, 90.0, 190.0] {
                        let f = m.eval(wo, dir_deg(t2, p));
                        assert!(f.is_finite() && f.min_component() >= 0.0, "{desc}: {f:?}");
                    }
                }
            }
            n += 1;
        }
    }
    assert!(n > 500);
}

#[test]
fn fits_of_one_material_agree_across_models() {
    // Directional albedo at 20 degrees incidence of each model's fit, relative to the same
    // material's Cook-Torrance fit; the median over materials must be within 6 % of one
    // (measured: 0.990 to 1.044). The total, not the specular part: how a fit splits the
    // data between its diffuse and specular terms depends on the model's shape (the
    // specular parts' medians range from 0.90 to 1.36, and were held to 0.5 to 2 only),
    // while the reflectance both fits reproduce is the data's. Single materials differ
    // more: the models' angular behaviours differ, which is the study's point. A model 5 %
    // off in value moves its median by 5 % of its specular share only: the x1.05 controls
    // of tools/python/tests/test_independent_references.py are the check for that.
    let Some(dir) = fits_dir() else { return };
    let reg = Registry::builtin();
    let models = [
        "ward",
        "ward-duer",
        "blinn-phong",
        "ashikhmin-shirley",
        "he",
        "cook-torrance",
    ];
    let table: Vec<Vec<lobe_materials::ngan_fit::Fit>> = models
        .iter()
        .map(|m| read_fits(&dir.join(MODELS.iter().find(|(n, _, _)| n == m).unwrap().1)).unwrap())
        .collect();
    let wo = dir_deg(20.0, 0.0);
    let total_albedo = |model: &str, fit: &lobe_materials::ngan_fit::Fit| {
        let desc = json!({"type": "ngan-fit", "material": fit.material, "model": model, "fits": dir.to_str().unwrap(), "channel_scale": "none"});
        let m = reg.create(&desc, "m").unwrap();
        albedo(m.as_ref(), wo, 256)
    };
    // Joined on the material's name (the files need not list materials in one order).
    let ct: std::collections::HashMap<&str, f64> = table[5]
        .iter()
        .map(|f| (f.material.as_str(), total_albedo("cook-torrance", f)))
        .collect();
    for (k, model) in models[..5].iter().enumerate() {
        let mut ratios: Vec<f64> = table[k]
            .iter()
            .filter_map(|f| ct.get(f.material.as_str()).map(|c| (f, *c)))
            .filter(|(f, c)| *c > 1e-4 && f.param("eta") != Some(1.0))
            .map(|(f, c)| total_albedo(model, f) / c)
            .collect();
        assert!(
            ratios.len() >= 50,
            "{model}: only {} materials joined with Cook-Torrance's fits",
            ratios.len()
        );
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        eprintln!(
            "{model}: median albedo relative to Cook-Torrance {median:.3} over {} materials",
            ratios.len()
        );
        assert!(
            (0.94..1.06).contains(&median),
            "{model}: median ratio {median:.3} to Cook-Torrance: a normalization is off"
        );
    }
}

/// The fit ranges hold Ngan et al.'s published optima: fitting the data they were fitted
/// to can reach them (the ranges were widened where they did not: Lafortune's cz, He's
/// sigma0 and tau, Ashikhmin-Shirley's exponents below 1). This replaces a hand-written
/// copy of the ranges: what matters of a range is what it must hold.
#[test]
fn fit_ranges_hold_the_published_optima() {
    let Some(dir) = fits_dir() else { return };
    let specs = lobe_materials::fit::builtin_specs();
    let (mut checked, mut outside) = (0, Vec::new());
    for model in lobe_materials::analytic::MODELS {
        let Some(published) = model.published else {
            continue;
        };
        let spec = specs
            .iter()
            .find(|s| s.model == model.schema.name && s.lobes == 1 && s.label == s.model)
            .unwrap_or_else(|| panic!("{}: no fit variant", model.schema.name));
        for fit in read_fits(&dir.join(published.file)).unwrap() {
            for (param, key) in published.keys {
                let Some(range) = spec.params.iter().find(|p| p.name == *param) else {
                    continue;
                };
                let Some(v) = fit.param(key) else { continue };
                // eta = 1 (4 of He's fits): no Fresnel reflection, a lobe that vanished; the
                // fitter reaches the same material with a specular colour of zero.
                if *param == "eta" && v == 1.0 {
                    continue;
                }
                if !(range.lo * (1.0 - 1e-9) <= v && v <= range.hi * (1.0 + 1e-9)) {
                    outside.push(format!(
                        "{} {}: {param} = {v} outside [{}, {}]",
                        fit.material, spec.label, range.lo, range.hi
                    ));
                }
                checked += 1;
            }
        }
    }
    assert!(outside.is_empty(), "{}", outside.join("\n"));
    assert!(checked > 700, "{checked} published values checked");
}
