//! `lobe fit`: fit measured data (MERL, binned, RGL, or any material) to the study's models
//! and write JSON reports (loadable as `{"type": "fit", "file": ..., "model": ...}`); over a
//! folder, fit every file, resumably and in deterministic shards (lobe_analysis::fitting);
//! `lobe fit merge` joins reports into CSV and Markdown tables (lobe_analysis::reports).

use crate::args::{finite, parse_shard};
use crate::material::{MaterialArgs, MaterialSource};
use lobe_analysis::fitting::{
    BatchProgress, BatchSummary, FitOptions, batch_jobs, data_material, file_key, fit_batch,
    fit_material_with, stem,
};
use lobe_analysis::reports::{merge, read_reports, report_files};
use lobe_materials::Bsdf;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{FitResult, ISOTROPIC_DEFAULT, Metric, Stop, builtin_specs};
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct FitArgs {
    #[command(subcommand)]
    sub: Option<FitSub>,
    /// Measured data: a MERL table, binned data or an RGL file (told apart by content), or a
    /// folder of them (batch mode: one report per file in the --output folder). Without it,
    /// the material given by --material / --ngan (synthetic data).
    data: Option<PathBuf>,
    #[command(flatten)]
    material: MaterialArgs,
    /// Comma-separated model labels (default: the seven models of the study's section 4, or for
    /// anisotropic binned data anisotropic Ward, Ashikhmin-Shirley and Poulin-Fournier).
    /// `lobe fit --list` shows them all.
    #[arg(long)]
    models: Option<String>,
    /// Bin size in degrees of the isotropic data (the study: 1).
    #[arg(long, default_value_t = 1.0, value_parser = finite::<f64>)]
    resolution: f64,
    /// Objective evaluations allowed per SLSQP start.
    #[arg(long, default_value_t = 300)]
    max_evals: usize,
    /// The metric the fits minimize: eq1 (Ngan et al.'s Eq. 1; alias ngan2005), log
    /// (Eq. 1 on ln(1 + f cos)), cube-root (on (f cos)^(1/3)) or image (renders of a sphere
    /// under --env maps). Reports keep the Eq. 1 error of every fit (docs/fitting.md).
    #[arg(long, default_value = "eq1")]
    metric: String,
    /// An environment map the image metric fits under (repeatable): builtin:studio,
    /// builtin:sunset or an .exr/.hdr file (default: builtin:studio and builtin:sunset).
    #[arg(long, value_name = "MAP")]
    env: Vec<String>,
    /// Output report (JSON), or in batch mode the folder of reports.
    #[arg(long, short)]
    output: Option<PathBuf>,
    /// Batch mode: fit only the files whose index (in sorted order) is i modulo n, e.g. 2/8
    /// for the third task of an 8-way job array (a Slurm array or a Kubernetes indexed Job).
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// List the model labels and exit.
    #[arg(long)]
    list: bool,
    /// Also pick, per material, the cheapest fitted model (eval + sample time per call,
    /// measured) whose normalized error is within --tolerance of the best; recorded in the
    /// report as "selected".
    #[arg(long)]
    select: bool,
    /// Relative tolerance of --select: error <= best error x (1 + tolerance).
    #[arg(long, default_value_t = 0.1, value_parser = finite::<f64>)]
    tolerance: f64,
}

#[derive(clap::Subcommand)]
enum FitSub {
    /// Join fit reports (files or folders of *.fit.json) into a CSV and a Markdown table.
    Merge {
        /// Reports or folders of reports.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output stem: writes STEM.csv and STEM.md.
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Which metric's fits look closest to the data: fits each file with each metric
    /// (reports kept in OUT/fits, reused when rerun), then estimates the image error of every
    /// fit on a sphere under held-out maps (all images from the same samples) and writes
    /// RMSE with its 95 % interval, FLIP and the noise floor to OUT/metrics.{csv,md}.
    CompareMetrics(Box<CompareMetricsArgs>),
}

#[derive(clap::Args)]
struct CompareMetricsArgs {
    /// Measured files (MERL, binned or RGL).
    #[arg(required = true)]
    data: Vec<PathBuf>,
    /// Comma-separated model labels.
    #[arg(long, default_value = "cook-torrance,ward,lafortune,blinn-phong")]
    models: String,
    /// Comma-separated metrics.
    #[arg(long, default_value = "eq1,log,cube-root,image")]
    metrics: String,
    /// The maps the image metric fits under (default builtin:studio, builtin:sunset).
    #[arg(long, value_name = "MAP")]
    env: Vec<String>,
    /// The held-out maps the renders are compared under (at least one).
    #[arg(long, value_name = "MAP", required = true)]
    test_env: Vec<String>,
    /// Bin size in degrees of isotropic data.
    #[arg(long, default_value_t = 2.0, value_parser = finite::<f64>)]
    resolution: f64,
    /// Image size in pixels.
    #[arg(long, default_value_t = 128)]
    size: u32,
    /// The most samples per pixel of the error estimate (mean over the image; spent where
    /// the fits' differences are noisy).
    #[arg(long, default_value_t = 256)]
    spp: u32,
    /// Output folder.
    #[arg(long, short)]
    output: PathBuf,
}

/// `lobe fit compare-metrics`: the experiment of lobe_analysis::metric_study.
fn compare_metrics(a: &CompareMetricsArgs, quiet: bool) -> Result<(), Error> {
    use lobe_analysis::metric_study::{MetricStudyConfig, run, write};
    let metrics = a
        .metrics
        .split(',')
        .map(|m| Metric::parse(m.trim()).map_err(|e| Error::Other(format!("--metrics: {e}"))))
        .collect::<Result<Vec<_>, _>>()?;
    crate::args::check_spp("--spp", a.spp)?;
    let sizes_ok = (0.25..=20.0).contains(&a.resolution) && (16..=2048).contains(&a.size);
    if !sizes_ok {
        return Err(Error::Other(format!(
            "--resolution {} / --size {}: expected [0.25, 20] degrees and 16 to 2048 pixels",
            a.resolution, a.size
        )));
    }
    let mut plan = FilePlan::new();
    for p in &a.data {
        plan.input(p, "measured data");
    }
    for e in a
        .env
        .iter()
        .chain(&a.test_env)
        .filter(|e| !e.starts_with("builtin:"))
    {
        plan.input(Path::new(e), "an environment map");
    }
    plan.output(a.output.join("metrics.csv"), "CSV table")
        .output(a.output.join("metrics.md"), "Markdown table")
        .check_overlaps()?;
    std::fs::create_dir_all(&a.output)
        .map_err(|e| Error::file(a.output.display(), format!("cannot create: {e}")))?;
    plan.check()?;
    let config = MetricStudyConfig {
        data: a.data.clone(),
        fit: FitOptions {
            models: Some(a.models.clone()),
            resolution: a.resolution,
            envs: a.env.clone(),
            ..Default::default()
        },
        metrics,
        test_envs: a.test_env.clone(),
        size: a.size,
        spp: a.spp,
        out: a.output.clone(),
    };
    let stop = stop_flag();
    let say = |m: &str| {
        if !quiet {
            eprintln!("{m}");
        }
    };
    let rows = run(
        &lobe_materials::registry::Registry::builtin(),
        &config,
        &stop,
        &say,
    )?;
    write(&rows, &a.output)?;
    if !quiet {
        eprintln!("wrote {}", a.output.join("metrics.md").display());
    }
    Ok(())
}

/// The fit options of the command line (the metric checked by [`check_options`]).
fn options(args: &FitArgs) -> FitOptions {
    FitOptions {
        models: args.models.clone(),
        resolution: args.resolution,
        max_evals: args.max_evals,
        select: args.select.then_some(args.tolerance),
        metric: Metric::parse(&args.metric).unwrap_or_default(),
        envs: args.env.clone(),
        ..Default::default()
    }
}

/// What a fit shows: each model's result as a line (unless quiet or a bar is shown), the
/// selection, and a progress bar over models (files x models) in batch mode.
struct Display {
    bar: Option<indicatif::ProgressBar>,
    /// Models per file the bar assumed.
    guess: usize,
    lines: bool,
    /// Print the warnings of each fit (not quiet).
    warn: bool,
    tolerance: f64,
}

impl BatchProgress for Display {
    fn skipped(&self) {
        self.bar.as_ref().inspect(|b| b.inc(self.guess as u64));
    }

    fn reading(&self, name: &str) {
        self.bar
            .as_ref()
            .inspect(|b| b.set_message(name.to_string()));
        if self.lines {
            eprintln!("{name}: reading the data");
        }
    }

    fn fitting(&self, _name: &str, models: usize) {
        // The bar assumed `guess` models; anisotropic data may get another number.
        if let Some(b) = &self.bar
            && models != self.guess
        {
            b.dec_length(self.guess as u64);
            b.inc_length(models as u64);
        }
    }

    fn fitted(&self, name: &str, r: &FitResult) {
        if self.lines {
            eprintln!(
                "{name}: {:28} error {:.4e}  normalized {:.4e}  ({} of {} starts agree, {:.1} s)",
                r.label, r.error, r.error_normalized, r.starts_agreeing, r.starts, r.seconds
            );
        }
        // Warnings show even under a progress bar; only --quiet hides them.
        for w in report::ModelFit::from_result(r).warnings(&r.label) {
            match &self.bar {
                Some(b) => b.println(format!("warning: {name}: {w}")),
                None if self.warn => eprintln!("warning: {name}: {w}"),
                None => {}
            }
        }
        self.bar.as_ref().inspect(|b| b.inc(1));
    }

    fn finished(&self, name: &str, report: &FitReport) {
        if let Some(s) = &report.selected
            && self.lines
        {
            eprintln!(
                "{name}: selected {} (tolerance {})",
                serde_json::Value::from(s.model.as_str()),
                self.tolerance
            );
        }
    }
}

/// Fits the chosen models to `data` and builds the report, printing each model's result
/// (unless `quiet`); `stop` is polled inside the optimizer (Ctrl-C).
fn fit_report(
    (name, source): (&str, &str),
    (data, measured): (&Dataset, Option<&dyn Bsdf>),
    args: &FitArgs,
    quiet: bool,
    stop: &Stop<'_>,
) -> Result<FitReport, Error> {
    let display = Display {
        bar: None,
        guess: 0,
        lines: !quiet,
        warn: !quiet,
        tolerance: args.tolerance,
    };
    let on_model = |r: &FitResult| display.fitted(name, r);
    let report = fit_material_with(
        &lobe_materials::registry::Registry::builtin(),
        (name, source),
        (data, measured),
        &options(args),
        stop,
        &on_model,
    )?;
    display.finished(name, &report);
    Ok(report)
}

fn check_options(args: &FitArgs) -> Result<(), Error> {
    if !(args.tolerance >= 0.0) {
        return Err(Error::Other(format!(
            "--tolerance: expected a non-negative relative tolerance, found {}",
            args.tolerance
        )));
    }
    let metric = Metric::parse(&args.metric).map_err(|e| Error::Other(format!("--metric: {e}")))?;
    if !args.env.is_empty() && metric != Metric::Image {
        return Err(Error::Other(format!(
            "--env: only for --metric image; expected no --env with --metric {metric}"
        )));
    }
    if !(args.resolution >= 0.25 && args.resolution <= 20.0) {
        return Err(Error::Other(format!(
            "--resolution: expected a bin size in [0.25, 20] degrees, found {}",
            args.resolution
        )));
    }
    Ok(())
}

/// The Ctrl-C flag of fits, as the poll the optimizer calls.
fn stop_flag() -> impl Fn() -> bool + Sync {
    let flag = crate::args::ctrl_c(
        "interrupted: stopping the running fits now (finished reports are kept, no partial one is written); Ctrl-C again to abort",
    );
    move || flag.load(std::sync::atomic::Ordering::Relaxed)
}

pub fn cmd_fit(args: FitArgs, quiet: bool) -> Result<(), Error> {
    match &args.sub {
        Some(FitSub::Merge { inputs, output }) => return write_merged(inputs, output, quiet),
        Some(FitSub::CompareMetrics(a)) => return compare_metrics(a, quiet),
        None => {}
    }
    if args.list {
        for s in builtin_specs() {
            println!("{}", s.label);
        }
        return Ok(());
    }
    check_options(&args)?;
    let output = args.output.clone().ok_or_else(|| Error::Other("--output: expected the path of the JSON report (or, for a folder of data, of the report folder)".into()))?;
    let stop = stop_flag();
    if let Some(dir) = args.data.as_ref().filter(|d| d.is_dir()) {
        return batch(dir, &output, &args, (&stop, quiet));
    }
    if args.shard.is_some() {
        return Err(Error::Other("--shard: only for a folder of data".into()));
    }
    let mut plan = FilePlan::new();
    plan.output(&output, "fit report");
    let report = match &args.data {
        Some(p) => {
            plan.input(p, "the measured data");
            plan_envs(&mut plan, &args);
            plan.check()?;
            let data = Dataset::read(p, args.resolution)?;
            let measured = data_material(
                &lobe_materials::registry::Registry::builtin(),
                p,
                &options(&args),
            )?;
            let source = p.display().to_string();
            let d = (&data, measured.as_deref());
            let key = file_key(p, &options(&args))?;
            FitReport {
                key: Some(key),
                ..fit_report((&stem(p), &source), d, &args, quiet, &stop)?
            }
        }
        None => {
            let source = MaterialSource::new(&args.material)?;
            source.plan_inputs(&mut plan);
            plan_envs(&mut plan, &args);
            plan.check()?;
            let m = source.build()?;
            let data = Dataset::isotropic(&|wi, wo| Some(m.eval(wo, wi)), args.resolution);
            let d = (&data, Some(m.as_ref()));
            fit_report(("synthetic", "material"), d, &args, quiet, &stop)?
        }
    };
    report::write(&output, &report)?;
    if !quiet {
        eprintln!("wrote {}", output.display());
    }
    Ok(())
}

/// The environment map files of --env, as inputs of the fit.
fn plan_envs(plan: &mut FilePlan, args: &FitArgs) {
    for e in args.env.iter().filter(|e| !e.starts_with("builtin:")) {
        plan.input(Path::new(e), "an environment map of the image metric");
    }
}

/// A progress bar over models (files x models each), shown on a terminal.
fn progress(files: usize, args: &FitArgs, quiet: bool) -> Option<indicatif::ProgressBar> {
    (!quiet && std::io::stderr().is_terminal()).then(|| {
        let pb = indicatif::ProgressBar::new((files * models_guess(args)) as u64);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "fitting [{bar:40}] {pos}/{len} models {elapsed_precise} ETA {eta} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb
    })
}

/// Models per file before the file is read: --models, or the isotropic default (a file of
/// anisotropic data corrects the bar when it is read).
fn models_guess(args: &FitArgs) -> usize {
    args.models
        .as_ref()
        .map_or(ISOTROPIC_DEFAULT.len(), |m| m.split(',').count())
}

/// Fits every data file of `dir` (sorted by name; this shard's share), writing
/// `out/<stem>.fit.json` atomically and skipping reports that already exist, so an
/// interrupted run resumes where it stopped and loses nothing already finished.
fn batch(
    dir: &Path,
    out: &Path,
    args: &FitArgs,
    (stop, quiet): (&Stop<'_>, bool),
) -> Result<(), Error> {
    let (i, n) = match &args.shard {
        Some(s) => parse_shard(s)?,
        None => (0, 1),
    };
    let jobs = batch_jobs(dir, out, (i, n))?;
    let bar = progress(jobs.len(), args, quiet);
    let display = Display {
        lines: !quiet && bar.is_none(),
        warn: !quiet,
        bar,
        guess: models_guess(args),
        tolerance: args.tolerance,
    };
    // A material that fails is reported and the others go on; it has no report, so a rerun
    // tries it again.
    let summary = fit_batch(
        &lobe_materials::registry::Registry::builtin(),
        &jobs,
        &options(args),
        stop,
        &display,
    );
    if let Some(b) = &display.bar {
        b.finish_and_clear();
    }
    outcome(summary, stop(), quiet, ((i, n), out))
}

/// The summary line and exit status of a batch.
fn outcome(
    mut summary: BatchSummary,
    interrupted: bool,
    quiet: bool,
    ((i, n), out): ((usize, usize), &Path),
) -> Result<(), Error> {
    let (done, skipped) = (summary.done, summary.skipped);
    if interrupted {
        return Err(Error::Other(format!(
            "interrupted: {done} reports written this run ({skipped} were already there), the rest not started or dropped; rerun to resume"
        )));
    }
    let failures = &mut summary.failures;
    if !quiet {
        eprintln!(
            "shard {i}/{n}: fitted {done} materials, {skipped} already done, {} failed, reports in {}",
            failures.len(),
            out.display()
        );
    }
    match failures.len() {
        0 => Ok(()),
        1 => Err(Error::Other(failures.remove(0))),
        k => {
            for f in &failures[1..] {
                eprintln!("error: {f}");
            }
            Err(Error::Other(format!(
                "{k} materials failed (a rerun retries them); the first: {}",
                failures[0]
            )))
        }
    }
}

/// Joins reports into STEM.csv and STEM.md ([`merge`]): one row per material, per model
/// the normalized error (and the absolute error in the CSV).
fn write_merged(inputs: &[PathBuf], stem: &Path, quiet: bool) -> Result<(), Error> {
    let files = report_files(inputs)?;
    let csv_path = PathBuf::from(format!("{}.csv", stem.display()));
    let md_path = PathBuf::from(format!("{}.md", stem.display()));
    let mut plan = FilePlan::new();
    for f in &files {
        plan.input(f, "a fit report");
    }
    plan.output(&csv_path, "CSV table")
        .output(&md_path, "Markdown table")
        .check()?;
    let reports = read_reports(&files)?;
    let tables = merge(&reports);
    let (csv, md) = (tables.csv, tables.markdown);
    lobe_renderer::film::atomic_write(&csv_path, |w| std::io::Write::write_all(w, csv.as_bytes()))?;
    lobe_renderer::film::atomic_write(&md_path, |w| std::io::Write::write_all(w, md.as_bytes()))?;
    if !quiet {
        eprintln!(
            "merged {} reports into {} and {}",
            reports.len(),
            csv_path.display(),
            md_path.display()
        );
    }
    Ok(())
}
