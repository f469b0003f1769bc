//! The published fits of Ngan, Durand and Matusik 2005 for the MERL materials, as
//! transcribed by the BSDF benchmark project (bbm `fits/ngan_<model>.fit`, one file per
//! model, one line per material:
//! `name = Aggregate(Lambertian(albedo = [r, g, b]), NganXxx(albedo = [r, g, b], key = value, ...))`).
//!
//! The material `{"type": "ngan-fit", "material": "green-metallic-paint", "model": "cook-torrance"}`
//! reads the line and builds the model through the registry of its build context, with the
//! conventions the fits were made with (docs/models.md), which each model declares next to
//! its schema ([`crate::schema::PublishedFit`]): Ward/Ward-Duer `roughness` = alpha;
//! Blinn-Phong `sharpness` = n (half-vector form); Lafortune `Cxy`, `Cz`, `sharpness` with
//! Ngan's normalization; Cook-Torrance Beckmann `roughness` = m, Schlick with F0 = `eta`,
//! divided by pi; Ashikhmin-Shirley `sharpness` = n, `fresnelReflectance` = Rs; He
//! `roughness` = sigma0, `autocorrelation` = tau (micrometres), real `eta`.
//!
//! Colours: Ngan's colours are in MERL units of 1/1500 for all three channels (the data
//! README's measurement); `channel_scale: "merl"` (the default) multiplies green by 1.15 and
//! blue by 1.66 so that the fit renders beside MERL-scaled measurements, `"none"` keeps the
//! published numbers.

use crate::analytic::common::setting;
use crate::registry::{
    Bounds, BuildContext, DefaultValue, ModelSchema, ParamKind, ParamRole, ParamSpec, Params,
    Registry,
};
use crate::schema::{LobeModel, PublishedFit};
use crate::{Bsdf, ParamError};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How many of the analytic models declare published fits.
const PUBLISHED_COUNT: usize = {
    let models = crate::analytic::MODELS;
    let (mut i, mut n) = (0, 0);
    while i < models.len() {
        if models[i].published.is_some() {
            n += 1;
        }
        i += 1;
    }
    n
};

/// The analytic models with published fits, in [`crate::analytic::MODELS`] order.
const PUBLISHED: [&LobeModel; PUBLISHED_COUNT] = {
    let models = crate::analytic::MODELS;
    let mut out = [models[0]; PUBLISHED_COUNT];
    let (mut i, mut n) = (0, 0);
    while i < models.len() {
        if models[i].published.is_some() {
            out[n] = models[i];
            n += 1;
        }
        i += 1;
    }
    out
};

/// Lobe models with published fits: (model, fits file, bbm class), from the models'
/// declarations.
pub const MODELS: [(&str, &str, &str); PUBLISHED_COUNT] = {
    let mut out = [("", "", ""); PUBLISHED_COUNT];
    let mut i = 0;
    while i < PUBLISHED_COUNT {
        if let Some(p) = PUBLISHED[i].published {
            out[i] = (PUBLISHED[i].schema.name, p.file, p.class);
        }
        i += 1;
    }
    out
};

const MODEL_NAMES: [&str; PUBLISHED_COUNT] = {
    let mut out = [""; PUBLISHED_COUNT];
    let mut i = 0;
    while i < PUBLISHED_COUNT {
        out[i] = MODELS[i].0;
        i += 1;
    }
    out
};

/// The published-fit declaration of `model`, if it has one.
fn published(model: &str) -> Option<&'static PublishedFit> {
    PUBLISHED
        .iter()
        .find(|m| m.schema.name == model)
        .and_then(|m| m.published.as_ref())
}

/// MERL's green and blue scale factors relative to red.
pub const MERL_CHANNEL_SCALE: [f64; 3] = [1.0, 1.15, 1.66];

/// One parsed fit line.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    pub material: String,
    pub diffuse: [f64; 3],
    /// The bbm class name (`NganWard`, ...).
    pub class: String,
    pub specular: [f64; 3],
    /// The other keyword arguments, in order.
    pub params: Vec<(String, f64)>,
}

impl Fit {
    pub fn param(&self, key: &str) -> Option<f64> {
        self.params.iter().find(|(k, _)| k == key).map(|(_, v)| *v)
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Arg {
    Num(f64),
    Vec3([f64; 3]),
}

/// Parses `key = value, key = [a, b, c], ...` up to the closing parenthesis.
fn parse_args(s: &str) -> Option<Vec<(String, Arg)>> {
    let mut out = Vec::new();
    let mut rest = s.trim();
    while !rest.is_empty() {
        let eq = rest.find('=')?;
        let key = rest[..eq].trim().trim_start_matches(',').trim().to_string();
        rest = rest[eq + 1..].trim_start();
        let (val, after) = if let Some(r) = rest.strip_prefix('[') {
            let close = r.find(']')?;
            let nums: Vec<f64> = r[..close]
                .split(',')
                .map(|x| x.trim().parse().ok())
                .collect::<Option<_>>()?;
            if nums.len() != 3 {
                return None;
            }
            (Arg::Vec3([nums[0], nums[1], nums[2]]), &r[close + 1..])
        } else {
            let end = rest.find(',').unwrap_or(rest.len());
            (Arg::Num(rest[..end].trim().parse().ok()?), &rest[end..])
        };
        out.push((key, val));
        rest = after.trim_start().trim_start_matches(',').trim_start();
    }
    Some(out)
}

/// Parses one line of a fit file; None for comments, blank lines and malformed lines.
pub fn parse_line(line: &str) -> Option<Fit> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return None;
    }
    let (name, expr) = line.split_once('=')?;
    let expr = expr.trim();
    let lam = expr.find("Lambertian(")?;
    let lam_args_start = lam + "Lambertian(".len();
    let lam_end = lam_args_start + expr[lam_args_start..].find(')')?;
    let lam_args = parse_args(&expr[lam_args_start..lam_end])?;
    let diffuse = match lam_args.iter().find(|(k, _)| k == "albedo")?.1 {
        Arg::Vec3(v) => v,
        Arg::Num(x) => [x; 3],
    };
    let after = &expr[lam_end + 1..];
    let ngan = after.find("Ngan")?;
    let open = ngan + after[ngan..].find('(')?;
    let class = after[ngan..open].trim().to_string();
    let close = open + after[open..].rfind(')')?;
    // The model call ends at its own parenthesis; the last ')' closes Aggregate(.
    let inner = &after[open + 1..close];
    let inner = inner
        .strip_suffix(')')
        .unwrap_or(inner)
        .trim_end()
        .trim_end_matches(')');
    let args = parse_args(inner)?;
    let mut specular = None;
    let mut params = Vec::new();
    for (k, a) in args {
        match (k.as_str(), a) {
            ("albedo", Arg::Vec3(v)) => specular = Some(v),
            ("albedo", Arg::Num(x)) => specular = Some([x; 3]),
            (_, Arg::Num(x)) => params.push((k, x)),
            _ => return None,
        }
    }
    Some(Fit {
        material: name.trim().to_string(),
        diffuse,
        class,
        specular: specular?,
        params,
    })
}

/// Reads every fit of a file.
pub fn read_fits(path: &Path) -> Result<Vec<Fit>, String> {
    let text = crate::io::read_regular_to_string(
        path,
        crate::io::MAX_TEXT_BYTES,
        "a .fit file of Ngan et al.'s fits",
    )
    .map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        out.push(parse_line(t).ok_or_else(|| {
            format!("{}: line {}: expected `name = Aggregate(Lambertian(albedo = [r, g, b]), NganModel(albedo = [r, g, b], key = value, ...))`", path.display(), i + 1)
        })?);
    }
    Ok(out)
}

/// Where the fits live: an explicit folder, `$LOBE_DATA/ngan-fits`, or `shared/data/ngan-fits`
/// in an ancestor of `base` or of the working directory.
pub fn locate_fits(explicit: &str, base: &Path) -> Option<PathBuf> {
    if !explicit.is_empty() {
        let p = PathBuf::from(explicit);
        return Some(if p.is_absolute() { p } else { base.join(p) });
    }
    if let Ok(d) = std::env::var("LOBE_DATA") {
        let p = PathBuf::from(d).join("ngan-fits");
        if p.is_dir() {
            return Some(p);
        }
    }
    let starts = [base.canonicalize().ok(), std::env::current_dir().ok()];
    for start in starts.into_iter().flatten() {
        for a in start.ancestors() {
            let p = a.join("shared/data/ngan-fits");
            if p.is_dir() {
                return Some(p);
            }
        }
    }
    None
}

/// The registry description of a fit for `model`, colours scaled by `scale`.
pub fn description(fit: &Fit, model: &str, scale: [f64; 3]) -> Result<Value, String> {
    let d: Vec<f64> = (0..3).map(|c| fit.diffuse[c] * scale[c]).collect();
    let s: Vec<f64> = (0..3).map(|c| fit.specular[c] * scale[c]).collect();
    let get = |k: &str| {
        fit.param(k)
            .ok_or_else(|| format!("fit of {} lacks `{k}`", fit.material))
    };
    let published =
        published(model).ok_or_else(|| format!("no published fits for model \"{model}\""))?;
    let mut v = json!({});
    for (param, key) in published.keys {
        v[*param] = json!(get(key)?);
    }
    for (name, value) in published.settings {
        v[*name] = json!(value);
    }
    v["type"] = json!(model);
    v["diffuse"] = json!(d);
    v["specular"] = json!(s);
    Ok(v)
}

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "ngan-fit",
    summary: "a published fit of Ngan et al. 2005 to a MERL material, for one of the seven models",
    params: &[
        ParamSpec {
            name: "material",
            kind: ParamKind::Text,
            role: ParamRole::Setting,
            bounds: Bounds::closed(0.0, 0.0),
            default: DefaultValue::Required,
            doc: "MERL material name, e.g. green-metallic-paint",
            fit: None,
        },
        setting("model", &MODEL_NAMES, "cook-torrance", "which model's fit"),
        ParamSpec {
            name: "fits",
            kind: ParamKind::Text,
            role: ParamRole::Setting,
            bounds: Bounds::closed(0.0, 0.0),
            default: DefaultValue::Choice(""),
            doc: "folder of ngan_<model>.fit files (default: $LOBE_DATA/ngan-fits or shared/data/ngan-fits above the scene)",
            fit: None,
        },
        setting(
            "channel_scale",
            &["merl", "none"],
            "merl",
            "scale G and B by MERL's 1.15 and 1.66, or not",
        ),
    ],
};

/// The fits file of a description's model, if its folder can be found.
fn fits_file(p: &Params, ctx: &BuildContext) -> Option<PathBuf> {
    let file = published(p.text("model")).expect("validated choice").file;
    locate_fits(p.text("fits"), &ctx.base_dir).map(|dir| dir.join(file))
}

fn build(p: &Params, ctx: &BuildContext) -> Result<Arc<dyn Bsdf>, ParamError> {
    let model = p.text("model");
    let path = fits_file(p, ctx).ok_or_else(|| {
        ParamError::new(
            format!("{}.fits", p.path),
            "cannot find the Ngan et al. fits; expected a folder of ngan_<model>.fit files given as \"fits\", in $LOBE_DATA/ngan-fits, or at shared/data/ngan-fits above the scene",
        )
    })?;
    let fits = read_fits(&path).map_err(|e| ParamError::new(format!("{}.fits", p.path), e))?;
    let name = p.text("material");
    let fit = fits.iter().find(|f| f.material == name).ok_or_else(|| {
        ParamError::new(
            format!("{}.material", p.path),
            format!(
                "no fit named \"{name}\" in {}; expected one of: {}",
                path.display(),
                fits.iter()
                    .map(|f| f.material.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
    })?;
    let scale = if p.text("channel_scale") == "merl" {
        MERL_CHANNEL_SCALE
    } else {
        [1.0; 3]
    };
    let desc = description(fit, model, scale).map_err(|e| ParamError::new(p.path.clone(), e))?;
    ctx.create(&desc, &p.path)
}

pub fn register(r: &mut Registry) {
    r.register(SCHEMA, build);
    r.register_inputs(SCHEMA.name, |p, ctx| {
        fits_file(p, ctx).into_iter().collect()
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_bbm_line_format() {
        let f = parse_line("blue-acrylic = Aggregate(Lambertian(albedo = [0.0143, 0.033, 0.0639]), NganCookTorrance(albedo = [0.0291, 0.0193, 0.0118], eta = 0.117, roughness = 0.0137))").unwrap();
        assert_eq!(f.material, "blue-acrylic");
        assert_eq!(f.diffuse, [0.0143, 0.033, 0.0639]);
        assert_eq!(f.class, "NganCookTorrance");
        assert_eq!(f.specular, [0.0291, 0.0193, 0.0118]);
        assert_eq!(
            f.params,
            vec![
                ("eta".to_string(), 0.117),
                ("roughness".to_string(), 0.0137)
            ]
        );
        let h = parse_line("x = Aggregate(Lambertian(albedo = [1, 2, 3]), NganHe(albedo = [2.93, 1.92, 1.17], autocorrelation = 28.7, roughness = 0.063, eta = 1.08))").unwrap();
        assert_eq!(h.param("autocorrelation"), Some(28.7));
        assert_eq!(h.param("eta"), Some(1.08));
        assert!(parse_line("# comment").is_none());
        assert!(parse_line("y = Aggregate(Lambertian(albedo = [1, 2]), NganWard(albedo = [1, 1, 1], roughness = 0.1))").is_none());
        let d = description(&f, "cook-torrance", MERL_CHANNEL_SCALE).unwrap();
        assert_eq!(d["f0"], 0.117);
        assert!((d["specular"][2].as_f64().unwrap() - 0.0118 * 1.66).abs() < 1e-12);
    }
}
