//! Hostile glTF files get one-line errors naming the offending JSON path, before the `gltf`
//! crate reads them (renderer/src/scene/gltf_check.rs): accessors of the wrong type or
//! out of their buffer views, node graphs with cycles, too deep or expanding to too many
//! instances, and buffer URIs that are not data. Each of these panicked inside gltf 1.4.1,
//! hung or aborted on an allocation before.

use base64::Engine;
use lobe_renderer::scene::mesh_io::load_gltf;
use serde_json::{Value, json};
use std::path::Path;

/// A triangle: 3 VEC3 float positions (36 bytes) then 3 u16 indices (6 bytes, padded to 8).
fn triangle_bytes() -> Vec<u8> {
    let mut b = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

fn triangle() -> Value {
    let b = triangle_bytes();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&b)
    );
    json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": b.len(), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]
    })
}

/// Loads `v` as a .gltf file; the error message (a panic fails the test).
fn error(dir: &Path, v: &Value) -> String {
    let p = dir.join("m.gltf");
    std::fs::write(&p, v.to_string()).unwrap();
    let e = match load_gltf(&p) {
        Ok(_) => panic!("accepted: {v}"),
        Err(e) => e.to_string(),
    };
    assert!(!e.contains('\n') && e.contains("m.gltf"), "{e}");
    e
}

/// `v` with the value at JSON pointer `pointer` set (an object key is added if absent).
fn with(mut v: Value, pointer: &str, x: Value) -> Value {
    let (parent, key) = pointer.rsplit_once('/').expect("a pointer");
    let p = v.pointer_mut(parent).unwrap_or_else(|| panic!("{pointer}"));
    match p {
        Value::Array(a) => a[key.parse::<usize>().expect("an index")] = x,
        _ => {
            p[key] = x;
        }
    }
    v
}

#[test]
fn valid_triangles_load_from_gltf_and_glb_with_shared_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.gltf");
    std::fs::write(&p, triangle().to_string()).unwrap();
    assert_eq!(load_gltf(&p).unwrap().mesh.indices.len(), 1);
    // Two parents sharing one child node: two instances of its triangle.
    let mut v = triangle();
    v["scenes"] = json!([{"nodes": [1, 2]}]);
    v["nodes"] =
        json!([{"mesh": 0}, {"children": [0]}, {"children": [0], "translation": [3, 0, 0]}]);
    std::fs::write(&p, v.to_string()).unwrap();
    assert_eq!(load_gltf(&p).unwrap().mesh.indices.len(), 2);
    // The same triangle as a GLB with a BIN chunk.
    let mut v = triangle();
    v["buffers"] = json!([{"byteLength": 44}]);
    let glb = lobe_tests::fuzz::glb(&v, &triangle_bytes());
    let p = dir.path().join("t.glb");
    std::fs::write(&p, glb).unwrap();
    assert_eq!(load_gltf(&p).unwrap().mesh.indices.len(), 1);
}

#[test]
fn accessors_are_checked_against_their_use_before_the_gltf_crate_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<(Value, &[&str])> = vec![
        // Indices naming the float positions: unreachable!() inside gltf 1.4.1.
        (
            with(triangle(), "/meshes/0/primitives/0/indices", json!(0)),
            &["meshes[0].primitives[0].indices", "SCALAR unsigned"],
        ),
        (
            with(triangle(), "/accessors/1/componentType", json!(5126)),
            &["indices", "SCALAR unsigned"],
        ),
        (
            with(triangle(), "/accessors/0/type", json!("VEC2")),
            &["attributes.POSITION", "VEC3 of floats"],
        ),
        (
            with(triangle(), "/accessors/0/componentType", json!(5121)),
            &["attributes.POSITION", "VEC3 of floats"],
        ),
        (
            with(
                triangle(),
                "/meshes/0/primitives/0/attributes",
                json!({"POSITION": 0, "NORMAL": 1}),
            ),
            &["attributes.NORMAL", "VEC3 of floats"],
        ),
        (
            with(
                triangle(),
                "/meshes/0/primitives/0/attributes",
                json!({"POSITION": 0, "TEXCOORD_0": 0}),
            ),
            &["attributes.TEXCOORD_0", "VEC2"],
        ),
        // More elements than the buffer view holds.
        (
            with(triangle(), "/accessors/0/count", json!(1000)),
            &["accessors[0]", "buffer view 0 has 36"],
        ),
        (
            with(triangle(), "/accessors/0/count", json!(0)),
            &["accessors[0].count", "at least 1"],
        ),
        (
            with(triangle(), "/accessors/0/byteOffset", json!(2)),
            &["accessors[0].byteOffset", "multiple of the 4-byte"],
        ),
        // A stride shorter than the element: gltf sliced past it.
        (
            with(triangle(), "/bufferViews/0/byteStride", json!(4)),
            &["bufferViews[0].byteStride", "at least the 12-byte"],
        ),
        (
            with(triangle(), "/bufferViews/1/byteOffset", json!(40)),
            &["bufferViews[1]", "past the end of buffer 0"],
        ),
        (
            with(triangle(), "/accessors/1/count", json!(2)),
            &["indices", "multiple of 3"],
        ),
        (
            with(
                triangle(),
                "/accessors/1/sparse",
                json!({"count": 1, "indices": {"bufferView": 1, "componentType": 5126}, "values": {"bufferView": 1}}),
            ),
            &["accessors[1].sparse.indices.componentType"],
        ),
    ];
    for (v, needles) in cases {
        let e = error(d, &v);
        for n in needles {
            assert!(e.contains(n), "{e}\n  lacks: {n}");
        }
    }
    // Attributes of different counts.
    let mut v = triangle();
    v["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}));
    v["meshes"][0]["primitives"][0]["attributes"] = json!({"POSITION": 0, "NORMAL": 2});
    assert!(error(d, &v).contains("the same count"));
}

#[test]
fn node_graphs_with_cycles_depth_or_blow_up_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A node that is its own child (spun forever before; with a mesh, a 3 GB allocation).
    let v = with(triangle(), "/nodes/0/children", json!([0]));
    assert!(error(d, &v).contains("cycle"));
    let mut v = triangle();
    v["nodes"] = json!([{"children": [1]}, {"mesh": 0, "children": [0]}]);
    assert!(error(d, &v).contains("nodes[0] is its own descendant"));
    // A chain 100 nodes deep.
    let mut v = triangle();
    v["nodes"] = Value::Array(
        (0..100)
            .map(|k| {
                if k < 99 {
                    json!({"children": [k + 1]})
                } else {
                    json!({"mesh": 0})
                }
            })
            .collect(),
    );
    assert!(error(d, &v).contains("levels deep; expected at most 64"));
    // 24 levels of nodes with two edges to the next: 2^24 instances of the last.
    let mut v = triangle();
    v["nodes"] = Value::Array(
        (0..24)
            .map(|k| {
                if k < 23 {
                    json!({"children": [k + 1, k + 1]})
                } else {
                    json!({"mesh": 0})
                }
            })
            .collect(),
    );
    assert!(error(d, &v).contains("node instances"));
    // 2^15 instances (within that limit) of a mesh of 3000 triangles: 98 million triangles,
    // refused from the accessor counts before any is read.
    let mut v = triangle();
    v["nodes"] = Value::Array(
        (0..16)
            .map(|k| {
                if k < 15 {
                    json!({"children": [k + 1, k + 1]})
                } else {
                    json!({"mesh": 0})
                }
            })
            .collect(),
    );
    let mut bytes = triangle_bytes()[..36].to_vec();
    for k in 0..9000u16 {
        bytes.extend_from_slice(&(k % 3).to_le_bytes());
    }
    v["buffers"][0] = json!({"byteLength": bytes.len(), "uri": format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    )});
    v["bufferViews"][1]["byteLength"] = json!(18000);
    v["accessors"][1]["count"] = json!(9000);
    let e = error(d, &v);
    assert!(
        e.contains("98304000 triangles; expected at most 67108864"),
        "{e}"
    );
}

#[test]
fn buffer_uris_must_be_data_or_regular_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // An invalid %-escape: gltf 1.4.1 unwrapped the decoding error.
    let v = with(triangle(), "/buffers/0/uri", json!("buf%FF.bin"));
    assert!(error(d, &v).contains("buffers[0].uri"));
    // A device or a folder is not a buffer (reading /dev/zero never ended).
    for uri in ["/dev/zero", "."] {
        let v = with(triangle(), "/buffers/0/uri", json!(uri));
        assert!(error(d, &v).contains("not a regular file"), "{uri}");
    }
    let v = with(triangle(), "/buffers/0/byteLength", json!(4000));
    assert!(error(d, &v).contains("byteLength declares 4000"));
    // A file buffer is read up to its byteLength.
    std::fs::write(d.join("t.bin"), triangle_bytes()).unwrap();
    let p = d.join("f.gltf");
    std::fs::write(
        &p,
        with(triangle(), "/buffers/0/uri", json!("t.bin")).to_string(),
    )
    .unwrap();
    assert_eq!(load_gltf(&p).unwrap().mesh.indices.len(), 1);
}

#[test]
fn documents_serde_json_cannot_parse_are_refused_before_the_gltf_crate() {
    // An unknown key with invalid UTF-8 hides "accessors": the gltf crate skipped the key
    // and its validation indexed the missing accessors (a panic, found by fuzzing).
    let dir = tempfile::tempdir().unwrap();
    let text = triangle()
        .to_string()
        .replace("\"accessors\"", "\"acc\u{1}essors\"");
    let mut bytes = text.into_bytes();
    let k = bytes.iter().position(|&b| b == 1).unwrap();
    bytes[k] = 0xff;
    let p = dir.path().join("m.gltf");
    std::fs::write(&p, bytes).unwrap();
    let e = load_gltf(&p).err().expect("refused").to_string();
    assert!(e.contains("m.gltf") && e.contains("invalid JSON"), "{e}");
}

#[test]
fn vertices_beyond_the_coordinate_limit_are_refused() {
    // Coordinates near 1e37 (finite) made the BVH build's costs NaN (found by fuzzing).
    let dir = tempfile::tempdir().unwrap();
    let mut b = triangle_bytes();
    b[12..16].copy_from_slice(&1e37f32.to_le_bytes());
    let mut v = triangle();
    v["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&b)
    ));
    let e = error(dir.path(), &v);
    assert!(e.contains("vertex 1") && e.contains("within 1e9"), "{e}");
    let obj = dir.path().join("m.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let e = lobe_renderer::scene::mesh_io::load_obj(&obj)
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertex 1") && e.contains("within 1e9"), "{e}");
}
