//! Fit reports as a collection: the report files of inputs (files or folders of
//! `*.fit.json`), reading them ([`lobe_materials::fit::report::read`]), merging them into
//! one CSV and one Markdown table (the study's per-material error tables, section 4), and
//! building a report's fitted models as materials.

use crate::NamedMaterial;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use std::path::{Path, PathBuf};

/// The report files of the inputs: each input is a report, or a folder whose `*.fit.json`
/// files are taken in name order.
pub fn report_files(inputs: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for i in inputs {
        if i.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(i)
                .map_err(|e| Error::file(i.display(), format!("cannot list: {e}")))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.to_string_lossy().ends_with(".fit.json"))
                .collect();
            v.sort();
            files.extend(v);
        } else {
            files.push(i.clone());
        }
    }
    if files.is_empty() {
        return Err(Error::Other(
            "no fit reports (*.fit.json) found in the inputs".into(),
        ));
    }
    Ok(files)
}

/// Reads fit reports; the first bad one is an error naming its file and field.
pub fn read_reports(files: &[PathBuf]) -> Result<Vec<FitReport>, Error> {
    files.iter().map(|f| Ok(report::read(f)?)).collect()
}

/// The labels of the models of `reports`, in the order they are first met.
pub fn model_labels(reports: &[&FitReport]) -> Vec<String> {
    let mut models: Vec<String> = Vec::new();
    for r in reports {
        for k in r.models.keys() {
            if !models.contains(k) {
                models.push(k.clone());
            }
        }
    }
    models
}

/// Reports joined into tables: one row per report (sorted by material name; reports of the
/// same material keep their order) with the metric its fits minimized, one column per
/// model of any report (empty where a report lacks it); the errors are Eq. (1) errors
/// whatever the metric, so rows of different metrics compare.
#[derive(Clone, Debug, PartialEq)]
pub struct Tables {
    /// Per model its absolute and normalized error, after the material and its max albedo.
    pub csv: String,
    /// Per model its normalized error.
    pub markdown: String,
}

/// A CSV field as RFC 4180 writes it: quoted (with inner quotes doubled) when it holds a
/// comma, a quote or a line break.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Text for a Markdown table cell: `|` and `\` escaped, line breaks made spaces.
pub fn markdown_cell(s: &str) -> String {
    s.replace('\\', "\\\\")
        .replace('|', "\\|")
        .replace(['\n', '\r'], " ")
}

/// Joins reports into [`Tables`].
pub fn merge(reports: &[FitReport]) -> Tables {
    let mut sorted: Vec<&FitReport> = reports.iter().collect();
    sorted.sort_by(|a, b| a.material.cmp(&b.material));
    let models = model_labels(&sorted);
    let mut csv = String::from("material,max_albedo,metric");
    for m in &models {
        csv += &format!(
            ",{},{}",
            csv_field(&format!("{m} error")),
            csv_field(&format!("{m} normalized error"))
        );
    }
    csv.push('\n');
    let cells: Vec<String> = models.iter().map(|m| markdown_cell(m)).collect();
    let mut md = format!(
        "| material | metric | {} |\n|---|---|{}\n",
        cells.join(" | "),
        "---|".repeat(models.len())
    );
    let finite = |x: f64| Some(x).filter(|x| x.is_finite());
    for r in sorted {
        let name = &r.material;
        // Written as JSON writes the number (null when not finite), as reports hold it.
        csv += &format!(
            "{},{},{}",
            csv_field(name),
            serde_json::Value::from(r.max_albedo),
            r.metric
        );
        md += &format!("| {} | {} |", markdown_cell(name), r.metric);
        for m in &models {
            let e = r.models.get(m);
            let a = e.and_then(|e| finite(e.error));
            let n = e.and_then(|e| finite(e.error_normalized));
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
    Tables { csv, markdown: md }
}

/// The fitted models of a report (those of the comma-separated `models`, or all), built;
/// a name the report does not have is an error listing those it has.
pub fn report_models(
    reg: &Registry,
    path: &Path,
    models: Option<&str>,
) -> Result<Vec<NamedMaterial>, Error> {
    let r = report::read(path)?;
    let wanted: Vec<String> = match models {
        Some(m) => m.split(',').map(|s| s.trim().to_string()).collect(),
        None => r.models.keys().cloned().collect(),
    };
    let mut out = Vec::new();
    for name in wanted {
        let fit = r.models.get(&name).ok_or_else(|| {
            Error::Other(format!(
                "--models: no model \"{name}\" in {}; expected one of: {}",
                path.display(),
                r.models.keys().cloned().collect::<Vec<_>>().join(", ")
            ))
        })?;
        let m = reg
            .create(&fit.material, &format!("models.{name}"))
            .map_err(|e| Error::file(path.display(), e.to_string()))?;
        out.push((name, m));
    }
    Ok(out)
}
