//! Images are bit-identical for a given seed whatever the number of threads, and change
//! with the seed.

use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value};
use serde_json::json;
use std::path::Path;

#[test]
fn same_image_with_one_and_two_threads() {
    let v = json!({
        "camera": {"type": "perspective", "fov": 45, "origin": [0, 1, 5], "target": [0, 0, 0]},
        "film": {"width": 40, "height": 30},
        "sampler": {"spp": 8, "seed": 11},
        "integrator": {"type": "path", "max_depth": 6},
        "shapes": [
            {"type": "sphere", "center": [-0.6, 0, 0], "radius": 0.5, "material": {"type": "lambert", "reflectance": [0.8, 0.3, 0.2]}},
            {"type": "sphere", "center": [0.7, 0.2, 0], "radius": 0.4, "emitter": {"radiance": 3}},
            {"type": "rectangle", "to_world": [{"scale": 5}, {"rotate": {"axis": [1, 0, 0], "angle": -90}}, {"translate": [0, -0.5, 0]}]}
        ],
        "lights": [{"type": "envmap", "file": "builtin:studio", "scale": 0.5}, {"type": "point", "position": [0, 3, 2], "intensity": 5}]
    });
    let mut scene =
        from_value(&v, "t.json", Path::new("."), &LoadOptions::with_builtins()).unwrap();
    let one = render(
        &scene,
        &RenderOptions {
            threads: Some(1),
            ..Default::default()
        },
    )
    .unwrap()
    .0;
    let two = render(
        &scene,
        &RenderOptions {
            threads: Some(2),
            ..Default::default()
        },
    )
    .unwrap()
    .0;
    let three = render(
        &scene,
        &RenderOptions {
            threads: Some(3),
            ..Default::default()
        },
    )
    .unwrap()
    .0;
    let bits = |img: &lobe_renderer::film::Image| {
        img.pixels
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(bits(&one), bits(&three));
    scene.seed = 12;
    let other = render(
        &scene,
        &RenderOptions {
            threads: Some(2),
            ..Default::default()
        },
    )
    .unwrap()
    .0;
    assert_ne!(
        bits(&one),
        bits(&other),
        "a different seed must give a different image"
    );
}
