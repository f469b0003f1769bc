//! `lobe.fit` and fit reports: measured data (MERL, binned or RGL, told apart by content)
//! or a material's values binned (Ngan et al. 2005 section 4, `fit::dataset`), fitted by
//! lobe-analysis' `fit_material` exactly as `lobe fit` fits it; the typed report
//! (`fit::report`) crosses to Python as its JSON text, and is read and written only by
//! that module. A fit reports each fitted model to a Python callable and stops on Ctrl-C
//! ([`interrupt`]).

use crate::material::Material;
use crate::{file_err, guarded, interrupt, on_threads, to_py};
use lobe_analysis::fitting::{
    BatchProgress, FileFit, FitOptions, data_material, file_key, fit_file_into, fit_material_with,
    stem,
};
use lobe_materials::Bsdf;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{FitResult, Metric, builtin_specs};
use lobe_materials::registry::Registry;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// What to fit: a measured file, or a material (synthetic data, as `lobe fit --material`).
#[derive(FromPyObject)]
enum Data<'py> {
    Material(PyRef<'py, Material>),
    File(PathBuf),
}

/// The data of a fit as its thread gets it: a file, or the BSDF whose values are binned.
enum Source {
    File(PathBuf),
    Values(Arc<dyn Bsdf>),
}

/// The options of a fit from Python's arguments (`metric` a name `lobe fit --metric`
/// takes).
fn fit_options(
    models: Option<String>,
    (resolution, max_evals): (f64, usize),
    select: Option<f64>,
    metric: &str,
    envs: Vec<String>,
) -> PyResult<FitOptions> {
    let metric = Metric::parse(metric)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("metric: {e}")))?;
    Ok(FitOptions {
        models,
        resolution,
        max_evals,
        select,
        metric,
        envs,
        ..Default::default()
    })
}

/// Fits and returns the report's JSON text; `progress(label, error_normalized, seconds)`
/// is called on the calling thread after each model. Ctrl-C or an exception from
/// `progress` stops the fit (at the next objective evaluation) and is raised. `metric` is
/// a name `lobe fit --metric` takes, `envs` the image metric's environment maps (empty:
/// the defaults).
#[pyfunction]
#[pyo3(signature = (data, models, resolution, max_evals, select, progress, metric="eq1", envs=Vec::new(), threads=None))]
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
    threads: Option<usize>,
) -> PyResult<String> {
    guarded(|| {
        let opts = fit_options(models, (resolution, max_evals), select, metric, envs)?;
        let registry = Registry::builtin();
        // What the fit's thread needs of `data` (a `PyRef` stays on this thread).
        let data = match data {
            Data::File(p) => Source::File(p),
            Data::Material(m) => Source::Values(m.bsdf()),
        };
        let work = |events: &interrupt::Events<FitResult>| {
            let stop = || events.cancel.load(Ordering::Relaxed);
            let on_model = |r: &FitResult| events.post(r.clone());
            on_threads(threads, || match &data {
                Source::File(p) => {
                    let d = Dataset::read(p, resolution)?;
                    let measured = data_material(&registry, p, &opts)?;
                    let source = p.display().to_string();
                    let key = file_key(p, &opts)?;
                    let r = fit_material_with(
                        &registry,
                        (&stem(p), &source),
                        (&d, measured.as_deref()),
                        &opts,
                        &stop,
                        &on_model,
                    )?;
                    Ok(FitReport {
                        key: Some(key),
                        ..r
                    })
                }
                Source::Values(b) => {
                    let d = Dataset::isotropic(&|wi, wo| Some(b.eval(wo, wi)), resolution);
                    fit_material_with(
                        &registry,
                        ("synthetic", "material"),
                        (&d, Some(b.as_ref())),
                        &opts,
                        &stop,
                        &on_model,
                    )
                }
            })
        };
        let show = |py: Python<'_>, batch: Vec<FitResult>| match &progress {
            Some(cb) => batch.iter().try_for_each(|r| {
                let args = (r.label.as_str(), r.error_normalized, r.seconds);
                cb.call1(py, args).map(drop)
            }),
            None => Ok(()),
        };
        let report = interrupt::run(py, work, show)?.map_err(to_py)?;
        Ok(report.to_json().to_string())
    })
}

/// Fits the measured file `data` into the report file `out` by content key, as a batch of
/// `lobe fit` does for each file: kept when complete for the same data and settings,
/// completed with the models it lacks, else redone; written atomically. Returns
/// (the report's JSON text, whether it was written). Ctrl-C stops it and is raised.
#[pyfunction]
#[pyo3(signature = (data, out, models, resolution, max_evals, select, metric="eq1", envs=Vec::new(), threads=None))]
#[allow(clippy::too_many_arguments)]
fn fit_into(
    py: Python<'_>,
    data: PathBuf,
    out: PathBuf,
    models: Option<String>,
    resolution: f64,
    max_evals: usize,
    select: Option<f64>,
    metric: &str,
    envs: Vec<String>,
    threads: Option<usize>,
) -> PyResult<(String, bool)> {
    guarded(|| {
        let opts = fit_options(models, (resolution, max_evals), select, metric, envs)?;
        struct Quiet;
        impl BatchProgress for Quiet {}
        let work = |events: &interrupt::Events<()>| {
            let stop = || events.cancel.load(Ordering::Relaxed);
            let registry = Registry::builtin();
            on_threads(threads, || {
                fit_file_into(&registry, (&data, &out), &opts, &stop, &Quiet)
            })
        };
        match interrupt::run(py, work, |_, _| Ok(()))?.map_err(to_py)? {
            FileFit::Written(r) => Ok((r.to_json().to_string(), true)),
            FileFit::Current(r) => Ok((r.to_json().to_string(), false)),
            FileFit::NotStarted => Err(pyo3::exceptions::PyKeyboardInterrupt::new_err(
                "interrupted before the fit began",
            )),
        }
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
        r.check_loads(&Registry::builtin())
            .map_err(|e| file_err(lobe_materials::FileError::new(&shown, e)))?;
        report::write(&path, &r).map_err(file_err)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit_models, m)?)?;
    m.add_function(wrap_pyfunction!(fit_into, m)?)?;
    m.add_function(wrap_pyfunction!(read_fit_report, m)?)?;
    m.add_function(wrap_pyfunction!(write_fit_report, m)?)?;
    Ok(())
}
