//! Criterion benchmarks of `eval` and `sample` per model (ns per call), on a fixed set of
//! direction pairs; the figures go into docs/performance.md.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use lobe_materials::registry::Registry;
use serde_json::json;
use std::hint::black_box;

fn dirs() -> Vec<(Vec3, Vec3)> {
    let mut v = Vec::new();
    for k in 0..64 {
        let t = k as f32 * 0.02;
        let wo = Vec3::new(t.sin() * 0.7, t.sin() * 0.3, 1.0).normalize();
        let wi = Vec3::new(-t.cos() * 0.4, 0.2, 0.8).normalize();
        v.push((wo, wi));
    }
    v
}

fn bench(c: &mut Criterion) {
    let models = [
        ("lambert", json!({"type": "lambert", "reflectance": 0.5})),
        (
            "ward",
            json!({"type": "ward", "diffuse": 0.2, "specular": 0.1, "alpha": 0.1}),
        ),
        (
            "ward-duer",
            json!({"type": "ward-duer", "diffuse": 0.2, "specular": 0.1, "alpha": 0.1}),
        ),
        (
            "blinn-phong",
            json!({"type": "blinn-phong", "diffuse": 0.2, "specular": 0.1, "n": 300}),
        ),
        (
            "cook-torrance",
            json!({"type": "cook-torrance", "diffuse": 0.2, "specular": 0.1, "m": 0.1}),
        ),
        (
            "lafortune",
            json!({"type": "lafortune", "diffuse": 0.2, "specular": 0.1, "n": 100}),
        ),
        (
            "ashikhmin-shirley",
            json!({"type": "ashikhmin-shirley", "diffuse": 0.2, "specular": 0.1, "n": 300, "f0": 0.05}),
        ),
        (
            "he",
            json!({"type": "he", "diffuse": 0.2, "specular": 1, "sigma0": 0.18, "tau": 3, "eta": 1.5}),
        ),
        (
            "he-rough",
            json!({"type": "he", "diffuse": 0.2, "specular": 1, "sigma0": 3.0, "tau": 28, "eta": 1.5}),
        ),
        (
            "poulin-fournier",
            json!({"type": "poulin-fournier", "diffuse": 0.2, "specular": 0.1, "n": 3000, "d": 0.18, "h": 0.5}),
        ),
    ];
    let reg = Registry::builtin();
    let pairs = dirs();
    let mut g = c.benchmark_group("bsdf");
    g.throughput(criterion::Throughput::Elements(pairs.len() as u64));
    for (name, desc) in models {
        let m = reg.create(&desc, "bench").expect("valid");
        g.bench_function(format!("{name}/eval"), |b| {
            b.iter(|| {
                for &(wo, wi) in &pairs {
                    black_box(m.eval(black_box(wo), black_box(wi)));
                }
            })
        });
        g.bench_function(format!("{name}/sample"), |b| {
            b.iter(|| {
                for (k, &(wo, _)) in pairs.iter().enumerate() {
                    let u = Vec2::new((k as f32 * 0.618).fract(), (k as f32 * 0.382).fract());
                    black_box(m.sample(black_box(wo), u, (k as f32 * 0.1).fract()));
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
