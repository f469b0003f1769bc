//! Fitting measured data to the analytic models with the study's procedure (Ngan et al.
//! 2005, sections 3.2-3.3): the error of Eq. (1),
//!
//!   E(p) = sqrt( sum w [(R - M(p)) cos(theta_i)]^2 / sum w ),
//!
//! (root mean square over the three colour channels as well), where the six (or, with two
//! lobes, nine) colour parameters are solved exactly inside every evaluation by
//! non-negative least squares ([`linear`]) and the lobe parameters are optimized by SLSQP
//! (the `slsqp` crate, NLopt's algorithm) with finite-difference gradients (forward in the
//! coarse stage, central in the refinement), from a grid of starting points; the report says how many starts reached the best error. The starts run
//! on a subset of the bins (the specular peak plus a weighted stride sample of the rest,
//! [`dataset::Dataset::coarse`]), the best optima are refined on a finer subset built the
//! same way, and the winner is judged on all of them: a 1-degree fit (1.15 M bins) costs a
//! couple of full-data passes instead of hundreds.

pub mod dataset;
pub mod image;
pub mod linear;
pub mod metric;
pub mod report;
pub mod spec;

use crate::lobe::Lobe;
use crate::registry::Registry;
use dataset::Dataset;
use linear::Gram;
pub use metric::{Metric, Objective};
use serde_json::{Value, json};
pub use spec::{
    ANISOTROPIC_DEFAULT, FitParam, ISOTROPIC_DEFAULT, ModelSpec, builtin_specs, model_specs,
};
use std::f64::consts::FRAC_1_PI;
use std::sync::Arc;

/// The result of fitting one model.
#[derive(Clone, Debug, Default)]
pub struct FitResult {
    pub label: String,
    /// The fitted material: a registry description (`composite` for two lobes).
    pub material: Value,
    /// Eq. (1) error, whatever the metric minimized.
    pub error: f64,
    /// Error divided by the data's largest directional albedo.
    pub error_normalized: f64,
    /// The metric minimized.
    pub metric: Metric,
    /// That metric's value at the fit (None for Eq. (1), whose value is `error`).
    pub metric_error: Option<f64>,
    pub starts: usize,
    /// Starts whose final error is within 1 % of the best.
    pub starts_agreeing: usize,
    pub evaluations: usize,
    pub seconds: f64,
    /// Parameters that ended at a bound of their fit range.
    pub at_bounds: Vec<report::BoundHit>,
    /// The coarse-stage final error of every start, ascending.
    pub start_errors: Vec<f64>,
    /// The contained model whose optimum was one of the starts.
    pub started_from: Option<report::StartedFrom>,
    /// An anisotropic model fitted to isotropic data.
    pub isotropic_data: bool,
}

/// Relative distance (of the value, or of its logarithm's range for linear parameters)
/// within which a fitted parameter counts as at a bound.
pub const AT_BOUND: f64 = 1e-3;

/// Normal equations per channel of the colours for fixed lobes: chunks of 4096 samples in
/// parallel, merged in order (as [`metric::ordered_sum`]), so that a fit is the same bits
/// for any thread count and any run.
fn grams(data: &Dataset, lobes: &[Arc<dyn Lobe>]) -> [Gram; 3] {
    use rayon::prelude::*;
    let n = 1 + lobes.len();
    data.samples
        .par_chunks(4096)
        .map(|chunk| {
            let mut g = [Gram::new(n), Gram::new(n), Gram::new(n)];
            let pairs: Vec<_> = chunk
                .iter()
                .map(|s| (s.wo.as_dvec3(), s.wi.as_dvec3()))
                .collect();
            // At most two lobes (the colour solve has three unknowns per channel).
            let mut values = vec![[[0.0; 3]; 2]; chunk.len()];
            let mut buf = vec![[0.0; 3]; chunk.len()];
            for (k, l) in lobes.iter().enumerate() {
                l.eval_f64_many(&pairs, &mut buf);
                for (v, b) in values.iter_mut().zip(&buf) {
                    v[k] = *b;
                }
            }
            for (c, gc) in g.iter_mut().enumerate() {
                gc.add_all(chunk.iter().zip(&values).map(|(s, v)| {
                    let mut f = [FRAC_1_PI; 3];
                    for k in 0..lobes.len() {
                        f[k + 1] = if v[k][c].is_finite() { v[k][c] } else { 0.0 };
                    }
                    (f, s.value[c], s.weight * s.cos2)
                }));
            }
            g
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold([Gram::new(n), Gram::new(n), Gram::new(n)], |a, b| {
            [a[0].merge(&b[0]), a[1].merge(&b[1]), a[2].merge(&b[2])]
        })
}

fn linear_colours_with(
    data: &Dataset,
    lobes: &[Arc<dyn Lobe>],
    total_weight: f64,
) -> (f64, [[f64; 3]; 3]) {
    let g = grams(data, lobes);
    let mut res = 0.0;
    let mut colours = [[0.0f64; 3]; 3];
    for c in 0..3 {
        let (xs, r) = g[c].solve_nonnegative();
        res += r;
        for k in 0..3 {
            colours[k][c] = xs[k];
        }
    }
    ((res / (3.0 * total_weight)).sqrt(), colours)
}

/// The linear part of the fit on its own (section 3.3): for fixed lobes (at most two), the
/// non-negative diffuse and specular colours minimizing Eq. (1), and that error. Returns
/// (error, [diffuse, specular of lobe 1, specular of lobe 2]) with colours per channel.
pub fn linear_colours(data: &Dataset, lobes: &[Arc<dyn Lobe>]) -> (f64, [[f64; 3]; 3]) {
    assert!(lobes.len() <= 2, "at most two lobes");
    linear_colours_with(data, lobes, data.total_weight().max(1e-300))
}

/// The Eq. (1) error of given colours ([diffuse, specular of each lobe] per channel) and
/// lobes on the data, from the normal equations: sum w (r - f.x)^2 = c - 2 b.x + x.A.x.
fn eq1_of_colours(data: &Dataset, lobes: &[Arc<dyn Lobe>], colours: &[[f64; 3]; 3]) -> f64 {
    let g = grams(data, lobes);
    let mut res = 0.0;
    for (c, g) in g.iter().enumerate() {
        let x: [f64; 3] = std::array::from_fn(|k| colours[k][c]);
        let mut r = g.c;
        for j in 0..g.n {
            r -= 2.0 * g.b[j] * x[j];
            for k in 0..g.n {
                r += x[j] * g.a[j][k] * x[k];
            }
        }
        res += r.max(0.0);
    }
    (res / (3.0 * data.total_weight().max(1e-300))).sqrt()
}

struct Problem<'a> {
    data: &'a Dataset,
    spec: &'a ModelSpec,
    registry: &'a Registry,
    total_weight: f64,
    objective: Objective<'a>,
}

impl Problem<'_> {
    fn values(&self, x: &[f64]) -> Vec<f64> {
        let k = self.spec.params.len();
        (0..self.spec.lobes * k)
            .map(|i| {
                let fp = &self.spec.params[i % k];
                let v = if fp.log { x[i].exp() } else { x[i] };
                v.clamp(fp.lo, fp.hi)
            })
            .collect()
    }

    fn lobe_desc(&self, vals: &[f64], lobe: usize) -> Value {
        let k = self.spec.params.len();
        let mut d = self.spec.settings.clone();
        d["type"] = json!(self.spec.model);
        for (j, fp) in self.spec.params.iter().enumerate() {
            let v = vals[lobe * k + j];
            d[fp.name] = json!(v);
            for t in fp.tied {
                d[*t] = json!(v);
            }
        }
        d
    }

    fn lobes(&self, vals: &[f64]) -> Option<Vec<Arc<dyn Lobe>>> {
        (0..self.spec.lobes)
            .map(|l| {
                let mut d = self.lobe_desc(vals, l);
                d["specular"] = json!(1.0);
                self.registry
                    .create_lobe(&d, "fit")
                    .ok()
                    .map(|(_, lobe)| lobe)
            })
            .collect()
    }

    /// The objective at `x` and the colours (diffuse, then each lobe's specular) per
    /// channel that minimize it.
    fn error(&self, x: &[f64]) -> (f64, [[f64; 3]; 3]) {
        let vals = self.values(x);
        let Some(lobes) = self.lobes(&vals) else {
            return (f64::INFINITY, [[0.0; 3]; 3]);
        };
        match self.objective {
            Objective::Eq1 => linear_colours_with(self.data, &lobes, self.total_weight),
            Objective::Compressed(g) => {
                metric::compressed_colours(self.data, &lobes, g, self.total_weight)
            }
            Objective::Image(images) => images.colours(&lobes),
        }
    }

    /// The Eq. (1) error on all the bins of the fit at `x` with `colours`.
    fn eq1_at(&self, x: &[f64], colours: &[[f64; 3]; 3]) -> f64 {
        match self.lobes(&self.values(x)) {
            Some(lobes) => eq1_of_colours(self.data, &lobes, colours),
            None => f64::INFINITY,
        }
    }

    /// The parameters of `x` at (within [`AT_BOUND`] of) a bound of their fit range.
    fn at_bounds(&self, x: &[f64]) -> Vec<report::BoundHit> {
        let k = self.spec.params.len();
        let vals = self.values(x);
        let mut hits = Vec::new();
        for (i, &v) in vals.iter().enumerate() {
            let fp = &self.spec.params[i % k];
            let near = |b: f64| {
                if fp.log {
                    (v / b).ln().abs() <= AT_BOUND
                } else {
                    (v - b).abs() <= AT_BOUND * (fp.hi - fp.lo)
                }
            };
            let side = if near(fp.lo) {
                (fp.lo, report::BoundSide::Lower)
            } else if near(fp.hi) {
                (fp.hi, report::BoundSide::Upper)
            } else {
                continue;
            };
            hits.push(report::BoundHit {
                param: if self.spec.lobes > 1 {
                    format!("lobes[{}].{}", i / k, fp.name)
                } else {
                    fp.name.to_string()
                },
                value: v,
                bound: side.0,
                side: side.1,
            });
        }
        hits
    }

    /// The optimizer point of the fitted `contained` model (one lobe, its parameters at
    /// the top of its material), through the parameter map of `spec.contains`; None if the
    /// map or the material lacks a parameter.
    fn start_from(&self, contained: &Value) -> Option<Vec<f64>> {
        let map = self.spec.contains?;
        (0..self.spec.lobes * self.spec.params.len())
            .map(|i| {
                let fp = &self.spec.params[i % self.spec.params.len()];
                let from = map.params.iter().find(|(p, _)| *p == fp.name)?.1;
                let v = contained.get(from)?.as_f64()?.clamp(fp.lo, fp.hi);
                Some(if fp.log { v.ln() } else { v })
            })
            .collect()
    }

    fn material(&self, x: &[f64], colours: &[[f64; 3]; 3]) -> Value {
        let vals = self.values(x);
        let diffuse = json!(colours[0]);
        if self.spec.lobes == 1 {
            let mut d = self.lobe_desc(&vals, 0);
            d["diffuse"] = diffuse;
            d["specular"] = json!(colours[1]);
            d
        } else {
            let lobes: Vec<Value> = (0..self.spec.lobes)
                .map(|l| {
                    let mut d = self.lobe_desc(&vals, l);
                    d["specular"] = json!(colours[l + 1]);
                    d
                })
                .collect();
            json!({"type": "composite", "diffuse": diffuse, "lobes": lobes})
        }
    }
}

/// The Eq. (1) error of any BRDF `f(wi, wo)` (per channel, cosine not included) on the data:
/// the measure that compares a fit, a tabulated distribution and the truth on equal terms.
pub fn eq1_error(data: &Dataset, f: &(dyn Fn(glam::Vec3, glam::Vec3) -> [f64; 3] + Sync)) -> f64 {
    let sum = metric::ordered_sum(
        data.samples.len(),
        |acc: &mut f64, i| {
            let s = &data.samples[i];
            let m = f(s.wi, s.wo);
            *acc += (0..3)
                .map(|c| s.weight * s.cos2 * (s.value[c] - m[c]).powi(2))
                .sum::<f64>();
        },
        0.0,
        |a, b| a + b,
    );
    (sum / (3.0 * data.total_weight().max(1e-300))).sqrt()
}

/// Bins of the coarse stage of the multi-start.
pub const COARSE_SAMPLES: usize = 12_000;
/// Bins of the refinement stage (all of them for smaller data).
pub const REFINE_SAMPLES: usize = 150_000;
/// Objective evaluations allowed to refine a coarse optimum.
pub const REFINE_EVALS: usize = 40;

/// One SLSQP run from `x0` within `bounds`, with central-difference gradients (`central`)
/// or forward differences (half the evaluations, for the coarse stage whose optima are
/// refined anyway); returns the best point the run evaluated (SLSQP's last point is not
/// always its best) and its error. Once `stop` returns true, every further evaluation
/// returns at once (the last error, a zero gradient), so SLSQP ends within an iteration
/// and the caller sees the request without waiting for the run to converge.
fn minimize(
    pr: &Problem,
    bounds: &[(f64, f64)],
    x0: &[f64],
    max_evals: usize,
    central: bool,
    evaluations: &mut usize,
    stop: &Stop<'_>,
) -> (f64, Vec<f64>) {
    let evals = std::cell::Cell::new(0usize);
    let best = std::cell::RefCell::new((f64::INFINITY, x0.to_vec()));
    let last = std::cell::Cell::new(0.0f64);
    let objective = |x: &[f64], grad: Option<&mut [f64]>, _: &mut ()| -> f64 {
        if stop() {
            if let Some(g) = grad {
                g.fill(0.0);
            }
            return last.get();
        }
        evals.set(evals.get() + 1);
        let e = pr.error(x).0;
        last.set(e);
        if e < best.borrow().0 {
            *best.borrow_mut() = (e, x.to_vec());
        }
        if let Some(g) = grad {
            let h = 1e-4;
            for i in 0..x.len() {
                let mut xp = x.to_vec();
                xp[i] = (x[i] + h).min(bounds[i].1);
                // Forward differences step back from the upper bound.
                if !central && xp[i] <= x[i] {
                    xp[i] = (x[i] - h).max(bounds[i].0);
                }
                let mut xm = x.to_vec();
                let em = if central {
                    xm[i] = (x[i] - h).max(bounds[i].0);
                    evals.set(evals.get() + 1);
                    pr.error(&xm).0
                } else {
                    e
                };
                let ep = pr.error(&xp).0;
                evals.set(evals.get() + 1);
                g[i] = if xp[i] != xm[i] {
                    (ep - em) / (xp[i] - xm[i])
                } else {
                    0.0
                };
            }
        }
        e
    };
    let no_cons: Vec<&dyn slsqp::Func<()>> = Vec::new();
    // Parameters are in log space where they are scales, so 1e-5 is a relative 1e-5.
    let tols = slsqp::StopTols {
        ftol_rel: 1e-7,
        xtol_abs: vec![1e-5; x0.len()],
        ..Default::default()
    };
    // The status does not matter: whatever happened, the best point seen is kept.
    let _ = slsqp::minimize(objective, x0, bounds, &no_cons, (), max_evals, Some(tols));
    *evaluations += evals.get();
    let (e, x) = best.into_inner();
    if e.is_finite() || stop() {
        (e, x)
    } else {
        (pr.error(x0).0, x0.to_vec())
    }
}

/// Polled during a fit (inside every objective evaluation): true asks it to stop, e.g.
/// `&|| flag.load(Ordering::Relaxed)` for a flag that Ctrl-C sets.
pub type Stop<'a> = dyn Fn() -> bool + Sync + 'a;

/// Why a fit returned no result.
#[derive(Clone, Debug, PartialEq)]
pub enum FitError {
    /// Data that cannot be fitted (empty, non-finite), with the reason.
    Data(String),
    /// The stop poll asked the fit to end; nothing was produced.
    Cancelled,
}

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            FitError::Data(m) => f.write_str(m),
            FitError::Cancelled => f.write_str("cancelled"),
        }
    }
}

impl std::error::Error for FitError {}

/// Fits one model to the data, building its lobes through `registry` (which must know
/// `spec.model`); fails (with the reason) on empty or non-finite data.
pub fn fit(
    registry: &Registry,
    data: &Dataset,
    spec: &ModelSpec,
    max_evals_per_start: usize,
) -> Result<FitResult, String> {
    fit_until(registry, data, spec, max_evals_per_start, &|| false).map_err(|e| e.to_string())
}

/// Optimizer bounds of every parameter (log space for scales) and the grid of starts (for
/// two lobes, the second lobe starts 4x wider).
fn bounds_and_starts(spec: &ModelSpec) -> (Vec<(f64, f64)>, Vec<Vec<f64>>) {
    let k = spec.params.len();
    let to_x = |fp: &FitParam, v: f64| if fp.log { v.ln() } else { v };
    let bounds: Vec<(f64, f64)> = (0..spec.lobes * k)
        .map(|i| {
            let fp = &spec.params[i % k];
            (to_x(fp, fp.lo), to_x(fp, fp.hi))
        })
        .collect();
    let mut grid: Vec<Vec<f64>> = vec![Vec::new()];
    for fp in &spec.params {
        grid = grid
            .into_iter()
            .flat_map(|g| {
                fp.starts.iter().map(move |&s| {
                    let mut h = g.clone();
                    h.push(s);
                    h
                })
            })
            .collect();
    }
    let starts = grid
        .iter()
        .map(|g| {
            (0..spec.lobes * k)
                .map(|i| {
                    let fp = &spec.params[i % k];
                    let mut v = g[i % k];
                    if i >= k && fp.log {
                        v = (v * 4.0).min(fp.hi);
                    }
                    to_x(fp, v)
                })
                .collect()
        })
        .collect();
    (bounds, starts)
}

/// [`fit`], polling `stop` inside the optimizer: once it returns true the fit ends within
/// one objective evaluation and returns [`FitError::Cancelled`].
pub fn fit_until(
    registry: &Registry,
    data: &Dataset,
    spec: &ModelSpec,
    max_evals_per_start: usize,
    stop: &Stop<'_>,
) -> Result<FitResult, FitError> {
    fit_from(registry, data, spec, max_evals_per_start, None, stop)
}

/// [`fit_until`], with `contained`, the fit of the variant `spec` contains
/// ([`ModelSpec::contains`], e.g. Ward for anisotropic Ward), as one more start: the
/// result is never worse than `contained` (its point is kept if nothing beats it on all
/// the bins). Without `contained`, or for a spec that contains nothing, it is
/// [`fit_until`].
pub fn fit_from(
    registry: &Registry,
    data: &Dataset,
    spec: &ModelSpec,
    max_evals_per_start: usize,
    contained: Option<&FitResult>,
    stop: &Stop<'_>,
) -> Result<FitResult, FitError> {
    fit_with(
        registry,
        data,
        spec,
        (max_evals_per_start, Objective::Eq1),
        contained,
        stop,
    )
}

/// [`fit_from`], minimizing `objective` ([`metric`]) instead of Eq. (1) (with at most
/// `max_evals_per_start` evaluations per start); the result's `error` is still the Eq. (1)
/// error, its `metric_error` the objective's value.
pub fn fit_with(
    registry: &Registry,
    data: &Dataset,
    spec: &ModelSpec,
    (max_evals_per_start, objective): (usize, Objective<'_>),
    contained: Option<&FitResult>,
    stop: &Stop<'_>,
) -> Result<FitResult, FitError> {
    data.check().map_err(FitError::Data)?;
    let t0 = std::time::Instant::now();
    let pr = Problem {
        data,
        spec,
        registry,
        total_weight: data.total_weight().max(1e-300),
        objective,
    };
    let (bounds, mut starts) = bounds_and_starts(spec);
    let seed = contained.and_then(|c| Some((c, pr.start_from(&c.material)?)));
    if let Some((_, x)) = &seed {
        starts.push(x.clone());
    }
    let cancelled = || {
        if stop() {
            Err(FitError::Cancelled)
        } else {
            Ok(())
        }
    };
    // Coarse to fine: every start runs on a subset of the data (the specular peak and a
    // stride sample of the rest, about COARSE_SAMPLES bins), then the best coarse optima are
    // refined on a finer subset (REFINE_SAMPLES bins).
    let coarse_data = data.coarse(COARSE_SAMPLES);
    let coarse = Problem {
        data: &coarse_data,
        total_weight: coarse_data.total_weight().max(1e-300),
        ..pr
    };
    let mut evaluations = 0usize;
    let mut finals: Vec<(f64, Vec<f64>)> = Vec::with_capacity(starts.len());
    for x0 in &starts {
        cancelled()?;
        let run = minimize(
            &coarse,
            &bounds,
            x0,
            max_evals_per_start,
            false,
            &mut evaluations,
            stop,
        );
        finals.push(run);
    }
    cancelled()?;
    finals.sort_by(|a, b| a.0.total_cmp(&b.0));
    let start_errors: Vec<f64> = finals.iter().map(|f| f.0).collect();
    let best_coarse = finals[0].0;
    let agreeing = finals
        .iter()
        .filter(|f| f.0 <= best_coarse * 1.01 + 1e-15)
        .count();
    let mut best = if coarse_data.samples.len() == data.samples.len() {
        finals.swap_remove(0).1
    } else {
        refine(&pr, &bounds, &finals, &mut evaluations, stop)
    };
    cancelled()?;
    let (mut value, mut colours) = pr.error(&best);
    evaluations += 1;
    if let Some((_, x)) = &seed {
        // The contained model's optimum, judged on all the bins like the winner.
        let (e, c) = pr.error(x);
        evaluations += 1;
        if e < value {
            (value, colours, best) = (e, c, x.clone());
        }
    }
    let (error, metric_error) = match objective {
        Objective::Eq1 => (value, None),
        _ => (pr.eq1_at(&best, &colours), Some(value)),
    };
    Ok(FitResult {
        label: spec.label.to_string(),
        material: pr.material(&best, &colours),
        error,
        metric: objective.metric(),
        metric_error,
        error_normalized: if data.max_albedo > 0.0 {
            error / data.max_albedo
        } else {
            f64::NAN
        },
        starts: starts.len(),
        starts_agreeing: agreeing,
        evaluations,
        seconds: t0.elapsed().as_secs_f64(),
        at_bounds: pr.at_bounds(&best),
        start_errors,
        started_from: seed.map(|(c, _)| report::StartedFrom {
            model: c.label.clone(),
            error: c.error,
        }),
        isotropic_data: spec.group == crate::schema::FitGroup::Anisotropic && !data.anisotropic,
    })
}

/// The refinement of sorted coarse optima `finals`: the candidates (the best one and the
/// best one of a different basin, if any is within 10 % of it) are ranked on a finer
/// stand-in (REFINE_SAMPLES bins, or all of them for smaller data) and the better one is
/// refined there; the caller judges the winner on all the bins.
fn refine(
    pr: &Problem,
    bounds: &[(f64, f64)],
    finals: &[(f64, Vec<f64>)],
    evaluations: &mut usize,
    stop: &Stop<'_>,
) -> Vec<f64> {
    let best_coarse = finals[0].0;
    let mut candidates = vec![&finals[0].1];
    if let Some(other) = finals[1..].iter().find(|f| {
        f.0 <= best_coarse * 1.1 + 1e-15
            && f.1
                .iter()
                .zip(&finals[0].1)
                .any(|(a, b)| (a - b).abs() > 0.05)
    }) {
        candidates.push(&other.1);
    }
    let fine_data = pr.data.coarse(REFINE_SAMPLES);
    let fine = Problem {
        data: &fine_data,
        total_weight: fine_data.total_weight().max(1e-300),
        ..*pr
    };
    let x0 = if candidates.len() > 1 {
        *evaluations += candidates.len();
        candidates
            .iter()
            .map(|x| (fine.error(x).0, *x))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("two candidates")
            .1
    } else {
        candidates[0]
    };
    minimize(&fine, bounds, x0, REFINE_EVALS, true, evaluations, stop).1
}

pub const FIT_SCHEMA: crate::registry::ModelSchema = crate::registry::ModelSchema {
    name: "fit",
    summary: "a model fitted by `lobe fit`: {\"type\": \"fit\", \"file\": \"x.fit.json\", \"model\": \"cook-torrance\"}",
    params: &[
        crate::registry::ParamSpec {
            name: "file",
            kind: crate::registry::ParamKind::Text,
            role: crate::registry::ParamRole::Setting,
            bounds: crate::registry::Bounds::closed(0.0, 0.0),
            default: crate::registry::DefaultValue::Required,
            doc: "the fit report (JSON) written by lobe fit",
            fit: None,
        },
        crate::registry::ParamSpec {
            name: "model",
            kind: crate::registry::ParamKind::Text,
            role: crate::registry::ParamRole::Setting,
            bounds: crate::registry::Bounds::closed(0.0, 0.0),
            default: crate::registry::DefaultValue::Required,
            doc: "the fitted model's label in the report",
            fit: None,
        },
    ],
};

fn build_fit(
    p: &crate::registry::Params,
    ctx: &crate::registry::BuildContext,
) -> Result<Arc<dyn crate::Bsdf>, crate::ParamError> {
    let path = crate::measured::material::resolve(ctx, p.text("file"));
    let err = |m: String| crate::ParamError::new(format!("{}.file", p.path), m);
    let report = report::read(&path).map_err(|e| err(e.to_string()))?;
    let label = p.text("model");
    let m = report
        .models
        .get(label)
        .map(|m| &m.material)
        .ok_or_else(|| {
            crate::ParamError::new(
                format!("{}.model", p.path),
                format!(
                    "no model \"{label}\" in {}; expected one of: {}",
                    path.display(),
                    report.models.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
    // A report holds the fitter's output: an analytic model or a composite of lobes (a
    // report naming another report, even itself, would recurse without end). Its model is
    // built through the caller's registry, which may know models lobe does not ship.
    let reg = ctx.registry;
    let ty = m.get("type").and_then(Value::as_str).unwrap_or("");
    let at = format!("{}(from {})", p.path, path.display());
    if !report_may_hold(reg, ty) {
        let message = if reg.schema(ty).is_none() {
            format!(
                "unknown model \"{ty}\" in model \"{label}\": the registry has no such model; expected one of: {}, {}",
                reg.lobe_model_names().collect::<Vec<_>>().join(", "),
                crate::registry::COMPOSITE
            )
        } else {
            format!(
                "\"{ty}\" in model \"{label}\"; expected an analytic model or a composite, as lobe fit writes"
            )
        };
        return Err(crate::ParamError::new(format!("{at}.type"), message));
    }
    let b = reg.create_with(m, &at, ctx)?;
    if let Some(bad) = crate::bsdf::first_nonfinite(b.as_ref()) {
        return Err(err(format!(
            "{}: model \"{label}\" is not finite in f32 at {bad}; expected parameters whose BRDF f32 holds",
            path.display()
        )));
    }
    Ok(b)
}

/// Whether a fit report's model may be of type `ty`: an analytic model or a composite of
/// them, as `lobe fit` writes (never a report naming a report, which could name itself).
fn report_may_hold(reg: &Registry, ty: &str) -> bool {
    ty == crate::registry::COMPOSITE || reg.is_lobe_model(ty)
}

/// The report a `fit` description reads, and the files of the model it names.
fn fit_inputs(
    p: &crate::registry::Params,
    ctx: &crate::registry::BuildContext,
) -> Vec<std::path::PathBuf> {
    let path = crate::measured::material::resolve(ctx, p.text("file"));
    let model = report::read(&path)
        .ok()
        .and_then(|mut r| r.models.remove(p.text("model")))
        .map(|m| m.material);
    let mut out = vec![path];
    // Only what `build_fit` accepts is followed: an analytic model or a composite. A
    // report naming a report (itself, or one that names it back) is refused when built,
    // and must not be followed here, where it would recurse without end.
    if let Some(m) = model {
        let ty = m.get("type").and_then(Value::as_str).unwrap_or("");
        if report_may_hold(ctx.registry, ty) {
            out.extend(ctx.registry.inputs(&m, ctx));
        }
    }
    out
}

pub fn register(r: &mut Registry) {
    r.register(FIT_SCHEMA, build_fit);
    r.register_inputs(FIT_SCHEMA.name, fit_inputs);
}
