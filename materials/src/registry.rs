//! The registry: model name -> constructor, and the parameter schema of every model
//! ([`crate::schema`]).
//!
//! A schema lists each parameter's name (the papers' names, see docs/models.md), its kind
//! (an RGB colour, a scalar, an integer, a choice), its role (a linear colour the fitter
//! solves for by least squares, or a lobe-shape parameter it optimizes), its legal range
//! and its default. Scene loading and the fitter both go through this table, so a value
//! is validated once, the same way, with an error that names its JSON path and its range.
//!
//! The registry is open: [`Registry::new`] starts empty, [`Registry::register_model`] adds
//! an analytic model declared anywhere (`Registry::builtin`, in [`crate::builtin`], adds
//! the ones lobe ships with), and constructors receive the registry in their
//! [`BuildContext`], so materials that build other materials (a fit report, a published
//! fit) build them through the caller's registry.

use crate::composite::Composite;
use crate::lobe::Lobe;
pub use crate::schema::{
    Bounds, DefaultValue, LobeConstructor, LobeModel, ModelSchema, ParamKind, ParamRole, ParamSpec,
    ParamValue, Params,
};
use crate::{Bsdf, ParamError, Rgb};

/// The registry name of the multi-lobe material.
pub const COMPOSITE: &str = "composite";
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

/// Where relative paths in a material description resolve (the scene file's folder), the
/// cache of measured tables already loaded for this scene (so each file is read once and
/// shared between shapes), and the registry that builds the materials a material names
/// (a fit report's model, a published fit).
#[derive(Clone, Debug)]
pub struct BuildContext<'r> {
    pub base_dir: PathBuf,
    pub tables: TableCache,
    pub registry: &'r Registry,
}

/// Loaded tables by key (kind, file, options).
pub type TableCache =
    Arc<std::sync::Mutex<std::collections::HashMap<String, Arc<dyn std::any::Any + Send + Sync>>>>;

impl<'r> BuildContext<'r> {
    pub fn new(base_dir: impl Into<PathBuf>, registry: &'r Registry) -> Self {
        Self {
            base_dir: base_dir.into(),
            tables: TableCache::default(),
            registry,
        }
    }

    /// Builds `desc` (at JSON path `path`) through the context's registry, sharing its base
    /// folder and table cache.
    pub fn create(&self, desc: &Value, path: &str) -> Result<Arc<dyn Bsdf>, ParamError> {
        self.registry.create_with(desc, path, self)
    }
}

/// Builds a material from validated parameters.
pub type Constructor = fn(&Params, &BuildContext) -> Result<Arc<dyn Bsdf>, ParamError>;

/// The files a material reads (tables, reports, distributions), resolved but not read, so
/// that a command can refuse an output path that is one of its inputs before any work.
pub type InputsFn = fn(&Params, &BuildContext) -> Vec<PathBuf>;

#[derive(Clone, Copy)]
enum Builder {
    Material(Constructor),
    Lobe(LobeConstructor),
}

struct Entry {
    schema: ModelSchema,
    build: Builder,
    inputs: Option<InputsFn>,
}

/// Model name -> schema and constructor.
pub struct Registry {
    models: BTreeMap<&'static str, Entry>,
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_set().entries(self.models.keys()).finish()
    }
}

fn describe_json(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("{b}"),
        Value::Number(n) => format!("{n}"),
        Value::String(s) => format!("\"{s}\""),
        // A short array of numbers (a colour) is shown as it is.
        Value::Array(a) if a.len() <= 4 && a.iter().all(Value::is_number) => v.to_string(),
        Value::Array(_) => "an array".into(),
        Value::Object(_) => "an object".into(),
    }
}

fn number(v: &Value) -> Option<f64> {
    v.as_f64()
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self {
            models: BTreeMap::new(),
        }
    }

    pub fn register(&mut self, schema: ModelSchema, build: Constructor) {
        self.models.insert(
            schema.name,
            Entry {
                schema,
                build: Builder::Material(build),
                inputs: None,
            },
        );
    }

    /// Registers an analytic model by its lobe: its schema has `diffuse` and `specular`
    /// colours and the lobe's parameters.
    pub fn register_lobe(&mut self, schema: ModelSchema, lobe: LobeConstructor) {
        debug_assert!(
            schema.params.iter().any(|p| p.name == "diffuse")
                && schema.params.iter().any(|p| p.name == "specular")
        );
        self.models.insert(
            schema.name,
            Entry {
                schema,
                build: Builder::Lobe(lobe),
                inputs: None,
            },
        );
    }

    /// Registers a declared analytic model (its schema and lobe; see [`LobeModel`]).
    pub fn register_model(&mut self, model: &LobeModel) {
        self.register_lobe(model.schema, model.lobe);
    }

    /// Declares the files a registered model reads (see [`Registry::inputs`]).
    pub fn register_inputs(&mut self, name: &str, inputs: InputsFn) {
        if let Some(e) = self.models.get_mut(name) {
            e.inputs = Some(inputs);
        }
    }

    /// The files a material description reads, resolved against `ctx` but not opened (for
    /// a `fit` material, its report is read to find the fitted model). A description that
    /// does not validate reads nothing here; building it reports the error.
    pub fn inputs(&self, desc: &Value, ctx: &BuildContext) -> Vec<PathBuf> {
        let Ok(params) = self.validate(desc, "material") else {
            return Vec::new();
        };
        match self.models[params.model].inputs {
            Some(f) => f(&params, ctx),
            None => Vec::new(),
        }
    }

    /// Checks a description without building it: a model's parameters against its schema,
    /// a `composite` by building its analytic lobes (cheap; they read no file).
    pub fn check(&self, desc: &Value, path: &str) -> Result<(), ParamError> {
        if desc.get("type").and_then(Value::as_str) == Some(COMPOSITE) {
            return self.create_composite(desc, path).map(|_| ());
        }
        self.validate(desc, path).map(|_| ())
    }

    /// True when `name` is an analytic model usable as a lobe of a `composite`.
    pub fn is_lobe_model(&self, name: &str) -> bool {
        matches!(
            self.models.get(name),
            Some(Entry {
                build: Builder::Lobe(_),
                ..
            })
        )
    }

    /// The names of the analytic models usable as lobes.
    pub fn lobe_model_names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.models
            .iter()
            .filter(|(_, e)| matches!(e.build, Builder::Lobe(_)))
            .map(|(n, _)| *n)
    }

    /// Builds the lobe of an analytic-model description, with its specular colour.
    pub fn create_lobe(
        &self,
        desc: &Value,
        path: &str,
    ) -> Result<(Rgb, Arc<dyn Lobe>), ParamError> {
        let params = self.validate(desc, path)?;
        match self.models[params.model].build {
            Builder::Lobe(f) => Ok((params.color("specular"), f(&params)?)),
            Builder::Material(_) => Err(ParamError::new(
                format!("{path}.type"),
                format!(
                    "\"{}\" is not an analytic lobe model; expected one of: {}",
                    params.model,
                    self.lobe_model_names().collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    }

    /// The parameter reference of every model as Markdown (docs/models.md embeds it;
    /// `lobe models` prints it).
    pub fn reference_markdown(&self) -> String {
        let mut out = String::new();
        for (name, e) in &self.models {
            out.push_str(&format!("### `{name}`\n\n{}\n\n", e.schema.summary));
            out.push_str("| parameter | kind | role | range | default | meaning |\n|---|---|---|---|---|---|\n");
            for p in e.schema.params {
                let kind = match p.kind {
                    ParamKind::Color => "colour".to_string(),
                    ParamKind::Scalar => "number".to_string(),
                    ParamKind::Integer => "integer".to_string(),
                    ParamKind::Choice(c) => format!("one of {}", c.join(", ")),
                    ParamKind::Text => "string".to_string(),
                    ParamKind::Bool => "boolean".to_string(),
                };
                let role = match p.role {
                    ParamRole::Diffuse => "diffuse colour",
                    ParamRole::Specular => "specular colour",
                    ParamRole::Lobe => "lobe shape",
                    ParamRole::Setting => "setting",
                };
                let range = match p.kind {
                    ParamKind::Color | ParamKind::Scalar | ParamKind::Integer => {
                        p.bounds.describe()
                    }
                    _ => String::new(),
                };
                let default = match p.default {
                    DefaultValue::Required => "required".to_string(),
                    DefaultValue::Scalar(v) => format!("{v}"),
                    DefaultValue::Color(c) => format!("[{}, {}, {}]", c[0], c[1], c[2]),
                    DefaultValue::Choice(c) => format!("\"{c}\""),
                    DefaultValue::Bool(b) => format!("{b}"),
                };
                out.push_str(&format!(
                    "| `{}` | {kind} | {role} | {range} | {default} | {} |\n",
                    p.name, p.doc
                ));
            }
            out.push('\n');
        }
        out.push_str("### `composite`\n\nLambert plus any number of lobes: `{\"type\": \"composite\", \"diffuse\": rgb, \"lobes\": [lobe, ...]}`; each lobe is the description of an analytic model (with its own `specular`, without `diffuse`).\n");
        out
    }

    pub fn schema(&self, name: &str) -> Option<&ModelSchema> {
        self.models.get(name).map(|e| &e.schema)
    }

    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        std::iter::once(COMPOSITE).chain(self.models.keys().copied())
    }

    /// `{"type": "composite", "diffuse": rgb, "lobes": [lobe, ...]}`: Lambert plus N
    /// lobes, each an analytic model description with its own `specular` colour (and no
    /// `diffuse` of its own).
    fn create_composite(&self, desc: &Value, path: &str) -> Result<Arc<dyn Bsdf>, ParamError> {
        let obj = desc.as_object().expect("checked by the caller");
        for k in obj.keys() {
            if !["type", "diffuse", "lobes"].contains(&k.as_str()) {
                return Err(ParamError::new(
                    format!("{path}.{k}"),
                    "unknown parameter of \"composite\"; expected one of: diffuse, lobes",
                ));
            }
        }
        let diffuse = match obj.get("diffuse") {
            None => Rgb::ZERO,
            Some(v) => match parse_value(
                &crate::analytic::common::DIFFUSE,
                v,
                &format!("{path}.diffuse"),
            )? {
                ParamValue::Color(c) => Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32),
                _ => unreachable!("diffuse is a colour"),
            },
        };
        let lobes = obj.get("lobes").and_then(Value::as_array).ok_or_else(|| {
            ParamError::new(format!("{path}.lobes"), "expected an array of lobe descriptions like {\"type\": \"cook-torrance\", \"specular\": 0.5, \"m\": 0.1}")
        })?;
        let mut out = Vec::with_capacity(lobes.len());
        for (i, l) in lobes.iter().enumerate() {
            let lp = format!("{path}.lobes[{i}]");
            if l.get("diffuse").is_some() {
                return Err(ParamError::new(
                    format!("{lp}.diffuse"),
                    "a lobe of a composite has no diffuse colour; give it once, on the composite",
                ));
            }
            out.push(self.create_lobe(l, &lp)?);
        }
        Ok(Arc::new(Composite::new(COMPOSITE, diffuse, out)))
    }

    /// Validates a description (`{"type": name, param: value, ...}`) against its model's
    /// schema. `path` is the JSON path of the description, used in errors.
    pub fn validate(&self, desc: &Value, path: &str) -> Result<Params, ParamError> {
        let obj = desc.as_object().ok_or_else(|| {
            ParamError::new(
                path,
                format!(
                    "expected a material object like {{\"type\": \"lambert\", ...}}, found {}",
                    describe_json(desc)
                ),
            )
        })?;
        let ty = match obj.get("type") {
            Some(Value::String(s)) => s.as_str(),
            Some(other) => {
                return Err(ParamError::new(
                    format!("{path}.type"),
                    format!(
                        "expected a model name string, found {}",
                        describe_json(other)
                    ),
                ));
            }
            None => {
                return Err(ParamError::new(
                    path,
                    format!(
                        "missing field \"type\"; expected one of: {}",
                        self.names().collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
        };
        let entry = self.models.get(ty).ok_or_else(|| {
            ParamError::new(
                format!("{path}.type"),
                format!(
                    "unknown material type \"{ty}\"; expected one of: {}",
                    self.names().collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
        let schema = &entry.schema;
        for key in obj.keys() {
            if key != "type" && !schema.params.iter().any(|p| p.name == key) {
                let known: Vec<_> = schema.params.iter().map(|p| p.name).collect();
                return Err(ParamError::new(
                    format!("{path}.{key}"),
                    format!(
                        "unknown parameter of \"{ty}\"; expected one of: {}",
                        if known.is_empty() {
                            "(none)".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                ));
            }
        }
        let mut values = BTreeMap::new();
        for spec in schema.params {
            let ppath = format!("{path}.{}", spec.name);
            let value = match obj.get(spec.name) {
                Some(v) => parse_value(spec, v, &ppath)?,
                None => match spec.default {
                    DefaultValue::Required => {
                        return Err(ParamError::new(
                            ppath,
                            format!("missing; expected {}", expectation(spec)),
                        ));
                    }
                    DefaultValue::Scalar(v) => ParamValue::Scalar(v),
                    DefaultValue::Color(c) => ParamValue::Color(c),
                    DefaultValue::Choice(c) => ParamValue::Text(c.to_string()),
                    DefaultValue::Bool(b) => ParamValue::Bool(b),
                },
            };
            values.insert(spec.name, value);
        }
        Ok(Params::new(schema.name, path.to_string(), values))
    }

    /// Validates a description and builds the material.
    pub fn create_with(
        &self,
        desc: &Value,
        path: &str,
        ctx: &BuildContext,
    ) -> Result<Arc<dyn Bsdf>, ParamError> {
        if desc.get("type").and_then(Value::as_str) == Some(COMPOSITE) {
            return self.create_composite(desc, path);
        }
        let params = self.validate(desc, path)?;
        match self.models[params.model].build {
            Builder::Material(f) => f(&params, ctx),
            Builder::Lobe(f) => {
                let lobe = f(&params)?;
                Ok(Arc::new(Composite::new(
                    params.model,
                    params.color("diffuse"),
                    vec![(params.color("specular"), lobe)],
                )))
            }
        }
    }

    /// [`Registry::create_with`] with relative paths resolving against the working directory.
    pub fn create(&self, desc: &Value, path: &str) -> Result<Arc<dyn Bsdf>, ParamError> {
        self.create_with(desc, path, &BuildContext::new("", self))
    }
}

fn expectation(spec: &ParamSpec) -> String {
    match spec.kind {
        ParamKind::Color => format!(
            "a colour (a number or [r, g, b]) with each channel in {}",
            spec.bounds.describe()
        ),
        ParamKind::Scalar => format!("a number in {}", spec.bounds.describe()),
        ParamKind::Integer => format!("an integer in {}", spec.bounds.describe()),
        ParamKind::Choice(c) => format!("one of: {}", c.join(", ")),
        ParamKind::Text => "a string".into(),
        ParamKind::Bool => "true or false".into(),
    }
}

fn parse_value(spec: &ParamSpec, v: &Value, path: &str) -> Result<ParamValue, ParamError> {
    let bad = || {
        ParamError::new(
            path,
            format!("expected {}, found {}", expectation(spec), describe_json(v)),
        )
    };
    let check = |x: f64| -> Result<f64, ParamError> {
        if x.is_finite() && spec.bounds.contains(x) {
            Ok(x)
        } else {
            Err(bad())
        }
    };
    match spec.kind {
        ParamKind::Scalar => Ok(ParamValue::Scalar(check(number(v).ok_or_else(bad)?)?)),
        ParamKind::Integer => {
            let x = number(v).ok_or_else(bad)?;
            if x.fract() != 0.0 {
                return Err(bad());
            }
            Ok(ParamValue::Scalar(check(x)?))
        }
        ParamKind::Color => {
            if let Some(x) = number(v) {
                let x = check(x)?;
                return Ok(ParamValue::Color([x; 3]));
            }
            let arr = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
            let mut c = [0.0; 3];
            for (i, e) in arr.iter().enumerate() {
                c[i] = check(number(e).ok_or_else(bad)?)?;
            }
            Ok(ParamValue::Color(c))
        }
        ParamKind::Choice(options) => {
            let s = v.as_str().ok_or_else(bad)?;
            if options.contains(&s) {
                Ok(ParamValue::Text(s.to_string()))
            } else {
                Err(bad())
            }
        }
        ParamKind::Text => Ok(ParamValue::Text(v.as_str().ok_or_else(bad)?.to_string())),
        ParamKind::Bool => Ok(ParamValue::Bool(v.as_bool().ok_or_else(bad)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn errors_name_the_path_and_the_range() {
        let r = Registry::builtin();
        let e = r
            .create(
                &json!({"type": "lambert", "reflectance": -0.5}),
                "materials.red",
            )
            .unwrap_err();
        assert_eq!(e.path, "materials.red.reflectance");
        assert!(e.message.contains("[0, 1]"), "{e}");
        let e = r
            .create(&json!({"type": "lambert", "colour": 0.5}), "m")
            .unwrap_err();
        assert_eq!(e.path, "m.colour");
        assert!(e.message.contains("reflectance"));
        let e = r.create(&json!({"type": "glass"}), "m").unwrap_err();
        assert!(e.message.contains("lambert"));
        let e = r
            .create(&json!({"type": "lambert", "reflectance": [0.1, 0.2]}), "m")
            .unwrap_err();
        assert!(e.message.contains("found [0.1,0.2]"), "{e}");
        let e = r
            .create(
                &json!({"type": "lambert", "reflectance": [1, 2, 3, 4, 5]}),
                "m",
            )
            .unwrap_err();
        assert!(e.message.contains("found an array"), "{e}");
        assert!(r.create(&json!("lambert"), "m").is_err());
    }
}
