//! The files a scene reads, found from its JSON without loading any of them: the scene
//! file, environment maps (`lights[i].file`), meshes (`shapes[i].file`, with a `.gltf`
//! file's external buffers), and whatever its materials read (measured tables, fit
//! reports, microfacet distributions, the Ngan et al. fits file; see
//! [`lobe_materials::registry::Registry::inputs`]), named materials whether or not a shape
//! uses them. Commands use it to refuse an output path that is one of these
//! ([`crate::outputs::FilePlan`]) before any work starts.

use crate::error::Result;
use lobe_materials::registry::{BuildContext, Registry};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// One file a scene reads and what refers to it (`lights[0].file of scenes/x.json`).
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    pub path: PathBuf,
    pub role: String,
}

/// The scene file itself and every file it refers to.
pub fn inputs(scene: &Path) -> Result<Vec<Input>> {
    let shown = scene.display().to_string();
    let v = super::read_json(scene)?;
    let base = scene.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut out = vec![Input {
        path: scene.to_path_buf(),
        role: "the scene file".into(),
    }];
    out.extend(inputs_of_value(&v, &shown, &base));
    Ok(out)
}

/// The files a parsed scene refers to; relative paths resolve against `base`, roles name
/// the JSON path in `file`.
pub fn inputs_of_value(v: &Value, file: &str, base: &Path) -> Vec<Input> {
    inputs_of_value_with(v, file, base, &Registry::builtin())
}

/// [`inputs_of_value`] with the materials read through `registry`.
pub fn inputs_of_value_with(v: &Value, file: &str, base: &Path, registry: &Registry) -> Vec<Input> {
    let mut out = Vec::new();
    let mut add = |path: PathBuf, at: String| {
        out.push(Input {
            path,
            role: format!("{at} of {file}"),
        })
    };
    let resolve = |p: &str| {
        let pb = PathBuf::from(p);
        if pb.is_absolute() { pb } else { base.join(pb) }
    };
    let list = |key: &str| v.get(key).and_then(Value::as_array).cloned();
    for (i, l) in list("lights").unwrap_or_default().iter().enumerate() {
        if let Some(f) = l.get("file").and_then(Value::as_str)
            && !f.starts_with("builtin:")
        {
            add(resolve(f), format!("lights[{i}].file"));
        }
    }
    let ctx = BuildContext::new(base, registry);
    for (i, s) in list("shapes").unwrap_or_default().iter().enumerate() {
        if let Some(f) = s.get("file").and_then(Value::as_str) {
            let mesh = resolve(f);
            for b in gltf_buffers(&mesh) {
                add(b, format!("a buffer of shapes[{i}].file"));
            }
            add(mesh, format!("shapes[{i}].file"));
        }
        if let Some(m) = s.get("material").filter(|m| m.is_object()) {
            for p in registry.inputs(m, &ctx) {
                add(p, format!("shapes[{i}].material"));
            }
        }
    }
    if let Some(named) = v.get("materials").and_then(Value::as_object) {
        for (name, m) in named {
            for p in registry.inputs(m, &ctx) {
                add(p, format!("materials.{name}"));
            }
        }
    }
    out
}

/// The external buffer files of a `.gltf` file (`buffers[i].uri` other than `data:`
/// URIs), resolved against its folder; none for `.glb` and unreadable files.
fn gltf_buffers(path: &Path) -> Vec<PathBuf> {
    if path.extension().and_then(|e| e.to_str()) != Some("gltf") {
        return Vec::new();
    }
    let Ok(bytes) =
        lobe_materials::io::read_regular(path, lobe_materials::io::MAX_DATA_BYTES, "a glTF file")
    else {
        return Vec::new();
    };
    let Ok(v) = serde_json::from_slice::<Value>(&bytes) else {
        return Vec::new();
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    v.get("buffers")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .filter_map(|b| b.get("uri").and_then(Value::as_str))
        .filter(|u| !u.starts_with("data:"))
        .map(|u| dir.join(u))
        .collect()
}
