//! Model selection (`lobe fit --select`): per material, the cheapest fitted model whose
//! Eq. (1) error is within a relative tolerance of the best model's, recorded in the fit
//! report as "selected". The cost ranked is the committed table's
//! ([`crate::cost::reference_cost`]: eval + sample time per call, measured once), so the
//! choice is the same on every run and machine; the timings measured in this run are
//! recorded beside it. Only a model the table lacks (one registered by a user) is ranked by
//! its measured timing.

use crate::cost::{Cost, measure, reference_cost};
use lobe_materials::fit::FitResult;
use lobe_materials::fit::report::{ModelCost, ModelFit, Selection};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use serde_json::Value;
use std::collections::BTreeMap;

/// The cheapest of `candidates` (label, Eq. (1) error, cost) whose error is at most the best
/// error x (1 + `tolerance`); of equally cheap ones, the first. Returns the label ("" when
/// there is none) and the best error (infinite when there is none).
pub fn cheapest_within<'a>(candidates: &[(&'a str, f64, Cost)], tolerance: f64) -> (&'a str, f64) {
    let best = candidates.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    let mut pick: Option<(&str, f64)> = None;
    for &(label, error, cost) in candidates {
        let total = cost.total();
        if error <= best * (1.0 + tolerance) && pick.is_none_or(|p| total < p.1) {
            pick = Some((label, total));
        }
    }
    (pick.map(|p| p.0).unwrap_or_default(), best)
}

/// Selects the cheapest model of `results` (by the committed cost table) within
/// `tolerance` of the best error, recording the cost measured now for each; a fitted
/// material that cannot be built is an error.
pub fn select(
    registry: &Registry,
    results: &[FitResult],
    tolerance: f64,
) -> Result<Selection, Error> {
    let fits = results
        .iter()
        .map(|r| (r.label.as_str(), &r.material, r.error));
    select_among(registry, fits, tolerance)
}

/// [`select`] over the fits of a report (after models were added to it).
pub fn select_fits(
    registry: &Registry,
    fits: &BTreeMap<String, ModelFit>,
    tolerance: f64,
) -> Result<Selection, Error> {
    let fits = fits.iter().map(|(l, f)| (l.as_str(), &f.material, f.error));
    select_among(registry, fits, tolerance)
}

/// [`select`] over (label, fitted material, Eq. (1) error).
fn select_among<'a>(
    registry: &Registry,
    fits: impl Iterator<Item = (&'a str, &'a Value, f64)>,
    tolerance: f64,
) -> Result<Selection, Error> {
    let mut candidates = Vec::new();
    let mut ranked = Vec::new();
    for (label, material, error) in fits {
        let b = registry
            .create(material, label)
            .map_err(|e| Error::Other(e.to_string()))?;
        let measured = measure(b.as_ref());
        let rank = reference_cost(label).unwrap_or(measured);
        candidates.push((label, error, measured));
        ranked.push((label, error, rank));
    }
    let (model, best_error) = cheapest_within(&ranked, tolerance);
    Ok(Selection {
        model: model.to_string(),
        tolerance,
        best_error,
        costs: candidates
            .iter()
            .map(|&(label, error, c)| {
                let cost = ModelCost {
                    eval_ns: c.eval_ns,
                    sample_ns: c.sample_ns,
                    error,
                };
                (label.to_string(), cost)
            })
            .collect(),
    })
}
