//! Which fitting metric gives the fits that look right (`lobe fit compare-metrics`): the
//! study's future work (Ngan et al. 2005 section 7, "a perceptually-based metric would
//! improve the visual quality of the fits") as an experiment. Every material is fitted with
//! every model under each metric ([`lobe_materials::fit::metric`]); then the images of each
//! fit and of the measured material on a sphere under environment maps the image metric
//! did not fit under are compared by [`crate::sphere_errors::estimate`]: all of them from
//! the same samples (common random numbers), each fit's RMSE against the data's image with
//! its 95 % interval and without the noise's bias, its FLIP, and the map's noise floor. A
//! metric wins a case only where its RMSE interval lies below every other metric's. Fits
//! are kept as reports in `DIR/fits/` (resumable: an existing report is not refitted), the
//! table in `DIR/metrics.csv` and `DIR/metrics.md`.

use crate::fit_images::FitEnvironment;
use crate::fitting::{FitOptions, data_material_desc, fit_material_with, stem};
use crate::sphere_errors::{ErrorSettings, Stage, estimate};
use lobe_materials::Bsdf;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::report::{self, FitReport};
use lobe_materials::fit::{Metric, Stop};
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What the experiment fits and compares.
#[derive(Clone, Debug)]
pub struct MetricStudyConfig {
    /// Measured files (MERL, binned, RGL).
    pub data: Vec<PathBuf>,
    /// How the fits are made: models, bin size, evaluations, the image metric's maps.
    pub fit: FitOptions,
    /// The metrics compared.
    pub metrics: Vec<Metric>,
    /// The maps the images are compared under (not those the image metric fitted under).
    pub test_envs: Vec<String>,
    /// Image size (pixels square) and the most samples per pixel (mean over the image) of
    /// the error estimate.
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
    /// Image RMSE against the data's image (noise bias removed) and its 95 % interval.
    pub rmse: f64,
    pub ci95: [f64; 2],
    pub flip: f64,
    /// The RMS noise of this fit's difference image from the data's.
    pub noise: f64,
    /// The noise of the difference image of the fit with the smallest error under this map
    /// ([`crate::sphere_errors::SphereErrors::noise_floor`]; the same for every row of the
    /// material and map).
    pub noise_floor: f64,
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
    if !(16..=2048).contains(&config.size) || config.spp == 0 {
        return Err(Error::Other(format!(
            "--size {} / --spp {}: expected 16 to 2048 pixels and at least one sample",
            config.size, config.spp
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
/// `out/fits`), then estimates every fit's image error under each test map; `progress`
/// hears a line per step. Rows in the order material, test map, metric, model.
pub fn run(
    registry: &Registry,
    config: &MetricStudyConfig,
    stop: &Stop<'_>,
    progress: &dyn Fn(&str),
) -> Result<Vec<Row>, Error> {
    check(config)?;
    let maps = config
        .test_envs
        .iter()
        .map(|e| Ok((e.as_str(), FitEnvironment::load(e)?)))
        .collect::<Result<Vec<_>, Error>>()?;
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
        let fits = fit_materials(registry, &reports)?;
        for (env, map) in &maps {
            progress(&format!("{}: images under {env}", path.display()));
            let stage = Stage::sphere(&map.0, config.size);
            let data = (stem(path), &measured, fits.as_slice());
            rows.extend(image_errors(config, &stage, data, env)?);
            if stop() {
                return Err(Error::Other("interrupted".into()));
            }
        }
    }
    Ok(rows)
}

/// Each fit of `reports` as a material: its metric, model, Eq. (1) error and BSDF.
type FitMaterial<'r> = (Metric, &'r str, f64, Arc<dyn Bsdf>);

/// The materials of every fit of `reports` (each metric's), made once per data file.
fn fit_materials<'r>(
    registry: &Registry,
    reports: &'r [(Metric, FitReport)],
) -> Result<Vec<FitMaterial<'r>>, Error> {
    let mut fits = Vec::new();
    for (metric, r) in reports {
        for (model, fit) in &r.models {
            let m = registry
                .create(&fit.material, model)
                .map_err(|e| Error::Other(e.to_string()))?;
            fits.push((*metric, model.as_str(), fit.error_normalized, m));
        }
    }
    Ok(fits)
}

/// The rows of one material under one map: the image error of each of its `fits` against
/// the data's image, all from one [`estimate`] on `stage`.
fn image_errors(
    config: &MetricStudyConfig,
    stage: &Stage<'_>,
    (material, measured, fits): (String, &Arc<dyn Bsdf>, &[FitMaterial<'_>]),
    env: &str,
) -> Result<Vec<Row>, Error> {
    let reps: Vec<&dyn Bsdf> = std::iter::once(measured.as_ref())
        .chain(fits.iter().map(|f| f.3.as_ref()))
        .collect();
    let settings = ErrorSettings {
        pilot_spp: (config.spp as usize).min(64),
        max_spp: config.spp as usize,
        ..ErrorSettings::default()
    };
    let est = estimate(stage, &reps, &settings)?;
    Ok(fits
        .iter()
        .zip(&est.errors[1..])
        .map(|(&(metric, model, eq1, _), e)| Row {
            material: material.clone(),
            model: model.to_string(),
            metric,
            env: stem_of(env),
            eq1_normalized: eq1,
            rmse: e.rmse,
            ci95: e.ci95,
            flip: e.flip,
            noise: e.noise,
            noise_floor: est.noise_floor,
        })
        .collect())
}

/// Per metric: the mean of RMSE and FLIP relative to the Eq. (1) fit of the same material,
/// model and map (the geometric mean of the ratios, [`GeoMean`]), and how often it gave
/// the lowest of the metrics' values: for RMSE only where its interval lies wholly below
/// every other metric's (a win the noise cannot have made), for FLIP, which has no
/// interval, the lowest value (ties count for each).
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
            let (mut lr, mut lf, mut le) =
                (GeoMean::default(), GeoMean::default(), GeoMean::default());
            let (mut rw, mut fw) = (0, 0);
            for r in &mine {
                let g = group(r);
                if let Some(base) = g.iter().find(|o| o.metric == Metric::Eq1) {
                    lr.add(r.rmse / base.rmse);
                    lf.add(r.flip / base.flip);
                    le.add(r.eq1_normalized / base.eq1_normalized);
                }
                rw += usize::from(
                    g.iter()
                        .all(|o| std::ptr::eq(*o, *r) || r.ci95[1] < o.ci95[0]),
                );
                fw += usize::from(g.iter().all(|o| r.flip <= o.flip));
            }
            Summary {
                metric,
                rmse_ratio: lr.value(),
                flip_ratio: lf.value(),
                eq1_ratio: le.value(),
                rmse_wins: rw,
                flip_wins: fw,
                cases: mine.len(),
            }
        })
        .collect()
}

/// The geometric mean of ratios, leaving out those that are not positive and finite (an
/// error the estimate found to be zero, below its noise, has no ratio); NaN when none is.
#[derive(Default)]
struct GeoMean {
    log_sum: f64,
    n: usize,
}

impl GeoMean {
    fn add(&mut self, ratio: f64) {
        if ratio.is_finite() && ratio > 0.0 {
            self.log_sum += ratio.ln();
            self.n += 1;
        }
    }

    fn value(&self) -> f64 {
        match self.n {
            0 => f64::NAN,
            n => (self.log_sum / n as f64).exp(),
        }
    }
}

/// The rows as CSV.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "material,model,metric,env,eq1_normalized,rmse,rmse_ci95_lo,rmse_ci95_hi,flip,noise,noise_floor\n",
    );
    for r in rows {
        s += &format!(
            "{},{},{},{},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e}\n",
            r.material,
            r.model,
            r.metric,
            r.env,
            r.eq1_normalized,
            r.rmse,
            r.ci95[0],
            r.ci95[1],
            r.flip,
            r.noise,
            r.noise_floor
        );
    }
    s
}

/// The summary and, per material, map and model, each metric's fit's RMSE with its 95 %
/// interval and FLIP, under a line giving the map's noise floor, as Markdown.
pub fn markdown(rows: &[Row]) -> String {
    let sum = summarize(rows);
    let mut s = String::from(
        "| metric | RMSE / eq1's (geo. mean) | FLIP / eq1's | Eq. (1) error / eq1's | lowest RMSE (intervals separate) | lowest FLIP | cases |\n|---|---|---|---|---|---|---|\n",
    );
    for m in &sum {
        s += &format!(
            "| {} | {:.3} | {:.3} | {:.3} | {} | {} | {} |\n",
            m.metric, m.rmse_ratio, m.flip_ratio, m.eq1_ratio, m.rmse_wins, m.flip_wins, m.cases
        );
    }
    let metrics: Vec<Metric> = sum.iter().map(|m| m.metric).collect();
    let header = format!(
        "| model | {} |\n|---|{}\n",
        metrics
            .iter()
            .map(|m| format!("{m}: RMSE [95 %] / FLIP"))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(metrics.len())
    );
    let mut cases: Vec<(&str, &str)> = Vec::new();
    for r in rows {
        if !cases.contains(&(&r.material, &r.env)) {
            cases.push((&r.material, &r.env));
        }
    }
    for (mat, env) in cases {
        let here: Vec<&Row> = rows
            .iter()
            .filter(|r| r.material == mat && r.env == env)
            .collect();
        s += &format!(
            "\n{mat} under {env} (noise floor {:.2e}):\n\n{header}",
            here[0].noise_floor
        );
        let mut models: Vec<&str> = Vec::new();
        for r in &here {
            if !models.contains(&r.model.as_str()) {
                models.push(&r.model);
            }
        }
        for model in models {
            s += &format!("| {model} |");
            for &metric in &metrics {
                match here.iter().find(|r| r.model == model && r.metric == metric) {
                    Some(r) => {
                        s += &format!(
                            " {:.4} [{:.4}, {:.4}] / {:.4} |",
                            r.rmse, r.ci95[0], r.ci95[1], r.flip
                        )
                    }
                    None => s += " |",
                }
            }
            s.push('\n');
        }
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
            ci95: [0.9 * rmse, 1.1 * rmse],
            flip,
            noise: 0.01 * rmse,
            noise_floor: 1e-3,
        }
    }

    #[test]
    fn the_summary_relates_each_metric_to_eq1_and_counts_wins() {
        let mut rows = vec![
            row("ward", Metric::Eq1, 0.2, 0.1),
            row("ward", Metric::Log, 0.1, 0.2),
            row("he", Metric::Eq1, 0.4, 0.1),
            row("he", Metric::Log, 0.1, 0.1),
            row("lafortune", Metric::Eq1, 0.3, 0.2),
            row("lafortune", Metric::Log, 0.25, 0.3),
        ];
        // Lafortune's intervals overlap: no metric wins that case on RMSE.
        rows[5].ci95 = [0.2, 0.31];
        let s = summarize(&rows);
        assert_eq!(s[0].metric, Metric::Eq1);
        assert_eq!(
            (s[0].rmse_ratio, s[0].rmse_wins, s[0].flip_wins),
            (1.0, 0, 3)
        );
        assert_eq!(s[1].metric, Metric::Log);
        // Ratios 0.5, 0.25 and 0.8333: geometric mean (0.5 * 0.25 * 0.8333)^(1/3).
        let expected = (0.5f64 * 0.25 * (0.25 / 0.3)).cbrt();
        assert!((s[1].rmse_ratio - expected).abs() < 1e-12);
        assert!((s[1].flip_ratio - (2.0f64 * 1.5).cbrt()).abs() < 1e-12);
        assert_eq!((s[1].rmse_wins, s[1].flip_wins, s[1].cases), (2, 1, 3));
        let md = markdown(&rows);
        assert!(
            md.contains(&format!(
                "| log | {expected:.3} | 1.442 | 1.000 | 2 | 1 | 3 |"
            )),
            "{md}"
        );
        assert!(md.contains("m under e (noise floor 1.00e-3):"), "{md}");
        assert!(
            md.contains(
                "| he | 0.4000 [0.3600, 0.4400] / 0.1000 | 0.1000 [0.0900, 0.1100] / 0.1000 |"
            ),
            "{md}"
        );
        let csv = csv(&rows);
        assert!(
            csv.lines().nth(1)
                == Some(
                    "m,ward,eq1,e,1.000000e-1,2.000000e-1,1.800000e-1,2.200000e-1,1.000000e-1,2.000000e-3,1.000000e-3"
                ),
            "{csv}"
        );
    }

    /// An error the estimate puts at zero has no ratio: it is left out of the mean rather
    /// than making it NaN or infinite.
    #[test]
    fn a_zero_error_leaves_its_ratio_out_of_the_mean() {
        let rows = [
            row("ward", Metric::Eq1, 0.0, 0.1),
            row("ward", Metric::Log, 0.1, 0.1),
            row("he", Metric::Eq1, 0.2, 0.1),
            row("he", Metric::Log, 0.1, 0.1),
        ];
        let s = summarize(&rows);
        assert_eq!((s[0].rmse_ratio, s[1].rmse_ratio), (1.0, 0.5));
    }
}
