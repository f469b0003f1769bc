//! The BVH returns the same closest hits as a brute-force loop over every primitive, on
//! random rays through a scene of triangles, spheres and rectangles; occlusion queries
//! agree with closest hits.

use glam::{Mat4, Vec3};
use lobe_renderer::geometry::bvh::ShapeGeom;
use lobe_renderer::geometry::primitive::{PrimKind, PrimShape, Primitive};
use lobe_renderer::geometry::{Geometry, Mesh, Ray, Rays, Rectangle, Sphere, Triangle};

struct Lcg(u64);
impl Lcg {
    fn f(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
    fn v(&mut self, s: f32) -> Vec3 {
        Vec3::new(
            self.f() * 2.0 - 1.0,
            self.f() * 2.0 - 1.0,
            self.f() * 2.0 - 1.0,
        ) * s
    }
}

fn scene() -> Geometry {
    scene_of(3000, 20)
}

/// `triangles` random triangles, `spheres` spheres and five rectangles in a box of side 8.
fn scene_of(triangles: usize, spheres: usize) -> Geometry {
    scene_at(triangles, spheres, Vec3::ZERO)
}

/// [`scene_of`] centred on `at`.
fn scene_at(triangles: usize, spheres: usize, at: Vec3) -> Geometry {
    let mut r = Lcg(7);
    let mut mesh = Mesh::default();
    for _ in 0..triangles {
        let c = at + r.v(4.0);
        let base = mesh.positions.len() as u32;
        for _ in 0..3 {
            mesh.positions.push(c + r.v(0.3));
        }
        mesh.indices.push([base, base + 1, base + 2]);
    }
    let mut prims = Vec::new();
    for t in 0..mesh.indices.len() as u32 {
        prims.push((PrimShape::Triangle(Triangle::new(0, &mesh, t)), 0));
    }
    for _ in 0..spheres {
        prims.push((
            PrimShape::Sphere(Sphere {
                center: at + r.v(4.0),
                radius: 0.1 + r.f(),
            }),
            1,
        ));
    }
    for k in 0..5 {
        let m = Mat4::from_translation(at + r.v(3.0))
            * Mat4::from_axis_angle(r.v(1.0).normalize(), k as f32)
            * Mat4::from_scale(Vec3::splat(0.8));
        prims.push((
            PrimShape::Rectangle(Rectangle::from_transform(&m).unwrap()),
            2,
        ));
    }
    Geometry::from_shapes(prims, vec![mesh], vec![ShapeGeom::default(); 3]).expect("BVH")
}

#[test]
fn closest_hits_equal_brute_force() {
    let g = scene();
    assert!(g.has_bvh());
    let mut r = Lcg(99);
    let mut hits = 0;
    for _ in 0..20_000 {
        let o = r.v(8.0);
        let target = r.v(3.0);
        let ray = Ray::new(o, (target - o).normalize());
        let a = g.closest(&ray);
        let b = g.closest_brute_force(&ray);
        match (a, b) {
            (None, None) => {}
            (Some((ta, ia)), Some((tb, ib))) => {
                hits += 1;
                assert_eq!(
                    ta, tb,
                    "distance differs: BVH prim {ia}, brute force prim {ib}"
                );
                // Ties between primitives at the same distance may resolve either way.
                assert_eq!(g.shape_of(ia).intersect(&ray), ta);
                // Nothing blocks the ray before its closest hit, something blocks it after.
                let before = Ray {
                    tmax: ta * 0.999,
                    ..ray
                };
                assert!(!g.occluded(&before));
                let after = Ray {
                    tmax: ta * 1.001 + 1e-4,
                    ..ray
                };
                assert!(g.occluded(&after));
            }
            _ => panic!("BVH and brute force disagree on whether {ray:?} hits: {a:?} vs {b:?}"),
        }
    }
    assert!(hits > 5000, "the test must hit things ({hits} hits)");
}

/// A scene bigger than a build chunk (65536 primitives, of three kinds mixed along the
/// Morton order): closest hits equal brute force, and the tree built on one thread answers
/// every query as the one built on two.
#[test]
fn chunked_builds_equal_brute_force_and_each_other() {
    let build = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| scene_of(150_000, 3000))
    };
    let (one, two) = (build(1), build(2));
    assert_eq!(one.bvh_memory_bytes(), two.bvh_memory_bytes());
    let mut r = Lcg(5);
    let mut hits = 0;
    for k in 0..3000 {
        let o = r.v(8.0);
        let ray = Ray::new(o, (r.v(3.0) - o).normalize());
        let a = one.closest(&ray);
        assert_eq!(a, two.closest(&ray), "ray {k}");
        if k % 4 == 0 {
            let b = one.closest_brute_force(&ray);
            assert_eq!(
                a.map(|h| h.0),
                b.map(|h| h.0),
                "ray {k}: BVH and brute force"
            );
        }
        hits += usize::from(a.is_some());
    }
    assert!(hits > 1000, "the test must hit things ({hits} hits)");
}

#[test]
fn spawned_rays_do_not_self_intersect_at_grazing_angles() {
    // A large sphere and a large rectangle: rays leaving the surface at grazing angles
    // must not hit the surface they leave.
    let sphere = Sphere {
        center: Vec3::new(0.0, 0.0, 0.0),
        radius: 1000.0,
    };
    let rect = Rectangle::from_transform(
        &(Mat4::from_translation(Vec3::new(0.0, 0.0, 3000.0))
            * Mat4::from_scale(Vec3::splat(500.0))),
    )
    .unwrap();
    let g = Geometry::from_shapes(
        vec![
            (PrimShape::Sphere(sphere), 0),
            (PrimShape::Rectangle(rect), 1),
        ],
        vec![],
        vec![ShapeGeom::default(); 2],
    )
    .expect("small scene");
    let mut r = Lcg(3);
    let mut naive_self_hits = 0;
    for k in 0..20_000 {
        // Hit a random point of either surface from outside, then leave at a grazing angle.
        let (o, target) = if k % 2 == 0 {
            let n = r.v(1.0).normalize();
            (n * 3000.0, n * 1000.0)
        } else {
            let p = Vec3::new(r.f() * 800.0 - 400.0, r.f() * 800.0 - 400.0, 3000.0);
            (p + Vec3::new(1.0, 2.0, 500.0), p)
        };
        let ray = Ray::new(o, (target - o).normalize());
        let Some(it) = g.intersect(&ray) else {
            continue;
        };
        let t1 = it.ng.any_orthonormal_vector();
        let d = (t1 + it.ng * 1e-3).normalize(); // 89.94 degrees from the normal
        let spawned = lobe_renderer::geometry::spawn_ray(&it, d);
        // The spawned ray skips the primitive it leaves (planar, or a sphere left outward);
        // the offset origin alone must also keep it off that surface.
        assert_eq!(spawned.skip, it.prim, "{d} from {}", it.p);
        let out = Ray {
            skip: Ray::NO_SKIP,
            ..spawned
        };
        if let Some((t, p)) = g.closest(&out) {
            assert!(
                g.prims.get(p).shape != it.shape || t > 1.0,
                "self-intersection at t = {t}"
            );
        }
        // The same ray without the offset does hit its own surface: the test can fail.
        if let Some((t, p)) = g.closest(&Ray::new(it.p, d))
            && g.prims.get(p).shape == it.shape
            && t < 1.0
        {
            naive_self_hits += 1;
        }
    }
    assert!(
        naive_self_hits > 100,
        "unoffset rays self-intersect ({naive_self_hits} times)"
    );
}

/// Spawned rays skip the primitive they leave only when it cannot be hit again: through
/// the BVH and by brute force, a secondary ray finds the same closest hit as the
/// unskipped ray except for a self-hit right at its origin, and a ray leaving a sphere
/// inward still finds the sphere's far side.
#[test]
fn spawned_rays_skip_only_what_they_cannot_hit() {
    let g = scene();
    assert!(g.has_bvh());
    let mut r = Lcg(11);
    let (mut inward, mut compared) = (0, 0);
    for _ in 0..20_000 {
        let o = r.v(6.0);
        let Some(it) = g.intersect(&Ray::new(o, r.v(1.0).normalize_or(Vec3::X))) else {
            continue;
        };
        let d = r.v(1.0).normalize_or(Vec3::Z);
        let spawned = lobe_renderer::geometry::spawn_ray(&it, d);
        let is_sphere = matches!(g.prims.get(it.prim).kind, PrimKind::Sphere(_));
        if is_sphere && d.dot(it.exit) < 0.0 {
            // Into the sphere: nothing skipped, and the far side (or something inside) is hit.
            assert_eq!(spawned.skip, Ray::NO_SKIP);
            let (t, _) = g.closest(&spawned).expect("a ray into a sphere hits");
            assert!(t > 0.0);
            inward += 1;
            continue;
        }
        assert_eq!(spawned.skip, it.prim);
        let unskipped = Ray {
            skip: Ray::NO_SKIP,
            ..spawned
        };
        let a = g.closest(&spawned);
        let b = g.closest_brute_force(&spawned);
        assert_eq!(a.map(|h| h.0), b.map(|h| h.0), "BVH and brute force differ");
        let c = g.closest(&unskipped);
        match (a, c) {
            (x, y) if x == y => compared += 1,
            // The only difference allowed: the unskipped ray re-hits its own primitive.
            (_, Some((t, p))) if p == it.prim => assert!(t < 1e-3, "own primitive at t = {t}"),
            (x, y) => panic!("skipping changed the hit: {x:?} vs {y:?}"),
        }
        if let Some((t, _)) = a {
            let shadow = Ray {
                tmax: t * 0.999,
                ..spawned
            };
            assert!(!g.occluded(&shadow));
        }
    }
    assert!(
        inward > 100 && compared > 3000,
        "{inward} inward, {compared} compared"
    );
}

/// `closest_many` and `occluded_many` (`LANES` rays per SIMD test in small scenes, ray by
/// ray through the BVH otherwise) return `closest` (bit for bit) and `occluded` of each
/// ray: rays from outside, inside and on the spheres, with finite and infinite ranges,
/// skipped primitives, and partial batches; on scenes of spheres, on a small scene of
/// triangles, spheres and rectangles (exhaustive tests in ray lanes), and on a large one
/// (the BVH).
#[test]
fn batched_closest_hits_equal_single_ones() {
    let mut r = Lcg(11);
    for g in &geometries_of_every_kind(&mut r) {
        let rays = rays_near_the_origin(g, &mut r);
        batched_queries_equal_single_ones(g, &rays);
    }
}

/// Scenes of one sphere, of four (with outward and inward normals), a small scene of
/// every kind (tested in ray lanes, without a BVH) and the whole random scene.
fn geometries_of_every_kind(r: &mut Lcg) -> Vec<Geometry> {
    let sphere_scenes: Vec<Vec<Sphere>> = vec![
        vec![Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        }],
        (0..4)
            .map(|_| Sphere {
                center: r.v(2.0),
                radius: 0.3 + r.f(),
            })
            .collect(),
    ];
    let mut geometries: Vec<Geometry> = sphere_scenes
        .iter()
        .map(|ss| {
            let prims = ss
                .iter()
                .map(|&s| Primitive {
                    kind: PrimKind::Sphere(s),
                    shape: 0,
                })
                .collect();
            Geometry::build(prims, vec![], vec![], vec![ShapeGeom::default()]).expect("spheres")
        })
        .collect();
    // Inward normals (flip_normals) on a scene of spheres too.
    geometries.push(
        Geometry::build(
            sphere_scenes[1]
                .iter()
                .map(|&s| Primitive {
                    kind: PrimKind::Sphere(s),
                    shape: 0,
                })
                .collect(),
            vec![],
            vec![],
            vec![ShapeGeom {
                flip_normals: true,
                ..ShapeGeom::default()
            }],
        )
        .expect("spheres"),
    );
    // A small scene of every kind (tested exhaustively in ray lanes, no BVH).
    let all: Vec<Primitive> = scene().prims.iter().collect();
    let small: Vec<Primitive> = all
        .iter()
        .step_by(600)
        .chain(all.iter().rev().take(5))
        .copied()
        .collect();
    assert!(small.len() <= lobe_renderer::geometry::bvh::SMALL_SCENE);
    for kind in ["triangle", "sphere", "rectangle"] {
        assert!(
            small.iter().any(|p| match p.kind {
                PrimKind::Triangle { .. } => kind == "triangle",
                PrimKind::Sphere(_) => kind == "sphere",
                PrimKind::Rectangle(_) => kind == "rectangle",
            }),
            "the small scene lacks a {kind}"
        );
    }
    let whole = scene();
    let small = Geometry::build(
        small.into_iter().collect(),
        whole.meshes.clone(),
        whole.rects.clone(),
        vec![ShapeGeom::default(); 3],
    )
    .expect("small scene");
    assert!(!small.has_bvh());
    geometries.push(small);
    geometries.push(scene());
    geometries
}

/// 203 rays aimed near the origin (some hit, some miss), with short ranges, skipped
/// primitives, starts on a sphere's surface, raised `tmin` and zero direction components
/// among them.
fn rays_near_the_origin(g: &Geometry, r: &mut Lcg) -> Vec<Ray> {
    let n_prims = g.prims.len() as u32;
    (0..203)
        .map(|i| {
            // Aimed near the origin: some rays hit, some miss.
            let o = r.v(3.0);
            let mut ray = Ray::new(o, r.v(2.0) - o);
            match i % 5 {
                0 => ray.tmax = 2.0 * r.f(),
                1 => ray.skip = (r.f() * n_prims as f32) as u32 % n_prims,
                2 => {
                    // On a sphere's surface, leaving it.
                    if let PrimKind::Sphere(s) = g.prims.get(0).kind {
                        let n = r.v(1.0).normalize();
                        ray = Ray::new(s.center + n * s.radius, n + r.v(0.5));
                        ray.skip = 0;
                    }
                }
                3 => ray.tmin = 0.5 * r.f(),
                // A zero direction component, of either sign (the box test's tiny-reciprocal
                // rule), in every other of the rest.
                _ if i % 10 == 4 => ray.d[i / 10 % 3] = if i % 20 == 4 { 0.0 } else { -0.0 },
                _ => {}
            }
            ray
        })
        .collect()
}

/// `closest_many`, `interactions_many` and `occluded_many` answer bit for bit as the
/// single queries, for batches of 1, 7, 8, 9 and all the rays (in columns, [`Rays`],
/// which hold each ray bit for bit).
fn batched_queries_equal_single_ones(g: &Geometry, records: &[Ray]) {
    let rays: Rays = records.iter().copied().collect();
    let bits = |r: &Ray| {
        let v = [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax];
        (v.map(f32::to_bits), r.skip)
    };
    assert_eq!(rays.len(), records.len());
    for (i, r) in records.iter().enumerate() {
        assert_eq!(bits(&rays.get(i)), bits(r), "ray {i} in columns");
    }
    let rays = &rays;
    for len in [1usize, 7, 8, 9, 203] {
        // Batches of 1, 7, 8, 9 and 203 rays (full lane vectors and padded tails) from
        // all over the set, in order and reversed.
        let n = records.len();
        let spread: Vec<u32> = (0..len)
            .map(|k| (k * n / len + n / (2 * len)) as u32)
            .collect();
        let reversed: Vec<u32> = (0..len as u32).rev().collect();
        for idx in [spread, reversed] {
            closest_many_equals_closest(g, records, &idx);
        }
        // Occlusion of the first `len` rays: full lane vectors and a padded tail.
        let first: Rays = records[..len].iter().copied().collect();
        let mut occluded = Vec::new();
        g.occluded_many(&first, &mut occluded);
        assert_eq!(occluded.len(), len);
        for (ray, &o) in records.iter().zip(&occluded) {
            assert_eq!(o, g.occluded(ray), "occluded_many on {ray:?}");
        }
    }
    // interactions_many: every field of every hit's interaction, bit for bit.
    let (hits, its) = hits_and_interactions(g, rays);
    assert_eq!(its.len(), hits.len());
    let its: Vec<_> = (0..its.len()).map(|h| its.get(h)).collect();
    let bits = |it: &lobe_renderer::geometry::Interaction| {
        let mut v = vec![it.t.to_bits(), it.shape, it.prim];
        for w in [it.p, it.ng, it.ns, it.dpdu, it.exit] {
            v.extend(w.to_array().map(f32::to_bits));
        }
        v.extend(it.uv.to_array().map(f32::to_bits));
        v
    };
    for (it, &(i, t, prim)) in its.iter().zip(&hits) {
        let e = g.interaction(&records[i as usize], t, prim);
        assert_eq!(bits(it), bits(&e), "ray {i}");
    }
    let hits = records
        .iter()
        .filter(|ray| g.closest(ray).is_some())
        .count();
    assert!(
        hits > 20 && hits < 190,
        "{hits} hits: the rays should both hit and miss"
    );
}

/// The closest hits of `rays` (ray index, distance, primitive; `closest_many`) and their
/// interactions (`interactions_many`).
fn hits_and_interactions(
    g: &Geometry,
    rays: &Rays,
) -> (Vec<(u32, f32, u32)>, lobe_renderer::geometry::Interactions) {
    let mut closest = Vec::new();
    g.closest_many(rays, &mut closest);
    let hits: Vec<(u32, f32, u32)> = closest
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.map(|(t, p)| (i as u32, t, p)))
        .collect();
    let mut its = lobe_renderer::geometry::Interactions::default();
    g.interactions_many(rays, &hits, &mut its);
    (hits, its)
}

/// `closest_many` and `closest_many_coherent` (eight rays a packet, here rays that are not
/// coherent at all) of the rays `idx` of `records`, in columns, answer bit for bit as
/// `closest` of each.
fn closest_many_equals_closest(g: &Geometry, records: &[Ray], idx: &[u32]) {
    let rays: Rays = idx.iter().map(|&i| records[i as usize]).collect();
    let (mut out, mut coherent) = (Vec::new(), Vec::new());
    g.closest_many(&rays, &mut out);
    g.closest_many_coherent(&rays, &mut coherent);
    assert_eq!(out.len(), idx.len());
    assert_eq!(coherent.len(), idx.len());
    let bits = |h: Option<(f32, u32)>| h.map(|(t, p)| (t.to_bits(), p));
    for (k, &i) in idx.iter().enumerate() {
        let e = bits(g.closest(&records[i as usize]));
        let ray = records[i as usize];
        assert_eq!(bits(out[k]), e, "ray {i}: {ray:?}");
        assert_eq!(bits(coherent[k]), e, "ray {i} in a packet: {ray:?}");
    }
}

/// Packets of coherent rays (`closest_many_coherent`: a camera's jittered rays, eight per
/// pixel and pixels in rows, as the wavefront's camera rays come) find each ray's closest
/// hit bit for bit (and, skipping the primitive each hits first, the hit behind it),
/// through a BVH of triangles, spheres and rectangles (each hit by some) at the origin and
/// far from it, and through the
/// tree of 70000 coincident triangles, whose ties any hit may settle: there the distance
/// matches and the primitive is one of those hit.
#[test]
fn coherent_packets_find_each_rays_closest_hit() {
    let mut r = Lcg(31);
    let camera_rays = |r: &mut Lcg, origin: Vec3, target: Vec3, spread: f32| -> Vec<Ray> {
        let (size, spp) = (12, 8);
        let mut rays = Vec::new();
        for py in 0..size {
            for px in 0..size {
                for _ in 0..spp {
                    let jitter = Vec3::new(px as f32 + r.f(), py as f32 + r.f(), 0.0);
                    let film = (jitter / size as f32 - Vec3::new(0.5, 0.5, 0.0)) * spread;
                    rays.push(Ray::new(origin, target + film - origin));
                }
            }
        }
        // A partial packet at the end.
        rays.truncate(rays.len() - 3);
        rays
    };
    // The scene at the origin and far from it (where the box tests' rounding is coarse).
    for at in [Vec3::ZERO, Vec3::new(1000.0, -700.0, 300.0)] {
        let g = scene_at(3000, 20, at);
        assert!(g.has_bvh());
        let rays = camera_rays(&mut r, at + Vec3::new(0.3, 0.4, 9.0), at, 9.0);
        let all: Vec<u32> = (0..rays.len() as u32).collect();
        closest_many_equals_closest(&g, &rays, &all);
        let hits: Vec<u32> = rays
            .iter()
            .filter_map(|ray| g.closest(ray))
            .map(|h| h.1)
            .collect();
        assert!(
            hits.len() > rays.len() / 4 && hits.len() < rays.len(),
            "{} of {} rays hit",
            hits.len(),
            rays.len()
        );
        let kinds =
            |k: fn(&PrimKind) -> bool| hits.iter().filter(|&&p| k(&g.prims.get(p).kind)).count();
        let (tris, spheres, rects) = (
            kinds(|k| matches!(k, PrimKind::Triangle { .. })),
            kinds(|k| matches!(k, PrimKind::Sphere(_))),
            kinds(|k| matches!(k, PrimKind::Rectangle(_))),
        );
        assert!(
            tris > 0 && spheres > 0 && rects > 0,
            "hits: {tris} triangles, {spheres} spheres, {rects} rectangles"
        );
        // The same rays skipping the primitive each hits first: the hits behind.
        let behind: Vec<Ray> = rays
            .iter()
            .map(|&ray| match g.closest(&ray) {
                Some((_, prim)) => Ray { skip: prim, ..ray },
                None => ray,
            })
            .collect();
        closest_many_equals_closest(&g, &behind, &all);
    }

    let piled = coincident_triangles();
    let rays = camera_rays(&mut r, Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), 2.5);
    let columns: Rays = rays.iter().copied().collect();
    let mut packets = Vec::new();
    piled.closest_many_coherent(&columns, &mut packets);
    let mut hits = 0;
    for (ray, p) in rays.iter().zip(&packets) {
        let e = piled.closest(ray);
        assert_eq!(
            p.map(|h| h.0.to_bits()),
            e.map(|h| h.0.to_bits()),
            "{ray:?}"
        );
        hits += usize::from(p.is_some());
    }
    assert!(hits > rays.len() / 4, "{hits} hits");
}

/// A BVH's SAH cost is the tests a ray expects: over spheres that all share one box every
/// box is hit whenever the root is, so the cost is every node and leaf block (at least one
/// block per eight spheres); spread along a line, a ray expects the root, about one node
/// per level below it, and one block.
#[test]
fn the_sah_cost_counts_the_tests_a_ray_expects() {
    let n = 200;
    let spheres = |spread: f32| {
        let prims = (0..n)
            .map(|k| {
                let center = Vec3::new(k as f32 * spread, 0.0, 0.0);
                (
                    PrimShape::Sphere(Sphere {
                        center,
                        radius: 0.5,
                    }),
                    0,
                )
            })
            .collect();
        Geometry::from_shapes(prims, vec![], vec![ShapeGeom::default()]).expect("BVH")
    };
    let (stacked, spread) = (spheres(0.0), spheres(3.0));
    assert!(stacked.has_bvh() && spread.has_bvh());
    let all = stacked.bvh_sah_cost();
    assert!(all >= 1.0 + n as f64 / 8.0, "{all}");
    let cost = spread.bvh_sah_cost();
    assert!(
        cost > 2.0 && cost < 4.0 && all > 10.0 * cost,
        "{cost} {all}"
    );
}

/// Primitives that share one box (duplicated geometry) make PLOC's tree a chain deeper
/// than the traversal stack; the build falls back to median splits, in one tree and in
/// chunks, and the tree answers as brute force does.
#[test]
fn coincident_primitives_build_and_hit_as_brute_force() {
    let sphere = PrimShape::Sphere(Sphere {
        center: Vec3::new(0.0, 0.0, 2.0),
        radius: 0.5,
    });
    let spheres =
        Geometry::from_shapes(vec![(sphere, 0); 4096], vec![], vec![ShapeGeom::default()])
            .expect("4096 coincident spheres");
    let triangles = coincident_triangles();
    let mut r = Lcg(5);
    for g in [&spheres, &triangles] {
        assert!(g.has_bvh());
        let mut hits = 0;
        for _ in 0..200 {
            let ray = Ray::new(
                Vec3::ZERO,
                (Vec3::new(0.0, 0.0, 2.0) + r.v(0.8)).normalize(),
            );
            let (a, b) = (g.closest(&ray), g.closest_brute_force(&ray));
            assert_eq!(a.map(|h| h.0), b.map(|h| h.0), "{ray:?}");
            hits += usize::from(a.is_some());
        }
        assert!(hits > 50, "{hits} hits");
    }
}

/// 70000 copies of one triangle, one mesh.
fn coincident_triangles() -> Geometry {
    let mesh = Mesh {
        positions: vec![
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ],
        indices: vec![[0, 1, 2]; 70_000],
        ..Default::default()
    };
    let prims = (0..70_000)
        .map(|t| (PrimShape::Triangle(Triangle::new(0, &mesh, t)), 0))
        .collect();
    Geometry::from_shapes(prims, vec![mesh], vec![ShapeGeom::default()])
        .expect("70000 coincident triangles")
}

/// The local geometry of triangle hits (`interactions_many`, in SIMD lanes, and
/// `interaction`, one hit) follows each triangle's own vertex data in lanes that mix
/// meshes: on a mesh with vertex normals and texture coordinates whose shape flips its
/// normals, a mesh with vertex normals shaded by face normals, and a mesh with neither.
/// Checked against Möller-Trumbore and the interpolations in f64: the position lies on
/// the ray, the shading normal is the normalized interpolation of the vertex normals (the
/// face normal where the shape does not use them), the geometric normal is the face normal
/// turned to the shading normal's side, the texture coordinates interpolate the vertices'
/// (the barycentrics without them), and `flip_normals` turns both normals.
#[test]
fn triangle_interactions_follow_their_vertex_data() {
    let mut r = Lcg(23);
    let mut meshes = Vec::new();
    let mut prims = Vec::new();
    for m in 0..3u32 {
        let mut mesh = Mesh::default();
        for _ in 0..400 {
            let c = r.v(2.0);
            let base = mesh.positions.len() as u32;
            for _ in 0..3 {
                mesh.positions.push(c + r.v(0.4));
                if m < 2 {
                    mesh.normals.push(r.v(1.0).normalize());
                }
                if m == 0 {
                    mesh.texcoords.push(glam::Vec2::new(r.f(), r.f()));
                }
            }
            mesh.indices.push([base, base + 1, base + 2]);
        }
        for t in 0..mesh.indices.len() as u32 {
            prims.push((PrimShape::Triangle(Triangle::new(m, &mesh, t)), m));
        }
        meshes.push(mesh);
    }
    let shapes = vec![
        ShapeGeom {
            flip_normals: true,
            face_normals: false,
        },
        ShapeGeom {
            flip_normals: false,
            face_normals: true,
        },
        ShapeGeom::default(),
    ];
    let g = Geometry::from_shapes(prims, meshes.clone(), shapes).expect("BVH");
    let records: Vec<Ray> = (0..2000)
        .map(|_| {
            let o = r.v(5.0);
            Ray::new(o, r.v(1.5) - o)
        })
        .collect();
    let rays: Rays = records.iter().copied().collect();
    let (hits, its) = hits_and_interactions(&g, &rays);
    let mut seen = [0usize; 3];
    for (h, &(i, t, prim)) in hits.iter().enumerate() {
        let it = its.get(h);
        let one = g.interaction(&records[i as usize], t, prim);
        let bits = |it: &lobe_renderer::geometry::Interaction| {
            [it.p, it.ng, it.ns, it.dpdu].map(|v| v.to_array().map(f32::to_bits))
        };
        assert_eq!(bits(&it), bits(&one), "hit {h}: lanes against one hit");
        assert_eq!(
            it.uv.to_array().map(f32::to_bits),
            one.uv.to_array().map(f32::to_bits),
            "hit {h}: uv, lanes against one hit"
        );
        let PrimKind::Triangle { mesh, index } = g.prims.get(prim).kind else {
            panic!("only triangles")
        };
        let reference = reference_geometry(
            &meshes[mesh as usize],
            index,
            &records[i as usize],
            g.shapes[mesh as usize],
        );
        let got = [it.p, it.ng, it.ns, it.dpdu, it.uv.extend(0.0)];
        assert_eq!(
            got.map(|v| v.to_array().map(f32::to_bits)),
            reference.map(|v| v.to_array().map(f32::to_bits)),
            "hit {h} on mesh {mesh}: against the one-hit formula in glam"
        );
        seen[mesh as usize] += 1;
        let m = &meshes[mesh as usize];
        let idx = m.indices[index as usize].map(|k| k as usize);
        let [a, b, c] = idx.map(|k| m.positions[k].as_dvec3());
        let ray = &records[i as usize];
        let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        // Möller-Trumbore in f64.
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        let s = o - a;
        let (b1, b2) = (s.dot(p) / det, d.dot(s.cross(e1)) / det);
        let w = [1.0 - b1 - b2, b1, b2];
        let close = |x: glam::DVec3, y: Vec3, what: &str| {
            assert!(
                (x - y.as_dvec3()).length() < 2e-4 * x.length().max(1.0),
                "hit {h} on mesh {mesh}: {what} {y} against {x}"
            )
        };
        close(o + d * t as f64, it.p, "position");
        let face = e1.cross(e2).normalize();
        let sign = if mesh == 0 { -1.0 } else { 1.0 };
        let shading = match mesh {
            0 => (0..3)
                .map(|k| m.normals[idx[k]].as_dvec3() * w[k])
                .sum::<glam::DVec3>()
                .normalize(),
            _ => face,
        };
        let geometric = if face.dot(shading) < 0.0 { -face } else { face };
        close(shading * sign, it.ns, "shading normal");
        close(geometric * sign, it.ng, "geometric normal");
        close(e1.normalize(), it.dpdu, "tangent");
        let uv = match mesh {
            0 => (0..3)
                .map(|k| m.texcoords[idx[k]].as_dvec2() * w[k])
                .sum::<glam::DVec2>(),
            _ => glam::DVec2::new(b1, b2),
        };
        assert!(
            (uv - it.uv.as_dvec2()).length() < 2e-4,
            "hit {h} on mesh {mesh}: uv {} against {uv}",
            it.uv
        );
    }
    assert!(
        seen.iter().all(|&n| n > 50),
        "hits per mesh: {seen:?}; every kind should be hit"
    );
    // A line in the triangle's plane (Möller-Trumbore's determinant 0), as no traversal
    // reports but a caller may pass: barycentrics of a third each, the centroid.
    let (prim, m) = (0u32, &meshes[0]);
    let [a, b, c] = m.indices[0].map(|k| m.positions[k as usize]);
    // Along the second edge: its cross product with itself is exactly zero.
    let along = Ray::new(a - (c - a), c - a);
    let mut its = lobe_renderer::geometry::Interactions::default();
    let rays: Rays = std::iter::once(along).collect();
    g.interactions_many(&rays, &[(0, 1.0, prim)], &mut its);
    let it = its.get(0);
    let centroid = (a + b + c) / 3.0;
    assert!(
        (it.p - centroid).length() < 1e-5,
        "{} against {centroid}",
        it.p
    );
    let reference = reference_geometry(m, 0, &along, g.shapes[0]);
    assert_eq!(
        [it.p, it.ng, it.ns, it.dpdu, it.uv.extend(0.0)].map(|v| v.to_array().map(f32::to_bits)),
        reference.map(|v| v.to_array().map(f32::to_bits)),
        "a line in the plane"
    );
}

/// The local geometry of a hit on triangle `index` of mesh `m` by `ray`, with glam's
/// operations as the renderer wrote it for one hit before the formula was shared with
/// lanes: position, geometric and shading normals, tangent, and uv (z 0).
fn reference_geometry(m: &Mesh, index: u32, ray: &Ray, sg: ShapeGeom) -> [Vec3; 5] {
    let tri = Triangle::new(0, m, index);
    let pvec = ray.d.cross(tri.e2);
    let det = tri.e1.dot(pvec);
    let inv_det = 1.0 / det;
    let tvec = ray.o - tri.p0;
    let u = tvec.dot(pvec) * inv_det;
    let qvec = tvec.cross(tri.e1);
    let v = ray.d.dot(qvec) * inv_det;
    let t = tri.e2.dot(qvec) * inv_det;
    let hit = det != 0.0
        && det.is_finite()
        && (0.0..=1.0).contains(&u)
        && !(v < 0.0 || u + v > 1.0)
        && t > f32::NEG_INFINITY
        && t < f32::INFINITY;
    let b = if hit {
        glam::Vec2::new(u, v)
    } else {
        glam::Vec2::splat(1.0 / 3.0)
    };
    let idx = m.indices[index as usize];
    let w = [1.0 - b.x - b.y, b.x, b.y];
    let mut ng = tri.e1.cross(tri.e2).normalize_or_zero();
    let mut ns = ng;
    if !sg.face_normals && !m.normals.is_empty() {
        let n = idx
            .iter()
            .zip(w)
            .fold(Vec3::ZERO, |a, (&k, wk)| a + m.normals[k as usize] * wk);
        if n.length_squared() > 0.0 {
            ns = n.normalize();
            if ng.dot(ns) < 0.0 {
                ng = -ng;
            }
        }
    }
    let uv = if m.texcoords.is_empty() {
        b
    } else {
        idx.iter().zip(w).fold(glam::Vec2::ZERO, |a, (&k, wk)| {
            a + m.texcoords[k as usize] * wk
        })
    };
    let flip = |n: Vec3| if sg.flip_normals { -n } else { n };
    [
        tri.p0 + tri.e1 * b.x + tri.e2 * b.y,
        flip(ng),
        flip(ns),
        tri.e1.normalize_or_zero(),
        uv.extend(0.0),
    ]
}
