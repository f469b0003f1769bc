//! The published Ngan et al. 2005 fits (../shared/data/ngan-fits) load for every material
//! and model, evaluate finite and non-negative, and agree with each other: under the
//! conventions lobe uses, the specular albedos of a material's Ward, Ward-Duer,
//! Blinn-Phong, Cook-Torrance and Ashikhmin-Shirley fits are close (they were fitted to the
//! same data), which a wrong normalization would break by large factors.

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
    // Specular albedo at 20 degrees incidence of each model's fit, relative to the same
    // material's Cook-Torrance fit; the median over materials must be near one. (Single
    // materials differ: the models' angular behaviours differ, which is the study's point.)
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
    let spec_albedo = |model: &str, fit: &lobe_materials::ngan_fit::Fit| {
        let desc = json!({"type": "ngan-fit", "material": fit.material, "model": model, "fits": dir.to_str().unwrap(), "channel_scale": "none"});
        let m = reg.create(&desc, "m").unwrap();
        albedo(m.as_ref(), wo, 256) - fit.diffuse.iter().fold(0.0f64, |a, &b| a.max(b))
    };
    // Joined on the material's name (the files need not list materials in one order).
    let ct: std::collections::HashMap<&str, f64> = table[5]
        .iter()
        .map(|f| (f.material.as_str(), spec_albedo("cook-torrance", f)))
        .collect();
    for (k, model) in models[..5].iter().enumerate() {
        let mut ratios: Vec<f64> = table[k]
            .iter()
            .filter_map(|f| ct.get(f.material.as_str()).map(|c| (f, *c)))
            .filter(|(f, c)| *c > 1e-4 && f.param("eta") != Some(1.0))
            .map(|(f, c)| spec_albedo(model, f) / c)
            .collect();
        assert!(
            ratios.len() >= 50,
            "{model}: only {} materials joined with Cook-Torrance's fits",
            ratios.len()
        );
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        eprintln!(
            "{model}: median specular albedo relative to Cook-Torrance {median:.2} over {} materials",
            ratios.len()
        );
        assert!(
            (0.5..2.0).contains(&median),
            "{model}: median ratio {median:.2} to Cook-Torrance: a normalization is off"
        );
    }
}
