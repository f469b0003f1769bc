//! Ngan et al. 2005 section 5.1 on a synthetic structure: a known microfacet distribution
//! (brushed metal, satin or velvet) is tabulated through the APS2000 forward model as
//! sparse 4D data, its distribution is recovered from that data (Eq. 4), and the
//! anisotropic analytic models are fitted to the same data, so that the estimate and the
//! fits are compared by their Eq. (1) errors and the estimate with the truth.

use crate::models::{ANISOTROPIC_DEFAULT, spec};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::{builtin_specs, fit};
use lobe_materials::microfacet_gen::{Estimate, Shape, Table, correlation, estimate, sparse_4d};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;

/// How the experiment is run.
#[derive(Clone, Debug)]
pub struct SynthConfig {
    /// Nodes per side of the truth's and the estimate's tables.
    pub nodes: usize,
    /// Schlick's f0 of the truth (1 when absent) and, when given, of the estimate (else
    /// searched for).
    pub f0: Option<f64>,
    /// Alternations of the p and g estimates.
    pub iterations: usize,
    /// 4D bin size in degrees.
    pub resolution: f64,
    /// Fraction of non-empty bins.
    pub filled: f64,
}

/// What the experiment found.
pub struct Synth {
    /// The sparse 4D data tabulated from the truth.
    pub data: Dataset,
    /// The true distribution.
    pub truth: Table,
    /// The distribution recovered from the data.
    pub estimate: Estimate,
    /// Correlation of the estimated p with the truth.
    pub correlation: f64,
    /// Per representation (the estimate first, then each anisotropic fit): its label, its
    /// Eq. (1) error, its fitting time in seconds (0 for the estimate) and a note on the
    /// fitted lobe (see [`lobe_note`]).
    pub rows: Vec<(String, f64, f64, String)>,
}

/// What a reader of the comparison must know about a fitted material: "specular lobe
/// vanished at the optimum" when its specular colour is zero in every channel (the fit is
/// then the best Lambertian term alone, and models whose lobes all vanish share one error),
/// else its specular colour.
pub fn lobe_note(material: &serde_json::Value) -> String {
    let spec: Vec<f64> = match material.get("specular") {
        Some(serde_json::Value::Array(a)) => a.iter().filter_map(|v| v.as_f64()).collect(),
        Some(v) => v.as_f64().into_iter().collect(),
        None => Vec::new(),
    };
    if !spec.is_empty() && spec.iter().all(|&s| s == 0.0) {
        "specular lobe vanished at the optimum: the fit is its diffuse term alone".into()
    } else {
        let shown: Vec<String> = spec.iter().map(|s| format!("{s:.3}")).collect();
        format!("specular [{}]", shown.join(", "))
    }
}

/// Runs the experiment on `shape` (named `structure` in errors).
pub fn synth(
    registry: &Registry,
    shape: &Shape,
    structure: &str,
    config: &SynthConfig,
) -> Result<Synth, Error> {
    let truth = Table::from_fn(config.nodes, |h| shape.density(h)).map_err(Error::Other)?;
    let f0 = config.f0.unwrap_or(1.0);
    let (kd, ks) = ([0.05, 0.04, 0.03], [0.5, 0.4, 0.3]);
    let data = sparse_4d(
        &|wi, wo| {
            let r = truth.rho(wo.as_dvec3().into(), wi.as_dvec3().into(), f0);
            [0, 1, 2].map(|c| kd[c] / std::f64::consts::PI + ks[c] * r)
        },
        config.resolution,
        config.filled,
        1,
    );
    let est = estimate(&data, config.nodes, config.f0, config.iterations)
        .map_err(|e| Error::file(structure, e))?;
    let mut rows = vec![(
        "sampled-microfacet (estimated p)".to_string(),
        est.error,
        0.0,
        String::new(),
    )];
    let specs = builtin_specs();
    for label in ANISOTROPIC_DEFAULT {
        let r = fit(registry, &data, &spec(&specs, label)?, 300).map_err(Error::Other)?;
        rows.push((
            label.to_string(),
            r.error,
            r.seconds,
            lobe_note(&r.material),
        ));
    }
    Ok(Synth {
        correlation: correlation(&est.table, &truth),
        data,
        truth,
        estimate: est,
        rows,
    })
}
