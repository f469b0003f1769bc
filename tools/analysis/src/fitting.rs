//! Fitting one material into a report (Ngan et al. 2005 section 4: every chosen model
//! fitted to the data by [`lobe_materials::fit::fit_with`] with the chosen metric,
//! optionally with the cheapest adequate model selected), and fitting a folder of measured
//! data in a batch: in deterministic shards, in parallel, resumably. Reports are keyed by
//! content ([`lobe_materials::key`]): a rerun fits only the models a report of the same data
//! and settings lacks and merges them in, and redoes a report of other data or settings.

use crate::fit_images::{DEFAULT_FIT_ENVS, fitting_images};
use crate::models::choose;
use crate::selection::{select, select_fits};
use lobe_materials::Bsdf;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::image::ImageSettings;
use lobe_materials::fit::report::{self, FitKey, FitReport};
use lobe_materials::fit::{
    FitError, FitResult, Metric, ModelSpec, Objective, Stop, builtin_specs, fit_with,
};
use lobe_materials::key::{KeyBuilder, file_digest, input_digest};
use lobe_materials::measured::format;
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// What to fit and how.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Comma-separated model labels, or the study's defaults for the data.
    pub models: Option<String>,
    /// Bin size in degrees of isotropic data (recorded in the report).
    pub resolution: f64,
    /// Objective evaluations allowed per SLSQP start.
    pub max_evals: usize,
    /// Select the cheapest model within this relative tolerance of the best error.
    pub select: Option<f64>,
    /// The metric the fits minimize.
    pub metric: Metric,
    /// The environment maps of the `image` metric (`builtin:studio`, `builtin:sunset` or
    /// files); empty: [`crate::fit_images::DEFAULT_FIT_ENVS`].
    pub envs: Vec<String>,
    /// The size of the `image` metric's renders.
    pub image: ImageSettings,
}

impl Default for FitOptions {
    /// The study's settings: its default models, 1-degree bins, Eq. (1), no selection.
    fn default() -> Self {
        Self {
            models: None,
            resolution: 1.0,
            max_evals: 300,
            select: None,
            metric: Metric::Eq1,
            envs: Vec::new(),
            image: ImageSettings::default(),
        }
    }
}

impl FitOptions {
    /// The digest of the settings that shape each model's fit ([`FitKey::settings`]): the
    /// bin size, the metric, the evaluations allowed and, for the image metric, its maps
    /// (by content) and image size. Not the models (reports merge model by model) nor the
    /// selection (made again when models are added).
    pub fn settings_key(&self) -> Result<String, Error> {
        let mut k = KeyBuilder::new("fit-settings")
            .number("resolution", self.resolution)
            .number("max_evals", self.max_evals as f64)
            .text("metric", &self.metric.to_string());
        if self.metric == Metric::Image {
            let defaults = DEFAULT_FIT_ENVS.map(String::from);
            let envs = match self.envs.is_empty() {
                true => &defaults[..],
                false => &self.envs[..],
            };
            for e in envs {
                k = k.text("env", &input_digest(e, "an environment map")?);
            }
            k = k
                .number("image_resolution", self.image.resolution as f64)
                .number("image_samples", self.image.samples as f64);
        }
        Ok(k.finish())
    }

    /// The key of fitting data whose bytes digest to `data`.
    pub fn key(&self, data: String) -> Result<FitKey, Error> {
        Ok(FitKey {
            data,
            settings: self.settings_key()?,
        })
    }
}

/// The key of fitting the measured file `p` with `opts`.
pub fn file_key(p: &Path, opts: &FitOptions) -> Result<FitKey, Error> {
    opts.key(file_digest(p, "measured data")?)
}

/// The digest that stands for the data of a material description tabulated (not
/// measured).
pub fn material_digest(desc: &Value) -> String {
    KeyBuilder::new("material").json("desc", desc).finish()
}

/// What a rerun must do with the report at hand.
#[derive(Clone, Debug, PartialEq)]
pub enum Resume {
    /// No usable report (none, unreadable, or of other data or settings): fit everything.
    Fresh,
    /// A report of the same key: fit these models (none: only the selection is stale).
    Add(Vec<String>),
    /// The report holds every model asked for and a current selection.
    Done,
}

/// What a rerun does with `existing` (a report of key `key` or not) for `opts`.
pub fn resume(
    existing: Option<&FitReport>,
    key: &FitKey,
    opts: &FitOptions,
) -> Result<Resume, Error> {
    let Some(r) = existing.filter(|r| r.key.as_ref() == Some(key)) else {
        return Ok(Resume::Fresh);
    };
    let specs = builtin_specs();
    let missing: Vec<String> = choose(&specs, opts.models.as_deref(), r.anisotropic)?
        .iter()
        .filter(|s| !r.models.contains_key(s.label))
        .map(|s| s.label.to_string())
        .collect();
    let selection_current = match opts.select {
        None => true,
        Some(t) => r.selected.as_ref().is_some_and(|s| s.tolerance == t),
    };
    Ok(match (missing.is_empty(), selection_current) {
        (true, true) => Resume::Done,
        _ => Resume::Add(missing),
    })
}

/// The report at `out` when it exists and reads; a report that does not read is redone.
pub fn existing_report(out: &Path) -> Option<FitReport> {
    out.exists().then(|| report::read(out).ok()).flatten()
}

/// The report for `key`: a fresh fit ([`fit_material_with`]), or `existing` completed
/// with the models `plan` names and, when models were added or the tolerance changed,
/// selected again (at `opts.select`, else at the report's own tolerance).
pub fn complete_report(
    registry: &Registry,
    (existing, plan, key): (Option<FitReport>, Resume, FitKey),
    (name, source): (&str, &str),
    (data, measured): (&Dataset, Option<&dyn Bsdf>),
    opts: &FitOptions,
    stop: &Stop<'_>,
    on_model: &dyn Fn(&FitResult),
) -> Result<FitReport, Error> {
    let fit = |o: &FitOptions| {
        fit_material_with(
            registry,
            (name, source),
            (data, measured),
            o,
            stop,
            on_model,
        )
    };
    let mut report = match (existing, plan) {
        (Some(mut r), Resume::Add(missing)) => {
            if !missing.is_empty() {
                let only = FitOptions {
                    models: Some(missing.join(",")),
                    select: None,
                    ..opts.clone()
                };
                r.models.extend(fit(&only)?.models);
            }
            let tolerance = opts.select.or(r.selected.as_ref().map(|s| s.tolerance));
            if let Some(t) = tolerance {
                r.selected = Some(select_fits(registry, &r.models, t)?);
            }
            r.format_version = report::FORMAT_VERSION;
            r
        }
        (Some(r), Resume::Done) => r,
        _ => fit(opts)?,
    };
    report.key = Some(key);
    Ok(report)
}

/// The material that renders a measured file (MERL, binned or RGL, told by its content).
pub fn data_material_desc(p: &Path) -> Result<Value, Error> {
    let abs = std::fs::canonicalize(p)
        .map_err(|e| Error::file(p.display(), format!("cannot open: {e}")))?;
    let kind = format::detect(&abs)?.material_type();
    Ok(json!({"type": kind, "file": abs.display().to_string()}))
}

/// The material of a measured file, built through `registry` when `opts` need it (the
/// `image` metric renders it), else None.
pub fn data_material(
    registry: &Registry,
    p: &Path,
    opts: &FitOptions,
) -> Result<Option<Arc<dyn Bsdf>>, Error> {
    if opts.metric != Metric::Image {
        return Ok(None);
    }
    let desc = data_material_desc(p)?;
    let m = registry
        .create(&desc, "data")
        .map_err(|e| Error::file(p.display(), e.to_string()))?;
    Ok(Some(m))
}

/// Fits the chosen models to `data` (named `name`, read from `source`) and builds the
/// report; `stop` is polled inside the optimizer (an interruption is an error saying so),
/// `on_model` is called on this thread with each model's result as soon as it and the
/// earlier models of its wave are done. The `image` metric needs
/// [`fit_material_with`] and the measured material.
pub fn fit_material(
    registry: &Registry,
    name: &str,
    source: &str,
    data: &Dataset,
    opts: &FitOptions,
    stop: &Stop<'_>,
    on_model: &dyn Fn(&FitResult),
) -> Result<FitReport, Error> {
    fit_material_with(registry, (name, source), (data, None), opts, stop, on_model)
}

/// One model's fit, from the optimum of the model it contains when given.
type FitOne<'a> = dyn Fn(&ModelSpec, Option<&FitResult>) -> Result<FitResult, Error> + Sync + 'a;

/// Fits the `chosen` models in waves, the models of a wave in parallel: a model that
/// contains another of them (anisotropic Ward contains Ward) waits for the wave that fits
/// that one and starts from its optimum; one whose contained model is not chosen fits that
/// model for the purpose. Every fit is the same bits for any thread count, so the results
/// are those of fitting the models one by one (their `seconds` apart: a fit's wall time
/// shares the cores with its wave). `on_model` sees each result on the calling thread as
/// soon as it and the wave's earlier ones are done, in `chosen`'s order within a wave.
fn fit_in_waves(
    chosen: &[&ModelSpec],
    specs: &[ModelSpec],
    fit_one: &FitOne<'_>,
    on_model: &dyn Fn(&FitResult),
) -> Result<Vec<FitResult>, Error> {
    let chosen_index = |label: &str| chosen.iter().position(|s| s.label == label);
    let mut done: Vec<Option<FitResult>> = vec![None; chosen.len()];
    while done.iter().any(Option::is_none) {
        let ready: Vec<usize> = (0..chosen.len())
            .filter(|&i| done[i].is_none())
            .filter(|&i| {
                let contained = chosen[i].contains.and_then(|c| chosen_index(c.label));
                contained.is_none_or(|j| done[j].is_some())
            })
            .collect();
        if ready.is_empty() {
            return Err(Error::Other(
                "the chosen models contain one another in a cycle; expected a model to contain only simpler ones".into(),
            ));
        }
        let fit = |i: usize| -> Result<FitResult, Error> {
            let fitted_for_the_purpose;
            let contained = match chosen[i].contains {
                None => None,
                Some(c) => match chosen_index(c.label) {
                    Some(j) => done[j].as_ref(),
                    None => match specs.iter().find(|s| s.label == c.label) {
                        Some(s) => {
                            fitted_for_the_purpose = fit_one(s, None)?;
                            Some(&fitted_for_the_purpose)
                        }
                        None => None,
                    },
                },
            };
            fit_one(chosen[i], contained)
        };
        let wave = in_parallel_reported_in_order(ready.len(), |k| fit(ready[k]), on_model);
        for (i, r) in ready.into_iter().zip(wave) {
            done[i] = Some(r?);
        }
    }
    Ok(done.into_iter().flatten().collect())
}

/// `job(0..n)` run in parallel on the rayon pool, the results in order; `report` is called
/// on the calling thread with each successful result as soon as it and every earlier one
/// are done, and no more after the first error. A pool thread runs pool work while it
/// waits (any, not only these jobs; it stops as soon as every result is in), another thread
/// blocks. A job's panic is raised again once the jobs end.
fn in_parallel_reported_in_order<T: Send>(
    n: usize,
    job: impl Fn(usize) -> Result<T, Error> + Sync,
    report: &dyn Fn(&T),
) -> Vec<Result<T, Error>> {
    use std::sync::mpsc::{RecvTimeoutError, TryRecvError, channel};
    let mut results: Vec<Option<Result<T, Error>>> = (0..n).map(|_| None).collect();
    rayon::in_place_scope(|scope| {
        let (tx, rx) = channel();
        // A pool thread takes its own newest job first, other threads the oldest: spawned
        // so that job 0, whose result is reported first, is taken first either way.
        let on_pool = rayon::current_thread_index().is_some();
        for k in 0..n {
            let k = if on_pool { n - 1 - k } else { k };
            let (tx, job) = (tx.clone(), &job);
            // A send fails only once the receiver is gone, after a panic of `report`.
            scope.spawn(move |_| drop(tx.send((k, job(k)))));
        }
        drop(tx);
        let (mut pending, mut reported) = (n, 0);
        while pending > 0 {
            let received = match rx.try_recv() {
                Ok(m) => Ok(m),
                Err(TryRecvError::Disconnected) => Err(RecvTimeoutError::Disconnected),
                Err(TryRecvError::Empty) => match rayon::yield_now() {
                    None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
                    Some(rayon::Yield::Executed) => Err(RecvTimeoutError::Timeout),
                    Some(rayon::Yield::Idle) => {
                        rx.recv_timeout(std::time::Duration::from_millis(1))
                    }
                },
            };
            let (k, r) = match received {
                Ok(m) => m,
                Err(RecvTimeoutError::Timeout) => continue,
                // A job panicked: the scope raises it again.
                Err(RecvTimeoutError::Disconnected) => break,
            };
            results[k] = Some(r);
            pending -= 1;
            while let Some(Some(Ok(r))) = results.get(reported) {
                report(r);
                reported += 1;
            }
        }
    });
    (results.into_iter())
        .map(|r| r.expect("every job sends its result, or its panic is raised again"))
        .collect()
}

/// [`fit_material`] with `measured`, the material `data` was measured from (the `image`
/// metric compares renders of it with renders of the fits; other metrics ignore it).
pub fn fit_material_with(
    registry: &Registry,
    (name, source): (&str, &str),
    (data, measured): (&Dataset, Option<&dyn Bsdf>),
    opts: &FitOptions,
    stop: &Stop<'_>,
    on_model: &dyn Fn(&FitResult),
) -> Result<FitReport, Error> {
    data.check().map_err(|m| Error::file(source, m))?;
    let specs = builtin_specs();
    let chosen = choose(&specs, opts.models.as_deref(), data.anisotropic)?;
    let images = match (opts.metric, measured) {
        (Metric::Image, Some(m)) => Some(fitting_images(&opts.envs, m, opts.image)?),
        (Metric::Image, None) => {
            return Err(Error::Other(format!(
                "{source}: the image metric renders the measured material, which was not given; expected a data file or a material"
            )));
        }
        _ => None,
    };
    let objective = match &images {
        Some(im) => Objective::Image(im),
        None => Objective::pointwise(opts.metric).unwrap_or_default(),
    };
    let fit_one = |spec: &ModelSpec, contained: Option<&FitResult>| {
        fit_with(
            registry,
            data,
            spec,
            (opts.max_evals, objective),
            contained,
            stop,
        )
        .map_err(|e| match e {
            FitError::Cancelled => Error::Other(format!("{source}: interrupted")),
            FitError::Data(m) => Error::file(source, m),
        })
    };
    let results = fit_in_waves(&chosen, &specs, &fit_one, on_model)?;
    let mut report = FitReport::new(name, source, opts.resolution, data, &results);
    report
        .check_loads(registry)
        .map_err(|e| Error::file(source, e))?;
    if let Some(tolerance) = opts.select {
        report.selected = Some(select(registry, &results, tolerance)?);
    }
    Ok(report)
}

/// True for a file named like measured data (.binary, .bin, .bsdf), whatever it holds.
pub fn named_like_data(p: &Path) -> bool {
    matches!(
        p.extension().and_then(|e| e.to_str()),
        Some("binary" | "bin" | "bsdf")
    )
}

/// The data files of a folder, sorted by name: every file whose content is a measured
/// format, and files named like one whatever they hold ([`named_like_data`]), so that a
/// broken one is reported rather than skipped. Other files (notes, reports) are ignored.
pub fn data_files(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::file(dir.display(), format!("cannot list: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter(|p| named_like_data(p) || format::detect(p).is_ok())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::file(
            dir.display(),
            "holds no measured data to fit; expected MERL, binned or RGL files",
        ));
    }
    Ok(files)
}

/// The stem of a data file, naming its material and report.
pub fn stem(p: &Path) -> String {
    p.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("material")
        .to_string()
}

/// One data file of a batch and the report it gets.
pub type BatchJob = (PathBuf, PathBuf);

/// Checks the report folder of a batch: an existing folder, or a new one whose name does
/// not look like a file (`-o x.fit.json` for a folder of data is a mistake, not a folder).
fn check_report_folder(out: &Path) -> Result<(), Error> {
    if out.is_dir() {
        return Ok(());
    }
    if out.exists() {
        return Err(Error::file(
            out.display(),
            "is a file; expected the folder of reports, since the data is a folder",
        ));
    }
    if out.extension().is_some() {
        return Err(Error::file(
            out.display(),
            "looks like a file name, but the data is a folder: -o must name the folder of reports (create it first to use this name)",
        ));
    }
    Ok(())
}

/// The jobs of shard `i` of `n` of the data files of `dir` (sorted by name, every n-th
/// from the i-th): each file with its report `out/<stem>.fit.json`. Checks that no report
/// is an input or another's report, then creates `out` if needed.
pub fn batch_jobs(dir: &Path, out: &Path, (i, n): (usize, usize)) -> Result<Vec<BatchJob>, Error> {
    check_report_folder(out)?;
    let files = data_files(dir)?;
    let mine: Vec<BatchJob> = files
        .iter()
        .enumerate()
        .filter(|(k, _)| k % n == i)
        .map(|(_, p)| (p.clone(), out.join(format!("{}.fit.json", stem(p)))))
        .collect();
    let mut plan = FilePlan::new();
    for p in &files {
        plan.input(p, "measured data to fit");
    }
    for (p, report) in &mine {
        plan.output(report, format!("report of {}", p.display()));
    }
    plan.check_overlaps()?;
    std::fs::create_dir_all(out).map_err(|e| {
        Error::file(
            out.display(),
            format!("cannot create the report folder: {e}"),
        )
    })?;
    plan.check()?;
    Ok(mine)
}

/// What a batch tells as it goes (called from its worker threads).
pub trait BatchProgress: Sync {
    /// A job was skipped: its report is complete for the same data and settings.
    fn skipped(&self) {}
    /// The data of `name` is being read.
    fn reading(&self, _name: &str) {}
    /// `models` models of `name` are to be fitted.
    fn fitting(&self, _name: &str, _models: usize) {}
    /// One model of `name` was fitted.
    fn fitted(&self, _name: &str, _result: &FitResult) {}
    /// The report of `name` is complete (about to be written).
    fn finished(&self, _name: &str, _report: &FitReport) {}
}

/// What a batch did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BatchSummary {
    /// Reports written.
    pub done: usize,
    /// Reports that were already complete.
    pub skipped: usize,
    /// One line per failed material (sorted); the others went on.
    pub failures: Vec<String>,
}

/// What [`fit_file_into`] did.
#[derive(Clone, Debug, PartialEq)]
pub enum FileFit {
    /// The report was made or completed, and written.
    Written(FitReport),
    /// The report was already complete for the same data and settings.
    Current(FitReport),
    /// `stop` was set before the fit began.
    NotStarted,
}

/// Fits the measured file `p` into the report `out` by content key ([`resume`]): skipped
/// when `out` is complete for the same data and settings, completed with the models it
/// lacks, or redone; written atomically.
pub fn fit_file_into(
    registry: &Registry,
    (p, out): (&Path, &Path),
    opts: &FitOptions,
    stop: &Stop<'_>,
    progress: &dyn BatchProgress,
) -> Result<FileFit, Error> {
    if stop() {
        return Ok(FileFit::NotStarted);
    }
    let key = file_key(p, opts)?;
    let existing = existing_report(out);
    let plan = resume(existing.as_ref(), &key, opts)?;
    if let (Resume::Done, Some(r)) = (&plan, &existing) {
        progress.skipped();
        return Ok(FileFit::Current(r.clone()));
    }
    let name = stem(p);
    progress.reading(&name);
    let data = Dataset::read(p, opts.resolution)?;
    let specs = builtin_specs();
    let count = match &plan {
        Resume::Add(missing) => Some(missing.len()),
        _ => choose(&specs, opts.models.as_deref(), data.anisotropic)
            .ok()
            .map(|c| c.len()),
    };
    if let Some(k) = count {
        progress.fitting(&name, k);
    }
    let source = p.display().to_string();
    let on_model = |r: &FitResult| progress.fitted(&name, r);
    let measured = data_material(registry, p, opts)?;
    let r = complete_report(
        registry,
        (existing, plan, key),
        (&name, &source),
        (&data, measured.as_deref()),
        opts,
        stop,
        &on_model,
    )?;
    progress.finished(&name, &r);
    report::write(out, &r)?;
    Ok(FileFit::Written(r))
}

/// Fits the jobs (materials in parallel; each fit is parallel over its bins too) and writes
/// each report atomically. A job whose report has the same key and every model asked for is
/// skipped, one of the same key lacking models gets them added ([`resume`]), any other is
/// redone; so an interrupted batch resumes where it stopped and a rerun with other models,
/// metric, bins or data computes exactly what they change ([`fit_file_into`] per job).
/// Once `stop` returns true no job starts and running fits end.
pub fn fit_batch(
    registry: &Registry,
    jobs: &[BatchJob],
    opts: &FitOptions,
    stop: &Stop<'_>,
    progress: &dyn BatchProgress,
) -> BatchSummary {
    use rayon::prelude::*;
    let (done, skipped) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let fit_one = |p: &Path, out: &Path| -> Result<(), Error> {
        match fit_file_into(registry, (p, out), opts, stop, progress)? {
            FileFit::Written(_) => done.fetch_add(1, Ordering::Relaxed),
            FileFit::Current(_) => skipped.fetch_add(1, Ordering::Relaxed),
            FileFit::NotStarted => 0,
        };
        Ok(())
    };
    let mut failures: Vec<String> = jobs
        .par_iter()
        .filter_map(|(p, out)| fit_one(p, out).err().map(|e| e.to_string()))
        .collect();
    failures.sort();
    BatchSummary {
        done: done.into_inner(),
        skipped: skipped.into_inner(),
        failures,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// What the jobs and the reports did, in order, on a pool of `threads`.
    fn events(threads: usize, fail: Option<usize>) -> (Vec<String>, Vec<bool>) {
        let log = Mutex::new(Vec::new());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let results = pool.install(|| {
            in_parallel_reported_in_order(
                4,
                |k| {
                    log.lock().unwrap().push(format!("job {k}"));
                    match Some(k) == fail {
                        true => Err(Error::Other(format!("job {k} failed"))),
                        false => Ok(k),
                    }
                },
                &|k| log.lock().unwrap().push(format!("report {k}")),
            )
        });
        let ok = results.iter().map(|r| r.is_ok()).collect();
        (log.into_inner().unwrap(), ok)
    }

    /// On one thread each result is reported as soon as its job ends, in order; on two,
    /// every result is reported once, in order.
    #[test]
    fn results_are_reported_in_order_as_they_are_done() {
        let (log, ok) = events(1, None);
        let expected: Vec<String> = (0..4)
            .flat_map(|k| [format!("job {k}"), format!("report {k}")])
            .collect();
        assert_eq!(log, expected);
        assert_eq!(ok, [true; 4]);
        let (log, _) = events(2, None);
        let reports: Vec<&String> = log.iter().filter(|e| e.starts_with("report")).collect();
        assert_eq!(reports, ["report 0", "report 1", "report 2", "report 3"]);
    }

    /// After a failed job nothing more is reported, and every result is returned.
    #[test]
    fn nothing_is_reported_after_an_error() {
        let (log, ok) = events(1, Some(1));
        assert_eq!(log, ["job 0", "report 0", "job 1", "job 2", "job 3"]);
        assert_eq!(ok, [true, false, true, true]);
    }

    #[test]
    #[should_panic(expected = "job 2 panicked")]
    fn a_job_that_panics_raises_its_panic() {
        rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| {
                in_parallel_reported_in_order(
                    3,
                    |k| match k {
                        2 => panic!("job 2 panicked"),
                        _ => Ok(k),
                    },
                    &|_| {},
                )
            });
    }
}
