//! The steps of a study, per material (see [`super`]): where each writes
//! ([`Layout`]), when it is done (its last file exists and records the step's content key:
//! the digest of the material's data, of the environment map and of the settings,
//! [`lobe_materials::key`]) and how it runs: the fits with
//! selection (Ngan et al. section 4), the microfacet estimate (section 5), the sphere
//! images under one environment map with image errors, intervals and equal-time errors
//! (Figures 3 and 6), the polar and lobe plots (Figures 4, 7, 8).

use super::{Env, Settings, StudyMaterial};
use crate::convergence;
use crate::cost::measure;
use crate::figures;
use crate::fit_images::FitEnvironment;
use crate::fitting::{FitOptions, Resume, complete_report};
use crate::sphere_errors::{self, RepError, Stage};
use lobe_materials::Bsdf;
use lobe_materials::fit::report::{self, FitKey, FitReport};
use lobe_materials::fit::{ANISOTROPIC_DEFAULT, Stop, builtin_specs};
use lobe_materials::key::KeyBuilder;
use lobe_materials::microfacet_gen::estimate;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_renderer::Error;
use lobe_renderer::compare::flip_heatmap;
use lobe_renderer::film::{Image, tonemap, write_json};
use lobe_renderer::image_io::{write_exr, write_png_rgb8};
use lobe_renderer::scene::{LoadOptions, from_value};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The files of a study folder.
#[derive(Clone, Debug)]
pub struct Layout {
    pub root: PathBuf,
}

impl Layout {
    pub fn new(root: &Path) -> Self {
        Self {
            root: root.to_path_buf(),
        }
    }

    /// A path under the root, created folder and all.
    fn at(&self, rel: &str) -> PathBuf {
        self.root.join(rel)
    }

    pub fn fit(&self, m: &str) -> PathBuf {
        self.at(&format!("fits/{m}.fit.json"))
    }

    /// The microfacet estimate's file with extension `ext` (exr: the table, png: its
    /// picture, json: its error, material and costs).
    pub fn microfacet(&self, m: &str, ext: &str) -> PathBuf {
        self.at(&format!("microfacet/{m}.{ext}"))
    }

    /// The renders of material `m` under environment `env`, relative to the root.
    pub fn renders_rel(m: &str, env: &str) -> String {
        format!("renders/{m}/{env}")
    }

    pub fn renders(&self, m: &str, env: &str) -> PathBuf {
        self.at(&Self::renders_rel(m, env))
    }

    /// A figure (PNG; charts also SVG) relative to the root.
    pub fn figure_rel(name: &str) -> String {
        format!("figures/{name}.png")
    }

    pub fn figure(&self, name: &str) -> PathBuf {
        self.at(&Self::figure_rel(name))
    }

    /// The polar plot of `m` at incidence `angle`, and its lobe plot (names).
    pub fn polar_name(m: &str, angle: f64) -> String {
        format!("{m}-polar-{angle:.0}")
    }

    pub fn lobes_name(m: &str, angle: f64) -> String {
        format!("{m}-lobes-{angle:.0}")
    }

    /// The record of a material's plots (their names and key), written after them.
    pub fn plots_record(&self, m: &str) -> PathBuf {
        self.at(&format!("figures/{m}-plots.json"))
    }
}

/// What every step needs.
pub struct Context<'a> {
    pub registry: &'a Registry,
    pub settings: &'a Settings,
    pub layout: &'a Layout,
    pub envs: &'a [Env],
    pub stop: &'a Stop<'a>,
    /// The digests of the materials' data, computed once per run.
    pub digests: Digests,
}

/// The digest of each material's data (its file's bytes, or its description), made the
/// first time a step asks; a file that cannot be read has none (its steps are never done,
/// and the fit step reports the error).
#[derive(Default)]
pub struct Digests(std::sync::Mutex<std::collections::BTreeMap<String, Option<String>>>);

impl Digests {
    fn of(&self, m: &StudyMaterial) -> Option<String> {
        let mut cache = self.0.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(m.name.clone())
            .or_insert_with(|| m.digest().ok())
            .clone()
    }
}

impl Context<'_> {
    /// Builds a material description (relative files resolve against the study folder).
    pub fn build(&self, desc: &Value, name: &str) -> Result<Arc<dyn Bsdf>, Error> {
        self.registry
            .create_with(
                desc,
                name,
                &BuildContext::new(&self.layout.root, self.registry),
            )
            .map_err(|e| Error::Other(format!("{name}: {e}")))
    }

    fn interrupted(&self) -> Result<(), Error> {
        match (self.stop)() {
            true => Err(Error::Other(
                "interrupted: finished steps are kept; rerun to resume".into(),
            )),
            false => Ok(()),
        }
    }
}

/// One step of one material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    Fit,
    Microfacet,
    /// The renders under the k-th environment map.
    Renders(usize),
    Plots,
}

/// Creates the folder of `path`.
fn parent_dir(path: &Path) -> Result<(), Error> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::file(dir.display(), format!("cannot create: {e}")))
}

impl Step {
    /// Every step of a material, in order, with `envs` environment maps.
    pub fn all(envs: usize) -> Vec<Step> {
        let mut v = vec![Step::Fit, Step::Microfacet];
        v.extend((0..envs).map(Step::Renders));
        v.push(Step::Plots);
        v
    }

    /// The step's name: `fit`, `microfacet`, `renders/K` (K the map's index) or `plots`.
    pub fn name(&self) -> String {
        match self {
            Step::Fit => "fit".into(),
            Step::Microfacet => "microfacet".into(),
            Step::Renders(k) => format!("renders/{k}"),
            Step::Plots => "plots".into(),
        }
    }

    /// The step named `name` ([`Step::name`]) of a study of `envs` maps.
    pub fn parse(name: &str, envs: usize) -> Result<Step, Error> {
        Step::all(envs)
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| {
                Error::Other(format!(
                    "step \"{name}\": expected fit, microfacet, renders/K (K below {envs}) or plots"
                ))
            })
    }

    /// The steps whose outputs this one reads.
    pub fn after(&self) -> Vec<Step> {
        match self {
            Step::Fit | Step::Microfacet => Vec::new(),
            Step::Renders(_) => vec![Step::Fit, Step::Microfacet],
            Step::Plots => vec![Step::Fit],
        }
    }

    pub fn describe(&self, envs: &[Env]) -> String {
        match self {
            Step::Fit => "fits".into(),
            Step::Microfacet => "microfacet estimate".into(),
            Step::Renders(k) => format!("renders under {}", envs[*k].name),
            Step::Plots => "polar and lobe plots".into(),
        }
    }

    /// The file a step writes last: it is done when that exists.
    fn last_file(&self, ctx: &Context<'_>, m: &StudyMaterial) -> PathBuf {
        let l = ctx.layout;
        match self {
            Step::Fit => l.fit(&m.name),
            Step::Microfacet => l.microfacet(&m.name, "json"),
            Step::Renders(k) => l.renders(&m.name, &ctx.envs[*k].name).join("metrics.json"),
            Step::Plots => l.plots_record(&m.name),
        }
    }

    /// The step's content key: what its outputs were made from. None when the data
    /// cannot be read.
    pub fn key(&self, ctx: &Context<'_>, m: &StudyMaterial) -> Option<String> {
        let data = ctx.digests.of(m)?;
        let settings = ctx.settings.to_json();
        let k = KeyBuilder::new("study-step")
            .text("data", &data)
            .json("settings", &settings);
        Some(match self {
            Step::Fit => fit_options(ctx.settings, false).key(data).ok()?.settings,
            Step::Microfacet => k.text("step", "microfacet").finish(),
            Step::Renders(e) => k
                .text("step", "renders")
                .text("environment", &ctx.envs[*e].digest)
                .text(
                    "estimate",
                    &crate::sphere_errors::form(&ctx.settings.error_settings()),
                )
                .finish(),
            Step::Plots => k.text("step", "plots").finish(),
        })
    }

    /// Done when its last file exists and records the step's key (a fit report: every
    /// model of the same data and settings, and a selection).
    pub fn done(&self, ctx: &Context<'_>, m: &StudyMaterial) -> bool {
        let last = self.last_file(ctx, m);
        let Some(key) = self.key(ctx, m) else {
            return false;
        };
        match self {
            Step::Fit => {
                let Some(r) = crate::fitting::existing_report(&last) else {
                    return false;
                };
                let want = FitKey {
                    data: ctx.digests.of(m).unwrap_or_default(),
                    settings: key,
                };
                let opts = fit_options(ctx.settings, r.anisotropic);
                crate::fitting::resume(Some(&r), &want, &opts).ok() == Some(Resume::Done)
            }
            _ => recorded_key(&last).as_deref() == Some(key.as_str()),
        }
    }

    pub fn run(&self, ctx: &Context<'_>, m: &StudyMaterial) -> Result<(), Error> {
        parent_dir(&self.last_file(ctx, m))?;
        let key = || {
            self.key(ctx, m).ok_or_else(|| {
                m.digest()
                    .err()
                    .unwrap_or_else(|| Error::Other(format!("{}: no content key", m.name)))
            })
        };
        match self {
            Step::Fit => fit(ctx, m),
            Step::Microfacet => microfacet(ctx, m, &key()?),
            Step::Renders(k) => renders(ctx, m, &ctx.envs[*k], &key()?),
            Step::Plots => plots(ctx, m, &key()?),
        }
    }
}

/// The `key` a step's JSON file records, if it reads.
fn recorded_key(path: &Path) -> Option<String> {
    let v = lobe_materials::json::read(path).ok()?;
    v.get("key")?.as_str().map(str::to_string)
}

/// The models fitted to data: the configured list (with anisotropic Ward added for 4D
/// data), or every applicable one: for isotropic data every model but the anisotropic
/// ones (the study's seven, the two-lobe and the distribution and Fresnel variants), for
/// anisotropic data the anisotropic ones and the isotropic defaults.
pub fn models_for(settings: &Settings, anisotropic: bool) -> String {
    let specs = builtin_specs();
    match (&settings.models, anisotropic) {
        (Some(list), false) => list.clone(),
        (Some(list), true) => format!("{list},ward-anisotropic"),
        (None, false) => specs
            .iter()
            .map(|s| s.label)
            .filter(|l| !ANISOTROPIC_DEFAULT.contains(l))
            .collect::<Vec<_>>()
            .join(","),
        (None, true) => {
            let mut v: Vec<&str> = ANISOTROPIC_DEFAULT.to_vec();
            v.extend(lobe_materials::fit::ISOTROPIC_DEFAULT);
            v.join(",")
        }
    }
}

/// The fit options of the study's settings, for isotropic or anisotropic data.
fn fit_options(s: &Settings, anisotropic: bool) -> FitOptions {
    FitOptions {
        models: Some(models_for(s, anisotropic)),
        resolution: s.resolution,
        max_evals: s.max_evals,
        select: Some(s.tolerance),
        ..Default::default()
    }
}

/// Fits every model and selects the cheapest adequate one (fits/NAME.fit.json); a report
/// of the same key keeps its models and gets only those it lacks.
fn fit(ctx: &Context<'_>, m: &StudyMaterial) -> Result<(), Error> {
    let s = ctx.settings;
    let data = m.dataset(ctx.registry, s.resolution)?;
    let opts = fit_options(s, data.anisotropic);
    let key = opts.key(m.digest()?)?;
    let path = ctx.layout.fit(&m.name);
    let existing = crate::fitting::existing_report(&path);
    let plan = crate::fitting::resume(existing.as_ref(), &key, &opts)?;
    let source = m.source_text();
    let r = complete_report(
        ctx.registry,
        (existing, plan, key),
        (&m.name, &source),
        (&data, None),
        &opts,
        ctx.stop,
        &|_| {},
    )?;
    ctx.interrupted()?;
    Ok(report::write(&path, &r)?)
}

/// Cost and memory of a material, as JSON.
fn cost_json(b: &dyn Bsdf) -> Value {
    let c = measure(b);
    json!({"eval_ns": c.eval_ns, "sample_ns": c.sample_ns, "memory_bytes": b.memory_bytes()})
}

/// The microfacet distribution estimated from the data (section 5): its table (EXR), its
/// picture (PNG) and its error, material and the costs of it and of the measured data.
fn microfacet(ctx: &Context<'_>, m: &StudyMaterial, key: &str) -> Result<(), Error> {
    let s = ctx.settings;
    let data = m.dataset(ctx.registry, s.resolution)?;
    let est = estimate(&data, s.microfacet_nodes, None, s.microfacet_iterations)
        .map_err(|e| Error::file(m.source_text(), e))?;
    ctx.interrupted()?;
    let l = ctx.layout;
    est.table.write_exr(&l.microfacet(&m.name, "exr"))?;
    let title = format!("{}: estimated distribution of normals", m.name);
    let top = figures::distribution_top(&[&est.table]);
    figures::distribution(&title, &est.table, top)?.save(&l.microfacet(&m.name, "png"))?;
    let desc = est.material(&format!("microfacet/{}.exr", m.name));
    let measured = ctx.build(&m.desc()?, &m.name)?;
    let micro = ctx.build(&desc, "sampled-microfacet")?;
    let v = json!({
        "key": key,
        "error": est.error,
        "error_normalized": est.error / data.max_albedo.max(1e-300),
        "material": desc,
        "costs": {
            "measured": cost_json(measured.as_ref()),
            "sampled-microfacet": cost_json(micro.as_ref()),
        },
    });
    write_json(&l.microfacet(&m.name, "json"), &v)
}

/// The representations of a material: the measured data, every fit of its report (in
/// label order) and the estimated microfacet distribution.
pub fn representations(
    ctx: &Context<'_>,
    m: &StudyMaterial,
) -> Result<Vec<(String, Value)>, Error> {
    let r = report::read(&ctx.layout.fit(&m.name))?;
    let mut v = vec![("measured".to_string(), m.desc()?)];
    v.extend(
        r.models
            .iter()
            .map(|(k, f)| (k.clone(), f.material.clone())),
    );
    let micro = lobe_materials::json::read(&ctx.layout.microfacet(&m.name, "json"))?;
    v.push(("sampled-microfacet".into(), micro["material"].clone()));
    Ok(v)
}

/// Writes an image as EXR and, at `exposure` stops, as PNG (`stem`.exr, `stem`.png).
fn save_image(img: &Image, stem: &Path, exposure: f32) -> Result<(), Error> {
    let (w, h) = (img.width, img.height);
    write_exr(&stem.with_extension("exr"), w, h, &img.pixels)?;
    write_png_rgb8(
        &stem.with_extension("png"),
        w,
        h,
        &tonemap(&img.pixels, exposure),
    )
}

/// An error with its interval as JSON.
fn error_json(e: &RepError) -> Value {
    json!({"rmse": e.rmse, "ci95": e.ci95, "noise": e.noise, "flip": e.flip,
           "negligible": e.negligible, "own_samples": e.own_samples,
           "pass": e.pass, "spp": e.spp})
}

/// The renders under one environment map ([`crate::sphere_errors`]): every representation's
/// converged sphere image from common random numbers (EXR, PNG at the common exposure,
/// FLIP map against the data's image) with its error, interval and the noise floor; then
/// each representation's speed/accuracy curve ([`crate::convergence`]) and its error at
/// equal time: in the time the measured data's render takes at the study's spp.
/// metrics.json last.
fn renders(ctx: &Context<'_>, m: &StudyMaterial, env: &Env, key: &str) -> Result<(), Error> {
    let s = ctx.settings;
    let dir = ctx.layout.renders(&m.name, &env.name);
    let reps = representations(ctx, m)?;
    let built: Vec<Arc<dyn Bsdf>> = reps
        .iter()
        .map(|(name, desc)| ctx.build(desc, name))
        .collect::<Result<_, _>>()?;
    let map = FitEnvironment::load(&env.file)?;
    let stage = Stage::sphere(&map.0, s.size);
    let refs: Vec<&dyn Bsdf> = built.iter().map(|b| b.as_ref()).collect();
    let est = sphere_errors::estimate(&stage, &refs, &s.error_settings())?;
    ctx.interrupted()?;
    for (k, (name, _)) in reps.iter().enumerate() {
        save_image(&est.images[k], &dir.join(name), est.exposure)?;
        let heat = flip_heatmap(&est.flip_maps[k], s.size, s.size);
        write_png_rgb8(&dir.join(format!("{name}-flip.png")), s.size, s.size, &heat)?;
    }
    let mut scene = from_value(
        &stage.scene_json(&env.file, s.spp),
        "study-sphere",
        &ctx.layout.root,
        &LoadOptions::with_builtins(),
    )?;
    let mut curves = Vec::new();
    for (b, img) in built.iter().zip(&est.images) {
        ctx.interrupted()?;
        curves.push(convergence::measure(&mut scene, b, img)?);
    }
    let budget = curves[0].seconds(s.spp as f64);
    let rows: Vec<Value> = reps
        .iter()
        .zip(&est.errors)
        .zip(&curves)
        .enumerate()
        .map(|(k, (((name, _), e), c))| {
            // The data's render converges to itself: its error at equal time is noise.
            let bias = |x: f64| if k == 0 { 0.0 } else { x };
            let spp = c.spp_in(budget);
            json!({
                "name": name, "error": error_json(e),
                "equal_time": {
                    "spp": spp, "rmse": c.rmse(spp, bias(e.rmse)),
                    "ci95": [c.rmse(spp, bias(e.ci95[0])), c.rmse(spp, bias(e.ci95[1]))],
                },
                "curve": {"v": c.v, "beta": c.beta, "seconds_fixed": c.a,
                          "seconds_per_spp": c.c, "spread": c.spread,
                          "points": c.points.iter().map(|p| json!({"spp": p.0, "seconds": p.1, "noise": p.2})).collect::<Vec<_>>()},
            })
        })
        .collect();
    let v = json!({
        "key": key, "environment": env.name, "size": s.size, "spp": est.spp, "spp_max": est.spp_max, "passes": est.passes,
        "batches": est.batches, "noise_floor": est.noise_floor,
        "exposure": est.exposure, "noise_target_met": est.noise_target_met,
        "interval_target_met": est.interval_target_met,
        "equal_time_budget": {"spp": s.spp, "seconds": budget}, "rows": rows,
    });
    write_json(&dir.join("metrics.json"), &v)
}

/// The fits drawn in a material's plots: the `k` lowest-error ones, in error order (not
/// the selected one: selection depends on timings, plots only on the data).
pub fn headline_fits(r: &FitReport, k: usize) -> Vec<String> {
    let mut v: Vec<(&String, f64)> = r.models.iter().map(|(n, f)| (n, f.error)).collect();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
    v.into_iter().take(k).map(|(n, _)| n.clone()).collect()
}

/// Polar plots and lobe contour plots (green channel) at each of the
/// study's incidence angles, of the data and of its headline fits.
fn plots(ctx: &Context<'_>, m: &StudyMaterial, key: &str) -> Result<(), Error> {
    let r = report::read(&ctx.layout.fit(&m.name))?;
    let measured = ctx.build(&m.desc()?, &m.name)?;
    let mut fits = Vec::new();
    for name in headline_fits(&r, 4) {
        fits.push((name.clone(), ctx.build(&r.models[&name].material, &name)?));
    }
    let mut panels = vec![("measured".to_string(), measured.clone())];
    panels.extend(fits.iter().take(3).cloned());
    for &a in &ctx.settings.angles {
        ctx.interrupted()?;
        figures::polar(&m.name, measured.as_ref(), &fits, a, 1)?
            .save(&ctx.layout.figure(&Layout::polar_name(&m.name, a)))?;
    }
    for &a in &ctx.settings.angles {
        ctx.interrupted()?;
        figures::lobe_contours(&m.name, &panels, a, 1)?
            .save(&ctx.layout.figure(&Layout::lobes_name(&m.name, a)))?;
    }
    let names: Vec<String> = ctx
        .settings
        .angles
        .iter()
        .flat_map(|&a| {
            [
                Layout::polar_name(&m.name, a),
                Layout::lobes_name(&m.name, a),
            ]
        })
        .collect();
    write_json(
        &ctx.layout.plots_record(&m.name),
        &json!({"key": key, "figures": names}),
    )
}
