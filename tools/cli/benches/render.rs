//! Criterion benchmark of the renderer on the built-in sphere-under-env-map scene (the
//! scene of docs/performance.md); `lobe render --bench` reports the same in Msamples/s.

use criterion::{Criterion, criterion_group, criterion_main};
use lobe_renderer::render::{RenderOptions, render};

fn bench_sphere_envmap(c: &mut Criterion) {
    let mut scene = lobe_renderer::showcase::bench_scene().expect("built-in scene loads");
    scene.settings.spp = 4;
    let opts = RenderOptions::default();
    let mut g = c.benchmark_group("render");
    g.sample_size(10);
    g.throughput(criterion::Throughput::Elements(
        (scene.settings.width * scene.settings.height * scene.settings.spp) as u64,
    ));
    g.bench_function("sphere_envmap_256x256x4spp", |b| {
        b.iter(|| render(&scene, &opts).expect("renders"))
    });
    g.finish();
}

criterion_group!(benches, bench_sphere_envmap);
criterion_main!(benches);
