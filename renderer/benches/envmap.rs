//! Criterion benchmarks of the environment map's batched calls, the hot spots of the
//! env-map sphere scenes (docs/performance.md): `EnvMap::sample_many` (light samples,
//! hierarchical warping of Clarberg et al. 2005) and `EnvMap::eval_pdf_many` (radiance
//! and pdf of escaped rays), per point, on the benchmark scene's 512 x 256 map and on a
//! 32 x 16 reduction of it that stays in L1 (the gap between the two is the cost of cache
//! misses). Batches of 256 points, about what the wavefront integrator passes per call
//! (wavefronts of 512 samples, of which about 57 % hit the sphere of sphere-envmap).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Mat3, Vec2, Vec3};
use lobe_renderer::Rgb;
use lobe_renderer::image_io::RgbImage;
use lobe_renderer::lights::EnvMap;
use lobe_renderer::lights::envmap::load_rgb_image;
use std::hint::black_box;
use std::path::Path;

const BATCH: usize = 256;
const CALLS: usize = 64;

/// Every `f`-th pixel of every `f`-th row.
fn reduce(img: &RgbImage, f: usize) -> RgbImage {
    let (w, h) = (img.width / f, img.height / f);
    RgbImage {
        width: w,
        height: h,
        pixels: (0..w * h)
            .map(|k| img.pixels[(k / w) * f * img.width + (k % w) * f])
            .collect(),
    }
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/envmaps/studio-512.exr");
    let img = load_rgb_image(&path).expect("scenes/envmaps/studio-512.exr");
    // Fixed pseudo-random points and directions (an LCG), the same in every run.
    let mut s = 12345u64;
    let mut rnd = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let us: lobe_materials::Vec2s = (0..CALLS * BATCH)
        .map(|_| Vec2::new(rnd(), rnd()))
        .collect();
    let dirs: Vec<Vec3> = (0..CALLS * BATCH)
        .map(|_| {
            let z = 2.0 * rnd() - 1.0;
            let phi = std::f32::consts::TAU * rnd();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    for (name, img) in [("512x256", img.clone()), ("32x16", reduce(&img, 16))] {
        let env = EnvMap::new(&img, 1.0, Mat3::IDENTITY);
        let mut g = c.benchmark_group(format!("envmap {name}"));
        g.throughput(Throughput::Elements((CALLS * BATCH) as u64));
        let (mut wi, mut li, mut pdf) = (
            lobe_materials::Vec3s::zeros(BATCH),
            vec![Rgb::ZERO; BATCH],
            vec![0.0f32; BATCH],
        );
        g.bench_function("sample_many", |b| {
            b.iter(|| {
                for first in (0..us.len()).step_by(BATCH) {
                    let u = us.cols().slice(first..(first + BATCH).min(us.len()));
                    env.sample_many(black_box(u), wi.cols_mut(), &mut li, &mut pdf);
                }
                black_box(pdf[0])
            })
        });
        let mut out = vec![(Rgb::ZERO, 0.0f32); BATCH];
        let dir_batches: Vec<lobe_materials::Vec3s> = dirs
            .chunks(BATCH)
            .map(lobe_materials::Vec3s::from)
            .collect();
        g.bench_function("eval_pdf_many", |b| {
            b.iter(|| {
                for d in &dir_batches {
                    env.eval_pdf_many(black_box(d.cols()), &mut out);
                }
                black_box(out[0].1)
            })
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
