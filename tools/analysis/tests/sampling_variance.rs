//! The sampling-variance table (docs/performance.md, "Sampling variance per model"): both
//! estimators are unbiased, a sampler that is already ideal scores 1, and the table itself
//! (`cargo test --release -p lobe-analysis --test sampling_variance -- --ignored
//! --nocapture`).

use lobe_analysis::fit_images::FitEnvironment;
use lobe_analysis::sampling_variance::{VIEWS, own_sampling, table_row, tabulated_sampling, view};
use lobe_materials::registry::Registry;
use serde_json::json;

fn model(desc: serde_json::Value) -> std::sync::Arc<dyn lobe_materials::Bsdf> {
    Registry::builtin().create(&desc, "m").unwrap()
}

#[test]
fn both_estimators_agree_and_cosine_sampling_of_lambert_is_ideal() {
    let env = FitEnvironment::load("builtin:studio").unwrap().0;
    let n = 100_000;
    for desc in [
        json!({"type": "lambert", "reflectance": 0.5}),
        json!({"type": "cook-torrance", "diffuse": 0, "specular": 1, "m": 0.2, "fresnel": "none"}),
        json!({"type": "ward", "diffuse": 0, "specular": 1, "alpha": 0.1}),
    ] {
        let m = model(desc.clone());
        for d in [0.0, 70.0] {
            let (a, b) = (
                own_sampling(m.as_ref(), &env, view(d), n),
                tabulated_sampling(m.as_ref(), &env, view(d), n),
            );
            let se = ((a.variance + b.variance) / n as f64).sqrt();
            assert!(
                (a.mean - b.mean).abs() < 5.0 * se,
                "{desc} at {d}: {a:?} vs {b:?}"
            );
            if desc["type"] == "lambert" {
                let ratio = a.variance / b.variance;
                assert!(
                    (0.85..1.2).contains(&ratio),
                    "lambert at {d}: ratio {ratio}"
                );
            }
        }
    }
}

#[test]
#[ignore = "prints the table of docs/performance.md"]
fn sampling_variance_table() {
    let env = FitEnvironment::load("builtin:studio").unwrap().0;
    let spec = |t: &str, extra: serde_json::Value| {
        let mut d = json!({"type": t, "diffuse": 0, "specular": 1});
        d.as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        d
    };
    let rows = [
        (
            "cook-torrance, Beckmann m 0.2",
            spec("cook-torrance", json!({"m": 0.2, "fresnel": "none"})),
        ),
        (
            "cook-torrance, Beckmann m 0.05",
            spec("cook-torrance", json!({"m": 0.05, "fresnel": "none"})),
        ),
        (
            "cook-torrance, Gaussian m 0.2",
            spec(
                "cook-torrance",
                json!({"m": 0.2, "distribution": "gaussian", "fresnel": "none"}),
            ),
        ),
        (
            "cook-torrance, cosine power m 0.2",
            spec(
                "cook-torrance",
                json!({"m": 0.2, "distribution": "cosine-power", "fresnel": "none"}),
            ),
        ),
        ("ward, alpha 0.15", spec("ward", json!({"alpha": 0.15}))),
        (
            "ward-duer, alpha 0.15",
            spec("ward-duer", json!({"alpha": 0.15})),
        ),
        ("blinn-phong, n 100", spec("blinn-phong", json!({"n": 100}))),
        ("lafortune, n 100", spec("lafortune", json!({"n": 100}))),
        (
            "ashikhmin-shirley, n 100",
            spec("ashikhmin-shirley", json!({"n": 100})),
        ),
        (
            "ashikhmin-shirley-anisotropic, 50 / 500",
            spec(
                "ashikhmin-shirley-anisotropic",
                json!({"nu": 50, "nv": 500}),
            ),
        ),
        ("he (defaults)", spec("he", json!({}))),
        (
            "he, sigma0 0.05, tau 2",
            spec("he", json!({"sigma0": 0.05, "tau": 2})),
        ),
        (
            "he, sigma0 1, tau 4",
            spec("he", json!({"sigma0": 1, "tau": 4})),
        ),
        (
            "ward-anisotropic, 0.1 / 0.3",
            spec("ward-anisotropic", json!({"alpha_x": 0.1, "alpha_y": 0.3})),
        ),
        (
            "sampled-microfacet, Beckmann 0.2 (table)",
            spec(
                "sampled-microfacet",
                json!({"alpha_x": 0.2, "alpha_y": 0.2}),
            ),
        ),
        (
            "sampled-microfacet, satin (table)",
            spec("sampled-microfacet", json!({"distribution": "satin"})),
        ),
        (
            "poulin-fournier (defaults)",
            spec("poulin-fournier", json!({})),
        ),
    ];
    println!(
        "| model | {} |\n|---|{}",
        VIEWS.map(|d| format!("theta_o {d}")).join(" | "),
        "---|".repeat(VIEWS.len())
    );
    // LOBE_VARIANCE_ROWS=text: only the rows whose name holds it.
    let only = std::env::var("LOBE_VARIANCE_ROWS").unwrap_or_default();
    for (name, desc) in rows.into_iter().filter(|(name, _)| name.contains(&only)) {
        let m = model(desc);
        let cells: Vec<String> = table_row(m.as_ref(), &env, 200_000)
            .iter()
            .map(|(own, ideal)| format!("{:.2}", own.variance / ideal.variance.max(1e-300)))
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}
