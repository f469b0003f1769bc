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

/// Reads fit reports; the first bad one is an error naming its file and field. Reports of
/// one content key (the same data and settings, made by different runs or machines) are
/// joined into one ([`join_keyed`]).
pub fn read_reports(files: &[PathBuf]) -> Result<Vec<FitReport>, Error> {
    let reports = files
        .iter()
        .map(|f| Ok((f.display().to_string(), report::read(f)?)))
        .collect::<Result<Vec<_>, Error>>()?;
    join_keyed(reports)
}

/// Relative difference within which two fits of one key agree (fits are deterministic;
/// this leaves room for another platform's last digits).
const SAME_FIT: f64 = 1e-6;

/// Joins (file, report) pairs of one key model by model, and checks them: a model in two
/// reports of one key must have the same error; two reports of one material name and
/// settings but different data are an error naming both files. Reports without a key
/// (written before keys) pass as they are. A joined report whose models changed loses its
/// selection (it was made over other models).
pub fn join_keyed(reports: Vec<(String, FitReport)>) -> Result<Vec<FitReport>, Error> {
    let mut out: Vec<(String, FitReport)> = Vec::new();
    for (file, r) in reports {
        let Some(key) = r.key.clone() else {
            out.push((file, r));
            continue;
        };
        let same_name = out.iter().find(|(_, o)| {
            o.material == r.material
                && o.key
                    .as_ref()
                    .is_some_and(|k| k.settings == key.settings && k.data != key.data)
        });
        if let Some((other, _)) = same_name {
            return Err(Error::Other(format!(
                "{file} and {other}: material \"{}\" fitted with the same settings from different data; expected one data file per material name",
                r.material
            )));
        }
        let Some((first, joined)) = out.iter_mut().find(|(_, o)| o.key.as_ref() == Some(&key))
        else {
            out.push((file, r));
            continue;
        };
        let mut added = false;
        for (label, fit) in r.models {
            match joined.models.get(&label) {
                Some(f) if (f.error - fit.error).abs() > SAME_FIT * f.error.abs().max(1e-300) => {
                    return Err(Error::Other(format!(
                        "{file} and {first}: model {label} of the same data and settings has error {} in one and {} in the other; expected equal fits",
                        fit.error, f.error
                    )));
                }
                Some(_) => {}
                None => {
                    joined.models.insert(label, fit);
                    added = true;
                }
            }
        }
        if added {
            joined.selected = None;
        }
    }
    Ok(out.into_iter().map(|(_, r)| r).collect())
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
