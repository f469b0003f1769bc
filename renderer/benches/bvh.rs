//! Criterion benchmarks of the BVH (docs/performance.md): building it over the benchmark
//! suite's million-triangle displaced sphere (the same surface as
//! tools/mitsuba/bench_assets.py makes for scenes/bench/mesh-1m-rgl.json), and closest-hit
//! and occlusion queries of incoherent bounce rays (from random points of the surface in
//! random directions) against it and against a 5,724-triangle one (the size of the suite's
//! 5,649-triangle bunny). Prints the tree's memory once. The same build and closest-hit
//! queries on the big mesh with obvhs's compressed wide BVH (CWBVH) as the peer.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use lobe_renderer::geometry::bvh::{Prims, ShapeGeom};
use lobe_renderer::geometry::primitive::{PrimKind, PrimShape, Primitive};
use lobe_renderer::geometry::{Geometry, Mesh, Ray};
use std::hint::black_box;

/// The displaced sphere of bench_assets.py: `rings` latitude rings of `segments`
/// segments, radius 1 + a sum of sinusoids.
fn displaced_sphere(rings: u32, segments: u32) -> Mesh {
    let mut m = Mesh::default();
    m.positions.push(Vec3::Y);
    for i in 1..rings {
        let t = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let p = std::f32::consts::TAU * j as f32 / segments as f32;
            let r = 1.0
                + 0.04 * (7.0 * t).sin() * (9.0 * p).cos()
                + 0.02 * (23.0 * t + 1.0).sin() * (17.0 * p).sin()
                + 0.008 * (61.0 * t).sin() * (47.0 * p + 2.0).cos();
            m.positions.push(Vec3::new(
                r * t.sin() * p.cos(),
                r * t.cos(),
                r * t.sin() * p.sin(),
            ));
        }
    }
    m.positions.push(-Vec3::Y);
    let vid = |i: u32, j: u32| 1 + i * segments + j % segments;
    let south = m.positions.len() as u32 - 1;
    let n = rings - 1;
    for j in 0..segments {
        m.indices.push([0, vid(0, j + 1), vid(0, j)]);
        m.indices.push([vid(n - 1, j), vid(n - 1, j + 1), south]);
    }
    for i in 0..n - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (vid(i, j), vid(i, j + 1), vid(i + 1, j), vid(i + 1, j + 1));
            m.indices.push([a, b, d]);
            m.indices.push([a, d, c]);
        }
    }
    m
}

fn prims(mesh: &Mesh) -> Prims {
    (0..mesh.indices.len() as u32)
        .map(|t| Primitive {
            kind: PrimKind::Triangle { mesh: 0, index: t },
            shape: 0,
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mesh = displaced_sphere(512, 1024);
    let tris = prims(&mesh);
    let mut g = c.benchmark_group("bvh build");
    g.sample_size(10);
    g.bench_function("displaced sphere, 1046528 triangles", |b| {
        b.iter(|| {
            Geometry::build(
                tris.clone(),
                vec![mesh.clone()],
                vec![],
                vec![ShapeGeom::default()],
            )
            .expect("BVH")
            .bvh_memory_bytes()
        })
    });
    g.finish();
    let geo =
        Geometry::build(tris, vec![mesh.clone()], vec![], vec![ShapeGeom::default()]).expect("BVH");
    println!(
        "BVH of {} triangles: {:.1} MB of nodes and leaf blocks, {:.1} MB of primitives and mesh data, SAH cost {:.2}",
        geo.prims.len(),
        geo.bvh_memory_bytes() as f64 / 1e6,
        geo.primitive_memory_bytes() as f64 / 1e6,
        geo.bvh_sah_cost()
    );
    let rays = queries(c, "1M triangles", &geo);
    // A mesh of 5,724 triangles, about the benchmark suite's bunny (5,649), whose tree is
    // a few levels deep: there each query's fixed cost and branches, not the tree's cache
    // misses, take the time.
    let small = displaced_sphere(54, 54);
    let small_geo = Geometry::build(
        prims(&small),
        vec![small],
        vec![],
        vec![ShapeGeom::default()],
    )
    .expect("BVH");
    queries(
        c,
        &format!("{} triangles", small_geo.prims.len()),
        &small_geo,
    );
    cwbvh_peer(c, &mesh, &rays);
}

/// Closest-hit and occlusion queries of 65,536 incoherent bounce rays against `geo` (a
/// triangle mesh), benchmarked as the group "bvh queries, `label`"; returns the rays.
fn queries(c: &mut Criterion, label: &str, geo: &Geometry) -> Vec<Ray> {
    let mut s = 7u64;
    let mut rnd = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    // Bounce rays: from the centre of a random triangle (pushed off it along its
    // normal) in a uniformly random direction, so that about half leave the surface and
    // half cross the inside to the other side, as a path tracer's secondary rays do. Each
    // ray starts somewhere else on the mesh, so these queries measure the tree's cache
    // misses as well (a render's rays from one pixel are far more coherent).
    let rays: Vec<Ray> = (0..1 << 16)
        .map(|_| {
            let k = ((rnd() * 0.5 + 0.5) * geo.prims.len() as f32) as usize;
            let PrimShape::Triangle(t) = geo.shape_of(k.min(geo.prims.len() - 1) as u32) else {
                unreachable!("triangles only")
            };
            let o = t.point(glam::Vec2::splat(1.0 / 3.0)) + t.normal() * 1e-4;
            let d = Vec3::new(rnd(), rnd(), rnd());
            Ray::new(o, d.normalize_or(Vec3::Z))
        })
        .collect();
    let mut g = c.benchmark_group(format!("bvh queries, {label}"));
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("closest", |b| {
        b.iter(|| {
            rays.iter()
                .filter_map(|r| geo.closest(black_box(r)))
                .count()
        })
    });
    g.bench_function("occluded", |b| {
        b.iter(|| rays.iter().filter(|r| geo.occluded(black_box(r))).count())
    });
    g.finish();
    rays
}

/// The same build and closest-hit queries with obvhs's own compressed wide BVH (Ylitie et
/// al. 2017: 80-byte nodes of eight quantized children, leaves of up to three triangles
/// tested one at a time, triangles stored in leaf order), to measure whether lobe's BVH8
/// (uncompressed boxes, leaf blocks of eight triangles in SIMD lanes) earns its place.
fn cwbvh_peer(c: &mut Criterion, mesh: &Mesh, rays: &[Ray]) {
    use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris, triangle::Triangle};
    let tris: Vec<Triangle> = mesh
        .indices
        .iter()
        .map(|t| {
            let [v0, v1, v2] = t.map(|i| mesh.positions[i as usize].into());
            Triangle { v0, v1, v2 }
        })
        .collect();
    let build = || {
        build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::fast_build(),
            &mut std::time::Duration::default(),
        )
    };
    let mut g = c.benchmark_group("obvhs cwbvh (peer)");
    g.sample_size(10);
    g.bench_function("build, displaced sphere", |b| {
        b.iter(|| build().nodes.len())
    });
    g.finish();
    let bvh = build();
    let ordered: Vec<Triangle> = bvh
        .primitive_indices
        .iter()
        .map(|&i| tris[i as usize])
        .collect();
    println!(
        "obvhs CWBVH of {} triangles: {:.1} MB of nodes, {:.1} MB of triangles in leaf order",
        tris.len(),
        (bvh.nodes.len() * size_of::<obvhs::cwbvh::node::CwBvhNode>()) as f64 / 1e6,
        (ordered.len() * size_of::<Triangle>()) as f64 / 1e6
    );
    let orays: Vec<obvhs::ray::Ray> = rays
        .iter()
        .map(|r| obvhs::ray::Ray::new(r.o.into(), r.d.into(), r.tmin, r.tmax))
        .collect();
    let mut g = c.benchmark_group("bvh queries, 1M triangles, obvhs cwbvh (peer)");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("closest", |b| {
        b.iter(|| {
            orays
                .iter()
                .filter(|r| {
                    let mut hit = obvhs::ray::RayHit::none();
                    bvh.ray_traverse(**black_box(r), &mut hit, |ray, id| {
                        ordered[id].intersect(ray)
                    })
                })
                .count()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
