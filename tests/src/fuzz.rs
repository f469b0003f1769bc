//! Fuzz targets for every reader, shared by the cargo-fuzz targets of `fuzz/`
//! (libFuzzer, nightly: `scripts/fuzz.sh`) and by the stable mutation test
//! `tests/tests/fuzz_smoke.rs` that CI runs. Each target takes arbitrary bytes and a scratch
//! folder and must return (an error is fine) without panicking, hanging or allocating
//! without bound; readers that take a path get the bytes written to a scratch file.
//! [`seeds`] makes a valid seed corpus for each target programmatically.

use lobe_materials::measured::binned::{Axis, Binned};
use lobe_materials::measured::merl::Merl;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value};
use serde_json::{Value, json};
use std::path::Path;

/// The targets, by name.
pub const TARGETS: &[&str] = &[
    "scene_json",
    "merl",
    "binned",
    "rgl",
    "fit_json",
    "obj",
    "ply",
    "gltf",
    "envmap_exr",
    "envmap_hdr",
    "partial_render",
];

/// Runs target `name` on `data`. A panic that [`lobe_materials::guard`] caught inside a
/// third-party reader is a failure too: the guard is the last line of defence, each input
/// reaching it needs a proper check.
pub fn run(name: &str, data: &[u8], scratch: &Path) {
    let caught = lobe_materials::guard::caught_panics();
    run_target(name, data, scratch);
    assert_eq!(
        lobe_materials::guard::caught_panics(),
        caught,
        "a third-party reader panicked (caught by the guard)"
    );
}

fn run_target(name: &str, data: &[u8], scratch: &Path) {
    match name {
        "scene_json" => scene_json(data, scratch),
        "merl" => merl(data),
        "binned" => binned(data),
        "rgl" => rgl(data, scratch),
        "fit_json" => fit_json(data, scratch),
        "obj" => mesh(data, scratch, "m.obj", "obj"),
        "ply" => mesh(data, scratch, "m.ply", "ply"),
        "gltf" => mesh(data, scratch, "m.gltf", "gltf"),
        "envmap_exr" => envmap(data, scratch, "e.exr"),
        "envmap_hdr" => envmap(data, scratch, "e.hdr"),
        "partial_render" => partial_render(data),
        _ => panic!("unknown fuzz target {name}"),
    }
}

fn dirs() -> [(glam::Vec3, glam::Vec3); 3] {
    [
        (glam::Vec3::Z, glam::Vec3::Z),
        (
            glam::Vec3::new(0.6, 0.0, 0.8),
            glam::Vec3::new(-0.6, 0.0, 0.8),
        ),
        (
            glam::Vec3::new(0.0, 0.99, 0.141),
            glam::Vec3::new(0.3, -0.9, 0.316),
        ),
    ]
}

/// Loads the scene; renders it when it is tiny (so that a fuzzed film size cannot hang).
fn load_and_render(v: &Value, scratch: &Path) {
    if let Ok(mut scene) = from_value(v, "fuzz.json", scratch, &LoadOptions::with_builtins()) {
        let work = scene.settings.width as u64 * scene.settings.height as u64;
        if work <= 64 * 64 {
            scene.settings.spp = scene.settings.spp.min(2);
            let (img, _) = render(
                &scene,
                &RenderOptions {
                    threads: Some(1),
                    ..Default::default()
                },
            )
            .expect("a loaded scene renders");
            assert!(img.pixels.iter().all(|p| p.is_finite()), "non-finite pixel");
        }
    }
}

pub fn scene_json(data: &[u8], scratch: &Path) {
    if let Ok(v) = serde_json::from_slice::<Value>(data) {
        load_and_render(&v, scratch);
    }
}

pub fn merl(data: &[u8]) {
    if let Ok(t) = Merl::from_bytes(data, "fuzz.binary") {
        for (wi, wo) in dirs() {
            assert!(t.lookup(wi, wo).is_finite());
            let _ = t.measured(wi, wo);
        }
    }
}

pub fn binned(data: &[u8]) {
    if let Ok(t) = Binned::from_bytes(data, "fuzz.bin") {
        for (wi, wo) in dirs() {
            assert!(t.lookup(wi, wo).is_finite());
        }
    }
}

/// A partial render (`.lobepart`): read, merged with itself shifted to the next range
/// when it is short, and turned into an image when complete; no pixel may be non-finite.
pub fn partial_render(data: &[u8]) {
    use lobe_renderer::partial::PartialRender;
    let Ok(p) = PartialRender::from_bytes(data, "fuzz.lobepart") else {
        return;
    };
    if let Ok(img) = p.image() {
        assert!(
            img.pixels
                .iter()
                .chain(&img.variance)
                .all(|c| c.is_finite())
        );
    }
    let _ = PartialRender::merge(vec![p.clone(), p]);
}

fn write(scratch: &Path, name: &str, data: &[u8]) -> std::path::PathBuf {
    let p = scratch.join(name);
    std::fs::write(&p, data).expect("scratch file");
    p
}

pub fn rgl(data: &[u8], scratch: &Path) {
    let p = write(scratch, "f.bsdf", data);
    let reg = Registry::builtin();
    let ctx = BuildContext::new(scratch, &reg);
    if let Ok(b) = reg.create_with(
        &json!({"type": "rgl", "file": p.display().to_string()}),
        "m",
        &ctx,
    ) {
        for (wi, wo) in dirs() {
            assert!(b.eval(wo, wi).is_finite());
            let _ = b.sample(wo, glam::Vec2::new(0.3, 0.7), 0.5);
        }
    }
}

pub fn fit_json(data: &[u8], scratch: &Path) {
    let p = write(scratch, "r.fit.json", data);
    let reg = Registry::builtin();
    let ctx = BuildContext::new(scratch, &reg);
    for model in ["ward", "cook-torrance", "he", "lafortune-2"] {
        let d = json!({"type": "fit", "file": p.display().to_string(), "model": model});
        if let Ok(b) = reg.create_with(&d, "m", &ctx) {
            for (wi, wo) in dirs() {
                assert!(b.eval(wo, wi).is_finite());
            }
        }
    }
}

pub fn mesh(data: &[u8], scratch: &Path, file: &str, kind: &str) {
    write(scratch, file, data);
    let v = json!({
        "camera": {"type": "perspective", "origin": [0, 0, 5], "target": [0, 0, 0]},
        "film": {"width": 8, "height": 8},
        "sampler": {"spp": 1},
        "shapes": [{"type": kind, "file": file}],
        "lights": [{"type": "constant"}]
    });
    load_and_render(&v, scratch);
}

pub fn envmap(data: &[u8], scratch: &Path, file: &str) {
    write(scratch, file, data);
    let v = json!({
        "camera": {"type": "perspective", "origin": [0, 0, 5], "target": [0, 0, 0]},
        "film": {"width": 8, "height": 8},
        "sampler": {"spp": 2},
        "shapes": [{"type": "sphere"}],
        "lights": [{"type": "envmap", "file": file}]
    });
    load_and_render(&v, scratch);
}

/// A tetrahedron as a PLY file in `format`: float positions and normals, a colour,
/// triangles and a quad as `uchar int` lists.
fn ply_tetrahedron(format: &str) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n\
         element face 3\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    let v = [
        [0.0f32, 0.0, 1.0],
        [1.0, 0.0, -0.5],
        [-1.0, 0.5, -0.5],
        [0.0, -1.0, -0.5],
    ];
    let faces: [&[i32]; 3] = [&[0, 1, 2], &[0, 2, 3], &[0, 3, 1, 2]];
    let big = format == "binary_big_endian";
    for p in v {
        let vals = [p[0], p[1], p[2], p[0], p[1], p[2]];
        if format == "ascii" {
            let line: Vec<String> = vals.iter().map(f32::to_string).collect();
            out.extend(format!("{} 200\n", line.join(" ")).bytes());
        } else {
            for x in vals {
                out.extend(if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            out.push(200);
        }
    }
    for f in faces {
        if format == "ascii" {
            let line: Vec<String> = f.iter().map(i32::to_string).collect();
            out.extend(format!("{} {}\n", f.len(), line.join(" ")).bytes());
        } else {
            out.push(f.len() as u8);
            for &i in f {
                out.extend(if big {
                    i.to_be_bytes()
                } else {
                    i.to_le_bytes()
                });
            }
        }
    }
    out
}

/// A valid seed corpus for each target.
pub fn seeds(name: &str) -> Vec<Vec<u8>> {
    let scene = json!({
        "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
        "film": {"width": 8, "height": 6},
        "sampler": {"spp": 2},
        "materials": {"m": {"type": "cook-torrance", "diffuse": 0.2, "specular": 0.5, "m": 0.2}},
        "shapes": [{"type": "sphere", "material": "m"}, {"type": "rectangle", "to_world": [{"scale": 3}, {"translate": [0, -1, 0]}]}],
        "lights": [{"type": "envmap", "file": "builtin:studio"}, {"type": "point", "position": [0, 3, 0], "intensity": 5}]
    });
    match name {
        "scene_json" => {
            let mut v = vec![serde_json::to_vec_pretty(&scene).expect("json")];
            if let Ok(rd) = std::fs::read_dir(crate::workspace().join("scenes")) {
                let mut files: Vec<_> = rd
                    .flatten()
                    .map(|e| e.path())
                    .filter(|p| p.extension().is_some_and(|e| e == "json"))
                    .collect();
                files.sort();
                v.extend(files.iter().filter_map(|p| std::fs::read(p).ok()));
            }
            v
        }
        "merl" => {
            // A full table is 35 MB; the seeds are its header and one real table.
            let t = Merl::from_fn(|wi, wo, _| Some([wi.z as f64 * 0.1, wo.z as f64 * 0.1, 0.05]));
            let bytes = t.to_bytes();
            vec![bytes[..12].to_vec(), bytes]
        }
        "binned" => binned_seeds(),
        "rgl" => {
            // The real files when present (read-only), else a tensor-file header.
            let mut v = vec![b"tensor_file\0\x01\x00\x00\x00\x00\x00".to_vec()];
            if let Some(d) = crate::shared_data()
                && let Ok(rd) = std::fs::read_dir(d.join("rgl"))
            {
                let mut files: Vec<_> = rd.flatten().map(|e| e.path()).collect();
                files.sort();
                v.extend(files.iter().filter_map(|p| std::fs::read(p).ok()));
            }
            v
        }
        "fit_json" => fit_json_seeds(),
        "obj" => {
            let mut v = vec![
                b"v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\nf 1 3 4\n"
                    .to_vec(),
            ];
            v.extend(std::fs::read(
                crate::workspace().join("scenes/meshes/bunny.obj"),
            ));
            v
        }
        "ply" => ["ascii", "binary_little_endian", "binary_big_endian"]
            .map(ply_tetrahedron)
            .to_vec(),
        "gltf" => gltf_seeds(),
        "envmap_exr" => {
            let dir = tempfile::tempdir().expect("tempdir");
            let p = dir.path().join("e.exr");
            let px: Vec<lobe_materials::Rgb> = (0..32)
                .map(|k| lobe_materials::Rgb::new(k as f32 * 0.1, 0.5, 1.0))
                .collect();
            lobe_renderer::image_io::write_exr(&p, 8, 4, &px).expect("exr");
            let mut v = vec![std::fs::read(p).expect("read")];
            v.extend(std::fs::read(
                crate::workspace().join("scenes/envmaps/studio-512.exr"),
            ));
            v
        }
        "envmap_hdr" => {
            let mut v = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n".to_vec();
            for k in 0..32u8 {
                v.extend_from_slice(&[128 + k, 100, 50, 129]);
            }
            vec![v]
        }
        "partial_render" => {
            let scene = from_value(
                &scene,
                "seed.json",
                Path::new("."),
                &LoadOptions::with_builtins(),
            )
            .expect("the seed scene loads");
            let opts = RenderOptions::default();
            [(0, 1), (0, 2)]
                .iter()
                .map(|&r| {
                    let (p, _) =
                        lobe_renderer::render::render_samples(&scene, r, &opts).expect("renders");
                    p.to_bytes()
                })
                .collect()
        }
        _ => panic!("unknown fuzz target {name}"),
    }
}

/// Seeds of the binned-data reader: an anisotropic table with every third bin set, and an
/// isotropic one with missing bins.
fn binned_seeds() -> Vec<Vec<u8>> {
    let mut b = Binned::empty(
        true,
        vec![
            Axis::new(3, 0.0, 90.0),
            Axis::new(3, 0.0, 90.0),
            Axis::new(4, 0.0, 360.0),
            Axis::new(4, 0.0, 360.0),
        ],
    );
    for k in (0..b.len()).step_by(3) {
        b.values[k] = Some([0.1, 0.2, 0.3]);
    }
    let mut iso = Binned::empty(
        false,
        vec![
            Axis::new(6, 0.0, 90.0),
            Axis::new(6, 0.0, 90.0),
            Axis::new(8, 0.0, 180.0),
        ],
    );
    for k in 0..iso.len() {
        iso.values[k] = (k % 5 != 0).then_some([0.05, 0.1 * (k % 7) as f32, 2.0]);
    }
    vec![b.to_bytes(), iso.to_bytes()]
}

/// Seeds of the fit-file reader: a fit of four models, one of them a two-lobe composite.
fn fit_json_seeds() -> Vec<Vec<u8>> {
    vec![
        serde_json::to_vec(&{
            let fit = |m: serde_json::Value, e: f64| json!({"material": m, "error": e,
                "error_normalized": e * 4.0, "starts": 3, "starts_agreeing": 2,
                "evaluations": 100, "seconds": 0.1});
            json!({"format_version": 1, "material": "x", "source": "x.binary",
                "resolution_deg": 1, "samples": 1000, "max_albedo": 0.25, "models": {
                "ward": fit(json!({"type": "ward", "diffuse": 0.1, "specular": 0.2, "alpha": 0.2}), 0.01),
                "cook-torrance": fit(json!({"type": "cook-torrance", "diffuse": [0.1, 0.2, 0.3], "specular": 0.5, "m": 0.15}), 0.02),
                "he": fit(json!({"type": "he", "diffuse": 0.05, "specular": 1.2, "sigma0": 0.3, "tau": 4, "eta": 1.6}), 0.02),
                "lafortune-2": fit(json!({"type": "composite", "diffuse": 0.1, "lobes": [
                    {"type": "lafortune", "specular": 0.3, "cx": -0.7, "cy": -0.7, "cz": 0.6, "n": 20},
                    {"type": "lafortune", "specular": 0.1, "cx": -0.3, "cy": -0.3, "cz": 0.9, "n": 3}]}), 0.03)
            }})
        })
        .expect("json"),
    ]
}

/// Seeds of the glTF reader: one triangle with an embedded base64 buffer (3 VEC3 floats +
/// 3 u16 indices), the same as a GLB with a BIN chunk, and the repository's glTF stage as
/// a GLB.
fn gltf_seeds() -> Vec<Vec<u8>> {
    let triangle = br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0,"translation":[0,0,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
"buffers":[{"byteLength":42,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIA"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#
        .to_vec();
    let mut v = vec![triangle.clone()];
    let mut doc: Value = serde_json::from_slice(&triangle).expect("json");
    let bin = base64_payload(&doc["buffers"][0]["uri"]);
    doc["buffers"][0] = json!({"byteLength": 42});
    v.push(glb(&doc, &bin));
    let stage = crate::workspace().join("scenes/meshes");
    if let (Ok(text), Ok(bin)) = (
        std::fs::read(stage.join("bunny-stage.gltf")),
        std::fs::read(stage.join("bunny-stage.bin")),
    ) && let Ok(mut doc) = serde_json::from_slice::<Value>(&text)
    {
        doc["buffers"][0] = json!({"byteLength": bin.len()});
        v.push(glb(&doc, &bin));
    }
    v
}

/// The bytes of a base64 `data:` URI.
fn base64_payload(uri: &Value) -> Vec<u8> {
    use base64::Engine;
    let s = uri.as_str().expect("a uri");
    let (_, b) = s.split_once(";base64,").expect("base64");
    base64::engine::general_purpose::STANDARD
        .decode(b)
        .expect("base64")
}

/// A GLB container of a glTF document and its BIN chunk.
pub fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = doc.to_string().into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Deterministic mutations of `seed` (bit flips, byte overwrites, truncations, insertions,
/// duplications of a slice), `n` of them, from a xorshift stream keyed by `key`.
pub fn mutations(seed: &[u8], n: usize, key: u64) -> Vec<Vec<u8>> {
    let mut s = key.wrapping_mul(0x9e3779b97f4a7c15) | 1;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let interesting: [u8; 8] = [0, 1, 0x7f, 0x80, 0xff, b'-', b'9', b'e'];
    (0..n)
        .map(|_| {
            let mut m = seed.to_vec();
            for _ in 0..1 + next() % 4 {
                let len = m.len().max(1);
                let at = (next() as usize) % len;
                match next() % 6 {
                    0 if !m.is_empty() => m[at] ^= 1 << (next() % 8),
                    1 if !m.is_empty() => m[at] = interesting[(next() % 8) as usize],
                    2 => m.truncate(at),
                    3 => m.insert(at.min(m.len()), interesting[(next() % 8) as usize]),
                    4 if m.len() > 8 => {
                        let end = (at + 1 + (next() as usize) % 16).min(m.len());
                        let chunk = m[at..end].to_vec();
                        let to = (next() as usize) % m.len();
                        m.splice(to..to, chunk);
                    }
                    _ if !m.is_empty() => {
                        // A JSON-ish number swap: an extreme value at a digit.
                        if m[at].is_ascii_digit() {
                            let big = b"1e308";
                            m.splice(at..at + 1, big.iter().cloned());
                        } else {
                            m[at] = m[at].wrapping_add(1);
                        }
                    }
                    _ => {}
                }
            }
            m
        })
        .collect()
}
