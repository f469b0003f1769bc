//! JSON input files (scenes, material descriptions, fit reports), read strictly and
//! explained: a key given twice in one object is an error naming its JSON path (serde_json
//! alone keeps the last one silently), and a number JSON cannot hold as a finite double
//! (`1e400`, `NaN`, `Infinity`) gets a message saying so. Every error names the file, the
//! line and the column.

use crate::error::FileError;
use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Value};
use std::fmt;
use std::path::Path;

/// Reads and parses a JSON file (see [`parse`]); a folder or an empty file is an error.
pub fn read(path: &Path) -> Result<Value, FileError> {
    let shown = path.display().to_string();
    let text = crate::io::read_regular_to_string(path, crate::io::MAX_TEXT_BYTES, "a JSON file")?;
    if text.trim().is_empty() {
        return Err(FileError::new(&shown, "is empty; expected JSON"));
    }
    parse(&text, &shown)
}

/// Parses JSON text; `file` names it in errors. Duplicate keys are refused.
pub fn parse(text: &str, file: &str) -> Result<Value, FileError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let value = Strict { path: "" }
        .deserialize(&mut de)
        .and_then(|v| de.end().map(|()| v))
        .map_err(|e| FileError::new(file, explain(&e, text)))?;
    Ok(value)
}

/// `line L, column C: what`, with non-finite numbers called out.
fn explain(e: &serde_json::Error, text: &str) -> String {
    let (line, column) = (e.line(), e.column());
    let full = e.to_string();
    let bare = full
        .strip_suffix(&format!(" at line {line} column {column}"))
        .unwrap_or(&full);
    if line == 0 {
        return format!("invalid JSON: {bare}");
    }
    let word = word_at(text, line, column);
    let non_finite = bare.starts_with("number out of range")
        || ["nan", "inf", "infinity"].contains(&word.to_ascii_lowercase().as_str());
    if non_finite {
        let found = if word.is_empty() { "a number" } else { &word };
        format!(
            "line {line}, column {column}: {found} is not a finite number; JSON numbers must be finite (no NaN, Infinity or magnitudes beyond 1.8e308)"
        )
    } else if e.classify() == serde_json::error::Category::Data {
        // Raised by `Strict` (a duplicate key): already phrased.
        format!("line {line}, column {column}: {bare}")
    } else {
        format!("line {line}, column {column}: invalid JSON: {bare}")
    }
}

/// The letters and digits around 1-based (line, column): the token the parser stopped at.
fn word_at(text: &str, line: usize, column: usize) -> String {
    let Some(l) = text.lines().nth(line - 1) else {
        return String::new();
    };
    let chars: Vec<char> = l.chars().collect();
    let at = column.saturating_sub(1).min(chars.len());
    let is_word = |c: &char| c.is_ascii_alphanumeric() || matches!(c, '.' | '+' | '-');
    let start = chars[..at]
        .iter()
        .rposition(|c| !is_word(c))
        .map_or(0, |p| p + 1);
    let token: String = chars[start..].iter().take_while(|c| is_word(c)).collect();
    token.trim_start_matches(['-', '+']).to_string()
}

/// Builds a `Value` while checking every object for duplicate keys; `path` is the JSON path
/// of the value being read.
struct Strict<'p> {
    path: &'p str,
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

impl<'de> DeserializeSeed<'de> for Strict<'_> {
    type Value = Value;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Strict<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, b: bool) -> Result<Value, E> {
        Ok(Value::Bool(b))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(v.into())
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(v.into())
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Value, E> {
        serde_json::Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| E::custom("number out of range"))
    }
    fn visit_str<E>(self, s: &str) -> Result<Value, E> {
        Ok(Value::String(s.to_string()))
    }
    fn visit_string<E>(self, s: String) -> Result<Value, E> {
        Ok(Value::String(s))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut out = Vec::new();
        loop {
            let path = format!("{}[{}]", self.path, out.len());
            match seq.next_element_seed(Strict { path: &path })? {
                Some(v) => out.push(v),
                None => return Ok(Value::Array(out)),
            }
        }
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut out = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            let path = join(self.path, &key);
            if out.contains_key(&key) {
                return Err(de::Error::custom(format!(
                    "{path}: \"{key}\" is given twice in one object; expected each name once"
                )));
            }
            let v = map.next_value_seed(Strict { path: &path })?;
            out.insert(key, v);
        }
        Ok(Value::Object(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_round_trip() {
        let text = r#"{"a": [1, -2, 3.5, "x", null, true], "b": {"c": 1e300}}"#;
        let v = parse(text, "f.json").unwrap();
        assert_eq!(v, serde_json::from_str::<Value>(text).unwrap());
    }

    #[test]
    fn duplicate_keys_name_the_path() {
        let e = parse(
            "{\"materials\": {\"gold\": {}, \n \"gold\": {\"type\": \"lambert\"}}}",
            "s.json",
        )
        .unwrap_err();
        assert_eq!(e.file, "s.json");
        assert!(e.message.contains("materials.gold"), "{e}");
        assert!(e.message.contains("line 2"), "{e}");
    }

    #[test]
    fn non_finite_numbers_are_explained() {
        for (text, word) in [
            ("{\"a\": 1e400}", "1e400"),
            ("{\"a\": NaN}", "NaN"),
            ("{\"a\": [0, -Infinity]}", "Infinity"),
            ("{\"a\":\n  inf}", "inf"),
        ] {
            let e = parse(text, "f.json").unwrap_err();
            assert!(
                e.message.contains("JSON numbers must be finite") && e.message.contains(word),
                "{text}: {e}"
            );
            assert!(e.message.starts_with("line "), "{e}");
        }
        let e = parse("{\"a\": tru}", "f.json").unwrap_err();
        assert!(!e.message.contains("finite"), "{e}");
        assert!(e.message.contains("line 1, column"), "{e}");
    }
}
