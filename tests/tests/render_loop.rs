//! The render loop: non-finite samples are dropped and counted, never written into the
//! image; a cancelled render returns an error instead of an image; progress is reported
//! per tile, in order, up to the film's pixel count, and changes nothing in the image.

use glam::{Vec2, Vec3};
use lobe_materials::{Bsdf, BsdfSample, Flags, Rgb};
use lobe_renderer::render::{Progress, RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value};
use serde_json::json;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

/// A broken material: NaN for directions on one side, fine elsewhere.
#[derive(Debug)]
struct HalfNan;

impl Bsdf for HalfNan {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            Rgb::ZERO
        } else if wi.x > 0.0 {
            Rgb::splat(f32::NAN)
        } else {
            Rgb::splat(0.1)
        }
    }
    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        let wi = lobe_materials::sampling::warp::square_to_cosine_hemisphere(u);
        let pdf = wi.z / std::f32::consts::PI;
        (wo.z > 0.0 && pdf > 0.0).then(|| BsdfSample {
            wi,
            weight: self.eval(wo, wi) * std::f32::consts::PI,
            pdf,
        })
    }
    fn pdf(&self, _wo: Vec3, wi: Vec3) -> f32 {
        wi.z.max(0.0) / std::f32::consts::PI
    }
    fn flags(&self) -> Flags {
        Flags::NONE
    }
    fn name(&self) -> &str {
        "half-nan"
    }
}

fn scene() -> lobe_renderer::scene::Scene {
    let v = json!({
        "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
        "film": {"width": 16, "height": 16},
        "sampler": {"spp": 8},
        "shapes": [{"type": "sphere"}],
        "lights": [{"type": "constant"}]
    });
    from_value(&v, "t.json", Path::new("."), &LoadOptions::default()).unwrap()
}

#[test]
fn non_finite_samples_are_dropped_and_counted() {
    let mut s = scene();
    s.world.shapes[0].material = Arc::new(HalfNan);
    let (img, stats) = render(&s, &RenderOptions::default()).unwrap();
    assert!(
        stats.nonfinite_dropped > 0,
        "the broken material must produce dropped samples"
    );
    assert!(stats.nonfinite_dropped < stats.samples);
    assert!(
        img.pixels.iter().all(|p| p.is_finite()),
        "a NaN reached the image"
    );
    assert!(img.variance.iter().all(|p| p.is_finite()));
    assert!(stats.summary().contains(&format!(
        "{} non-finite samples dropped",
        stats.nonfinite_dropped
    )));
}

#[test]
fn a_cancelled_render_returns_an_error() {
    let s = scene();
    let opts = RenderOptions {
        cancel: Some(Arc::new(AtomicBool::new(true))),
        ..Default::default()
    };
    let e = render(&s, &opts).unwrap_err();
    assert!(e.to_string().contains("interrupted"));
}

#[test]
fn progress_reports_every_tile_in_order_and_changes_nothing() {
    // 37 x 21: six tiles, four of them partial.
    let v = json!({
        "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
        "film": {"width": 37, "height": 21},
        "sampler": {"spp": 8},
        "shapes": [{"type": "sphere", "material": {"type": "ward", "specular": 0.2, "alpha": 0.2}}],
        "lights": [{"type": "constant"}]
    });
    let s = from_value(&v, "t.json", Path::new("."), &LoadOptions::default()).unwrap();
    let (plain, _) = render(&s, &RenderOptions::default()).unwrap();
    for threads in [1, 2, 3] {
        let calls = Arc::new(Mutex::new(Vec::new()));
        let c = calls.clone();
        let opts = RenderOptions {
            threads: Some(threads),
            progress: Some(Progress::new(move |done, total| {
                c.lock().unwrap().push((done, total))
            })),
            ..Default::default()
        };
        let (img, _) = render(&s, &opts).unwrap();
        let calls = calls.lock().unwrap().clone();
        assert_eq!(calls.len(), 6, "one report per tile: {calls:?}");
        assert!(calls.windows(2).all(|w| w[0].0 < w[1].0), "{calls:?}");
        assert!(calls.iter().all(|&(_, t)| t == 37 * 21), "{calls:?}");
        assert_eq!(calls.last().unwrap().0, 37 * 21);
        let bits = |i: &lobe_renderer::film::Image| {
            let f = |p: &Rgb| p.to_array().map(f32::to_bits);
            (
                i.pixels.iter().map(f).collect::<Vec<_>>(),
                i.variance.iter().map(f).collect::<Vec<_>>(),
            )
        };
        assert!(bits(&img) == bits(&plain), "{threads} threads");
    }
}
