//! "Model only what a scene requires": a scene of analytic materials without an
//! environment map builds no measured table and no environment-map distribution, even when
//! its material list names measured tables it does not use; the same counters move when a
//! scene does use them. (Its own test binary: the counters are process-wide.)

use lobe_materials::measured::material::TABLES_BUILT;
use lobe_materials::measured::tabulate::{Acquisition, merl_from};
use lobe_materials::registry::Registry;
use lobe_renderer::lights::envmap::DISTRIBUTIONS_BUILT;
use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value};
use serde_json::json;
use std::sync::atomic::Ordering;

#[test]
fn scenes_build_only_the_tables_and_distributions_they_use() {
    let dir = tempfile::tempdir().unwrap();
    let ct = Registry::builtin()
        .create(
            &json!({"type": "cook-torrance", "diffuse": 0.2, "specular": 0.5, "m": 0.2}),
            "m",
        )
        .unwrap();
    merl_from(&|wo, wi| ct.eval(wo, wi), &Acquisition::default())
        .write(&dir.path().join("t.binary"))
        .unwrap();
    let counts = || {
        (
            TABLES_BUILT.load(Ordering::SeqCst),
            DISTRIBUTIONS_BUILT.load(Ordering::SeqCst),
        )
    };
    let before = counts();
    let analytic = json!({
        "camera": {"type": "perspective", "origin": [0, 0, 5], "target": [0, 0, 0]},
        "film": {"width": 16, "height": 16},
        "sampler": {"spp": 4},
        "materials": {
            "measured": {"type": "merl", "file": "t.binary"},
            "rgl": {"type": "rgl", "file": "missing.bsdf"},
            "gold": {"type": "cook-torrance", "specular": [1, 0.8, 0.4], "m": 0.1}
        },
        "shapes": [
            {"type": "sphere", "material": "gold"},
            {"type": "sphere", "center": [2, 0, 0], "material": {"type": "ward", "alpha": 0.2}}
        ],
        "lights": [{"type": "point", "position": [0, 3, 3], "intensity": 10}, {"type": "constant", "radiance": 0.1}]
    });
    let scene = from_value(
        &analytic,
        "analytic.json",
        dir.path(),
        &LoadOptions::with_builtins(),
    )
    .unwrap();
    let (img, _) = render(&scene, &RenderOptions::default()).unwrap();
    assert!(img.mean().r > 0.0);
    assert_eq!(
        counts(),
        before,
        "an analytic scene without an environment map built a table or a distribution"
    );
    // A scene that uses the table and an environment map builds each once.
    let mut used = analytic.clone();
    used["shapes"][1]["material"] = json!("measured");
    used["lights"] = json!([{"type": "envmap", "file": "builtin:studio"}]);
    let scene = from_value(
        &used,
        "used.json",
        dir.path(),
        &LoadOptions::with_builtins(),
    )
    .unwrap();
    render(&scene, &RenderOptions::default()).unwrap();
    let after = counts();
    assert_eq!(after.0, before.0 + 1, "measured tables built");
    assert_eq!(after.1, before.1 + 1, "environment distributions built");
    // Two shapes of one table, one by a named material and one inline, share one build.
    let mut shared = used.clone();
    shared["shapes"][0]["material"] = json!({"type": "merl", "file": "t.binary"});
    from_value(
        &shared,
        "shared.json",
        dir.path(),
        &LoadOptions::with_builtins(),
    )
    .unwrap();
    assert_eq!(counts().0, after.0 + 1, "one table for two shapes");
}
