//! The declaration of a model, in one place: its parameter schema (each parameter's name,
//! kind, role, legal range, default; the papers' names, see docs/models.md), how the fitter
//! treats its lobe parameters (search range, log scale, starting points; Ngan et al. 2005,
//! section 3.3), the variants it is fitted as, and how the published fits of Ngan et al.
//! 2005 (bbm `.fit` files) name its parameters. A model file under `analytic/` declares a
//! [`LobeModel`]; the registry validates descriptions against its schema, the fitter
//! derives its model specs from it, and the `ngan-fit` material its keyword mapping.
//!
//! This module depends on no registry machinery, so model files import only it.

use crate::lobe::Lobe;
use crate::{ParamError, Rgb};
use std::collections::BTreeMap;
use std::sync::Arc;

/// What kind of value a parameter takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamKind {
    /// Linear RGB: a number (grey) or an array of three numbers.
    Color,
    Scalar,
    Integer,
    /// One of the listed strings.
    Choice(&'static [&'static str]),
    /// Any string (a name, a path); its default is given as `DefaultValue::Choice`.
    Text,
    Bool,
}

/// What a parameter means to the fitter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamRole {
    /// Diffuse colour: linear, solved exactly by the fitter.
    Diffuse,
    /// Specular colour of a lobe: linear, solved exactly by the fitter.
    Specular,
    /// Lobe shape: optimized by the fitter.
    Lobe,
    /// A discrete choice fixed before fitting (distribution, Fresnel form, ...).
    Setting,
}

/// Inclusive or exclusive bounds of a numeric parameter (applied to every channel of a
/// colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: f64,
    pub max: f64,
    pub min_open: bool,
    pub max_open: bool,
}

impl Bounds {
    pub const fn closed(min: f64, max: f64) -> Self {
        Self {
            min,
            max,
            min_open: false,
            max_open: false,
        }
    }
    /// (min, max]: strictly above `min`.
    pub const fn above(min: f64, max: f64) -> Self {
        Self {
            min,
            max,
            min_open: true,
            max_open: false,
        }
    }
    pub fn contains(&self, v: f64) -> bool {
        let lo = if self.min_open {
            v > self.min
        } else {
            v >= self.min
        };
        let hi = if self.max_open {
            v < self.max
        } else {
            v <= self.max
        };
        lo && hi
    }
    pub fn describe(&self) -> String {
        let fmt = |v: f64| {
            if v.is_infinite() {
                if v > 0.0 { "inf".into() } else { "-inf".into() }
            } else if v.abs() >= 1e5 {
                format!("{v:e}")
            } else {
                format!("{v}")
            }
        };
        format!(
            "{}{}, {}{}",
            if self.min_open { "(" } else { "[" },
            fmt(self.min),
            fmt(self.max),
            if self.max_open { ")" } else { "]" }
        )
    }
}

/// Default of a parameter; `Required` means the description must give it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DefaultValue {
    Required,
    Scalar(f64),
    Color([f64; 3]),
    Choice(&'static str),
    Bool(bool),
}

/// One parameter of a model's schema.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub kind: ParamKind,
    pub role: ParamRole,
    pub bounds: Bounds,
    pub default: DefaultValue,
    pub doc: &'static str,
    /// How the fitter searches this parameter; `None`: the fitter does not optimize it
    /// (a colour, a setting, or a parameter tied to another one).
    pub fit: Option<FitRange>,
}

impl ParamSpec {
    /// The same parameter, optimized by the fitter as `fit` says.
    pub const fn fitted(self, fit: FitRange) -> Self {
        Self {
            fit: Some(fit),
            ..self
        }
    }
}

/// The schema of a model: its registry name, a one-line summary and its parameters.
#[derive(Clone, Copy, Debug)]
pub struct ModelSchema {
    pub name: &'static str,
    pub summary: &'static str,
    pub params: &'static [ParamSpec],
}

/// A validated parameter value.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Scalar(f64),
    Color([f64; 3]),
    Text(String),
    Bool(bool),
}

/// Validated parameters of one material description, all present (defaults filled in).
#[derive(Clone, Debug)]
pub struct Params {
    pub model: &'static str,
    /// JSON path of the description, for errors raised by constructors.
    pub path: String,
    values: BTreeMap<&'static str, ParamValue>,
}

impl Params {
    /// Parameters validated by the registry (every schema parameter present).
    pub(crate) fn new(
        model: &'static str,
        path: String,
        values: BTreeMap<&'static str, ParamValue>,
    ) -> Self {
        Self {
            model,
            path,
            values,
        }
    }
    fn get(&self, name: &str) -> &ParamValue {
        self.values
            .get(name)
            .unwrap_or_else(|| panic!("model {}: no parameter {name} in its schema", self.model))
    }
    pub fn scalar(&self, name: &str) -> f64 {
        match self.get(name) {
            ParamValue::Scalar(v) => *v,
            other => panic!("parameter {name} is {other:?}, not a scalar"),
        }
    }
    pub fn color(&self, name: &str) -> Rgb {
        match self.get(name) {
            ParamValue::Color(c) => Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32),
            other => panic!("parameter {name} is {other:?}, not a colour"),
        }
    }
    pub fn text(&self, name: &str) -> &str {
        match self.get(name) {
            ParamValue::Text(t) => t,
            other => panic!("parameter {name} is {other:?}, not a choice"),
        }
    }
    pub fn flag(&self, name: &str) -> bool {
        match self.get(name) {
            ParamValue::Bool(b) => *b,
            other => panic!("parameter {name} is {other:?}, not a boolean"),
        }
    }
}

/// How the fitter searches one lobe parameter: within `[lo, hi]` (tighter than the legal
/// range: the shapes the data can tell apart), in log space for scale parameters, from each
/// of `starts` (the multi-start grid is the product over the parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitRange {
    pub lo: f64,
    pub hi: f64,
    /// Optimize its logarithm (scale parameters).
    pub log: bool,
    /// Starting values of the multi-start grid.
    pub starts: &'static [f64],
    /// Also sets these parameters to the same value (e.g. Lafortune's cy = cx on isotropic
    /// data).
    pub tied: &'static [&'static str],
    /// Fitted only when a setting has a value (`("fresnel", "schlick")` for Schlick's
    /// `f0`); the lobe ignores the parameter otherwise.
    pub when: Option<(&'static str, &'static str)>,
}

impl FitRange {
    /// A parameter optimized in linear space.
    pub const fn linear(lo: f64, hi: f64, starts: &'static [f64]) -> Self {
        Self {
            lo,
            hi,
            log: false,
            starts,
            tied: &[],
            when: None,
        }
    }
    /// A scale parameter, optimized in log space.
    pub const fn log(lo: f64, hi: f64, starts: &'static [f64]) -> Self {
        Self {
            log: true,
            ..Self::linear(lo, hi, starts)
        }
    }
    /// Also sets `tied` to the fitted value.
    pub const fn tied(self, tied: &'static [&'static str]) -> Self {
        Self { tied, ..self }
    }
    /// Fitted only when `setting` is `value`.
    pub const fn when(self, setting: &'static str, value: &'static str) -> Self {
        Self {
            when: Some((setting, value)),
            ..self
        }
    }
}

/// Which of the study's sets a fitted variant belongs to; the fitter lists variants set by
/// set in this order, and fits the `Isotropic` set by default on isotropic data and the
/// `Anisotropic` set on 4D data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum FitGroup {
    /// The study's models for isotropic data (section 4).
    Isotropic,
    /// Variations of a model's parts (sections 4.3, 4.4: distributions, Fresnel terms).
    Variant,
    /// Two lobes of the same family (section 4.2).
    TwoLobes,
    /// Anisotropic models, for 4D data (section 5).
    Anisotropic,
}

/// One way a model is fitted: its label in fit reports, the settings fixed for the fit,
/// and how many lobes of the family (each with its own shape parameters and colour; two
/// lobes are written as a `composite`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitVariant {
    pub label: &'static str,
    pub settings: &'static [(&'static str, &'static str)],
    pub lobes: usize,
    pub group: FitGroup,
    /// The simpler fitted variant this one contains, if any: the fitter starts from that
    /// variant's optimum, so the fit is never worse than it.
    pub contains: Option<Contains>,
}

/// A fitted variant that another one contains as a special case (anisotropic Ward with
/// alpha_x = alpha_y = alpha is Ward): its label, and which of its parameters gives each
/// parameter of the containing variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contains {
    /// The contained variant's label, e.g. `ward`.
    pub label: &'static str,
    /// (parameter of the containing variant, parameter of the contained one whose fitted
    /// value it starts from), for every fitted parameter of the containing variant.
    pub params: &'static [(&'static str, &'static str)],
}

impl FitVariant {
    /// One lobe with the schema's default settings.
    pub const fn single(label: &'static str, group: FitGroup) -> Self {
        Self {
            label,
            settings: &[],
            lobes: 1,
            group,
            contains: None,
        }
    }

    /// The same variant, containing `contains` as a special case.
    pub const fn containing(self, contains: Contains) -> Self {
        Self {
            contains: Some(contains),
            ..self
        }
    }
}

/// How the published fits of Ngan et al. 2005 (bbm `fits/<file>`, lines like
/// `name = Aggregate(Lambertian(albedo = ..), <class>(albedo = .., key = value, ..))`)
/// name a model's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PublishedFit {
    /// The fits file, e.g. `ngan_ward.fit`.
    pub file: &'static str,
    /// The bbm class of its lines, e.g. `NganWard`.
    pub class: &'static str,
    /// (parameter, keyword of the file whose value it takes), in schema order.
    pub keys: &'static [(&'static str, &'static str)],
    /// The settings the fits were made with.
    pub settings: &'static [(&'static str, &'static str)],
}

/// Builds the specular lobe of an analytic model from validated parameters; the material
/// is then `diffuse * Lambert + specular * lobe` (a [`crate::composite::Composite`]).
pub type LobeConstructor = fn(&Params) -> Result<Arc<dyn Lobe>, ParamError>;

/// An analytic model, declared in its own file: its schema (with `diffuse`, `specular` and
/// the lobe's parameters, fit ranges on those the fitter optimizes), its lobe, the
/// variants it is fitted as, and its published fits' keywords, if any.
#[derive(Clone, Copy, Debug)]
pub struct LobeModel {
    pub schema: ModelSchema,
    pub lobe: LobeConstructor,
    pub fits: &'static [FitVariant],
    pub published: Option<PublishedFit>,
}
