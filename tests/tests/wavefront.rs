//! The wavefront path integrator (`Wavefront::trace`, what `render` runs) gives bit for bit
//! the radiance of the scalar one (`path::li`) for every sample: same sampler dimensions,
//! same operations, same sums, whatever the lights (env maps, several of them, constant,
//! point, area), the materials, the depth limits and Russian roulette.

use glam::Vec2;
use lobe_renderer::Rgb;
use lobe_renderer::geometry::Rays;
use lobe_renderer::integrators::Wavefront;
use lobe_renderer::sampler::Sampler;
use lobe_renderer::scene::{LoadOptions, Scene, from_value, load};
use serde_json::{Value, json};
use std::path::Path;

/// Every third pixel of every third row: the samples of a row's pixels traced together
/// in batches of `batch` samples (a batch may hold samples of several pixels, and a
/// pixel's samples may span batches), each equal to the scalar integrator's.
fn check(scene: &Scene, batch: usize) {
    let inv = Vec2::new(
        1.0 / scene.settings.width as f32,
        1.0 / scene.settings.height as f32,
    );
    let mut ws = Wavefront::default();
    let mut checked = 0;
    for y in (0..scene.settings.height).step_by(3) {
        let mut base = Sampler::with_scramble(
            scene.settings.seed,
            scene.settings.spp,
            scene.settings.scramble,
        );
        let (mut rays, mut keys, mut indices, mut scalar) = (vec![], vec![], vec![], vec![]);
        for x in (0..scene.settings.width).step_by(3) {
            for s in 0..scene.settings.spp {
                base.start(x, y, s);
                let film = (Vec2::new(x as f32, y as f32) + base.next_2d()) * inv;
                let ray = scene.camera.ray(film);
                rays.push(ray);
                keys.push(base.key());
                indices.push(s);
                let mut own = base.clone();
                scalar.push((x, scene.settings.integrator.li(&scene.world, ray, &mut own)));
            }
        }
        let mut many = vec![Rgb::ZERO; rays.len()];
        for (((r, k), idx), o) in rays
            .chunks(batch)
            .zip(keys.chunks(batch))
            .zip(indices.chunks(batch))
            .zip(many.chunks_mut(batch))
        {
            // A sampler at the dimension after the camera's (of whichever pixel).
            let mut sampler = base.clone();
            let r: Rays = r.iter().copied().collect();
            scene
                .settings
                .integrator
                .li_many(&scene.world, &r, k, idx, &mut sampler, o, &mut ws);
        }
        for (((x, a), b), s) in scalar.iter().zip(&many).zip(&indices) {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits),
                "{}: pixel ({x}, {y}) sample {s}: scalar {a:?}, wavefront {b:?}",
                scene.file
            );
        }
        checked += scalar.len();
    }
    assert!(checked > 100, "{}: only {checked} samples", scene.file);
}

/// A scene from JSON, with the built-in images.
fn built(v: &Value, name: &str) -> Scene {
    from_value(v, name, Path::new("."), &LoadOptions::with_builtins()).unwrap()
}

#[test]
fn mixed_lights_and_materials() {
    let v = json!({
        "camera": {"type": "perspective", "fov": 45, "origin": [0, 1, 5], "target": [0, 0, 0]},
        "film": {"width": 30, "height": 24},
        "sampler": {"spp": 12, "seed": 5},
        "integrator": {"type": "path", "max_depth": -1, "rr_depth": 2},
        "shapes": [
            {"type": "sphere", "center": [-0.6, 0, 0], "radius": 0.5,
             "material": {"type": "ashikhmin-shirley", "diffuse": [0.3, 0.2, 0.1], "specular": 0.4, "n": 60}},
            {"type": "sphere", "center": [0.7, 0.2, 0], "radius": 0.4, "emitter": {"radiance": 3}},
            {"type": "sphere", "center": [0.0, 0.6, -0.8], "radius": 0.3,
             "material": {"type": "ngan-fit", "material": "green-metallic-paint", "model": "cook-torrance"}},
            {"type": "rectangle", "to_world": [{"scale": 5}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}, {"translate": [0, -0.5, 0]}]}
        ],
        "lights": [
            {"type": "envmap", "file": "builtin:studio", "scale": 0.5},
            {"type": "envmap", "file": "builtin:studio", "scale": 0.3, "mis_compensation": true, "to_world": {"rotate": {"axis": [0, 1, 0], "angle": 70}}},
            {"type": "constant", "radiance": 0.1},
            {"type": "point", "position": [0, 3, 2], "intensity": 5}
        ]
    });
    let mut v = v;
    if lobe_tests::shared_data().is_none() {
        lobe_tests::skip_without_data(
            "the mixed scene's published Ngan et al. fit (an analytic Cook-Torrance stands in)",
        );
        v["shapes"][2]["material"] =
            json!({"type": "cook-torrance", "diffuse": 0.1, "specular": 0.5, "m": 0.2});
    }
    let scene = built(&v, "mixed.json");
    // Batches that split a pixel's samples unevenly, one sample at a time, and batches of
    // several lane vectors (whose shadow rays mix area-light and infinite-light chunks).
    check(&scene, 5);
    check(&scene, 1);
    check(&scene, 3 * lobe_materials::simd::LANES + 5);
    // The direct integrator, which runs sample by sample.
    v["integrator"] = json!({"type": "direct", "emitter_samples": 2, "bsdf_samples": 1});
    let scene = built(&v, "direct.json");
    check(&scene, 7);
}

#[test]
fn one_env_map_and_depth_limits() {
    for depth in [1, 2, 3, 8] {
        let v = json!({
            "camera": {"type": "perspective", "fov": 30, "origin": [0, 0, 4.5], "target": [0, 0, 0]},
            "film": {"width": 24, "height": 24},
            "sampler": {"spp": 16, "seed": 1},
            "integrator": {"type": "path", "max_depth": depth},
            "shapes": [
                {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"type": "lambert", "reflectance": 0.6}},
                {"type": "sphere", "center": [0.9, 0.9, 0.5], "radius": 0.3, "material": {"type": "lambert", "reflectance": 0.9}}
            ],
            "lights": [{"type": "envmap", "file": "builtin:studio"}]
        });
        let scene = built(&v, "env.json");
        check(&scene, 16);
    }
}

#[test]
fn scene_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    for name in [
        "cornell-box.json",
        "spheres-envmap.json",
        "bunny-obj.json",
        "ngan-fits-green-metallic-paint.json",
    ] {
        if name.starts_with("ngan-fits") && lobe_tests::shared_data().is_none() {
            lobe_tests::skip_without_data(&format!("wavefront against scalar on {name}"));
            continue;
        }
        let mut scene = load(&root.join(name)).unwrap();
        scene.settings.spp = 4;
        check(&scene, 64);
    }
}
