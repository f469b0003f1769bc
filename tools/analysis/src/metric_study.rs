//! Which fitting metric gives the fits that look right (`lobe fit compare-metrics`): the
//! study's future work (Ngan et al. 2005 section 7, "a perceptually-based metric would
//! improve the visual quality of the fits") as an experiment. Every material is fitted with
//! every model under each metric ([`lobe_materials::fit::metric`]); then each fit and the
//! measured material are rendered on a sphere ([`crate::figures::sphere_scene`]) under
//! environment maps the image metric did not fit under, and compared (RMSE, FLIP;
//! `lobe_renderer::compare`). Fits are kept as reports in `DIR/fits/` (resumable: an
//! existing report is not refitted), the table in `DIR/metrics.csv` and `DIR/metrics.md`.

use crate::figures::sphere_scene;
use crate::fitting::{FitOptions, data_material_desc, fit_material_with, stem};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{Metric, Stop};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use lobe_renderer::compare::metrics;
use lobe_renderer::render::{RenderOptions, render};
use std::path::{Path, PathBuf};

/// What the experiment fits and renders.
#[derive(Clone, Debug)]
pub struct MetricStudyConfig {
    /// Measured files (MERL, binned, RGL).
    pub data: Vec<PathBuf>,
    /// How the fits are made: models, bin size, evaluations, the image metric's maps.
    pub fit: FitOptions,
    /// The metrics compared.
    pub metrics: Vec<Metric>,
    /// The maps the renders are compared under (not those the image metric fitted under).
    pub test_envs: Vec<String>,
    /// Render size (pixels square) and samples per pixel (every render has seed 0).
    pub size: u32,
    pub spp: u32,
    /// Output folder.
    pub out: PathBuf,
}

/// One fit under one test map.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub material: String,
    pub model: String,
    pub metric: Metric,
    pub env: String,
    /// Eq. (1) error, normalized (section 4.1).
    pub eq1_normalized: f64,
    pub rmse: f64,
    pub flip: f64,
}

fn check(config: &MetricStudyConfig) -> Result<(), Error> {
    let fitted: Vec<String> = if config.fit.envs.is_empty() {
        crate::fit_images::DEFAULT_FIT_ENVS
            .iter()
            .map(|e| stem_of(e))
            .collect()
    } else {
        config.fit.envs.iter().map(|e| stem_of(e)).collect()
    };
    let image_metric = config.metrics.contains(&Metric::Image);
    if let Some(e) = config
        .test_envs
        .iter()
        .find(|e| image_metric && fitted.contains(&stem_of(e)))
    {
        return Err(Error::Other(format!(
            "--test-env {e}: is also a map the image metric fits under; expected held-out maps"
        )));
    }
    if config.test_envs.is_empty() || config.metrics.is_empty() || config.data.is_empty() {
        return Err(Error::Other(
            "expected at least one data file, metric and test map".into(),
        ));
    }
    Ok(())
}

fn stem_of(env: &str) -> String {
    match env.strip_prefix("builtin:") {
        Some(b) => b.to_string(),
        None => stem(Path::new(env)),
    }
}

/// Fits (or reads, when its report exists) the report of `data` under `metric`.
fn fitted(
    registry: &Registry,
    config: &MetricStudyConfig,
    (path, metric): (&Path, Metric),
    stop: &Stop<'_>,
) -> Result<FitReport, Error> {
    let name = stem(path);
    let file = config
        .out
        .join("fits")
        .join(format!("{name}.{metric}.fit.json"));
    if file.exists() {
        return Ok(report::read(&file)?);
    }
    let data = Dataset::read(path, config.fit.resolution)?;
    let measured = registry
        .create(&data_material_desc(path)?, "data")
        .map_err(|e| Error::file(path.display(), e.to_string()))?;
    let opts = FitOptions {
        metric,
        ..config.fit.clone()
    };
    let source = path.display().to_string();
    let r = fit_material_with(
        registry,
        (&name, &source),
        (&data, Some(measured.as_ref())),
        &opts,
        stop,
        &|_| {},
    )?;
    std::fs::create_dir_all(file.parent().expect("a folder"))
        .map_err(|e| Error::file(config.out.display(), format!("cannot create: {e}")))?;
    report::write(&file, &r)?;
    Ok(r)
}

/// Runs the experiment: fits every file under every metric (reusing reports already in
/// `out/fits`), then renders and compares under each test map; `progress` hears a line per
/// step. Rows in the order material, test map, model, metric.
pub fn run(
    registry: &Registry,
    config: &MetricStudyConfig,
    stop: &Stop<'_>,
    progress: &dyn Fn(&str),
) -> Result<Vec<Row>, Error> {
    check(config)?;
    let mut rows = Vec::new();
    for path in &config.data {
        let mut reports = Vec::new();
        for &metric in &config.metrics {
            progress(&format!("{}: fitting with {metric}", path.display()));
            reports.push((metric, fitted(registry, config, (path, metric), stop)?));
            if stop() {
                return Err(Error::Other("interrupted".into()));
            }
        }
        let measured = registry
            .create(&data_material_desc(path)?, "data")
            .map_err(|e| Error::file(path.display(), e.to_string()))?;
        for env in &config.test_envs {
            progress(&format!("{}: rendering under {env}", path.display()));
            let mut scene = sphere_scene(env, config.size, config.spp)?;
            scene.shapes[0].material = measured.clone();
            let (reference, _) = render(&scene, &RenderOptions::default())?;
            for (metric, r) in &reports {
                for (model, fit) in &r.models {
                    scene.shapes[0].material = registry
                        .create(&fit.material, model)
                        .map_err(|e| Error::Other(e.to_string()))?;
                    let (img, _) = render(&scene, &RenderOptions::default())?;
                    let (m, _) = metrics(&img, &reference, 0.0)?;
                    rows.push(Row {
                        material: r.material.clone(),
                        model: model.clone(),
                        metric: *metric,
                        env: stem_of(env),
                        eq1_normalized: fit.error_normalized,
                        rmse: m.rmse,
                        flip: m.flip,
                    });
                }
            }
        }
    }
    Ok(rows)
}

/// Per metric: the mean of RMSE and FLIP relative to the Eq. (1) fit of the same material,
/// model and map (the geometric mean of the ratios), and how often it gave the lowest of
/// the metrics' values (wins; ties count for each).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub metric: Metric,
    pub rmse_ratio: f64,
    pub flip_ratio: f64,
    pub eq1_ratio: f64,
    pub rmse_wins: usize,
    pub flip_wins: usize,
    pub cases: usize,
}

/// The summary of `rows` per metric, in the order the metrics first appear.
pub fn summarize(rows: &[Row]) -> Vec<Summary> {
    let mut metrics: Vec<Metric> = Vec::new();
    for r in rows {
        if !metrics.contains(&r.metric) {
            metrics.push(r.metric);
        }
    }
    let case = |r: &Row| (r.material.clone(), r.model.clone(), r.env.clone());
    let group = |r: &Row| -> Vec<&Row> { rows.iter().filter(|o| case(o) == case(r)).collect() };
    metrics
        .iter()
        .map(|&metric| {
            let mine: Vec<&Row> = rows.iter().filter(|r| r.metric == metric).collect();
            let (mut lr, mut lf, mut le, mut n) = (0.0, 0.0, 0.0, 0usize);
            let (mut rw, mut fw) = (0, 0);
            for r in &mine {
                let g = group(r);
                if let Some(base) = g.iter().find(|o| o.metric == Metric::Eq1) {
                    lr += (r.rmse / base.rmse).ln();
                    lf += (r.flip / base.flip).ln();
                    le += (r.eq1_normalized / base.eq1_normalized).ln();
                    n += 1;
                }
                rw += usize::from(g.iter().all(|o| r.rmse <= o.rmse));
                fw += usize::from(g.iter().all(|o| r.flip <= o.flip));
            }
            let mean = |s: f64| {
                if n > 0 {
                    (s / n as f64).exp()
                } else {
                    f64::NAN
                }
            };
            Summary {
                metric,
                rmse_ratio: mean(lr),
                flip_ratio: mean(lf),
                eq1_ratio: mean(le),
                rmse_wins: rw,
                flip_wins: fw,
                cases: mine.len(),
            }
        })
        .collect()
}

/// The rows as CSV.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("material,model,metric,env,eq1_normalized,rmse,flip\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{:.6e},{:.6e},{:.6e}\n",
            r.material, r.model, r.metric, r.env, r.eq1_normalized, r.rmse, r.flip
        );
    }
    s
}

/// The summary and, per material and model, the RMSE and FLIP of each metric's fit
/// (averaged over the test maps), as Markdown.
pub fn markdown(rows: &[Row]) -> String {
    let sum = summarize(rows);
    let mut s = String::from(
        "| metric | RMSE / eq1's (geo. mean) | FLIP / eq1's | Eq. (1) error / eq1's | lowest RMSE | lowest FLIP | cases |\n|---|---|---|---|---|---|---|\n",
    );
    for m in &sum {
        s += &format!(
            "| {} | {:.3} | {:.3} | {:.3} | {} | {} | {} |\n",
            m.metric, m.rmse_ratio, m.flip_ratio, m.eq1_ratio, m.rmse_wins, m.flip_wins, m.cases
        );
    }
    let metrics: Vec<Metric> = sum.iter().map(|m| m.metric).collect();
    s += &format!(
        "\n| material | model | {} |\n|---|---|{}\n",
        metrics
            .iter()
            .map(|m| format!("{m} RMSE / FLIP"))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(metrics.len())
    );
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in rows {
        let k = (r.material.clone(), r.model.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (mat, model) in keys {
        s += &format!("| {mat} | {model} |");
        for &metric in &metrics {
            let v: Vec<&Row> = rows
                .iter()
                .filter(|r| r.material == mat && r.model == model && r.metric == metric)
                .collect();
            let n = v.len().max(1) as f64;
            let rmse = v.iter().map(|r| r.rmse).sum::<f64>() / n;
            let flip = v.iter().map(|r| r.flip).sum::<f64>() / n;
            s += &format!(" {rmse:.4} / {flip:.4} |");
        }
        s.push('\n');
    }
    s
}

/// Writes `out/metrics.csv` and `out/metrics.md` atomically.
pub fn write(rows: &[Row], out: &Path) -> Result<(), Error> {
    for (name, text) in [("metrics.csv", csv(rows)), ("metrics.md", markdown(rows))] {
        lobe_renderer::film::atomic_write(&out.join(name), |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(model: &str, metric: Metric, rmse: f64, flip: f64) -> Row {
        Row {
            material: "m".into(),
            model: model.into(),
            metric,
            env: "e".into(),
            eq1_normalized: 0.1,
            rmse,
            flip,
        }
    }

    #[test]
    fn the_summary_relates_each_metric_to_eq1_and_counts_wins() {
        let rows = [
            row("ward", Metric::Eq1, 0.2, 0.1),
            row("ward", Metric::Log, 0.1, 0.2),
            row("he", Metric::Eq1, 0.4, 0.1),
            row("he", Metric::Log, 0.1, 0.1),
        ];
        let s = summarize(&rows);
        assert_eq!(s[0].metric, Metric::Eq1);
        assert_eq!(
            (s[0].rmse_ratio, s[0].rmse_wins, s[0].flip_wins),
            (1.0, 0, 2)
        );
        assert_eq!(s[1].metric, Metric::Log);
        // Ratios 0.5 and 0.25: geometric mean 0.3536.
        assert!((s[1].rmse_ratio - 0.125f64.sqrt()).abs() < 1e-12);
        assert!((s[1].flip_ratio - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!((s[1].rmse_wins, s[1].flip_wins, s[1].cases), (2, 1, 2));
        let md = markdown(&rows);
        assert!(
            md.contains("| log | 0.354 | 1.414 | 1.000 | 2 | 1 | 2 |"),
            "{md}"
        );
        assert!(
            md.contains("| m | he | 0.4000 / 0.1000 | 0.1000 / 0.1000 |"),
            "{md}"
        );
    }
}
