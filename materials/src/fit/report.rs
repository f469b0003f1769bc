//! The fit report (`lobe fit`'s JSON output, Ngan et al. 2005 section 4's per-material fits):
//! its typed form, and the one place it is read ([`read`]) and written ([`write`]).
//!
//! A report names the material and its data (source file, bin size, bin count, the largest
//! directional albedo that normalizes errors) and, per fitted model, the fitted material
//! description, its Eq. (1) error (absolute and normalized) and how the multi-start went;
//! with `lobe fit --select`, also the model chosen for its cost. Reports carry a format
//! version ([`FORMAT_VERSION`]); a report without one is of version 1 (written before the
//! field existed), one of a newer version is refused, naming both versions. Version 2 added
//! what a fit should not report silently (per model: the parameters that ended at a bound
//! of their fit range, every start's error, the contained model the fit started from, and
//! whether an anisotropic model was fitted to isotropic data); a version 1 report reads
//! with those empty. Version 3 added the metric the fits minimized (`metric`, see
//! [`super::metric`]) and, per model fitted with another metric than Eq. (1), that
//! metric's value (`metric_error`; `error` stays the Eq. (1) error); an older report reads
//! as fitted with Eq. (1). Version 4 added the report's content key (`key`: the digests of
//! the data's bytes and of the settings that shape every fit, [`FitKey`]) and whether the
//! data are anisotropic, so that a rerun fits only the models a report lacks and a report
//! of other data or settings is redone; an older report has no key and is redone.
//!
//! Written JSON keeps its keys in alphabetical order (serde_json's map), as reports always
//! had; a non-finite number (the normalized error of all-zero data) is written as `null` and
//! read back as NaN.

use super::FitResult;
use super::dataset::Dataset;
use super::metric::Metric;
use crate::error::FileError;
use serde::{Deserialize, Deserializer, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// The report format this build writes and the newest it reads.
pub const FORMAT_VERSION: u32 = 4;

fn version_one() -> u32 {
    1
}

/// A number written as `null` when it was not finite (serde_json's way), read back as NaN.
fn nullable_f64<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// An optional number (present: written as `null` when not finite, read back as NaN).
fn nullable_some_f64<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    Ok(Some(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN)))
}

/// A list of numbers, each written as `null` when it was not finite, read back as NaN.
fn nullable_f64s<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    Ok(Vec::<Option<f64>>::deserialize(d)?
        .into_iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect())
}

/// The report of fitting one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitReport {
    /// [`FORMAT_VERSION`] when written; 1 when absent.
    #[serde(default = "version_one")]
    pub format_version: u32,
    /// The material's name (the data file's stem, or "synthetic").
    pub material: String,
    /// Where the data came from (the data file, or "material").
    pub source: String,
    /// Bin size in degrees of isotropic data.
    pub resolution_deg: f64,
    /// Bins of the data.
    pub samples: usize,
    /// The data's largest directional albedo (errors are normalized by it).
    #[serde(deserialize_with = "nullable_f64")]
    pub max_albedo: f64,
    /// The metric the fits minimized (absent before version 3: Eq. (1)).
    #[serde(default)]
    pub metric: Metric,
    /// Per model label, its fit.
    pub models: BTreeMap<String, ModelFit>,
    /// The cheapest model within a tolerance of the best error (`lobe fit --select`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selected: Option<Selection>,
    /// What the fits were made from (absent before version 4, and for data given as a
    /// material rather than a file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key: Option<FitKey>,
    /// The data hold anisotropic (4D) measurements (absent before version 4: false).
    #[serde(default)]
    pub anisotropic: bool,
}

/// The content key of a report ([`crate::key`]): every model fitted under the same key is
/// the same fit, whatever machine or run made it, so reports of one key merge model by
/// model.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitKey {
    /// The digest of the data's bytes (or of the description of the material tabulated).
    pub data: String,
    /// The digest of the settings that shape each fit: bin size, metric, evaluations
    /// allowed, the image metric's maps (by content) and image size, lobe's version.
    pub settings: String,
}

/// One fitted model of a report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFit {
    /// The fitted material: a registry description (`composite` for two lobes).
    pub material: Value,
    /// Eq. (1) error, whatever the metric minimized.
    #[serde(deserialize_with = "nullable_f64")]
    pub error: f64,
    /// The error divided by the data's largest directional albedo.
    #[serde(deserialize_with = "nullable_f64")]
    pub error_normalized: f64,
    /// The value of the report's metric at this fit, when it is not Eq. (1).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "nullable_some_f64"
    )]
    pub metric_error: Option<f64>,
    pub starts: usize,
    /// Starts whose final error is within 1 % of the best.
    pub starts_agreeing: usize,
    pub evaluations: usize,
    /// Wall time of the fit, shared with the fits running beside it (its wave's; in a
    /// batch, other materials').
    #[serde(deserialize_with = "nullable_f64")]
    pub seconds: f64,
    /// Parameters that ended at (within a relative 1e-3 of) a bound of their fit range:
    /// the optimum may lie beyond it (absent in version 1: empty).
    #[serde(default)]
    pub at_bounds: Vec<BoundHit>,
    /// The final error of every start in the coarse stage, ascending: their spread shows
    /// how many basins the starts fell into (absent in version 1: empty).
    #[serde(default, deserialize_with = "nullable_f64s")]
    pub start_errors: Vec<f64>,
    /// The contained model whose optimum was one of the starts (anisotropic Ward from
    /// Ward): the fit is never worse than it (absent in version 1: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub started_from: Option<StartedFrom>,
    /// An anisotropic model fitted to isotropic data, whose anisotropy the data cannot
    /// show (absent in version 1: false).
    #[serde(default)]
    pub isotropic_data: bool,
}

/// Which bound of its fit range a parameter reached.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BoundSide {
    Lower,
    Upper,
}

/// A fitted parameter at a bound of its fit range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundHit {
    /// The parameter (`lobes[1].m` for the second lobe of two).
    pub param: String,
    pub value: f64,
    pub bound: f64,
    pub side: BoundSide,
}

/// The contained model a fit started from, and that model's error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartedFrom {
    pub model: String,
    #[serde(deserialize_with = "nullable_f64")]
    pub error: f64,
}

/// The model chosen for its cost: the cheapest (eval + sample time per call) whose error is
/// within `tolerance` (relative) of the best.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Selection {
    /// The chosen label ("" when no model qualified).
    pub model: String,
    pub tolerance: f64,
    #[serde(deserialize_with = "nullable_f64")]
    pub best_error: f64,
    /// Per model label, its measured cost and error.
    pub costs: BTreeMap<String, ModelCost>,
}

/// The measured cost of one fitted model, with its error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelCost {
    /// Nanoseconds per evaluation.
    pub eval_ns: f64,
    /// Nanoseconds per sample.
    pub sample_ns: f64,
    #[serde(deserialize_with = "nullable_f64")]
    pub error: f64,
}

impl ModelFit {
    /// The fit of one model, as [`super::fit`] returned it.
    pub fn from_result(r: &FitResult) -> Self {
        Self {
            material: r.material.clone(),
            error: r.error,
            error_normalized: r.error_normalized,
            metric_error: r.metric_error,
            starts: r.starts,
            starts_agreeing: r.starts_agreeing,
            evaluations: r.evaluations,
            seconds: r.seconds,
            at_bounds: r.at_bounds.clone(),
            start_errors: r.start_errors.clone(),
            started_from: r.started_from.clone(),
            isotropic_data: r.isotropic_data,
        }
    }

    /// Fewer than half the starts reached the best error (within 1 %): the optimum was
    /// found by few of them, and a better one may have been missed.
    pub fn starts_disagree(&self) -> bool {
        self.starts > 1 && 2 * self.starts_agreeing < self.starts
    }

    /// One line per thing about this fit (of model `label`) that should not pass silently:
    /// an anisotropic model on isotropic data, parameters at a bound of their fit range,
    /// starts that disagree. Empty for a clean fit.
    pub fn warnings(&self, label: &str) -> Vec<String> {
        let mut out = Vec::new();
        if self.isotropic_data {
            let from = self.started_from.as_ref().map_or(String::new(), |s| {
                format!(
                    "; it started from the {} optimum (error {:.4e})",
                    s.model, s.error
                )
            });
            out.push(format!(
                "{label}: ANISOTROPIC MODEL ON ISOTROPIC DATA: the data cannot show anisotropy (one light azimuth, or phi_d only), so its anisotropic parameters and any gain in error are artefacts of the sampling{from}"
            ));
        }
        if !self.at_bounds.is_empty() {
            let hits: Vec<String> = self
                .at_bounds
                .iter()
                .map(|h| {
                    let side = match h.side {
                        BoundSide::Lower => "lower",
                        BoundSide::Upper => "upper",
                    };
                    format!(
                        "{} = {:.4e} at its {side} bound {}",
                        h.param, h.value, h.bound
                    )
                })
                .collect();
            out.push(format!(
                "{label}: {} (the optimum may lie beyond the fit range)",
                hits.join(", ")
            ));
        }
        if self.starts_disagree() {
            let spread = match (self.start_errors.first(), self.start_errors.last()) {
                (Some(a), Some(b)) => format!("; start errors span {a:.4e} to {b:.4e}"),
                _ => String::new(),
            };
            out.push(format!(
                "{label}: only {} of {} starts reached the best error (within 1 %){spread}; a better optimum may have been missed",
                self.starts_agreeing, self.starts
            ));
        }
        out
    }
}

impl FitReport {
    /// Refuses a report that a `{"type": "fit"}` material could not load: every model's
    /// material must build through `registry` (its parameters within their ranges) and be
    /// finite in f32. Every writer of reports checks this first, so that no report is
    /// written that cannot be rendered.
    pub fn check_loads(&self, registry: &crate::registry::Registry) -> Result<(), String> {
        for (label, m) in &self.models {
            let at = format!("models.{label}.material");
            let b = registry.create(&m.material, &at).map_err(|e| {
                let mut msg = format!("the fit of model \"{label}\" would not load: {e}");
                if self.max_albedo > 1.0 {
                    msg += &format!(
                        " (the data reflect more than they receive: largest albedo {:.4})",
                        self.max_albedo
                    );
                }
                msg
            })?;
            if let Some(bad) = crate::bsdf::first_nonfinite(b.as_ref()) {
                return Err(format!(
                    "the fit of model \"{label}\" is not finite in f32 at {bad}; expected parameters whose BRDF f32 holds"
                ));
            }
        }
        Ok(())
    }

    /// The report of fitting `data` (named `material`, read from `source` at
    /// `resolution_deg`) to the models of `results`, without a selection.
    pub fn new(
        material: &str,
        source: &str,
        resolution_deg: f64,
        data: &Dataset,
        results: &[FitResult],
    ) -> Self {
        Self {
            format_version: FORMAT_VERSION,
            material: material.to_string(),
            source: source.to_string(),
            resolution_deg,
            samples: data.samples.len(),
            max_albedo: data.max_albedo,
            metric: results.first().map_or(Metric::Eq1, |r| r.metric),
            models: results
                .iter()
                .map(|r| (r.label.clone(), ModelFit::from_result(r)))
                .collect(),
            selected: None,
            key: None,
            anisotropic: data.anisotropic,
        }
    }

    /// The report as JSON (keys in alphabetical order, non-finite numbers as `null`).
    pub fn to_json(&self) -> Value {
        serde_json::to_value(self).expect("a report serializes")
    }

    /// The report of JSON `v`; `file` names it in errors, which name the field too.
    pub fn from_json(v: &Value, file: &str) -> Result<Self, FileError> {
        let found = match v.get("format_version") {
            None => Some(1),
            Some(n) => n.as_u64(),
        };
        if let Some(found) = found
            && found > FORMAT_VERSION as u64
        {
            return Err(FileError::new(
                file,
                format!(
                    "format_version: {found} is newer than this lobe reads (version {FORMAT_VERSION}); refit the data or use a newer lobe"
                ),
            ));
        }
        serde_path_to_error::deserialize(v).map_err(|e| {
            let field = e.path().to_string();
            let what = e.inner().to_string();
            let message = if field == "." {
                format!("{what}; expected a lobe fit report")
            } else {
                format!("{field}: {what}; expected a lobe fit report")
            };
            FileError::new(file, message)
        })
    }
}

/// Reads a fit report: a strict JSON file ([`crate::json::read`]) of a supported format
/// version, every field present and of its type; errors are one line naming the file and
/// the field.
pub fn read(path: &Path) -> Result<FitReport, FileError> {
    let v = crate::json::read(path)?;
    FitReport::from_json(&v, &path.display().to_string())
}

/// Writes a fit report atomically (pretty JSON and a final newline).
pub fn write(path: &Path, report: &FitReport) -> Result<(), FileError> {
    let v = report.to_json();
    crate::io::atomic_write(path, |out| {
        serde_json::to_writer_pretty(&mut *out, &v).map_err(std::io::Error::other)?;
        std::io::Write::write_all(out, b"\n")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn sample() -> FitReport {
        let fit = |e: f64| ModelFit {
            material: json!({"type": "ward", "alpha": 0.1, "diffuse": [0.1, 0.2, 0.3], "specular": [0.5, 0.5, 0.5]}),
            error: e,
            error_normalized: e / 0.5,
            metric_error: Some(e * 2.0),
            starts: 3,
            starts_agreeing: 2,
            evaluations: 120,
            seconds: 0.25,
            at_bounds: vec![BoundHit {
                param: "alpha".into(),
                value: 1.0,
                bound: 1.0,
                side: BoundSide::Upper,
            }],
            start_errors: vec![e, e * 1.005, e * 1.5],
            started_from: None,
            isotropic_data: false,
        };
        FitReport {
            format_version: FORMAT_VERSION,
            material: "nickel".into(),
            source: "data/nickel.binary".into(),
            resolution_deg: 1.0,
            samples: 1000,
            max_albedo: 0.5,
            metric: Metric::CubeRoot,
            models: [
                ("ward".to_string(), fit(0.01)),
                ("he".to_string(), fit(0.02)),
            ]
            .into_iter()
            .collect(),
            selected: Some(Selection {
                model: "ward".into(),
                tolerance: 0.1,
                best_error: 0.01,
                costs: [(
                    "ward".to_string(),
                    ModelCost {
                        eval_ns: 12.5,
                        sample_ns: 30.0,
                        error: 0.01,
                    },
                )]
                .into_iter()
                .collect(),
            }),
            key: Some(FitKey {
                data: "d".repeat(64),
                settings: "s".repeat(64),
            }),
            anisotropic: false,
        }
    }

    #[test]
    fn a_report_round_trips_through_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.fit.json");
        let r = sample();
        write(&path, &r).unwrap();
        assert_eq!(read(&path).unwrap(), r);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains(&format!("\"format_version\": {FORMAT_VERSION}")),
            "{text}"
        );
        assert!(text.contains("\"metric\": \"cube-root\""), "{text}");
        assert!(text.contains("\"metric_error\": 0.02"), "{text}");
        // Keys in alphabetical order, as reports always had.
        let (a, b) = (
            text.find("\"material\"").unwrap(),
            text.find("\"models\"").unwrap(),
        );
        assert!(a < b, "{text}");
    }

    #[test]
    fn a_report_without_a_version_is_version_one() {
        let mut v = sample().to_json();
        v.as_object_mut().unwrap().remove("format_version");
        let r = FitReport::from_json(&v, "old.fit.json").unwrap();
        assert_eq!(r.format_version, 1);
        assert_eq!(r.models["ward"].error, 0.01);
    }

    #[test]
    fn a_newer_version_is_refused_naming_both_versions() {
        let mut v = sample().to_json();
        v["format_version"] = json!(FORMAT_VERSION + 1);
        let e = FitReport::from_json(&v, "new.fit.json")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("new.fit.json: format_version"), "{e}");
        assert!(e.contains(&format!("{}", FORMAT_VERSION + 1)), "{e}");
        assert!(e.contains(&format!("version {FORMAT_VERSION}")), "{e}");
    }

    #[test]
    fn a_missing_or_renamed_field_is_named() {
        let mut v = sample().to_json();
        let ward = v["models"]["ward"].as_object_mut().unwrap();
        let e = ward.remove("error_normalized").unwrap();
        let missing = FitReport::from_json(&v, "r.fit.json")
            .unwrap_err()
            .to_string();
        assert!(missing.starts_with("r.fit.json: models.ward"), "{missing}");
        assert!(
            missing.contains("missing field `error_normalized`"),
            "{missing}"
        );
        v["models"]["ward"]["normalized_error"] = e;
        let renamed = FitReport::from_json(&v, "r.fit.json")
            .unwrap_err()
            .to_string();
        assert!(renamed.contains("models.ward"), "{renamed}");
        assert!(renamed.contains("normalized_error"), "{renamed}");
        // A field of the wrong type is named by its path.
        let mut w = sample().to_json();
        w["samples"] = json!("many");
        let wrong = FitReport::from_json(&w, "r.fit.json")
            .unwrap_err()
            .to_string();
        assert!(wrong.starts_with("r.fit.json: samples: "), "{wrong}");
    }

    #[test]
    fn a_non_finite_error_is_written_as_null_and_read_as_nan() {
        let mut r = sample();
        r.models.get_mut("he").unwrap().error_normalized = f64::NAN;
        let v = r.to_json();
        assert!(v["models"]["he"]["error_normalized"].is_null());
        let back = FitReport::from_json(&v, "r.fit.json").unwrap();
        assert!(back.models["he"].error_normalized.is_nan());
    }

    #[test]
    fn a_version_one_report_reads_without_the_later_fields() {
        let mut v = sample().to_json();
        v["format_version"] = json!(1);
        for m in v["models"].as_object_mut().unwrap().values_mut() {
            let m = m.as_object_mut().unwrap();
            for k in [
                "at_bounds",
                "start_errors",
                "started_from",
                "isotropic_data",
            ] {
                m.remove(k);
            }
        }
        v.as_object_mut().unwrap().remove("metric");
        for m in v["models"].as_object_mut().unwrap().values_mut() {
            m.as_object_mut().unwrap().remove("metric_error");
        }
        let r = FitReport::from_json(&v, "old.fit.json").unwrap();
        assert_eq!(r.format_version, 1);
        assert_eq!(r.metric, Metric::Eq1);
        let ward = &r.models["ward"];
        assert_eq!(ward.metric_error, None);
        assert!(ward.at_bounds.is_empty() && ward.start_errors.is_empty());
        assert!(ward.started_from.is_none() && !ward.isotropic_data);
        // Nothing recorded, nothing to warn about (2 of 3 starts agree).
        assert!(ward.warnings("ward").is_empty());
    }

    #[test]
    fn a_fit_at_a_bound_with_disagreeing_starts_on_isotropic_data_warns_once_each() {
        let mut fit = sample().models["ward"].clone();
        let w = fit.warnings("ward");
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("alpha = 1.0000e0 at its upper bound 1"),
            "{w:?}"
        );
        fit.starts_agreeing = 1;
        fit.isotropic_data = true;
        fit.started_from = Some(StartedFrom {
            model: "ward".into(),
            error: 0.01,
        });
        let w = fit.warnings("ward-anisotropic");
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(w[0].contains("ISOTROPIC DATA") && w[0].contains("ward optimum"));
        assert!(w[2].contains("only 1 of 3 starts") && w[2].contains("1.0000e-2 to 1.5000e-2"));
        fit.at_bounds.clear();
        fit.isotropic_data = false;
        fit.starts_agreeing = 3;
        assert!(fit.warnings("ward").is_empty());
    }
}
