//! The committed cost table that model selection ranks by (`lobe_analysis::cost`): every fit
//! variant has an entry, selection follows the table and not this run's timings, and the
//! table's generator (ignored: `cargo test --release -p lobe-analysis --test model_costs --
//! --ignored`) writes tools/analysis/src/model_costs.json.

use lobe_analysis::cost::{Cost, MODEL_COSTS_JSON, measure, reference_cost};
use lobe_analysis::selection::cheapest_within;
use lobe_materials::fit::builtin_specs;
use lobe_materials::registry::Registry;
use serde_json::{Value, json};

/// The material a fit variant's cost is measured on: its model at default parameters with
/// the variant's settings, a diffuse term, and as many lobes as the variant fits.
fn default_material(spec: &lobe_materials::fit::ModelSpec) -> Value {
    let mut lobe = spec.settings.clone();
    lobe["type"] = json!(spec.model);
    lobe["specular"] = json!(0.3);
    if spec.lobes == 1 {
        lobe["diffuse"] = json!(0.2);
        lobe
    } else {
        json!({"type": "composite", "diffuse": 0.2, "lobes": vec![lobe; spec.lobes]})
    }
}

#[test]
fn every_fit_variant_has_a_committed_cost() {
    let table: Value = serde_json::from_str(MODEL_COSTS_JSON).unwrap();
    let missing: Vec<&str> = builtin_specs()
        .iter()
        .map(|s| s.label)
        .filter(|l| reference_cost(l).is_none())
        .collect();
    assert!(
        missing.is_empty(),
        "no committed cost for {missing:?}: regenerate model_costs.json (see cost::MODEL_COSTS_JSON)"
    );
    for (label, e) in table["models"].as_object().unwrap() {
        let c = reference_cost(label).unwrap();
        assert!(
            c.eval_ns > 0.0 && c.sample_ns > 0.0 && c.total().is_finite(),
            "{label}: {e}"
        );
    }
}

#[test]
fn selection_ranks_by_the_table_whatever_the_timings() {
    // Two models of equal error: the table's cheaper one wins, even when this run's timings
    // say the opposite (as a loaded machine might).
    let (a, b) = ("ward", "he");
    let (ca, cb) = (reference_cost(a).unwrap(), reference_cost(b).unwrap());
    let cheaper = if ca.total() <= cb.total() { a } else { b };
    let (pick, _) = cheapest_within(&[(a, 0.01, ca), (b, 0.01, cb)], 0.1);
    assert_eq!(pick, cheaper);
    let fast = Cost {
        eval_ns: 0.1,
        sample_ns: 0.1,
    };
    let slow = Cost {
        eval_ns: 1e6,
        sample_ns: 1e6,
    };
    let timings = if cheaper == a {
        [slow, fast]
    } else {
        [fast, slow]
    };
    let (by_timing, _) = cheapest_within(&[(a, 0.01, timings[0]), (b, 0.01, timings[1])], 0.1);
    assert_ne!(
        by_timing, cheaper,
        "the timings must disagree with the table here"
    );
}

/// Regenerates tools/analysis/src/model_costs.json on this machine.
#[test]
#[ignore = "writes the committed cost table; run on an idle machine"]
fn write_model_cost_table() {
    let reg = Registry::builtin();
    let mut models = serde_json::Map::new();
    for spec in builtin_specs() {
        let b = reg
            .create(&default_material(&spec), spec.label)
            .unwrap_or_else(|e| panic!("{}: {e}", spec.label));
        let mut runs: Vec<Cost> = (0..5).map(|_| measure(b.as_ref())).collect();
        runs.sort_by(|x, y| x.total().total_cmp(&y.total()));
        let c = runs[2];
        let round = |x: f64| (x * 10.0).round() / 10.0;
        models.insert(
            spec.label.to_string(),
            json!({"eval_ns": round(c.eval_ns), "sample_ns": round(c.sample_ns)}),
        );
    }
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_default();
    let v = json!({
        "about": "ns per eval and per sample at default parameters, median of 5 measures (lobe_analysis::cost); selection ranks by these",
        "machine": cpu,
        "simd_lanes": lobe_materials::simd::LANES,
        "models": models,
    });
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/model_costs.json");
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap() + "\n").unwrap();
}
