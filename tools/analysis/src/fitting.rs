//! Fitting one material into a report (Ngan et al. 2005 section 4: every chosen model
//! fitted to the data by [`lobe_materials::fit::fit_until`], optionally with the cheapest
//! adequate model selected), and the measured data files of a folder (what a batch fits).

use crate::models::choose;
use crate::selection::select;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::FitReport;
use lobe_materials::fit::{FitError, FitResult, Stop, builtin_specs, fit_until};
use lobe_materials::measured::format;
use lobe_renderer::Error;
use std::path::{Path, PathBuf};

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
}

/// Fits the chosen models to `data` (named `name`, read from `source`) and builds the
/// report; `stop` is polled inside the optimizer (an interruption is an error saying so),
/// `on_model` is called with each model's result as it is fitted.
pub fn fit_material(
    name: &str,
    source: &str,
    data: &Dataset,
    opts: &FitOptions,
    stop: &Stop<'_>,
    on_model: &dyn Fn(&FitResult),
) -> Result<FitReport, Error> {
    data.check().map_err(|m| Error::file(source, m))?;
    let specs = builtin_specs();
    let chosen = choose(&specs, opts.models.as_deref(), data.anisotropic)?;
    let mut results = Vec::new();
    for spec in chosen {
        let r = fit_until(data, spec, opts.max_evals, stop).map_err(|e| match e {
            FitError::Cancelled => Error::Other(format!("{source}: interrupted")),
            FitError::Data(m) => Error::file(source, m),
        })?;
        on_model(&r);
        results.push(r);
    }
    let mut report = FitReport::new(name, source, opts.resolution, data, &results);
    if let Some(tolerance) = opts.select {
        report.selected = Some(select(&results, tolerance)?);
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
