//! `lobe.fit` and fit reports: measured data (MERL, binned or RGL, told apart by content)
//! or a material's values binned (Ngan et al. 2005 section 4, `fit::dataset`), fitted by
//! lobe-analysis' `fit_material` exactly as `lobe fit` fits it; the typed report
//! (`fit::report`) crosses to Python as its JSON text, and is read and written only by
//! that module.

use crate::material::Material;
use crate::{file_err, guarded, to_py};
use lobe_analysis::fitting::{FitOptions, data_material, fit_material_with, stem};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{FitResult, Metric, builtin_specs};
use lobe_materials::registry::Registry;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Mutex;

/// What to fit: a measured file, or a material (synthetic data, as `lobe fit --material`).
#[derive(FromPyObject)]
enum Data<'py> {
    Material(PyRef<'py, Material>),
    File(PathBuf),
}

/// Fits and returns the report's JSON text; `progress(label, error_normalized, seconds)`
/// is called after each model. `metric` is a name `lobe fit --metric` takes, `envs` the
/// image metric's environment maps (empty: the defaults).
#[pyfunction]
#[pyo3(signature = (data, models, resolution, max_evals, select, progress, metric="eq1", envs=Vec::new()))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    data: Data<'_>,
    models: Option<String>,
    resolution: f64,
    max_evals: usize,
    select: Option<f64>,
    progress: Option<Py<PyAny>>,
    metric: &str,
    envs: Vec<String>,
) -> PyResult<String> {
    guarded(|| {
        let metric = Metric::parse(metric)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("metric: {e}")))?;
        let opts = FitOptions {
            models,
            resolution,
            max_evals,
            select,
            metric,
            envs,
            ..Default::default()
        };
        let callback_error: Mutex<Option<PyErr>> = Mutex::new(None);
        let on_model = |r: &FitResult| {
            if let Some(cb) = &progress {
                Python::attach(|py| {
                    let args = (r.label.as_str(), r.error_normalized, r.seconds);
                    if let Err(e) = cb.call1(py, args) {
                        callback_error.lock().expect("unpoisoned").get_or_insert(e);
                    }
                });
            }
        };
        let never = || false;
        let registry = Registry::builtin();
        let report = match data {
            Data::File(p) => py.detach(|| {
                let d = Dataset::read(&p, resolution)?;
                let measured = data_material(&registry, &p, &opts)?;
                let source = p.display().to_string();
                fit_material_with(
                    &registry,
                    (&stem(&p), &source),
                    (&d, measured.as_deref()),
                    &opts,
                    &never,
                    &on_model,
                )
            }),
            Data::Material(m) => {
                let b = m.bsdf();
                py.detach(|| {
                    let d = Dataset::isotropic(&|wi, wo| Some(b.eval(wo, wi)), resolution);
                    fit_material_with(
                        &registry,
                        ("synthetic", "material"),
                        (&d, Some(b.as_ref())),
                        &opts,
                        &never,
                        &on_model,
                    )
                })
            }
        }
        .map_err(to_py)?;
        if let Some(e) = callback_error.into_inner().expect("unpoisoned") {
            return Err(e);
        }
        Ok(report.to_json().to_string())
    })
}

/// The labels `models=` accepts (`lobe fit --list`).
#[pyfunction]
fn fit_models() -> Vec<String> {
    builtin_specs()
        .into_iter()
        .map(|s| s.label.to_string())
        .collect()
}

/// A fit report file's JSON text, read and checked by lobe's report reader.
#[pyfunction]
fn read_fit_report(path: PathBuf) -> PyResult<String> {
    guarded(|| {
        let r = report::read(&path).map_err(file_err)?;
        Ok(r.to_json().to_string())
    })
}

/// Checks a report's JSON text as a report and writes it atomically.
#[pyfunction]
fn write_fit_report(path: PathBuf, text: &str) -> PyResult<()> {
    guarded(|| {
        let shown = path.display().to_string();
        let v = lobe_materials::json::parse(text, &shown).map_err(file_err)?;
        let r: FitReport = FitReport::from_json(&v, &shown).map_err(file_err)?;
        report::write(&path, &r).map_err(file_err)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit_models, m)?)?;
    m.add_function(wrap_pyfunction!(read_fit_report, m)?)?;
    m.add_function(wrap_pyfunction!(write_fit_report, m)?)?;
    Ok(())
}
