//! The built-in showcase: spheres on a floor under the procedural HDR "studio"
//! environment (`"file": "builtin:studio"`, see [`crate::scene::builtin_images`]), so that
//! `lobe render` with no scene file needs no data on disk; and the benchmark scene. This
//! module builds on [`crate::scene`]; the scene loader does not depend on it.

use serde_json::{Value, json};

/// The showcase scene description: five of the study's models side by side.
pub fn showcase_scene() -> Value {
    let materials = [
        json!({"type": "cook-torrance", "diffuse": [0.55, 0.06, 0.05], "specular": 0.25, "m": 0.08, "f0": 0.04}),
        json!({"type": "ashikhmin-shirley", "diffuse": [0.02, 0.015, 0.005], "specular": [0.9, 0.6, 0.25], "n": 400, "f0": 0.8}),
        json!({"type": "ward-anisotropic", "diffuse": 0.03, "specular": 0.7, "alpha_x": 0.04, "alpha_y": 0.35}),
        json!({"type": "he", "diffuse": [0.04, 0.12, 0.35], "specular": 1.0, "sigma0": 0.25, "tau": 4.0, "eta": 1.5}),
        json!({"type": "lafortune", "diffuse": [0.6, 0.6, 0.55], "specular": 0.15, "n": 30}),
    ];
    let mut shapes: Vec<Value> = materials
        .iter()
        .enumerate()
        .map(|(k, m)| {
            json!({
                "type": "sphere",
                "center": [-2.6 + 1.3 * k as f32, 0.6, 0.0],
                "radius": 0.6,
                "material": m
            })
        })
        .collect();
    shapes.push(json!({
        "type": "rectangle",
        "to_world": [{"scale": 20}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}],
        "material": {"type": "lambert", "reflectance": 0.3}
    }));
    json!({
        "camera": {"type": "perspective", "fov": 42, "origin": [0, 1.8, 9.5], "target": [0, 0.45, 0], "up": [0, 1, 0]},
        "film": {"width": 640, "height": 360},
        "sampler": {"spp": 64, "seed": 0},
        "integrator": {"type": "path", "max_depth": 8},
        "shapes": shapes,
        "lights": [{"type": "envmap", "file": "builtin:studio"}]
    })
}

/// The model name of each showcase sphere, left to right, and where to write it: the
/// film position (pixels, x right, y down) just in front of the sphere's foot on the floor.
pub fn labels(scene: &crate::scene::Scene) -> Vec<(String, glam::Vec2)> {
    let film = glam::Vec2::new(scene.settings.width as f32, scene.settings.height as f32);
    let desc = showcase_scene();
    let spheres = desc["shapes"].as_array().into_iter().flatten();
    spheres
        .filter(|s| s["type"] == "sphere")
        .filter_map(|s| {
            let c = &s["center"];
            let at = |k: usize| c[k].as_f64().unwrap_or(0.0) as f32;
            let r = s["radius"].as_f64().unwrap_or(1.0) as f32;
            let foot = glam::Vec3::new(at(0), 0.0, at(2) + r);
            let name = s["material"]["type"].as_str()?.to_string();
            Some((name, scene.camera.project(foot)? * film))
        })
        .collect()
}

/// Loads the showcase scene.
pub fn showcase() -> crate::error::Result<crate::scene::Scene> {
    crate::scene::from_value(
        &showcase_scene(),
        "<built-in showcase>",
        std::path::Path::new("."),
        &crate::scene::LoadOptions::with_builtins(),
    )
}

/// The benchmark scene of docs/performance.md: one diffuse sphere under a 512 x 256
/// environment map, 256 x 256 pixels, 64 spp, path tracer of depth 8.
pub fn bench_scene_description() -> Value {
    json!({
        "camera": {"type": "perspective", "fov": 30, "origin": [0, 0, 4.5], "target": [0, 0, 0], "up": [0, 1, 0]},
        "film": {"width": 256, "height": 256},
        "sampler": {"spp": 64, "seed": 0},
        "integrator": {"type": "path", "max_depth": 8},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"type": "lambert", "reflectance": 0.6}}],
        "lights": [{"type": "envmap", "file": "builtin:studio"}]
    })
}

pub fn bench_scene() -> crate::error::Result<crate::scene::Scene> {
    crate::scene::from_value(
        &bench_scene_description(),
        "<built-in benchmark>",
        std::path::Path::new("."),
        &crate::scene::LoadOptions::with_builtins(),
    )
}
