//! Numerical stability at the extremes. Every analytic model of the
//! registry is swept over its parameter box (each lobe parameter at its lower bound, or
//! 1e-4 above an open zero, a middle value and its upper bound capped at 1e6; every choice
//! of every setting) and over direction pairs including normal and grazing incidence (to
//! 89.99 degrees), wi = wo and wi = mirror(wo); the sampled-microfacet generator and the
//! measured readers (a MERL table, the RGL files if present, and MERL and binned tables of
//! extreme values: the largest accepted, denormal, zero, checkerboard peaks, mostly
//! missing, negative) over the same directions.
//! Counts per model: non-finite and negative values (of f32 and f64 evaluation, pdf and
//! sampling weights), reciprocity violations (models flagged reciprocal), energy violations
//! (directional albedo above 1 for models flagged energy-bounded) and f32/f64 disagreements.
//! Any non-finite or negative value is a failure ([`StabilityReport::failures`]).

use lobe_materials::composite::directional_albedo;
use lobe_materials::registry::{Bounds, ParamKind, ParamRole, Registry};
use lobe_materials::{Bsdf, Flags};
use lobe_renderer::Error;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// What to sweep.
#[derive(Clone, Debug, Default)]
pub struct StabilityConfig {
    /// Models to sweep (default: every analytic model, sampled-microfacet, merl,
    /// measured-extremes, rgl).
    pub models: Option<Vec<String>>,
    /// Fewer parameter values and directions (for CI).
    pub quick: bool,
    /// Folder of RGL .bsdf files (default: ../shared/data/rgl or $LOBE_DATA/rgl, if present).
    pub rgl: Option<PathBuf>,
}

/// The counts of every swept model, in sweep order.
#[derive(Clone, Debug)]
pub struct StabilityReport {
    pub rows: Vec<(String, Counts)>,
    /// True when "rgl" was wanted but no folder of RGL files was found.
    pub rgl_skipped: bool,
}

/// What a sweep found for one model.
#[derive(Default, Clone, Debug)]
pub struct Counts {
    /// Descriptions built and swept.
    pub configs: usize,
    /// Descriptions the model refused.
    pub rejected: usize,
    /// Direction pairs evaluated.
    pub evals: usize,
    /// Pairs with a non-finite value (f32 or f64 eval, pdf, sample weight or pdf).
    pub nonfinite: usize,
    /// Pairs with a negative value.
    pub negative: usize,
    /// Pairs violating reciprocity (models flagged reciprocal).
    pub reciprocity: usize,
    /// Directional albedos above 1 (models flagged energy-bounded).
    pub energy: usize,
    /// Pairs where f32 and f64 evaluation disagree.
    pub precision: usize,
    /// The first non-finite or negative case.
    pub example: Option<String>,
    /// The first reciprocity violation.
    pub reciprocity_example: Option<String>,
    /// The first directional albedo above 1.
    pub energy_example: Option<String>,
    /// The first f32/f64 disagreement.
    pub precision_example: Option<String>,
}

impl Counts {
    /// The first case of each kind found (failures first), for `--verbose`.
    pub fn examples(&self) -> impl Iterator<Item = &String> {
        [
            &self.example,
            &self.reciprocity_example,
            &self.energy_example,
            &self.precision_example,
        ]
        .into_iter()
        .flatten()
    }
}

fn dir(theta_deg: f64, phi_deg: f64) -> glam::Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    glam::Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
    .normalize()
}

fn pairs(quick: bool) -> Vec<(glam::Vec3, glam::Vec3)> {
    let thetas: &[f64] = if quick {
        &[0.0, 30.0, 75.0, 89.99]
    } else {
        &[
            0.0, 1e-3, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9, 89.99,
        ]
    };
    let phis: &[f64] = if quick {
        &[0.0, 100.0, 180.0]
    } else {
        &[0.0, 45.0, 90.0, 135.0, 180.0, 270.0, 333.0]
    };
    let dirs: Vec<glam::Vec3> = thetas
        .iter()
        .flat_map(|&t| phis.iter().map(move |&p| dir(t, p)))
        .collect();
    let mut out = Vec::new();
    for &wo in &dirs {
        for &wi in &dirs {
            out.push((wo, wi));
        }
        out.push((wo, wo));
        out.push((wo, glam::Vec3::new(-wo.x, -wo.y, wo.z)));
    }
    out
}

/// Values of one bounded parameter: the bounds (open zero -> 1e-4, upper capped at 1e6) and
/// a middle value.
fn values(b: &Bounds, quick: bool) -> Vec<f64> {
    let mut lo = b.min;
    if b.min_open {
        lo = if b.min == 0.0 {
            1e-4
        } else {
            b.min + 1e-4 * b.min.abs().max(1.0)
        };
    }
    let mut hi = b.max.min(1e6);
    if b.max_open {
        hi = hi - 1e-4 * hi.abs().max(1.0);
    }
    if !lo.is_finite() {
        lo = -1e6;
    }
    let mid = if lo > 0.0 {
        (lo * hi).sqrt()
    } else {
        0.5 * (lo + hi)
    };
    if quick {
        vec![lo, hi]
    } else {
        vec![lo, mid, hi]
    }
}

/// Every description of a model over its parameter box and settings.
fn descriptions(reg: &Registry, model: &str, quick: bool) -> Vec<Value> {
    let schema = reg.schema(model).expect("registered");
    let mut descs = vec![json!({"type": model, "diffuse": 0.0, "specular": 1.0})];
    for p in schema.params {
        let opts: Vec<Value> = match (p.role, p.kind) {
            (ParamRole::Lobe, ParamKind::Scalar | ParamKind::Integer) => values(&p.bounds, quick)
                .into_iter()
                .map(|v| json!(v))
                .collect(),
            (ParamRole::Setting, ParamKind::Choice(c)) => c.iter().map(|s| json!(s)).collect(),
            (ParamRole::Setting, ParamKind::Bool) => vec![json!(false), json!(true)],
            _ => continue,
        };
        descs = descs
            .into_iter()
            .flat_map(|d| {
                opts.iter().map(move |o| {
                    let mut d = d.clone();
                    d[p.name] = o.clone();
                    d
                })
            })
            .collect();
    }
    descs
}

/// `reciprocity`: check f(wo, wi) = f(wi, wo) here (the analytic models check it on their
/// f64 path instead, where grazing pairs do not lose the half vector to f32 cancellation).
fn check_bsdf(
    b: &dyn Bsdf,
    pairs: &[(glam::Vec3, glam::Vec3)],
    c: &mut Counts,
    what: &str,
    reciprocity: bool,
) {
    let bad = |v: f32| !v.is_finite();
    for (k, &(wo, wi)) in pairs.iter().enumerate() {
        c.evals += 1;
        let f = b.eval(wo, wi).to_array();
        let pdf = b.pdf(wo, wi);
        let u = glam::Vec2::new(
            ((k as f32) * 0.618_034).fract(),
            ((k as f32) * 0.754_877_7).fract(),
        );
        let s = b.sample(wo, u, ((k as f32) * 0.569_84).fract());
        let mut vals: Vec<f32> = f.to_vec();
        vals.push(pdf);
        if let Some(s) = &s {
            vals.extend(s.weight.to_array());
            vals.push(s.pdf);
        }
        if vals.iter().any(|v| bad(*v)) {
            c.nonfinite += 1;
            c.example
                .get_or_insert_with(|| format!("{what}: non-finite at wo {wo}, wi {wi}: {vals:?}"));
        } else if vals.iter().any(|v| *v < 0.0) {
            c.negative += 1;
            c.example
                .get_or_insert_with(|| format!("{what}: negative at wo {wo}, wi {wi}: {vals:?}"));
        }
        if reciprocity && b.flags().contains(Flags::RECIPROCAL) {
            let g = b.eval(wi, wo).to_array();
            let m = f.iter().chain(&g).fold(0.0f32, |a, x| a.max(x.abs()));
            if (0..3).any(|i| (f[i] - g[i]).abs() > 1e-3 * m + 1e-6) {
                c.reciprocity += 1;
                c.reciprocity_example.get_or_insert_with(|| {
                    format!("{what}: f(wo, wi) = {f:?}, f(wi, wo) = {g:?} at wo {wo}, wi {wi}")
                });
            }
        }
    }
}

fn sweep_lobe_model(
    reg: &Registry,
    model: &str,
    quick: bool,
    pairs: &[(glam::Vec3, glam::Vec3)],
) -> Counts {
    let mut c = Counts::default();
    for d in descriptions(reg, model, quick) {
        let Ok((_, lobe)) = reg.create_lobe(&d, "sweep") else {
            c.rejected += 1;
            continue;
        };
        let Ok(b) = reg.create(&d, "sweep") else {
            c.rejected += 1;
            continue;
        };
        c.configs += 1;
        let what = d.to_string();
        check_bsdf(b.as_ref(), pairs, &mut c, &what, false);
        // f64 path: finite, non-negative, reciprocal where flagged, agreeing with f32.
        let reciprocal = lobe.flags().contains(Flags::RECIPROCAL);
        for &(wo, wi) in pairs {
            let a = lobe.eval(wo, wi).to_array();
            let b64 = lobe.eval_f64(wo.as_dvec3(), wi.as_dvec3());
            if reciprocal {
                let g = lobe.eval_f64(wi.as_dvec3(), wo.as_dvec3());
                let m = b64.iter().chain(&g).fold(0.0f64, |x, y| x.max(y.abs()));
                if (0..3).any(|i| (b64[i] - g[i]).abs() > 1e-4 * m + 1e-12) {
                    c.reciprocity += 1;
                    c.reciprocity_example.get_or_insert_with(|| {
                        format!(
                            "{what}: f64 f(wo, wi) = {b64:?}, f(wi, wo) = {g:?} at wo {wo}, wi {wi}"
                        )
                    });
                }
            }
            if b64.iter().any(|v| !v.is_finite()) {
                c.nonfinite += 1;
                c.example
                    .get_or_insert_with(|| format!("{what}: f64 non-finite at wo {wo}, wi {wi}"));
            } else if b64.iter().any(|v| *v < 0.0) {
                c.negative += 1;
                c.example.get_or_insert_with(|| {
                    format!("{what}: f64 negative at wo {wo}, wi {wi}: {b64:?}")
                });
            }
            if (0..3).any(|i| {
                let (x, y) = (a[i] as f64, b64[i]);
                (x - y).abs() > 1e-3 * y.abs().max(1e-3)
            }) {
                c.precision += 1;
                c.precision_example.get_or_insert_with(|| {
                    format!("{what}: f32 {a:?} against f64 {b64:?} at wo {wo}, wi {wi}")
                });
            }
        }
        if lobe.flags().contains(Flags::ENERGY_BOUNDED) {
            for t in [0.0, 45.0, 80.0, 89.0] {
                let albedo =
                    directional_albedo(lobe.as_ref(), dir(t, 10.0), if quick { 16 } else { 32 });
                if albedo > 1.02 {
                    c.energy += 1;
                    c.energy_example.get_or_insert_with(|| {
                        format!("{what}: directional albedo {albedo:.4} at theta_o {t} degrees")
                    });
                }
            }
        }
    }
    c
}

fn sweep_materials(
    reg: &Registry,
    descs: &[Value],
    base: &std::path::Path,
    pairs: &[(glam::Vec3, glam::Vec3)],
) -> Counts {
    let ctx = lobe_materials::registry::BuildContext::new(base, reg);
    let mut c = Counts::default();
    for d in descs {
        match reg.create_with(d, "sweep", &ctx) {
            Ok(b) => {
                c.configs += 1;
                check_bsdf(b.as_ref(), pairs, &mut c, &d.to_string(), true);
            }
            Err(_) => c.rejected += 1,
        }
    }
    c
}

/// MERL and binned tables of extreme values (as measured readers accept them): every bin
/// at the largest accepted value (MAX_VALUE), denormal, zero, a checkerboard of the largest
/// value and zero (the sharpest possible peaks), mostly missing, and for binned data
/// negative bins too; both MERL lookups.
fn extreme_tables(dir: &std::path::Path, quick: bool) -> Result<Vec<Value>, Error> {
    use lobe_materials::measured::MAX_VALUE;
    use lobe_materials::measured::binned::{Axis, Binned};
    use lobe_materials::measured::merl::Merl;
    type Fill = fn(usize) -> Option<[f64; 3]>;
    let mut fills: Vec<(&str, Fill)> = vec![
        ("max", |_| Some([MAX_VALUE; 3])),
        ("checker", |k| {
            Some([if k % 2 == 0 { MAX_VALUE } else { 0.0 }; 3])
        }),
    ];
    if !quick {
        fills.extend([
            ("denormal", (|_| Some([1e-41; 3])) as Fill),
            ("zero", |_| Some([0.0; 3])),
            ("sparse", |k| {
                (k % 97 == 0).then_some([MAX_VALUE, 1.0, 1e-41])
            }),
            ("negative", |k| {
                Some([if k % 3 == 0 { -MAX_VALUE } else { MAX_VALUE }, -1.0, 0.5])
            }),
        ]);
    }
    let to_err = |path: &std::path::Path, e: lobe_materials::FileError| {
        Error::file(path.display(), e.message)
    };
    let mut descs = Vec::new();
    for (name, fill) in fills {
        if name != "negative" {
            // MERL stores no negative values (they mark missing samples).
            let path = dir.join(format!("extreme-{name}.binary"));
            Merl::from_fn(|_, _, (a, b, c)| fill(a + b + c))
                .write(&path)
                .map_err(|e| to_err(&path, e))?;
            for interp in [true, false] {
                descs.push(json!({"type": "merl", "file": path.display().to_string(), "interpolate": interp}));
            }
        }
        let mut t = Binned::empty(
            false,
            vec![
                Axis::new(18, 0.0, 90.0),
                Axis::new(18, 0.0, 90.0),
                Axis::new(36, 0.0, 180.0),
            ],
        );
        for k in 0..t.len() {
            let b = t.unindex(k);
            t.values[k] = fill(b.iter().sum()).map(|v| v.map(|x| x as f32));
        }
        let path = dir.join(format!("extreme-{name}.bin"));
        t.write(&path).map_err(|e| to_err(&path, e))?;
        descs.push(json!({"type": "binned", "file": path.display().to_string()}));
    }
    Ok(descs)
}

/// The names [`sweep`] accepts: every lobe model, sampled-microfacet, merl and rgl.
fn known_models(reg: &Registry) -> Vec<&'static str> {
    reg.names()
        .filter(|n| reg.is_lobe_model(n))
        .chain(["sampled-microfacet", "merl", "rgl"])
        .collect()
}

/// Sweeps the models of `config` (see the module doc); an unknown model name is an error
/// listing the known ones.
pub fn sweep(reg: &Registry, config: &StabilityConfig) -> Result<StabilityReport, Error> {
    let pairs = pairs(config.quick);
    let wanted = config.models.as_ref();
    let want = |n: &str| wanted.is_none_or(|w| w.iter().any(|x| x == n));
    let known = known_models(reg);
    if let Some(unknown) = wanted
        .into_iter()
        .flatten()
        .find(|w| !known.contains(&w.as_str()))
    {
        return Err(Error::Other(format!(
            "--models: unknown model \"{unknown}\"; expected one of: {}",
            known.join(", ")
        )));
    }
    let mut rows: Vec<(String, Counts)> = Vec::new();
    for m in reg.names().filter(|n| reg.is_lobe_model(n)) {
        if want(m) {
            rows.push((
                m.to_string(),
                sweep_lobe_model(reg, m, config.quick, &pairs),
            ));
        }
    }
    if want("sampled-microfacet") {
        rows.push((
            "sampled-microfacet".into(),
            sweep_materials(reg, &microfacet_descriptions(), Path::new("."), &pairs),
        ));
    }
    let tmp = tempfile::tempdir().map_err(|e| Error::Other(format!("temporary folder: {e}")))?;
    if want("merl") {
        let descs = merl_tables(reg, tmp.path())?;
        rows.push((
            "merl".into(),
            sweep_materials(reg, &descs, tmp.path(), &pairs),
        ));
    }
    if want("measured-extremes") {
        let descs = extreme_tables(tmp.path(), config.quick)?;
        rows.push((
            "measured-extremes".into(),
            sweep_materials(reg, &descs, tmp.path(), &pairs),
        ));
    }
    let mut rgl_skipped = false;
    if want("rgl") {
        match rgl_folder(config) {
            Some(f) => {
                let descs = rgl_files(&f)?;
                rows.push(("rgl".into(), sweep_materials(reg, &descs, &f, &pairs)));
            }
            None => rgl_skipped = true,
        }
    }
    Ok(StabilityReport { rows, rgl_skipped })
}

/// The sampled-microfacet generator: Beckmann tables from sharp to rough, isotropic and
/// not, with and without Fresnel, and the synthetic structures.
fn microfacet_descriptions() -> Vec<Value> {
    let mut descs = Vec::new();
    for (ax, ay) in [(0.01, 0.01), (0.01, 2.0), (2.0, 2.0)] {
        for f0 in [0.0, 1.0] {
            descs.push(json!({"type": "sampled-microfacet", "distribution": "beckmann", "alpha_x": ax, "alpha_y": ay, "f0": f0, "specular": 1, "resolution": 65}));
        }
    }
    for d in ["brushed", "satin", "velvet"] {
        descs.push(json!({"type": "sampled-microfacet", "distribution": d, "specular": 1, "resolution": 65}));
    }
    descs
}

/// A sharp and a rough tabulated Cook-Torrance (written into `dir`), both interpolated and
/// nearest.
fn merl_tables(reg: &Registry, dir: &Path) -> Result<Vec<Value>, Error> {
    let mut descs = Vec::new();
    for (k, m) in [0.01, 0.8].iter().enumerate() {
        let ct = reg
            .create(
                &json!({"type": "cook-torrance", "diffuse": 0.1, "specular": 1, "m": m}),
                "m",
            )
            .map_err(|e| Error::Other(e.to_string()))?;
        let path = dir.join(format!("t{k}.binary"));
        lobe_materials::measured::tabulate::merl_from(
            &|wo, wi| ct.eval(wo, wi),
            &Default::default(),
        )
        .write(&path)
        .map_err(|e| Error::file(path.display(), e.message))?;
        for interp in [true, false] {
            descs.push(
                json!({"type": "merl", "file": path.display().to_string(), "interpolate": interp}),
            );
        }
    }
    Ok(descs)
}

/// The folder of RGL files: the configured one, else $LOBE_DATA/rgl or ../shared/data/rgl
/// if it exists.
fn rgl_folder(config: &StabilityConfig) -> Option<PathBuf> {
    config.rgl.clone().or_else(|| {
        std::env::var_os("LOBE_DATA")
            .map(|d| PathBuf::from(d).join("rgl"))
            .or_else(|| Some(PathBuf::from("../shared/data/rgl")))
            .filter(|p| p.is_dir())
    })
}

/// The descriptions of the .bsdf files of a folder, sorted.
fn rgl_files(folder: &Path) -> Result<Vec<Value>, Error> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(folder)
        .map_err(|e| Error::file(folder.display(), format!("cannot list: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "bsdf"))
        .map(|p| std::fs::canonicalize(&p).unwrap_or(p))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::file(
            folder.display(),
            "no .bsdf file; expected a folder of RGL measured BRDFs (--rgl)",
        ));
    }
    Ok(files
        .iter()
        .map(|p| json!({"type": "rgl", "file": p.display().to_string()}))
        .collect())
}

impl StabilityReport {
    /// The Markdown table's header (two lines, no final newline).
    pub const HEADER: &'static str = "| model | configurations | rejected | evaluations | non-finite | negative | reciprocity | energy | f32/f64 |\n|---|---|---|---|---|---|---|---|---|";

    /// One model's row of the Markdown table.
    pub fn row(name: &str, c: &Counts) -> String {
        format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} |",
            c.configs,
            c.rejected,
            c.evals,
            c.nonfinite,
            c.negative,
            c.reciprocity,
            c.energy,
            c.precision
        )
    }

    /// The sweep's verdict as one line: PASS or FAIL (a non-finite or negative value is a
    /// failure), saying which columns are failures and which are findings.
    pub fn verdict(&self) -> String {
        let evals: usize = self.rows.iter().map(|(_, c)| c.evals).sum();
        let failed = self.failures();
        let findings: usize = self
            .rows
            .iter()
            .map(|(_, c)| c.reciprocity + c.energy + c.precision)
            .sum();
        let head = match failed.is_empty() {
            true => format!(
                "PASS: no non-finite or negative value in {evals} evaluations of {} models",
                self.rows.len()
            ),
            false => format!(
                "FAIL: non-finite or negative values, or nothing swept, in {} of {} models",
                failed.len(),
                self.rows.len()
            ),
        };
        format!(
            "{head}; the reciprocity, energy and f32/f64 columns ({findings} in all) are findings to read, not failures"
        )
    }

    /// The models with non-finite or negative values, each with its first example, and
    /// those of which nothing was swept (every description refused).
    pub fn failures(&self) -> Vec<String> {
        self.rows
            .iter()
            .filter_map(|(name, c)| {
                if c.nonfinite + c.negative > 0 {
                    Some(format!(
                        "{name} ({})",
                        c.example.clone().unwrap_or_default()
                    ))
                } else if c.evals == 0 {
                    Some(format!(
                        "{name} (nothing swept: {} descriptions refused)",
                        c.rejected
                    ))
                } else {
                    None
                }
            })
            .collect()
    }
}
