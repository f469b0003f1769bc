//! A small path-aware reader over `serde_json::Value` for scene files: every accessor
//! knows the JSON path of the value it reads (`shapes[2].radius`) so that errors name the
//! file, the path, what was found and what was expected; unknown keys are rejected with
//! the list of accepted ones.

use crate::error::{Error, Result};
use glam::Vec3;
use lobe_materials::Rgb;
use serde_json::{Map, Value};

/// One-word description of a JSON value for error messages.
pub fn describe(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => n.to_string(),
        Value::String(s) => format!("\"{s}\""),
        Value::Array(a) => format!("an array of {} elements", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

/// A JSON object being read, with its file and path.
pub struct Obj<'a> {
    pub file: &'a str,
    pub path: String,
    map: &'a Map<String, Value>,
}

impl<'a> Obj<'a> {
    /// Checks that `v` is an object whose keys are all in `allowed`.
    pub fn new(
        file: &'a str,
        path: impl Into<String>,
        v: &'a Value,
        allowed: &[&str],
    ) -> Result<Self> {
        let path = path.into();
        let map = v.as_object().ok_or_else(|| {
            Error::scene(
                file,
                &path,
                format!("expected an object, found {}", describe(v)),
            )
        })?;
        for k in map.keys() {
            if !allowed.contains(&k.as_str()) {
                return Err(Error::scene(
                    file,
                    join(&path, k),
                    format!("unknown key; expected one of: {}", allowed.join(", ")),
                ));
            }
        }
        Ok(Self { file, path, map })
    }

    pub fn key_path(&self, key: &str) -> String {
        join(&self.path, key)
    }

    pub fn err(&self, key: &str, msg: impl Into<String>) -> Error {
        Error::scene(self.file, self.key_path(key), msg)
    }

    pub fn get(&self, key: &str) -> Option<&'a Value> {
        self.map.get(key)
    }

    pub fn has(&self, key: &str) -> bool {
        self.map.contains_key(key)
    }

    pub fn require(&self, key: &str, what: &str) -> Result<&'a Value> {
        self.get(key).ok_or_else(|| {
            Error::scene(
                self.file,
                &self.path,
                format!("missing key \"{key}\"; expected {what}"),
            )
        })
    }

    fn number(&self, key: &str, v: &Value, what: &str) -> Result<f64> {
        v.as_f64()
            .ok_or_else(|| self.err(key, format!("expected {what}, found {}", describe(v))))
    }

    /// A number satisfying `ok`, described by `what` ("a positive number").
    pub fn f32_opt(&self, key: &str, what: &str, ok: impl Fn(f64) -> bool) -> Result<Option<f32>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => {
                let x = self.number(key, v, what)?;
                if !ok(x) {
                    return Err(self.err(key, format!("expected {what}, found {x}")));
                }
                if !(x as f32).is_finite() {
                    return Err(self.err(
                        key,
                        format!(
                            "{x} is beyond single precision (at most {:e}); expected {what} that f32 holds",
                            f32::MAX
                        ),
                    ));
                }
                Ok(Some(x as f32))
            }
        }
    }

    pub fn f32_or(
        &self,
        key: &str,
        default: f32,
        what: &str,
        ok: impl Fn(f64) -> bool,
    ) -> Result<f32> {
        Ok(self.f32_opt(key, what, ok)?.unwrap_or(default))
    }

    /// An integer in [lo, hi].
    pub fn int_opt(&self, key: &str, lo: i64, hi: i64) -> Result<Option<i64>> {
        let what = format!("an integer in [{lo}, {hi}]");
        match self.get(key) {
            None => Ok(None),
            Some(v) => {
                let x = self.number(key, v, &what)?;
                if x.fract() != 0.0 || x < lo as f64 || x > hi as f64 {
                    return Err(self.err(key, format!("expected {what}, found {}", describe(v))));
                }
                Ok(Some(x as i64))
            }
        }
    }

    pub fn bool_or(&self, key: &str, default: bool) -> Result<bool> {
        match self.get(key) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(*b),
            Some(v) => Err(self.err(
                key,
                format!("expected true or false, found {}", describe(v)),
            )),
        }
    }

    pub fn str_opt(&self, key: &str) -> Result<Option<&'a str>> {
        match self.get(key) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.err(key, format!("expected a string, found {}", describe(v)))),
        }
    }

    /// An optional string naming one of `names`, converted by `parse`.
    pub fn name_opt<T>(
        &self,
        key: &str,
        names: &[&str],
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<Option<T>> {
        let Some(s) = self.str_opt(key)? else {
            return Ok(None);
        };
        let v = parse(s).ok_or_else(|| {
            self.err(
                key,
                format!("expected one of {}, found \"{s}\"", names.join(", ")),
            )
        })?;
        Ok(Some(v))
    }

    pub fn str_req(&self, key: &str, what: &str) -> Result<&'a str> {
        match self.require(key, what)? {
            Value::String(s) => Ok(s),
            v => Err(self.err(key, format!("expected {what}, found {}", describe(v)))),
        }
    }

    /// Three finite numbers.
    pub fn vec3_opt(&self, key: &str) -> Result<Option<Vec3>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => Ok(Some(vec3_value(self.file, &self.key_path(key), v)?)),
        }
    }

    pub fn vec3_req(&self, key: &str) -> Result<Vec3> {
        let v = self.require(key, "an array of 3 numbers")?;
        vec3_value(self.file, &self.key_path(key), v)
    }

    /// A non-negative colour: a number (grey) or [r, g, b].
    pub fn rgb_opt(&self, key: &str) -> Result<Option<Rgb>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => {
                let what = "a non-negative colour (a number or [r, g, b])";
                let bad = || self.err(key, format!("expected {what}, found {}", describe(v)));
                let c = if let Some(x) = v.as_f64() {
                    Rgb::splat(x as f32)
                } else {
                    let a = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
                    let mut c = [0.0f32; 3];
                    for (i, e) in a.iter().enumerate() {
                        c[i] = e.as_f64().ok_or_else(bad)? as f32;
                    }
                    Rgb::from(c)
                };
                if !c.is_finite() || c.min_component() < 0.0 {
                    return Err(bad());
                }
                Ok(Some(c))
            }
        }
    }

    pub fn rgb_req(&self, key: &str) -> Result<Rgb> {
        self.require(key, "a non-negative colour (a number or [r, g, b])")?;
        Ok(self.rgb_opt(key)?.expect("present"))
    }
}

pub fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

pub fn vec3_value(file: &str, path: &str, v: &Value) -> Result<Vec3> {
    let bad = || {
        Error::scene(
            file,
            path,
            format!(
                "expected an array of 3 finite numbers, found {}",
                describe(v)
            ),
        )
    };
    let a = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
    let mut out = [0.0f32; 3];
    for (i, e) in a.iter().enumerate() {
        out[i] = e.as_f64().ok_or_else(bad)? as f32;
        if !out[i].is_finite() {
            return Err(bad());
        }
    }
    Ok(Vec3::from_array(out))
}
