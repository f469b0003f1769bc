//! The study from Python (Ngan et al. 2005 sections 3 to 5, lobe-analysis' `study`): the
//! whole study on one machine (`lobe.study`, as `lobe study`), and its parts as separate
//! calls so that `lobe.distributed.study` can run each step as a Dask task: the plan (the
//! steps and what each waits for), one step, and the report once every step is done. A
//! configuration crosses as JSON: `{"inputs": [...], "out": DIR, "quick": bool, "envs":
//! [...], "shard": [i, n], "error_spp": n or null}`.

use crate::{guarded, interrupt, on_threads, to_py};
use lobe_analysis::study::steps::Step;
use lobe_analysis::study::{self, Prepared, StepOutcome, StudyConfig, StudyProgress};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use pyo3::prelude::*;
use serde_json::{Value, json};
use std::path::PathBuf;
use std::sync::atomic::Ordering;

/// The configuration of JSON text.
fn config(text: &str) -> Result<StudyConfig, Error> {
    let v = lobe_materials::json::parse(text, "<study config>")?;
    let bad = |f: &str, what: &str| Error::Other(format!("study config: {f}: expected {what}"));
    let strings = |f: &str| -> Result<Vec<String>, Error> {
        match v.get(f) {
            None | Some(Value::Null) => Ok(Vec::new()),
            Some(x) => serde_json::from_value(x.clone()).map_err(|_| bad(f, "a list of strings")),
        }
    };
    let out = v
        .get("out")
        .and_then(Value::as_str)
        .ok_or_else(|| bad("out", "the study folder"))?;
    let shard: (usize, usize) = match v.get("shard") {
        None | Some(Value::Null) => (0, 1),
        Some(x) => serde_json::from_value(x.clone()).map_err(|_| bad("shard", "[i, n]"))?,
    };
    if shard.1 == 0 || shard.0 >= shard.1 {
        return Err(bad("shard", "[i, n] with 0 <= i < n"));
    }
    Ok(StudyConfig {
        inputs: strings("inputs")?.into_iter().map(PathBuf::from).collect(),
        out: PathBuf::from(out),
        quick: v.get("quick").and_then(Value::as_bool).unwrap_or(false),
        shard,
        envs: strings("envs")?,
        error_spp: match v.get("error_spp") {
            None | Some(Value::Null) => None,
            Some(x) => Some(
                x.as_u64()
                    .map(|n| n as usize)
                    .ok_or_else(|| bad("error_spp", "a whole number of samples per pixel"))?,
            ),
        },
    })
}

/// The study of a configuration, prepared (settings recorded, maps resolved).
fn prepare(text: &str) -> Result<Prepared, Error> {
    let c = config(text)?;
    let mats = match c.inputs.is_empty() {
        true => study::builtin_materials()?,
        false => study::materials(&c.inputs)?,
    };
    Prepared::new(&c, mats)
}

/// Prepares the study folder and returns its plan as JSON: `{"materials": [names],
/// "steps": [{"material", "step", "after": [step names of the same material]}]}` (this
/// shard's steps).
#[pyfunction]
fn study_plan(py: Python<'_>, config: &str) -> PyResult<String> {
    guarded(|| {
        let s = py.detach(|| prepare(config)).map_err(to_py)?;
        let steps: Vec<Value> = s
            .plan()
            .iter()
            .map(|(m, step)| {
                let after: Vec<String> = step.after().iter().map(Step::name).collect();
                json!({"material": m.name, "step": step.name(), "after": after})
            })
            .collect();
        let names: Vec<&str> = s.mats.iter().map(|m| m.name.as_str()).collect();
        Ok(json!({"materials": names, "steps": steps}).to_string())
    })
}

/// Runs one step of one material unless it is done: returns "computed" or "done".
/// Ctrl-C stops it and is raised; its failure is a `ValueError` with the step's message.
#[pyfunction]
#[pyo3(signature = (config, material, step, threads=None))]
fn study_step(
    py: Python<'_>,
    config: &str,
    material: &str,
    step: &str,
    threads: Option<usize>,
) -> PyResult<String> {
    guarded(|| {
        let work = |events: &interrupt::Events<()>| {
            let s = prepare(config)?;
            let stop = || events.cancel.load(Ordering::Relaxed);
            let registry = Registry::builtin();
            let ctx = s.context(&registry, &stop);
            let m = s.material(material)?;
            let step = Step::parse(step, s.envs.len())?;
            on_threads(threads, || s.run_step(&ctx, m, step))
        };
        let outcome = interrupt::run(py, work, |_, _| Ok(()))?.map_err(to_py)?;
        Ok(match outcome {
            StepOutcome::Computed => "computed",
            StepOutcome::AlreadyDone => "done",
        }
        .into())
    })
}

/// Builds the report if every material not in `failures` (JSON `[[name, error], ...]`) is
/// complete: returns `{"pending": N, "index": path or null}`.
#[pyfunction]
fn study_finish(py: Python<'_>, config: &str, failures: &str) -> PyResult<String> {
    guarded(|| {
        let failures: Vec<(String, String)> = serde_json::from_str(failures).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "failures: expected [[material, error], ...]: {e}"
            ))
        })?;
        let work = |_: &interrupt::Events<()>| {
            let s = prepare(config)?;
            let registry = Registry::builtin();
            let ctx = s.context(&registry, &|| false);
            s.finish(&ctx, &failures)
        };
        let (pending, index) = interrupt::run(py, work, |_, _| Ok(()))?.map_err(to_py)?;
        Ok(json!({"pending": pending, "index": index}).to_string())
    })
}

/// Counts the steps as they finish, for the progress callback.
struct Steps<'a>(
    &'a interrupt::Events<(usize, usize)>,
    std::sync::atomic::AtomicUsize,
    std::sync::atomic::AtomicUsize,
);

impl StudyProgress for Steps<'_> {
    fn planned(&self, total: usize) {
        self.2.store(total, Ordering::Relaxed);
        self.0.post((0, total));
    }
    fn finished(&self, _what: &str) {
        let done = self.1.fetch_add(1, Ordering::Relaxed) + 1;
        self.0.post((done, self.2.load(Ordering::Relaxed)));
    }
}

/// The whole study on this machine (`lobe study`): returns its summary as JSON
/// (`materials`, `computed`, `skipped`, `pending`, `index`, `failures`);
/// `progress(done, total)` is called with the steps finished.
#[pyfunction]
#[pyo3(signature = (config, progress=None))]
fn study_run(py: Python<'_>, config: &str, progress: Option<Py<PyAny>>) -> PyResult<String> {
    guarded(|| {
        let work = |events: &interrupt::Events<(usize, usize)>| {
            let c = self::config(config)?;
            let stop = || events.cancel.load(Ordering::Relaxed);
            let count = Steps(events, Default::default(), Default::default());
            study::run(&Registry::builtin(), &c, &stop, &count)
        };
        let show = |py: Python<'_>, batch: Vec<(usize, usize)>| match (&progress, batch.last()) {
            (Some(cb), Some(&(done, total))) => cb.call1(py, (done, total)).map(drop),
            _ => Ok(()),
        };
        let s = interrupt::run(py, work, show)?.map_err(to_py)?;
        Ok(json!({
            "materials": s.materials, "computed": s.computed, "skipped": s.skipped,
            "pending": s.pending, "index": s.index, "failures": s.failures,
        })
        .to_string())
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(study_plan, m)?)?;
    m.add_function(wrap_pyfunction!(study_step, m)?)?;
    m.add_function(wrap_pyfunction!(study_finish, m)?)?;
    m.add_function(wrap_pyfunction!(study_run, m)?)?;
    Ok(())
}
