//! Model selection (`lobe fit --select`): per material, the cheapest fitted model (eval +
//! sample time per call, [`crate::cost`]) whose Eq. (1) error is within a relative
//! tolerance of the best model's, recorded in the fit report as "selected".

use crate::cost::{Cost, measure};
use lobe_materials::fit::FitResult;
use lobe_materials::fit::report::{ModelCost, Selection};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;

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

/// Measures the cost of every fitted model of `results` and selects the cheapest within
/// `tolerance` of the best error; a fitted material that cannot be built is an error.
pub fn select(
    registry: &Registry,
    results: &[FitResult],
    tolerance: f64,
) -> Result<Selection, Error> {
    let mut candidates = Vec::with_capacity(results.len());
    for r in results {
        let b = registry
            .create(&r.material, &r.label)
            .map_err(|e| Error::Other(e.to_string()))?;
        candidates.push((r.label.as_str(), r.error, measure(b.as_ref())));
    }
    let (model, best_error) = cheapest_within(&candidates, tolerance);
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
