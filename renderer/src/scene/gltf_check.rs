//! Checks of a glTF 2.0 file (Khronos glTF 2.0 specification: GLB container, section 4;
//! buffers, buffer views and accessors, 3.6; nodes and hierarchy, 3.5) made before the
//! `gltf` crate reads it, because gltf 1.4 trusts much of its input: its validation indexes
//! arrays unchecked, its readers reach `unreachable!()` for an index accessor of floats and
//! slice past a buffer view for a short stride, its GLB header arithmetic can underflow and
//! its URI decoding unwraps (all found by fuzzing or by hand). So this module
//!
//! - splits a GLB container after checking its header and chunk lengths;
//! - checks every index between glTF objects (meshes, accessors, buffer views, buffers,
//!   nodes, scenes, cameras, materials);
//! - loads the buffers itself (GLB BIN chunk, base64 `data:` URIs, regular files next to
//!   the glTF file), reading exactly each buffer's declared `byteLength`;
//! - checks every accessor a mesh primitive names against its use (indices: unsigned
//!   integer SCALAR; POSITION and NORMAL: float VEC3; TEXCOORD_n: float or normalized
//!   unsigned VEC2; all attributes of a primitive of one count; a multiple of 3 indices for
//!   triangles) and its bytes (component alignment, stride, offsets and count within its
//!   buffer view, the view within its buffer, sparse parts likewise);
//! - walks the node graph of the scene with cycle detection (a node on its own path),
//!   a depth limit and an instance limit ([`crate::limits`]).
//!
//! Every error names the JSON path of the offending value and what was expected.

use crate::limits::{MAX_GLTF_DEPTH, MAX_GLTF_INSTANCES};
use serde_json::Value;
use std::path::Path;

type Res<T> = std::result::Result<T, String>;

/// A glTF file split into its JSON document and, for a GLB file, its BIN chunk.
pub struct Container<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

fn u32_at(bytes: &[u8], o: usize) -> Option<usize> {
    bytes
        .get(o..o.checked_add(4)?)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
}

/// Splits a .gltf (JSON) or .glb (binary container) file, checking the GLB header: version
/// 2, declared length within the file, a JSON chunk first, chunks within the declared
/// length.
pub fn container(bytes: &[u8]) -> Res<Container<'_>> {
    if !bytes.starts_with(b"glTF") {
        return Ok(Container {
            json: bytes,
            bin: None,
        });
    }
    let (Some(version), Some(length), Some(json_len)) =
        (u32_at(bytes, 4), u32_at(bytes, 8), u32_at(bytes, 12))
    else {
        return Err("truncated GLB header; expected a 12-byte header and a JSON chunk".into());
    };
    if version != 2 {
        return Err(format!("GLB version {version}; expected 2"));
    }
    if length < 20 || length > bytes.len() {
        return Err(format!(
            "GLB header declares {length} bytes, the file has {}; expected 20 to {}",
            bytes.len(),
            bytes.len()
        ));
    }
    if bytes.get(16..20) != Some(b"JSON".as_slice()) {
        return Err("the first GLB chunk is not JSON; expected a JSON chunk".into());
    }
    let json_end = 20usize.saturating_add(json_len);
    if json_end > length {
        return Err(format!(
            "GLB JSON chunk of {json_len} bytes runs past the declared length {length}"
        ));
    }
    let bin_at = json_end.next_multiple_of(4);
    let mut bin = None;
    if bin_at + 8 <= length
        && let Some(bin_len) = u32_at(bytes, bin_at)
    {
        if bin_at + 8 + bin_len > length {
            return Err(format!(
                "GLB BIN chunk of {bin_len} bytes runs past the declared length {length}"
            ));
        }
        if bytes.get(bin_at + 4..bin_at + 8) == Some(b"BIN\0".as_slice()) {
            bin = Some(&bytes[bin_at + 8..bin_at + 8 + bin_len]);
        }
    }
    Ok(Container {
        json: &bytes[20..json_end],
        bin,
    })
}

fn arr<'a>(o: &'a Value, k: &str) -> &'a [Value] {
    o.get(k)
        .and_then(Value::as_array)
        .map_or(&[], |a| a.as_slice())
}

fn count(v: &Value, k: &str) -> usize {
    arr(v, k).len()
}

/// `idx` as an index into the top-level array `target`.
fn index(v: &Value, what: &str, idx: &Value, target: &str) -> Res<usize> {
    match idx.as_u64() {
        Some(i) if (i as usize) < count(v, target) => Ok(i as usize),
        _ => Err(format!(
            "{what}: {idx} is not an index into \"{target}\" (which has {} entries)",
            count(v, target)
        )),
    }
}

/// A non-negative integer field (default when absent).
fn uint(o: &Value, what: &str, key: &str, default: Option<u64>) -> Res<usize> {
    match o.get(key) {
        None => default
            .map(|d| d as usize)
            .ok_or_else(|| format!("{what}.{key}: missing; expected a non-negative integer")),
        Some(x) => x
            .as_u64()
            .filter(|&n| n <= u32::MAX as u64)
            .map(|n| n as usize)
            .ok_or_else(|| {
                format!("{what}.{key}: {x}; expected a non-negative integer below 2^32")
            }),
    }
}

/// Checks every index between glTF objects (the gltf crate's validation indexes some
/// arrays unchecked: a primitive naming a missing accessor panicked inside gltf-json 1.4).
pub fn check_indices(v: &Value) -> Res<()> {
    for (m, mesh) in arr(v, "meshes").iter().enumerate() {
        for (p, prim) in arr(mesh, "primitives").iter().enumerate() {
            let at = format!("meshes[{m}].primitives[{p}]");
            if let Some(a) = prim.get("attributes").and_then(Value::as_object) {
                for (name, idx) in a {
                    index(v, &format!("{at}.attributes.{name}"), idx, "accessors")?;
                }
            }
            if let Some(i) = prim.get("indices") {
                index(v, &format!("{at}.indices"), i, "accessors")?;
            }
            for (t, target) in arr(prim, "targets").iter().enumerate() {
                if let Some(a) = target.as_object() {
                    for (name, idx) in a {
                        index(v, &format!("{at}.targets[{t}].{name}"), idx, "accessors")?;
                    }
                }
            }
            if let Some(i) = prim.get("material") {
                index(v, &format!("{at}.material"), i, "materials")?;
            }
        }
    }
    for (a, acc) in arr(v, "accessors").iter().enumerate() {
        if let Some(i) = acc.get("bufferView") {
            index(v, &format!("accessors[{a}].bufferView"), i, "bufferViews")?;
        }
        if let Some(s) = acc.get("sparse") {
            for part in ["indices", "values"] {
                if let Some(i) = s.get(part).and_then(|p| p.get("bufferView")) {
                    let what = format!("accessors[{a}].sparse.{part}.bufferView");
                    index(v, &what, i, "bufferViews")?;
                }
            }
        }
    }
    for (b, view) in arr(v, "bufferViews").iter().enumerate() {
        if let Some(i) = view.get("buffer") {
            index(v, &format!("bufferViews[{b}].buffer"), i, "buffers")?;
        }
    }
    for (n, node) in arr(v, "nodes").iter().enumerate() {
        if let Some(i) = node.get("mesh") {
            index(v, &format!("nodes[{n}].mesh"), i, "meshes")?;
        }
        if let Some(i) = node.get("camera") {
            index(v, &format!("nodes[{n}].camera"), i, "cameras")?;
        }
        for (c, child) in arr(node, "children").iter().enumerate() {
            index(v, &format!("nodes[{n}].children[{c}]"), child, "nodes")?;
        }
    }
    for (sc, scene) in arr(v, "scenes").iter().enumerate() {
        for (k, node) in arr(scene, "nodes").iter().enumerate() {
            index(v, &format!("scenes[{sc}].nodes[{k}]"), node, "nodes")?;
        }
    }
    if let Some(i) = v.get("scene") {
        index(v, "scene", i, "scenes")?;
    }
    Ok(())
}

/// Decodes `%XX` escapes of a relative URI (glTF 2.0, 3.3: URIs are RFC 3986 encoded).
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut k = 0;
    while k < b.len() {
        if b[k] == b'%' {
            let hex = std::str::from_utf8(b.get(k + 1..k + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            k += 3;
        } else {
            out.push(b[k]);
            k += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The bytes of every buffer: the GLB BIN chunk (a buffer without `uri`), a base64 `data:`
/// URI, or a regular file relative to `base`; exactly `byteLength` bytes of each.
pub fn load_buffers(v: &Value, base: &Path, bin: Option<&[u8]>) -> Res<Vec<Vec<u8>>> {
    use base64::Engine;
    let mut out = Vec::new();
    for (b, buf) in arr(v, "buffers").iter().enumerate() {
        let what = format!("buffers[{b}]");
        let len = uint(buf, &what, "byteLength", None)?;
        let data: Vec<u8> = match buf.get("uri") {
            None => bin
                .ok_or_else(|| format!("{what}: no uri and no GLB BIN chunk; expected one"))?
                .to_vec(),
            Some(Value::String(uri)) if uri.starts_with("data:") => {
                let (_, payload) = uri.split_once(";base64,").ok_or_else(|| {
                    format!("{what}.uri: a data URI without \";base64,\"; expected base64 data")
                })?;
                base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .map_err(|e| format!("{what}.uri: invalid base64 ({e})"))?
            }
            Some(Value::String(uri)) => {
                if uri.contains(':') {
                    return Err(format!(
                        "{what}.uri: \"{uri}\"; expected a data: URI or a relative file path"
                    ));
                }
                let rel = percent_decode(uri).ok_or_else(|| {
                    format!("{what}.uri: \"{uri}\" has an invalid %-escape; expected UTF-8 after decoding")
                })?;
                let path = base.join(&rel);
                let meta = std::fs::metadata(&path)
                    .map_err(|e| format!("{what}.uri: cannot open {}: {e}", path.display()))?;
                if !meta.is_file() {
                    return Err(format!(
                        "{what}.uri: {} is not a regular file; expected the buffer's bytes",
                        path.display()
                    ));
                }
                if meta.len() < len as u64 {
                    return Err(format!(
                        "{what}: {} has {} bytes; byteLength declares {len}",
                        path.display(),
                        meta.len()
                    ));
                }
                use std::io::Read;
                let mut data = Vec::new();
                std::fs::File::open(&path)
                    .and_then(|f| f.take(len as u64).read_to_end(&mut data))
                    .map_err(|e| format!("{what}.uri: cannot read {}: {e}", path.display()))?;
                data
            }
            Some(other) => return Err(format!("{what}.uri: {other}; expected a string")),
        };
        if data.len() < len {
            return Err(format!(
                "{what}: {} bytes of data; byteLength declares {len}",
                data.len()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Byte size of a component type, and whether it is an unsigned integer.
fn component(ct: usize) -> Option<(usize, bool)> {
    Some(match ct {
        5120 => (1, false),
        5121 => (1, true),
        5122 => (2, false),
        5123 => (2, true),
        5125 => (4, true),
        5126 => (4, false),
        _ => return None,
    })
}

fn components(ty: &str) -> Option<usize> {
    Some(match ty {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" | "MAT2" => 4,
        "MAT3" => 9,
        "MAT4" => 16,
        _ => return None,
    })
}

/// Checks that `count` elements of `elem` bytes at `offset` (with the view's stride, or
/// packed) lie within buffer view `view_idx`, and the view within its buffer.
fn check_span(
    v: &Value,
    buffers: &[Vec<u8>],
    what: &str,
    view_idx: &Value,
    offset: usize,
    count: usize,
    elem: usize,
) -> Res<()> {
    let vi = index(v, &format!("{what}.bufferView"), view_idx, "bufferViews")?;
    let view = &arr(v, "bufferViews")[vi];
    let vw = format!("bufferViews[{vi}]");
    let bi = index(
        v,
        &format!("{vw}.buffer"),
        view.get("buffer").unwrap_or(&Value::Null),
        "buffers",
    )?;
    let v_off = uint(view, &vw, "byteOffset", Some(0))?;
    let v_len = uint(view, &vw, "byteLength", None)?;
    let buf_len = uint(
        &arr(v, "buffers")[bi],
        &format!("buffers[{bi}]"),
        "byteLength",
        None,
    )?;
    let data_len = buffers.get(bi).map_or(0, Vec::len).min(buf_len);
    if v_off + v_len > data_len {
        return Err(format!(
            "{vw}: bytes {v_off}..{} lie past the end of buffer {bi} ({data_len} bytes)",
            v_off + v_len
        ));
    }
    let stride = match view.get("byteStride") {
        None => elem,
        Some(_) => {
            let s = uint(view, &vw, "byteStride", None)?;
            if !(4..=252).contains(&s) || s % 4 != 0 || s < elem {
                return Err(format!(
                    "{vw}.byteStride: {s}; expected a multiple of 4 in [4, 252], at least the {elem}-byte element of {what}"
                ));
            }
            s
        }
    };
    let end = (count as u64 - 1) * stride as u64 + elem as u64 + offset as u64;
    if end > v_len as u64 {
        return Err(format!(
            "{what}: {count} elements of {elem} bytes (stride {stride}) from byte {offset} need {end} bytes; buffer view {vi} has {v_len}"
        ));
    }
    Ok(())
}

/// Accessor `a`'s type, component type and count (a known type and component type, a
/// count of at least one).
fn accessor(v: &Value, a: usize) -> Res<Accessor> {
    let acc = &arr(v, "accessors")[a];
    let what = format!("accessors[{a}]");
    let ct = uint(acc, &what, "componentType", None)?;
    let (csize, unsigned) = component(ct).ok_or_else(|| {
        format!("{what}.componentType: {ct}; expected 5120, 5121, 5122, 5123, 5125 or 5126")
    })?;
    let ty = acc.get("type").and_then(Value::as_str).unwrap_or("");
    let n = components(ty).ok_or_else(|| {
        format!("{what}.type: \"{ty}\"; expected SCALAR, VEC2, VEC3, VEC4, MAT2, MAT3 or MAT4")
    })?;
    let count = uint(acc, &what, "count", None)?;
    if count == 0 {
        return Err(format!("{what}.count: 0; expected at least 1"));
    }
    Ok(Accessor {
        index: a,
        ct,
        csize,
        elem: n * csize,
        unsigned,
        ty: ty.to_string(),
        normalized: acc.get("normalized").and_then(Value::as_bool) == Some(true),
        count,
    })
}

/// Checks an accessor's bytes (and its sparse parts') lie within their buffer views.
fn check_bytes(v: &Value, buffers: &[Vec<u8>], m: &Accessor) -> Res<()> {
    let acc = &arr(v, "accessors")[m.index];
    let what = format!("accessors[{}]", m.index);
    let offset = uint(acc, &what, "byteOffset", Some(0))?;
    if offset % m.csize != 0 {
        return Err(format!(
            "{what}.byteOffset: {offset}; expected a multiple of the {}-byte component",
            m.csize
        ));
    }
    let sparse = acc.get("sparse");
    match acc.get("bufferView") {
        Some(view) => check_span(v, buffers, &what, view, offset, m.count, m.elem)?,
        None if sparse.is_none() => {
            return Err(format!(
                "{what}: no bufferView and no sparse data; expected data"
            ));
        }
        None => {}
    }
    if let Some(s) = sparse {
        let sw = format!("{what}.sparse");
        let sc = uint(s, &sw, "count", None)?;
        if sc == 0 || sc > m.count {
            return Err(format!(
                "{sw}.count: {sc}; expected 1 to the accessor's count {}",
                m.count
            ));
        }
        let ind = s.get("indices").unwrap_or(&Value::Null);
        let iw = format!("{sw}.indices");
        let ict = uint(ind, &iw, "componentType", None)?;
        let isize = match component(ict) {
            Some((k, true)) => k,
            _ => {
                return Err(format!(
                    "{iw}.componentType: {ict}; expected 5121, 5123 or 5125"
                ));
            }
        };
        let ioff = uint(ind, &iw, "byteOffset", Some(0))?;
        let iview = ind.get("bufferView").unwrap_or(&Value::Null);
        check_span(v, buffers, &iw, iview, ioff, sc, isize)?;
        let val = s.get("values").unwrap_or(&Value::Null);
        let vw = format!("{sw}.values");
        let voff = uint(val, &vw, "byteOffset", Some(0))?;
        let vview = val.get("bufferView").unwrap_or(&Value::Null);
        check_span(v, buffers, &vw, vview, voff, sc, m.elem)?;
    }
    Ok(())
}

struct Accessor {
    index: usize,
    ct: usize,
    csize: usize,
    elem: usize,
    unsigned: bool,
    ty: String,
    normalized: bool,
    count: usize,
}

/// Checks every accessor a mesh primitive names against its use and its bytes.
pub fn check_accessors(v: &Value, buffers: &[Vec<u8>]) -> Res<()> {
    for (m, mesh) in arr(v, "meshes").iter().enumerate() {
        for (p, prim) in arr(mesh, "primitives").iter().enumerate() {
            let at = format!("meshes[{m}].primitives[{p}]");
            let mut vertices: Option<(String, usize)> = None;
            if let Some(attrs) = prim.get("attributes").and_then(Value::as_object) {
                for (name, idx) in attrs {
                    let what = format!("{at}.attributes.{name}");
                    let a = index(v, &what, idx, "accessors")?;
                    let acc = accessor(v, a).map_err(|e| format!("{what}: {e}"))?;
                    let ok = match name.as_str() {
                        "POSITION" | "NORMAL" => acc.ty == "VEC3" && acc.ct == 5126,
                        n if n.starts_with("TEXCOORD_") => {
                            acc.ty == "VEC2"
                                && (acc.ct == 5126
                                    || (acc.normalized && matches!(acc.ct, 5121 | 5123)))
                        }
                        _ => true,
                    };
                    if !ok {
                        let expected = if name.starts_with("TEXCOORD_") {
                            "VEC2 of floats (5126) or of normalized unsigned bytes or shorts"
                        } else {
                            "VEC3 of floats (5126)"
                        };
                        return Err(format!(
                            "{what}: accessor {a} is {} of component type {}; expected {expected}",
                            acc.ty, acc.ct
                        ));
                    }
                    check_bytes(v, buffers, &acc).map_err(|e| format!("{what}: {e}"))?;
                    match &vertices {
                        Some((first, c)) if *c != acc.count => {
                            return Err(format!(
                                "{what}: {} elements, but {first} has {c}; expected every attribute of a primitive to have the same count",
                                acc.count
                            ));
                        }
                        None => vertices = Some((name.clone(), acc.count)),
                        _ => {}
                    }
                }
            }
            let triangles = prim.get("mode").and_then(Value::as_u64).unwrap_or(4) == 4;
            if let Some(idx) = prim.get("indices") {
                let what = format!("{at}.indices");
                let a = index(v, &what, idx, "accessors")?;
                let acc = accessor(v, a).map_err(|e| format!("{what}: {e}"))?;
                if acc.ty != "SCALAR" || !acc.unsigned || acc.normalized {
                    return Err(format!(
                        "{what}: accessor {a} is {} of component type {}; expected SCALAR unsigned integers (5121, 5123 or 5125)",
                        acc.ty, acc.ct
                    ));
                }
                if triangles && acc.count % 3 != 0 {
                    return Err(format!(
                        "{what}: {} indices; expected a multiple of 3 for triangles",
                        acc.count
                    ));
                }
                check_bytes(v, buffers, &acc).map_err(|e| format!("{what}: {e}"))?;
            } else if let Some((first, c)) = &vertices
                && triangles
                && c % 3 != 0
            {
                return Err(format!(
                    "{at}.attributes.{first}: {c} vertices without indices; expected a multiple of 3 for triangles"
                ));
            }
        }
    }
    Ok(())
}

/// One node instance of the scene: the node and the index (in the walk) of its parent
/// instance.
#[derive(Clone, Copy, Debug)]
pub struct Visit {
    pub node: usize,
    pub parent: Option<usize>,
}

/// Depth-first walk of the node graph from the roots of `scene` (children in order), with
/// cycle detection (a node met again on its own path), at most [`MAX_GLTF_DEPTH`] levels
/// and [`MAX_GLTF_INSTANCES`] instances.
pub fn walk(v: &Value, scene: usize) -> Res<Vec<Visit>> {
    let nodes = arr(v, "nodes");
    let roots = arr(&arr(v, "scenes")[scene], "nodes");
    let mut out: Vec<Visit> = Vec::new();
    // (node, parent instance, depth)
    let mut stack: Vec<(usize, Option<usize>, usize)> = roots
        .iter()
        .rev()
        .filter_map(|r| r.as_u64().map(|n| (n as usize, None, 1)))
        .collect();
    while let Some((node, parent, depth)) = stack.pop() {
        let mut up = parent;
        while let Some(k) = up {
            if out[k].node == node {
                return Err(format!(
                    "nodes[{node}] is its own descendant (the node graph has a cycle); expected a tree"
                ));
            }
            up = out[k].parent;
        }
        if depth > MAX_GLTF_DEPTH {
            return Err(format!(
                "nodes[{node}] is {depth} levels deep; expected at most {MAX_GLTF_DEPTH}"
            ));
        }
        if out.len() >= MAX_GLTF_INSTANCES {
            return Err(format!(
                "the node graph expands to more than {MAX_GLTF_INSTANCES} node instances (nodes shared by several parents); expected at most {MAX_GLTF_INSTANCES}"
            ));
        }
        let me = out.len();
        out.push(Visit { node, parent });
        for c in arr(&nodes[node], "children").iter().rev() {
            if let Some(c) = c.as_u64() {
                stack.push((c as usize, Some(me), depth + 1));
            }
        }
    }
    Ok(out)
}

/// Triangles the walk's instances expand to (from the accessor counts, before any is read).
pub fn triangle_count(v: &Value, visits: &[Visit]) -> u64 {
    let accessors = arr(v, "accessors");
    let count_of = |idx: Option<&Value>| {
        idx.and_then(Value::as_u64)
            .and_then(|a| accessors.get(a as usize))
            .and_then(|a| a.get("count"))
            .and_then(Value::as_u64)
            .unwrap_or(0)
    };
    let per_mesh: Vec<u64> = arr(v, "meshes")
        .iter()
        .map(|mesh| {
            arr(mesh, "primitives")
                .iter()
                .filter(|p| p.get("mode").and_then(Value::as_u64).unwrap_or(4) == 4)
                .map(|p| match p.get("indices") {
                    Some(i) => count_of(Some(i)) / 3,
                    None => count_of(p.pointer("/attributes/POSITION")) / 3,
                })
                .sum()
        })
        .collect();
    let nodes = arr(v, "nodes");
    visits
        .iter()
        .filter_map(|vi| nodes[vi.node].get("mesh").and_then(Value::as_u64))
        .map(|m| per_mesh.get(m as usize).copied().unwrap_or(0))
        .sum()
}
