//! The whole experiment of Ngan, Durand and Matusik 2005 (sections 3 to 5) on any set of
//! measured materials, as resumable steps whose outputs are files in one folder, and the
//! browsable report built from them ([`site`]).
//!
//! Per material ([`steps`]): the fits of every applicable model with the cheapest adequate
//! one selected (section 4, [`crate::fitting::fit_material`]), the microfacet distribution
//! estimated from the data (section 5), images of the data and of every representation on
//! a sphere under each environment map (Figures 3 and 6) with their image errors, 95 %
//! intervals and noise floor ([`crate::sphere_errors`]) and equal-time errors
//! ([`crate::convergence`]), polar plots (Figure 4) and lobe contour plots (Figures 7 and
//! 8). Over all materials: Figures 14 and 5, the trade-off table and DIR/results.json
//! (docs/study.md).
//!
//! Every step writes each file by temp file and rename and counts as done when its last
//! file exists and records the step's content key (the digests of the data, the map and
//! the settings), so an interrupted study resumes where it stopped and a rerun computes
//! only what is missing or was made from other data; a shard (i of n) takes every n-th material for job arrays, and the
//! report is built once every material is complete.

pub mod site;
pub mod steps;

use lobe_materials::fit::Stop;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::registry::Registry;
use lobe_renderer::Error;
use lobe_renderer::scene::builtin_images::SUNSET_EXR;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// What a study runs on and where it writes.
#[derive(Clone, Debug)]
pub struct StudyConfig {
    /// Measured data files and folders of them; empty: the built-in set
    /// ([`builtin_materials`]).
    pub inputs: Vec<PathBuf>,
    /// The study folder.
    pub out: PathBuf,
    /// The small version: fewer models, coarser bins, fewer samples.
    pub quick: bool,
    /// This shard (i, n): materials whose index in name order is i modulo n.
    pub shard: (usize, usize),
    /// Environment maps (EXR/HDR files or builtin:studio); empty: the built-in studio and
    /// the sunset map embedded in lobe.
    pub envs: Vec<String>,
    /// The image-error estimate's budget, a mean of samples per pixel over its planned
    /// pass ([`Settings::error_max_spp`]); None: the settings' own. Fewer samples finish
    /// sooner with more noise (recorded per map, with whether the targets hold).
    pub error_spp: Option<usize>,
}

/// The budgets `--error-spp` takes: from the fewest samples the estimate gives a pixel (8
/// in each of its 4 batches) to 16,384, where a highlight's pixel (64 times the budget)
/// already takes a million samples.
pub const ERROR_SPP_RANGE: std::ops::RangeInclusive<usize> =
    crate::sphere_errors::FLOOR_PER_BATCH * 4..=16_384;

/// How much work each step does: the full study on the user's data, a lighter one on the
/// built-in set (a complete report in minutes), or the quick one.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Bin size of isotropic data in degrees.
    pub resolution: f64,
    /// Objective evaluations per SLSQP start.
    pub max_evals: usize,
    /// Comma-separated models, or None for every applicable one.
    pub models: Option<String>,
    /// Relative error tolerance of the model selection.
    pub tolerance: f64,
    /// Sphere image size (pixels across; a multiple of 4 for the speed/accuracy curves).
    pub size: u32,
    /// Samples per pixel of the measured data's render whose time is the equal-time
    /// budget.
    pub spp: u32,
    /// Samples per pixel of the image-error estimate's pilot pass and its cap
    /// ([`crate::sphere_errors`]).
    pub error_pilot_spp: usize,
    pub error_max_spp: usize,
    /// Nodes per side and alternations of the microfacet estimate.
    pub microfacet_nodes: usize,
    pub microfacet_iterations: usize,
    /// Incidence angles (degrees) of the polar and lobe plots.
    pub angles: Vec<f64>,
}

impl Settings {
    /// The settings of a configuration: `quick`, else the built-in set's when it has no
    /// inputs, else the full study's. With [`StudyConfig::error_spp`], that budget, and a
    /// pilot pass of at most as many.
    pub fn of(config: &StudyConfig) -> Self {
        let settings = match (config.quick, config.inputs.is_empty()) {
            (true, _) => Self::new(true),
            (false, true) => Self::builtin(),
            (false, false) => Self::new(false),
        };
        match config.error_spp {
            Some(budget) => Self {
                error_pilot_spp: settings.error_pilot_spp.min(budget),
                error_max_spp: budget,
                ..settings
            },
            None => settings,
        }
    }

    /// The built-in set's: every applicable model at 5-degree bins, 256-pixel sphere
    /// images, equal time at the data's 32 spp, a 64 spp pilot (the full study's cap).
    pub fn builtin() -> Self {
        Self {
            resolution: 5.0,
            max_evals: 100,
            size: 256,
            spp: 32,
            error_pilot_spp: 64,
            microfacet_nodes: 33,
            microfacet_iterations: 3,
            ..Self::new(false)
        }
    }

    /// The quick settings (`quick`) or the full study's.
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                resolution: 6.0,
                max_evals: 40,
                models: Some("ward,cook-torrance,cook-torrance-2,lafortune,lafortune-2".into()),
                tolerance: 0.1,
                size: 64,
                spp: 8,
                error_pilot_spp: 32,
                error_max_spp: 128,
                microfacet_nodes: 17,
                microfacet_iterations: 2,
                angles: vec![45.0],
            }
        } else {
            Self {
                resolution: 2.0,
                max_evals: 150,
                models: None,
                tolerance: 0.1,
                size: 256,
                spp: 64,
                error_pilot_spp: 128,
                error_max_spp: 4096,
                microfacet_nodes: 65,
                microfacet_iterations: 4,
                angles: vec![30.0, 60.0],
            }
        }
    }
}

impl Settings {
    /// The settings as JSON (recorded in DIR/study.json).
    pub fn to_json(&self) -> Value {
        json!({
            "resolution_deg": self.resolution, "max_evals": self.max_evals,
            "models": self.models, "tolerance": self.tolerance, "size": self.size,
            "spp": self.spp, "error_pilot_spp": self.error_pilot_spp,
            "error_max_spp": self.error_max_spp,
            "microfacet_nodes": self.microfacet_nodes,
            "microfacet_iterations": self.microfacet_iterations, "angles_deg": self.angles,
        })
    }

    /// The image-error estimate's settings.
    pub fn error_settings(&self) -> crate::sphere_errors::ErrorSettings {
        crate::sphere_errors::ErrorSettings {
            pilot_spp: self.error_pilot_spp,
            max_spp: self.error_max_spp,
            ..Default::default()
        }
    }

    /// Records the settings in DIR/study.json, or checks that a study folder already
    /// made has the same ones (its finished steps would otherwise mix two studies).
    fn record(&self, out: &Path, envs: &[Env]) -> Result<(), Error> {
        let path = out.join("study.json");
        let envs: Vec<&str> = envs.iter().map(|e| e.name.as_str()).collect();
        let v = json!({"settings": self.to_json(), "environments": envs});
        if path.exists() {
            let old = lobe_materials::json::read(&path)?;
            if old != v {
                return Err(Error::file(
                    path.display(),
                    format!(
                        "the study in this folder was made with other settings ({old}); expected {v}: use another folder, or the same options (--quick, --env, --error-spp) as before"
                    ),
                ));
            }
            return Ok(());
        }
        lobe_renderer::film::write_json(&path, &v)
    }
}

/// Where a material's data comes from.
#[derive(Clone, Debug)]
pub enum Source {
    /// A measured file (MERL, binned or RGL, told apart by content).
    File(PathBuf),
    /// An analytic material tabulated in memory (the built-in set).
    Analytic(Value),
}

/// A material of the study.
#[derive(Clone, Debug)]
pub struct StudyMaterial {
    /// Its name (the data file's stem), naming its files and page.
    pub name: String,
    pub source: Source,
}

impl StudyMaterial {
    /// The binned data the models are fitted to.
    pub fn dataset(&self, registry: &Registry, resolution: f64) -> Result<Dataset, Error> {
        match &self.source {
            Source::File(p) => Ok(Dataset::read(p, resolution)?),
            Source::Analytic(desc) => {
                let m = registry
                    .create(desc, &self.name)
                    .map_err(|e| Error::Other(e.to_string()))?;
                Ok(Dataset::isotropic(
                    &|wi, wo| Some(m.eval(wo, wi)),
                    resolution,
                ))
            }
        }
    }

    /// The material description that renders the data itself.
    pub fn desc(&self) -> Result<Value, Error> {
        match &self.source {
            Source::File(p) => crate::fitting::data_material_desc(p),
            Source::Analytic(desc) => Ok(desc.clone()),
        }
    }

    /// The digest of the data: the file's bytes, or the analytic description.
    pub fn digest(&self) -> Result<String, Error> {
        Ok(match &self.source {
            Source::File(p) => lobe_materials::key::file_digest(p, "measured data")?,
            Source::Analytic(d) => crate::fitting::material_digest(d),
        })
    }

    /// Where the data comes from, for reports and pages.
    pub fn source_text(&self) -> String {
        match &self.source {
            Source::File(p) => p.display().to_string(),
            Source::Analytic(d) => format!("built-in: {d}"),
        }
    }
}

/// The analytic materials of the built-in set: a plastic, a metal, a two-lobe paint and a
/// rough clay, each of a different model, so that the fits disagree as on real data.
pub fn analytic_materials() -> Vec<StudyMaterial> {
    let m = |name: &str, desc: Value| StudyMaterial {
        name: name.into(),
        source: Source::Analytic(desc),
    };
    vec![
        m(
            "builtin-red-plastic",
            json!({"type": "cook-torrance", "diffuse": [0.35, 0.06, 0.04], "specular": 0.3, "m": 0.12}),
        ),
        m(
            "builtin-gold",
            json!({"type": "ashikhmin-shirley", "specular": [0.9, 0.6, 0.25], "n": 300, "f0": 0.8}),
        ),
        m(
            "builtin-two-layer-paint",
            json!({"type": "composite", "diffuse": [0.05, 0.12, 0.2], "lobes": [
                {"type": "ward", "specular": 0.4, "alpha": 0.05},
                {"type": "ward", "specular": 0.15, "alpha": 0.3}]}),
        ),
        m(
            "builtin-rough-clay",
            json!({"type": "ward", "diffuse": [0.45, 0.3, 0.2], "specular": 0.05, "alpha": 0.4}),
        ),
    ]
}

/// The folder of shared RGL files, if present: $LOBE_DATA/rgl or ../shared/data/rgl.
pub fn shared_rgl_folder() -> Option<PathBuf> {
    std::env::var_os("LOBE_DATA")
        .map(|d| PathBuf::from(d).join("rgl"))
        .into_iter()
        .chain(std::iter::once(PathBuf::from("../shared/data/rgl")))
        .find(|p| p.is_dir())
}

/// The built-in set: [`analytic_materials`], and the RGL files of
/// [`shared_rgl_folder`] when present.
pub fn builtin_materials() -> Result<Vec<StudyMaterial>, Error> {
    let mut v = analytic_materials();
    if let Some(dir) = shared_rgl_folder() {
        v.extend(materials(&[dir])?);
    }
    Ok(v)
}

/// The materials of data files and folders (each folder's data files in name order,
/// [`crate::fitting::data_files`]); two with the same name are an error naming both.
pub fn materials(inputs: &[PathBuf]) -> Result<Vec<StudyMaterial>, Error> {
    let mut v: Vec<StudyMaterial> = Vec::new();
    for i in inputs {
        let files = if i.is_dir() {
            crate::fitting::data_files(i)?
        } else if i.is_file() {
            vec![i.clone()]
        } else {
            return Err(Error::file(
                i.display(),
                "does not exist; expected a measured data file (MERL, binned, RGL) or a folder of them",
            ));
        };
        for f in files {
            let name = crate::fitting::stem(&f);
            check_output_name(&name).map_err(|e| Error::file(f.display(), e))?;
            if let Some(other) = v.iter().find(|m| m.name == name) {
                return Err(Error::file(
                    f.display(),
                    format!(
                        "has the same name \"{name}\" as {}; expected distinct file names",
                        other.source_text()
                    ),
                ));
            }
            v.push(StudyMaterial {
                name,
                source: Source::File(f),
            });
        }
    }
    Ok(v)
}

/// Refuses a material or map name that cannot name the study's files inside its folders:
/// empty, `.` or `..` (a data file named `...binary` has the stem `..`), or holding a path
/// separator.
fn check_output_name(name: &str) -> Result<(), String> {
    if name.is_empty() || name == "." || name == ".." || name.contains(['/', '\\']) {
        return Err(format!(
            "its name \"{name}\" cannot name the study's files; expected a file name with a stem other than \".\" or \"..\""
        ));
    }
    Ok(())
}

/// An environment map the renders are lit by.
#[derive(Clone, Debug, PartialEq)]
pub struct Env {
    /// Its name in file names and pages.
    pub name: String,
    /// What the scene's envmap light reads (a path or builtin:studio).
    pub file: String,
    /// The digest of its content ([`lobe_materials::key::input_digest`]).
    pub digest: String,
}

impl Env {
    fn new(name: String, file: String) -> Result<Self, Error> {
        let digest = lobe_materials::key::input_digest(&file, "an EXR or HDR environment map")?;
        Ok(Self { name, file, digest })
    }
}

/// The environment maps: the configured ones, or builtin:studio and the embedded sunset
/// map (written to DIR/assets/ the first time).
pub fn environments(config: &StudyConfig) -> Result<Vec<Env>, Error> {
    if config.envs.is_empty() {
        let sunset = config.out.join("assets").join("sunset-512.exr");
        if !sunset.exists() {
            std::fs::create_dir_all(config.out.join("assets"))
                .map_err(|e| Error::file(config.out.display(), format!("cannot create: {e}")))?;
            lobe_renderer::film::atomic_write(&sunset, |w| {
                std::io::Write::write_all(w, SUNSET_EXR)
            })?;
        }
        let abs = std::fs::canonicalize(&sunset).unwrap_or(sunset);
        return Ok(vec![
            Env::new("studio".into(), "builtin:studio".into())?,
            Env::new("sunset".into(), abs.display().to_string())?,
        ]);
    }
    let mut v: Vec<Env> = Vec::new();
    for e in &config.envs {
        let name = match e.strip_prefix("builtin:") {
            Some(b) => b.to_string(),
            None => crate::fitting::stem(Path::new(e)),
        };
        check_output_name(&name).map_err(|m| Error::Other(format!("--env {e}: {m}")))?;
        if v.iter().any(|o| o.name == name) {
            return Err(Error::Other(format!(
                "--env {e}: a second environment map named \"{name}\"; expected distinct names"
            )));
        }
        let file = match e.starts_with("builtin:") {
            true => e.clone(),
            false => std::fs::canonicalize(e)
                .map_err(|err| {
                    Error::file(
                        e,
                        format!("cannot open: {err}; expected an EXR or HDR environment map"),
                    )
                })?
                .display()
                .to_string(),
        };
        v.push(Env::new(name, file)?);
    }
    Ok(v)
}

/// What a study tells as it goes.
pub trait StudyProgress: Sync {
    /// `total` steps are to be checked (done ones are skipped quickly).
    fn planned(&self, _total: usize) {}
    /// A step starts.
    fn began(&self, _what: &str) {}
    /// A step is done or was already done.
    fn finished(&self, _what: &str) {}
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StudySummary {
    pub materials: usize,
    /// Steps computed in this run, and found done.
    pub computed: usize,
    pub skipped: usize,
    /// Materials (of any shard) not yet complete: the report waits for them.
    pub pending: usize,
    /// The report's index page, when it was built.
    pub index: Option<PathBuf>,
    /// Materials that failed (their data could not be read or fitted), with the error:
    /// their later steps are skipped, the report lists them, and the study goes on.
    pub failures: Vec<(String, String)>,
}

impl StudySummary {
    fn failed(&self, name: &str) -> bool {
        self.failures.iter().any(|(n, _)| n == name)
    }

    /// The study's last line, for a script and a person: `FAIL` when a material failed,
    /// else `PASS`, with how many material-maps of DIR/results.json (when the report was
    /// built) meet the interval and noise targets; those are findings about the sample
    /// count, not failures.
    pub fn verdict(&self) -> String {
        if !self.failures.is_empty() {
            return format!(
                "FAIL: {} of {} materials failed (listed above); the others are done",
                self.failures.len(),
                self.materials
            );
        }
        let Some(index) = &self.index else {
            return format!(
                "PASS: this run's steps are done; the report waits for {} materials of other shards",
                self.pending
            );
        };
        let results = index
            .parent()
            .map(|d| d.join("results.json"))
            .and_then(|p| lobe_materials::json::read(&p).ok());
        let maps: Vec<&Value> = results
            .as_ref()
            .and_then(|r| r["materials"].as_object())
            .into_iter()
            .flat_map(|m| m.values())
            .filter_map(|m| m["maps"].as_object())
            .flat_map(|m| m.values())
            .collect();
        let met = |key: &str| maps.iter().filter(|m| m[key] == true).count();
        let count = |n: usize, what: &str| match n {
            1 => format!("1 {what}"),
            n => format!("{n} {what}s"),
        };
        format!(
            "PASS: {} done; of {}, {} have every interval under 20 % of its error and {} every fit's noise under 10 % of its error (sample-count targets, findings rather than failures: results.json)",
            count(self.materials, "material"),
            count(maps.len(), "material-map"),
            met("interval_target_met"),
            met("noise_target_met")
        )
    }
}

/// Refuses an input inside the study folder (its outputs could overwrite it) and an
/// output folder that is a file.
fn check_paths(config: &StudyConfig, mats: &[StudyMaterial], envs: &[Env]) -> Result<(), Error> {
    if config.out.exists() && !config.out.is_dir() {
        return Err(Error::file(
            config.out.display(),
            "is a file; expected the study folder",
        ));
    }
    std::fs::create_dir_all(&config.out).map_err(|e| {
        Error::file(
            config.out.display(),
            format!("cannot create the study folder: {e}"),
        )
    })?;
    let root = std::fs::canonicalize(&config.out).unwrap_or(config.out.clone());
    let files = mats
        .iter()
        .filter_map(|m| match &m.source {
            Source::File(p) => Some(p.clone()),
            Source::Analytic(_) => None,
        })
        .chain(envs.iter().map(|e| PathBuf::from(&e.file)));
    for f in files {
        let abs = std::fs::canonicalize(&f).unwrap_or(f.clone());
        if abs.starts_with(&root) && !abs.starts_with(root.join("assets")) {
            return Err(Error::file(
                f.display(),
                format!(
                    "is inside the study folder {}; expected inputs outside it (the study writes there)",
                    config.out.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Runs the study: this shard's missing steps, then, if every material is complete, the
/// report (figures over all materials, the trade-off table, the pages). `stop` is polled
/// between steps and inside fits; once it returns true the run ends with an error saying
/// so, keeping every finished file and no partial one.
pub fn run(
    registry: &Registry,
    config: &StudyConfig,
    stop: &Stop<'_>,
    progress: &dyn StudyProgress,
) -> Result<StudySummary, Error> {
    let (i, n) = config.shard;
    if n == 0 || i >= n {
        return Err(Error::Other(format!(
            "--shard: expected I/N with 0 <= I < N, found {i}/{n}"
        )));
    }
    let mats = if config.inputs.is_empty() {
        builtin_materials()?
    } else {
        materials(&config.inputs)?
    };
    run_materials(registry, config, &mats, stop, progress)
}

/// A study folder set up for its materials: paths checked, maps resolved and digested,
/// settings recorded in DIR/study.json. Its steps run in any process that prepares the
/// same configuration ([`Prepared::run_step`]), which is how `lobe.distributed.study` runs
/// them as Dask tasks.
pub struct Prepared {
    pub config: StudyConfig,
    pub mats: Vec<StudyMaterial>,
    pub settings: Settings,
    pub envs: Vec<Env>,
    pub layout: steps::Layout,
}

/// What [`Prepared::run_step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepOutcome {
    Computed,
    AlreadyDone,
}

impl Prepared {
    pub fn new(config: &StudyConfig, mats: Vec<StudyMaterial>) -> Result<Self, Error> {
        if let Some(n) = config.error_spp.filter(|n| !ERROR_SPP_RANGE.contains(n)) {
            let (lo, hi) = ERROR_SPP_RANGE.into_inner();
            return Err(Error::Other(format!(
                "--error-spp: expected a mean of {lo} to {hi} samples per pixel, found {n}"
            )));
        }
        let settings = Settings::of(config);
        check_paths(config, &mats, &[])?;
        let envs = environments(config)?;
        check_paths(config, &mats, &envs)?;
        settings.record(&config.out, &envs)?;
        Ok(Self {
            layout: steps::Layout::new(&config.out),
            config: config.clone(),
            mats,
            settings,
            envs,
        })
    }

    /// The context the steps run in.
    pub fn context<'a>(&'a self, registry: &'a Registry, stop: &'a Stop<'a>) -> steps::Context<'a> {
        steps::Context {
            registry,
            settings: &self.settings,
            layout: &self.layout,
            envs: &self.envs,
            stop,
            digests: Default::default(),
        }
    }

    /// This shard's steps, material by material in name order, each material's in order.
    pub fn plan(&self) -> Vec<(&StudyMaterial, steps::Step)> {
        let (i, n) = self.config.shard;
        self.mats
            .iter()
            .enumerate()
            .filter(|(k, _)| k % n == i)
            .flat_map(|(_, m)| {
                steps::Step::all(self.envs.len())
                    .into_iter()
                    .map(move |s| (m, s))
            })
            .collect()
    }

    /// The material named `name`.
    pub fn material(&self, name: &str) -> Result<&StudyMaterial, Error> {
        self.mats
            .iter()
            .find(|m| m.name == name)
            .ok_or_else(|| Error::Other(format!("the study has no material named \"{name}\"")))
    }

    /// Runs one step unless it is done.
    pub fn run_step(
        &self,
        ctx: &steps::Context<'_>,
        m: &StudyMaterial,
        step: steps::Step,
    ) -> Result<StepOutcome, Error> {
        if step.done(ctx, m) {
            return Ok(StepOutcome::AlreadyDone);
        }
        step.run(ctx, m)?;
        Ok(StepOutcome::Computed)
    }

    /// Builds the report when every material that did not fail is complete; returns the
    /// materials still pending and the index page, if built.
    pub fn finish(
        &self,
        ctx: &steps::Context<'_>,
        failures: &[(String, String)],
    ) -> Result<(usize, Option<PathBuf>), Error> {
        let complete: Vec<StudyMaterial> = self
            .mats
            .iter()
            .filter(|m| !failures.iter().any(|(n, _)| *n == m.name))
            .cloned()
            .collect();
        let all = steps::Step::all(self.envs.len());
        let pending = complete
            .iter()
            .filter(|m| !all.iter().all(|s| s.done(ctx, m)))
            .count();
        let index = match pending == 0 && !complete.is_empty() {
            true => Some(site::build(ctx, &complete, failures)?),
            false => None,
        };
        Ok((pending, index))
    }
}

/// [`run`] on the given materials.
pub fn run_materials(
    registry: &Registry,
    config: &StudyConfig,
    mats: &[StudyMaterial],
    stop: &Stop<'_>,
    progress: &dyn StudyProgress,
) -> Result<StudySummary, Error> {
    let study = Prepared::new(config, mats.to_vec())?;
    let envs = &study.envs;
    let ctx = study.context(registry, stop);
    let plan = study.plan();
    progress.planned(plan.len());
    let mut summary = StudySummary {
        materials: mats.len(),
        ..Default::default()
    };
    for (m, step) in plan {
        let what = format!("{}: {}", m.name, step.describe(envs));
        if step.done(&ctx, m) {
            summary.skipped += 1;
            progress.finished(&what);
            continue;
        }
        if stop() {
            return Err(Error::Other(
                "interrupted: finished steps are kept; rerun to resume".into(),
            ));
        }
        if summary.failed(&m.name) {
            continue;
        }
        progress.began(&what);
        match step.run(&ctx, m) {
            Ok(()) => summary.computed += 1,
            // An interrupt stops the study; a material's own failure (a corrupt file)
            // skips that material's later steps and the study goes on with the others.
            Err(e) if stop() => return Err(e),
            Err(e) => summary.failures.push((m.name.clone(), e.to_string())),
        }
        progress.finished(&what);
    }
    (summary.pending, summary.index) = study.finish(&ctx, &summary.failures)?;
    Ok(summary)
}
