//! Scene files: every file in scenes/ loads and renders without a non-finite sample, and
//! every kind of bad input gives a one-line error naming the file, the JSON path and what
//! was expected, never a panic.

use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value, load};
use serde_json::{Value, json};
use std::path::Path;

#[test]
fn every_shipped_scene_loads_and_renders() {
    let dir = lobe_tests::workspace().join("scenes");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("json") {
            continue;
        }
        if std::fs::read_to_string(&path)
            .unwrap()
            .contains("\"ngan-fit\"")
            && lobe_tests::shared_data().is_none()
        {
            lobe_tests::skip_without_data(&format!(
                "loading {} (Ngan et al. fits)",
                path.display()
            ));
            continue;
        }
        let mut scene = load(&path).unwrap_or_else(|e| panic!("{e}"));
        scene.settings.spp = 2;
        let (img, stats) = render(&scene, &RenderOptions::default()).unwrap();
        assert_eq!(stats.nonfinite_dropped, 0, "{}", path.display());
        assert!(
            img.mean().max_component() > 0.0,
            "{} renders black",
            path.display()
        );
        n += 1;
    }
    assert!(n >= 4, "expected the shipped scenes, found {n}");
}

fn base() -> Value {
    json!({
        "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
        "film": {"width": 8, "height": 8},
        "shapes": [{"type": "sphere", "radius": 1}],
        "lights": [{"type": "constant"}]
    })
}

fn error_of(v: Value) -> String {
    let dir = lobe_tests::workspace().join("scenes");
    match std::panic::catch_unwind(|| {
        from_value(&v, "bad.json", &dir, &LoadOptions::with_builtins())
    }) {
        Ok(Ok(_)) => panic!("scene {v} was accepted"),
        Ok(Err(e)) => e.to_string(),
        Err(_) => panic!("loading {v} panicked"),
    }
}

/// `v` with the value at `pointer` set (created if its parent object lacks it).
fn with(mut v: Value, pointer: &str, x: Value) -> Value {
    let (parent, key) = pointer.rsplit_once('/').expect("a JSON pointer");
    let target = v.pointer_mut(parent).unwrap_or_else(|| panic!("{parent}"));
    match target {
        Value::Object(m) => {
            m.insert(key.to_string(), x);
        }
        Value::Array(a) => a[key.parse::<usize>().unwrap()] = x,
        _ => panic!("{parent} is not a container"),
    }
    v
}

#[test]
fn bad_values_are_named_by_file_path_and_expectation() {
    for (v, needles) in [settings_cases(), world_cases(), light_and_document_cases()].concat() {
        let e = error_of(v.clone());
        assert!(!e.contains('\n'), "error is not one line: {e}");
        for n in needles {
            assert!(e.contains(n), "error for {v}\n  was: {e}\n  lacks: {n}");
        }
    }
}

/// A scene with a bad sphere radius, film, sampler or camera, and what its error must say.
fn settings_cases() -> Vec<(Value, &'static [&'static str])> {
    vec![
        (
            with(base(), "/shapes/0/radius", json!(-1)),
            &["bad.json: shapes[0].radius: expected a positive radius, found -1"],
        ),
        (
            with(base(), "/shapes/0/radius", json!("big")),
            &["shapes[0].radius", "expected a positive radius", "\"big\""],
        ),
        (
            with(base(), "/film/width", json!(0)),
            &["film.width: expected an integer in [1, 16384], found 0"],
        ),
        (
            with(base(), "/film/width", json!(10.5)),
            &["film.width", "integer"],
        ),
        (
            with(base(), "/sampler", json!({"spp": 4, "scramble": "sobol"})),
            &["bad.json: sampler.scramble: expected one of xor, owen, found \"sobol\""],
        ),
        (
            with(base(), "/camera/fov", json!(200)),
            &["camera.fov", "(0, 180)", "200"],
        ),
        (
            with(base(), "/camera/type", json!("fisheye")),
            &["camera.type", "perspective", "orthographic", "fisheye"],
        ),
        (
            with(base(), "/camera/origin", json!([0, 0])),
            &["camera.origin", "3 finite numbers", "2 elements"],
        ),
        (
            with(base(), "/camera/target", json!([0, 0, 4])),
            &["camera", "degenerate"],
        ),
    ]
}

/// A scene with a bad shape or material, and what its error must say.
fn world_cases() -> Vec<(Value, &'static [&'static str])> {
    vec![
        (
            with(base(), "/shapes/0/type", json!("torus")),
            &["shapes[0].type", "sphere", "\"torus\""],
        ),
        (
            with(base(), "/shapes/0/material", json!("nope")),
            &["shapes[0].material", "unknown material \"nope\""],
        ),
        (
            with(
                base(),
                "/shapes/0/material",
                json!({"type": "lambert", "reflectance": 2}),
            ),
            &["shapes[0].material.reflectance", "[0, 1]", "2"],
        ),
        (
            with(base(), "/shapes/0/material", json!({"type": "plastic"})),
            &[
                "shapes[0].material.type",
                "unknown material type \"plastic\"",
                "lambert",
            ],
        ),
        (
            with(
                base(),
                "/shapes/0/material",
                json!({"type": "lambert", "albedo": 0.5}),
            ),
            &[
                "shapes[0].material.albedo",
                "unknown parameter",
                "reflectance",
            ],
        ),
        (
            with(base(), "/shapes/0/material", json!(3)),
            &["shapes[0].material", "material name or a material object"],
        ),
    ]
}

/// A scene with a bad light, integrator, mesh file, transform or emitter (or a bad
/// document), and what its error must say.
fn light_and_document_cases() -> Vec<(Value, &'static [&'static str])> {
    vec![
        (
            with(
                base(),
                "/lights/0",
                json!({"type": "constant", "radiance": -1}),
            ),
            &["lights[0].radiance", "non-negative colour"],
        ),
        (
            with(base(), "/lights/0", json!({"type": "spot"})),
            &["lights[0].type", "envmap", "\"spot\""],
        ),
        (
            with(
                base(),
                "/lights/0",
                json!({"type": "envmap", "file": "missing.exr"}),
            ),
            &["lights[0].file", "does not exist"],
        ),
        (
            with(
                base(),
                "/lights/0",
                json!({"type": "envmap", "file": "builtin:nowhere"}),
            ),
            &["lights[0].file", "unknown built-in image", "studio"],
        ),
        (
            with(
                base(),
                "/lights/0",
                json!({"type": "envmap", "file": "builtin:studio", "to_world": {"scale": 2}}),
            ),
            &["lights[0].to_world", "rotation"],
        ),
        (
            with(
                base(),
                "/lights/0",
                json!({"type": "directional", "direction": [0, 0, 0], "irradiance": 1}),
            ),
            &["lights[0].direction", "non-zero"],
        ),
        (
            with(
                base(),
                "/lights/0",
                json!({"type": "point", "position": [0, 1, 0]}),
            ),
            &["lights[0]", "missing key \"intensity\""],
        ),
        (
            with(base(), "/integrator", json!({"type": "bdpt"})),
            &["integrator.type", "\"path\" or \"direct\"", "\"bdpt\""],
        ),
        (
            with(
                base(),
                "/integrator",
                json!({"type": "path", "max_depth": 0}),
            ),
            &["integrator.max_depth", "-1", "0"],
        ),
        (
            with(
                base(),
                "/shapes/0",
                json!({"type": "obj", "file": "nothing.obj"}),
            ),
            &["shapes[0].file", "does not exist"],
        ),
        (
            with(
                base(),
                "/shapes/0",
                json!({"type": "rectangle", "to_world": {"scale": [1, 0, 1]}}),
            ),
            &["shapes[0].to_world", "non-zero"],
        ),
        (
            with(
                base(),
                "/shapes/0",
                json!({"type": "rectangle", "to_world": {"rotate": {"axis": [0, 0, 0], "angle": 3}}}),
            ),
            &["shapes[0].to_world.rotate.axis", "non-zero"],
        ),
        (
            with(
                base(),
                "/shapes/0",
                json!({"type": "rectangle", "to_world": [{"translate": [1, 2, 3], "scale": 2}]}),
            ),
            &["shapes[0].to_world[0]", "exactly one"],
        ),
        (
            with(
                base(),
                "/shapes/0",
                json!({"type": "sphere", "emitter": {"type": "area"}}),
            ),
            &["shapes[0].emitter", "missing key \"radiance\""],
        ),
        (json!({"shapes": []}), &["bad.json: camera: missing"]),
        (
            json!({"camera": {"type": "perspective"}, "colour": 1}),
            &["bad.json: colour: unknown key", "camera, film"],
        ),
        (json!([1, 2]), &["bad.json", "expected an object", "array"]),
    ]
}

#[test]
fn bad_files_give_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str, content: &[u8]| {
        let path = tmp.path().join(name);
        std::fs::write(&path, content).unwrap();
        path
    };
    let msg = |path: &Path| match std::panic::catch_unwind(|| load(path)) {
        Ok(Ok(_)) => panic!("{} was accepted", path.display()),
        Ok(Err(e)) => e.to_string(),
        Err(_) => panic!("{} panicked", path.display()),
    };
    assert!(msg(&p("empty.json", b"  \n")).contains("is empty"));
    let e = msg(&p("syntax.json", b"{\"camera\": {,}}"));
    assert!(
        e.contains("syntax.json") && e.contains("invalid JSON") && e.contains("line 1"),
        "{e}"
    );
    assert!(msg(tmp.path()).contains("is a directory"));
    assert!(msg(&tmp.path().join("absent.json")).contains("cannot read"));
    // A broken OBJ and a broken glTF referenced by a scene.
    p("broken.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 7\n");
    p("garbage.gltf", b"{ not gltf");
    p("bad-env.exr", b"not an exr");
    let scene = |shape: Value| {
        let mut v = base();
        v["shapes"] = json!([shape]);
        p("s.json", v.to_string().as_bytes())
    };
    let e = msg(&scene(json!({"type": "obj", "file": "broken.obj"})));
    assert!(e.contains("broken.obj"), "{e}");
    p(
        "broken.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
    );
    let e = msg(&scene(json!({"type": "ply", "file": "broken.ply"})));
    assert!(e.contains("broken.ply") && e.contains("vertex 0"), "{e}");
    let e = msg(&scene(json!({"type": "gltf", "file": "garbage.gltf"})));
    assert!(e.contains("garbage.gltf") && e.contains("glTF"), "{e}");
    let mut v = base();
    v["lights"] = json!([{"type": "envmap", "file": "bad-env.exr"}]);
    let e = msg(&p("env.json", v.to_string().as_bytes()));
    assert!(e.contains("bad-env.exr") && e.contains("OpenEXR"), "{e}");
}

#[test]
fn named_materials_may_be_composites_and_names_are_unique() {
    let tmp = tempfile::tempdir().unwrap();
    let two_coat = json!({"type": "composite", "diffuse": 0.1, "lobes": [
        {"type": "cook-torrance", "specular": 0.2, "m": 0.05},
        {"type": "cook-torrance", "specular": 0.3, "m": 0.3}]});
    let mut v = base();
    v["materials"] = json!({"two-coat": two_coat});
    v["shapes"][0]["material"] = json!("two-coat");
    let scene = from_value(&v, "c.json", tmp.path(), &LoadOptions::with_builtins()).unwrap();
    assert_eq!(scene.world.shapes[0].material.name(), "composite");
    // A bad lobe of a named composite is named by its path.
    v["materials"]["two-coat"]["lobes"][1]["m"] = json!(-1);
    let e = error_of(v);
    assert!(e.contains("materials.two-coat.lobes[1].m"), "{e}");
    // Two materials of one name: an error naming the file and the name, not the last one.
    let path = tmp.path().join("dup.json");
    let text = base().to_string().replacen(
        "{",
        r#"{"materials": {"m": {"type": "lambert"}, "m": {"type": "ward", "alpha": 0.1}},"#,
        1,
    );
    std::fs::write(&path, text).unwrap();
    let e = load(&path)
        .err()
        .expect("a duplicate name is an error")
        .to_string();
    assert!(
        e.contains("dup.json") && e.contains("materials.m") && e.contains("given twice"),
        "{e}"
    );
}

#[test]
fn json_numbers_must_be_finite() {
    let tmp = tempfile::tempdir().unwrap();
    for (k, bad) in ["1e400", "NaN", "-Infinity"].iter().enumerate() {
        let path = tmp.path().join(format!("n{k}.json"));
        let text = format!("{{\"camera\": {{\"type\": \"perspective\",\n \"fov\": {bad}}}}}");
        std::fs::write(&path, text).unwrap();
        let e = load(&path).err().expect("accepted").to_string();
        assert!(
            e.contains(&format!("n{k}.json: line 2, column"))
                && e.contains("JSON numbers must be finite"),
            "{e}"
        );
    }
}

#[test]
fn scene_inputs_list_every_file_the_scene_reads() {
    use lobe_renderer::scene::inputs::inputs;
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::create_dir(d.join("meshes")).unwrap();
    std::fs::write(
        d.join("meshes/m.gltf"),
        r#"{"buffers": [{"uri": "m.bin", "byteLength": 4}, {"uri": "data:,x", "byteLength": 1}]}"#,
    )
    .unwrap();
    std::fs::write(
        d.join("r.fit.json"),
        r#"{"material": "r", "source": "r.binary", "resolution_deg": 1, "samples": 1, "max_albedo": 1,
            "models": {"x": {"material": {"type": "merl", "file": "in-report.binary"},
            "error": 0, "error_normalized": 0, "starts": 1, "starts_agreeing": 1, "evaluations": 1, "seconds": 0}}}"#,
    )
    .unwrap();
    let v = json!({
        "materials": {
            "used": {"type": "binned", "file": "t.bin"},
            "unused": {"type": "fit", "file": "r.fit.json", "model": "x"},
            "gen": {"type": "sampled-microfacet", "distribution": "p.exr"},
            "analytic": {"type": "ward"}
        },
        "shapes": [
            {"type": "gltf", "file": "meshes/m.gltf", "material": "used"},
            {"type": "obj", "file": "/abs/bunny.obj", "material": {"type": "rgl", "file": "x.bsdf"}}
        ],
        "lights": [{"type": "envmap", "file": "env.exr"}, {"type": "envmap", "file": "builtin:studio"}]
    });
    let scene = d.join("s.json");
    std::fs::write(&scene, v.to_string()).unwrap();
    let found: Vec<(String, String)> = inputs(&scene)
        .unwrap()
        .into_iter()
        .map(|i| {
            let p = i
                .path
                .strip_prefix(d)
                .unwrap_or(&i.path)
                .display()
                .to_string();
            (p, i.role)
        })
        .collect();
    let paths: Vec<&str> = found.iter().map(|f| f.0.as_str()).collect();
    for want in [
        "s.json",
        "env.exr",
        "meshes/m.gltf",
        "meshes/m.bin",
        "/abs/bunny.obj",
        "x.bsdf",
        "t.bin",
        "r.fit.json",
        "p.exr",
    ] {
        assert!(paths.contains(&want), "{want} missing from {found:?}");
    }
    // A report is followed only to what a report may hold (an analytic model or a
    // composite, which read no file): its `merl` model is refused when built, never read.
    assert!(!paths.contains(&"in-report.binary"), "{found:?}");
    assert_eq!(paths.len(), 9, "{found:?}");
    let role = |p: &str| &found.iter().find(|f| f.0 == p).unwrap().1;
    assert!(
        role("env.exr").starts_with("lights[0].file of"),
        "{found:?}"
    );
    assert!(role("t.bin").starts_with("materials.used of"), "{found:?}");
}

/// Every model that reads a file names it among its inputs (`Registry::inputs`), so that
/// commands can refuse to write over it: each model is built with its string parameters
/// naming absent files, and every path its error names must be one of its inputs.
#[test]
fn every_file_a_material_reads_is_among_its_inputs() {
    use lobe_materials::registry::{BuildContext, DefaultValue, ParamKind, Registry};
    let tmp = tempfile::tempdir().unwrap();
    let base = tmp.path().join("scene-folder");
    std::fs::create_dir(&base).unwrap();
    let reg = Registry::builtin();
    let mut reading = Vec::new();
    for name in reg.names().filter(|n| *n != "composite") {
        let schema = reg.schema(name).unwrap();
        let mut desc = json!({"type": name});
        for p in schema.params {
            match (p.kind, p.default) {
                (ParamKind::Text, _) => desc[p.name] = json!(format!("absent-{}", p.name)),
                (_, DefaultValue::Required) => panic!("{name}.{}: fill this in", p.name),
                _ => {}
            }
        }
        let ctx = BuildContext::new(&base, &reg);
        let Err(e) = reg.create_with(&desc, "m", &ctx) else {
            continue;
        };
        let e = e.to_string();
        if !e.contains(&base.display().to_string()) {
            continue;
        }
        let inputs = reg.inputs(&desc, &ctx);
        assert!(
            inputs.iter().any(|i| e.contains(&i.display().to_string())),
            "{name} reads a file its inputs {inputs:?} do not name: {e}"
        );
        reading.push(name);
    }
    for name in [
        "merl",
        "binned",
        "rgl",
        "fit",
        "sampled-microfacet",
        "ngan-fit",
    ] {
        assert!(reading.contains(&name), "{name} read no file: {reading:?}");
    }
}

/// The same mesh as OBJ, binary PLY (both byte orders) and ASCII PLY renders the same
/// image, bit for bit.
#[test]
fn a_mesh_renders_the_same_from_obj_and_ply() {
    let tmp = tempfile::tempdir().unwrap();
    let obj = lobe_tests::workspace().join("scenes/meshes/bunny.obj");
    let mesh = lobe_renderer::scene::mesh_io::load_obj(&obj).unwrap();
    let render = |shape: Value| {
        let mut v = base();
        v["shapes"] = json!([shape]);
        let path = tmp.path().join("s.json");
        std::fs::write(&path, v.to_string()).unwrap();
        let scene = load(&path).unwrap_or_else(|e| panic!("{e}"));
        let (img, _) =
            lobe_renderer::render::render(&scene, &lobe_renderer::render::RenderOptions::default())
                .unwrap();
        img.pixels
    };
    let reference = render(json!({"type": "obj", "file": obj.to_str().unwrap()}));
    for format in ["binary_little_endian", "binary_big_endian", "ascii"] {
        let path = tmp.path().join(format!("{format}.ply"));
        std::fs::write(&path, ply_bytes(&mesh, format)).unwrap();
        let img = render(json!({"type": "ply", "file": path.to_str().unwrap()}));
        assert!(img == reference, "{format}");
    }
}

/// `mesh` as a PLY file (positions, and triangles as `uchar uint` lists).
fn ply_bytes(mesh: &lobe_renderer::geometry::Mesh, format: &str) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    )
    .into_bytes();
    let big = format == "binary_big_endian";
    for p in &mesh.positions {
        match format {
            // Shortest round-trip decimal: the same f32 back.
            "ascii" => out.extend(format!("{} {} {}\n", p.x, p.y, p.z).bytes()),
            _ => {
                for c in p.to_array() {
                    out.extend(if big {
                        c.to_be_bytes()
                    } else {
                        c.to_le_bytes()
                    });
                }
            }
        }
    }
    for t in &mesh.indices {
        match format {
            "ascii" => out.extend(format!("3 {} {} {}\n", t[0], t[1], t[2]).bytes()),
            _ => {
                out.push(3);
                for i in t {
                    out.extend(if big {
                        i.to_be_bytes()
                    } else {
                        i.to_le_bytes()
                    });
                }
            }
        }
    }
    out
}

#[test]
fn gltf_camera_and_node_transforms_are_used() {
    let path = lobe_tests::workspace().join("scenes/gltf-stage.json");
    let scene = load(&path).unwrap();
    // The camera comes from the glTF file: node at (0, 2.2, 6), pitched down 12 degrees.
    let ray = scene.camera.ray(glam::Vec2::splat(0.5));
    assert!(
        (ray.o - glam::Vec3::new(0.0, 2.2, 6.0)).length() < 0.05,
        "{:?}",
        ray.o
    );
    let pitch = ray.d.y.asin().to_degrees();
    assert!((pitch + 12.0).abs() < 0.1, "pitch {pitch}");
    // The floor quad is scaled by 3 (node) x 1.5 (stage): it spans x in [-4.5, 4.5].
    let down = lobe_renderer::geometry::Ray::new(glam::Vec3::new(4.4, 5.0, 0.0), glam::Vec3::NEG_Y);
    assert!(scene.world.geometry.intersect(&down).is_some());
    let outside =
        lobe_renderer::geometry::Ray::new(glam::Vec3::new(4.6, 5.0, 0.0), glam::Vec3::NEG_Y);
    assert!(scene.world.geometry.intersect(&outside).is_none());
}

#[test]
fn models_doc_has_the_current_parameter_reference() {
    let doc = std::fs::read_to_string(lobe_tests::workspace().join("docs/models.md")).unwrap();
    let start = doc.find("<!-- BEGIN lobe models -->\n").expect("marker")
        + "<!-- BEGIN lobe models -->\n".len();
    let end = doc.find("<!-- END lobe models -->").expect("marker");
    let generated = lobe_materials::registry::Registry::builtin().reference_markdown();
    assert!(
        doc[start..end] == generated,
        "docs/models.md is out of date: regenerate its reference with `lobe models`"
    );
}

/// The showcase names its five models: each label sits under its sphere (the sphere's
/// centre projects above it, within half a sphere spacing), left to right, inside the film.
#[test]
fn showcase_labels_name_each_sphere_below_it() {
    let scene = lobe_renderer::showcase::showcase().unwrap();
    let labels = lobe_renderer::showcase::labels(&scene);
    let names: Vec<&str> = labels.iter().map(|l| l.0.as_str()).collect();
    assert_eq!(
        names,
        [
            "cook-torrance",
            "ashikhmin-shirley",
            "ward-anisotropic",
            "he",
            "lafortune"
        ]
    );
    let film = glam::Vec2::new(scene.settings.width as f32, scene.settings.height as f32);
    for (k, (name, at)) in labels.iter().enumerate() {
        let centre = glam::Vec3::new(-2.6 + 1.3 * k as f32, 0.6, 0.0);
        let c = scene.camera.project(centre).unwrap() * film;
        assert!(
            (c.x - at.x).abs() < 0.1 * film.x && at.y > c.y,
            "{name}: {at} vs {c}"
        );
        assert!(at.x > 0.0 && at.x < film.x && at.y < film.y, "{name}: {at}");
        if k > 0 {
            assert!(at.x > labels[k - 1].1.x + 0.1 * film.x, "{name}");
        }
    }
}

/// Shapes that name the same material share its material group (the key the wavefront
/// batches hits by), numbered in order of first appearance; every other material, named
/// or inline (even with equal parameters), has a group of its own.
#[test]
fn shapes_sharing_a_material_share_its_group() {
    let mut v = base();
    v["materials"] = json!({
        "matte": {"type": "lambert", "reflectance": 0.5},
        "gloss": {"type": "cook-torrance", "specular": 0.3, "m": 0.1}
    });
    v["shapes"] = json!([
        {"type": "sphere", "radius": 1, "material": "gloss"},
        {"type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "matte"},
        {"type": "sphere", "center": [-3, 0, 0], "radius": 1, "material": "gloss"},
        {"type": "sphere", "center": [0, 3, 0], "radius": 1,
         "material": {"type": "lambert", "reflectance": 0.5}},
        {"type": "sphere", "center": [0, -3, 0], "radius": 1, "material": "matte"}
    ]);
    let dir = lobe_tests::workspace().join("scenes");
    let scene = from_value(&v, "groups.json", &dir, &LoadOptions::with_builtins()).unwrap();
    let groups: Vec<u32> = scene
        .world
        .shapes
        .iter()
        .map(|s| s.material_group)
        .collect();
    assert_eq!(groups, [0, 1, 0, 2, 1]);
}
