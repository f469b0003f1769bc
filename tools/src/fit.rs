//! `lobe fit`: fit measured data (MERL, binned, RGL, or any material) to the study's models
//! and write JSON reports (loadable as `{"type": "fit", "file": ..., "model": ...}`); over a
//! folder, fit every file, resumably and in deterministic shards; `lobe fit merge` joins
//! reports into CSV and Markdown tables.

use crate::eval::{MaterialArgs, load_material};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::{ISOTROPIC_DEFAULT, ModelSpec, builtin_specs, fit, report_json};
use lobe_materials::measured::binned::Binned;
use lobe_materials::measured::merl::Merl;
use lobe_materials::measured::rgl::Rgl;
use lobe_renderer::Error;
use serde_json::Value;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct FitArgs {
    #[command(subcommand)]
    sub: Option<FitSub>,
    /// Measured data: a MERL table (.binary), binned data (.bin) or an RGL file (.bsdf), or a
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
    #[arg(long, default_value_t = 1.0)]
    resolution: f64,
    /// Objective evaluations allowed per SLSQP start.
    #[arg(long, default_value_t = 300)]
    max_evals: usize,
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
    #[arg(long, default_value_t = 0.1)]
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
}

pub(crate) fn to_err(e: lobe_materials::FileError) -> Error {
    Error::File {
        file: e.file,
        message: e.message,
    }
}

/// The measured-material type of a data file by its extension: merl, binned or rgl.
pub(crate) fn measured_kind(p: &Path) -> Result<&'static str, Error> {
    match p.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "binary" => Ok("merl"),
        "bin" => Ok("binned"),
        "bsdf" => Ok("rgl"),
        ext => Err(Error::file(
            p.display(),
            format!(
                "unknown extension \"{ext}\"; expected .binary (MERL), .bin (binned) or .bsdf (RGL)"
            ),
        )),
    }
}

pub(crate) fn load_data(p: &Path, resolution: f64) -> Result<Dataset, Error> {
    if !p.exists() {
        return Err(Error::file(
            p.display(),
            "does not exist; expected a MERL .binary, binned .bin or RGL .bsdf file",
        ));
    }
    Ok(match measured_kind(p)? {
        "merl" => Dataset::from_merl(&Merl::read(p).map_err(to_err)?, resolution),
        "binned" => Dataset::from_binned(&Binned::read(p).map_err(to_err)?),
        _ => {
            let t = Rgl::read(p).map_err(to_err)?;
            Dataset::isotropic(&|wi, wo| Some(t.eval(wo, wi)), resolution)
        }
    })
}

fn choose<'a>(
    specs: &'a [ModelSpec],
    models: &Option<String>,
    anisotropic: bool,
) -> Result<Vec<&'a ModelSpec>, Error> {
    let default: &[&str] = if anisotropic {
        &[
            "ward-anisotropic",
            "ashikhmin-shirley-anisotropic",
            "poulin-fournier",
        ]
    } else {
        ISOTROPIC_DEFAULT
    };
    match models {
        None => Ok(specs
            .iter()
            .filter(|s| default.contains(&s.label))
            .collect()),
        Some(list) => list
            .split(',')
            .map(|l| {
                specs.iter().find(|s| s.label == l.trim()).ok_or_else(|| {
                    Error::Other(format!(
                        "--models: unknown model \"{}\"; expected one of: {}",
                        l.trim(),
                        specs.iter().map(|s| s.label).collect::<Vec<_>>().join(", ")
                    ))
                })
            })
            .collect(),
    }
}

/// Set by Ctrl-C: fits stop at the next model and nothing unfinished is written.
fn interrupted() -> bool {
    INTERRUPTED
        .get()
        .is_some_and(|f| f.load(std::sync::atomic::Ordering::SeqCst))
}

static INTERRUPTED: std::sync::OnceLock<std::sync::Arc<std::sync::atomic::AtomicBool>> =
    std::sync::OnceLock::new();

fn fit_report(
    name: &str,
    source: &str,
    data: &Dataset,
    args: &FitArgs,
    quiet: bool,
) -> Result<Value, Error> {
    data.check().map_err(|m| Error::file(source, m))?;
    let specs = builtin_specs();
    let chosen = choose(&specs, &args.models, data.anisotropic)?;
    let mut results = Vec::new();
    for spec in chosen {
        if interrupted() {
            return Err(Error::Other(format!("{source}: interrupted")));
        }
        let r = fit(data, spec, args.max_evals).map_err(|m| Error::file(source, m))?;
        if !quiet {
            eprintln!(
                "{name}: {:28} error {:.4e}  normalized {:.4e}  ({} of {} starts agree, {:.1} s)",
                r.label, r.error, r.error_normalized, r.starts_agreeing, r.starts, r.seconds
            );
        }
        results.push(r);
    }
    let mut report = report_json(name, source, args.resolution, data, &results);
    if args.select {
        report["selected"] = select(&results, args.tolerance)?;
        if !quiet {
            eprintln!(
                "{name}: selected {} (tolerance {})",
                report["selected"]["model"], args.tolerance
            );
        }
    }
    Ok(report)
}

/// The cheapest model within `tolerance` of the best error, cost measured per call.
fn select(results: &[lobe_materials::fit::FitResult], tolerance: f64) -> Result<Value, Error> {
    let registry = lobe_materials::registry::Registry::builtin();
    let best = results
        .iter()
        .map(|r| r.error)
        .fold(f64::INFINITY, f64::min);
    let mut costs = serde_json::Map::new();
    let mut pick: Option<(&str, f64)> = None;
    for r in results {
        let b = registry
            .create(&r.material, &r.label)
            .map_err(|e| Error::Other(e.to_string()))?;
        let (eval_ns, sample_ns) = crate::tradeoff::cost(b.as_ref());
        let total = eval_ns + sample_ns;
        costs.insert(
            r.label.clone(),
            serde_json::json!({"eval_ns": eval_ns, "sample_ns": sample_ns, "error": r.error}),
        );
        if r.error <= best * (1.0 + tolerance) && pick.is_none_or(|p| total < p.1) {
            pick = Some((&r.label, total));
        }
    }
    let model = pick.map(|p| p.0).unwrap_or_default();
    Ok(
        serde_json::json!({"model": model, "tolerance": tolerance, "best_error": best, "costs": costs}),
    )
}

fn parse_shard(s: &str) -> Result<(usize, usize), Error> {
    let bad = || {
        Error::Other(format!(
            "--shard: expected I/N with 0 <= I < N, found \"{s}\""
        ))
    };
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

pub fn cmd_fit(args: FitArgs, quiet: bool) -> Result<(), Error> {
    if let Some(FitSub::Merge { inputs, output }) = &args.sub {
        return merge(inputs, output, quiet);
    }
    if args.list {
        for s in builtin_specs() {
            println!("{}", s.label);
        }
        return Ok(());
    }
    if !(args.tolerance >= 0.0 && args.tolerance.is_finite()) {
        return Err(Error::Other(format!(
            "--tolerance: expected a non-negative relative tolerance, found {}",
            args.tolerance
        )));
    }
    if !(args.resolution >= 0.25 && args.resolution <= 20.0) {
        return Err(Error::Other(format!(
            "--resolution: expected a bin size in [0.25, 20] degrees, found {}",
            args.resolution
        )));
    }
    INTERRUPTED.get_or_init(crate::install_ctrlc);
    let output = args.output.clone().ok_or_else(|| Error::Other("--output: expected the path of the JSON report (or, for a folder of data, of the report folder)".into()))?;
    match &args.data {
        Some(dir) if dir.is_dir() => batch(dir, &output, &args, quiet),
        Some(p) => {
            if args.shard.is_some() {
                return Err(Error::Other("--shard: only for a folder of data".into()));
            }
            let data = load_data(p, args.resolution)?;
            let name = p
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("material")
                .to_string();
            let report = fit_report(&name, &p.display().to_string(), &data, &args, quiet)?;
            lobe_renderer::film::write_json(&output, &report)?;
            if !quiet {
                eprintln!("wrote {}", output.display());
            }
            Ok(())
        }
        None => {
            let m = load_material(&args.material)?;
            let data = Dataset::isotropic(&|wi, wo| Some(m.eval(wo, wi)), args.resolution);
            let report = fit_report("synthetic", "material", &data, &args, quiet)?;
            lobe_renderer::film::write_json(&output, &report)
        }
    }
}

/// Fits every data file of `dir` (sorted by name; this shard's share), writing
/// `out/<stem>.fit.json` atomically and skipping reports that already exist, so an
/// interrupted run resumes where it stopped and loses nothing already finished.
fn batch(dir: &Path, out: &Path, args: &FitArgs, quiet: bool) -> Result<(), Error> {
    if !out.is_dir() {
        std::fs::create_dir_all(out).map_err(|e| {
            Error::file(
                out.display(),
                format!("cannot create the report folder: {e}"),
            )
        })?;
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::file(dir.display(), format!("cannot list: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("binary" | "bin" | "bsdf")
            )
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::file(
            dir.display(),
            "holds no .binary, .bin or .bsdf files to fit",
        ));
    }
    let (i, n) = match &args.shard {
        Some(s) => parse_shard(s)?,
        None => (0, 1),
    };
    let mine: Vec<&PathBuf> = files
        .iter()
        .enumerate()
        .filter(|(k, _)| k % n == i)
        .map(|(_, p)| p)
        .collect();
    let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
        let pb = indicatif::ProgressBar::new(mine.len() as u64);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "fitting [{bar:40}] {pos}/{len} {elapsed_precise} ETA {eta} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb
    });
    // Materials in parallel (each fit is parallel over its bins too; rayon balances both).
    // A material that fails is reported and the others go on; it has no report, so a rerun
    // tries it again.
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let (done, skipped) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let mut failures: Vec<String> = mine
        .par_iter()
        .filter_map(|p| {
            let stem = p
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("material")
                .to_string();
            let report = out.join(format!("{stem}.fit.json"));
            let result = if report.exists() {
                skipped.fetch_add(1, Ordering::Relaxed);
                Ok(())
            } else if interrupted() {
                Ok(())
            } else {
                if let Some(b) = &bar {
                    b.set_message(stem.clone());
                }
                load_data(p, args.resolution)
                    .and_then(|data| {
                        fit_report(
                            &stem,
                            &p.display().to_string(),
                            &data,
                            args,
                            quiet || bar.is_some(),
                        )
                    })
                    .and_then(|r| lobe_renderer::film::write_json(&report, &r))
                    .map(|()| {
                        done.fetch_add(1, Ordering::Relaxed);
                    })
            };
            if let Some(b) = &bar {
                b.inc(1);
            }
            result.err().map(|e| e.to_string())
        })
        .collect();
    failures.sort();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let (done, skipped) = (done.into_inner(), skipped.into_inner());
    if interrupted() {
        return Err(Error::Other(format!(
            "interrupted: {done} reports written this run ({skipped} were already there), the rest not started or dropped; rerun to resume"
        )));
    }
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

/// Reads fit reports: each input is a report or a folder whose `*.fit.json` files are read
/// in name order. Every report must have a `models` object; no report at all is an error.
pub(crate) fn read_reports(inputs: &[PathBuf]) -> Result<Vec<(PathBuf, Value)>, Error> {
    let mut reports: Vec<(PathBuf, Value)> = Vec::new();
    for i in inputs {
        let files: Vec<PathBuf> = if i.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(i)
                .map_err(|e| Error::file(i.display(), format!("cannot list: {e}")))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.to_string_lossy().ends_with(".fit.json"))
                .collect();
            v.sort();
            v
        } else {
            vec![i.clone()]
        };
        for f in files {
            let text = std::fs::read_to_string(&f)
                .map_err(|e| Error::file(f.display(), format!("cannot read: {e}")))?;
            let v: Value = serde_json::from_str(&text)
                .map_err(|e| Error::file(f.display(), format!("invalid JSON: {e}")))?;
            if v.get("models").and_then(Value::as_object).is_none() {
                return Err(Error::file(
                    f.display(),
                    "no \"models\" object; expected a lobe fit report",
                ));
            }
            reports.push((f, v));
        }
    }
    if reports.is_empty() {
        return Err(Error::Other(
            "no fit reports (*.fit.json) found in the inputs".into(),
        ));
    }
    Ok(reports)
}

/// Joins reports into STEM.csv and STEM.md: one row per material, per model the
/// normalized error (and the absolute error in the CSV).
fn merge(inputs: &[PathBuf], stem: &Path, quiet: bool) -> Result<(), Error> {
    let mut reports = read_reports(inputs)?;
    reports.sort_by(|a, b| a.1["material"].as_str().cmp(&b.1["material"].as_str()));
    let mut models: Vec<String> = Vec::new();
    for (_, r) in &reports {
        for k in r["models"].as_object().expect("checked").keys() {
            if !models.contains(k) {
                models.push(k.clone());
            }
        }
    }
    let mut csv = String::from("material,max_albedo");
    for m in &models {
        csv += &format!(",{m} error,{m} normalized error");
    }
    csv.push('\n');
    let mut md = format!(
        "| material | {} |\n|---|{}\n",
        models.join(" | "),
        "---|".repeat(models.len())
    );
    for (_, r) in &reports {
        let name = r["material"].as_str().unwrap_or("?");
        csv += &format!("{name},{}", r["max_albedo"]);
        md += &format!("| {name} |");
        for m in &models {
            let e = &r["models"][m];
            let (a, n) = (e["error"].as_f64(), e["error_normalized"].as_f64());
            csv += &format!(
                ",{},{}",
                a.map_or(String::new(), |x| format!("{x:.6e}")),
                n.map_or(String::new(), |x| format!("{x:.6e}"))
            );
            md += &format!(" {} |", n.map_or("".to_string(), |x| format!("{x:.4e}")));
        }
        csv.push('\n');
        md.push('\n');
    }
    let csv_path = PathBuf::from(format!("{}.csv", stem.display()));
    let md_path = PathBuf::from(format!("{}.md", stem.display()));
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
