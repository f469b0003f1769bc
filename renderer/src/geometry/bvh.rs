//! All primitives of a scene under one BVH ([`Bvh8`]: eight-wide nodes and leaf blocks
//! tested in SIMD lanes) for closest-hit and occlusion queries, the local geometry of
//! hits, and the batched forms of these queries that the wavefront integrator calls.

use super::bvh8::{Bvh8, WIDTH, slab_reciprocal};
use super::kernels;
use super::kernels::V3;
use super::{Interaction, Interactions, Mesh, Ray, Rays, Rectangle, Sphere, Triangle};
use glam::{Vec2, Vec3};
use lobe_materials::math::{Arith, gt, lt, select, select_v3, sqrt};
use lobe_materials::simd;
use lobe_materials::simd::{LANES, f32xn, u32xn};

use super::primitive::{PrimKind, PrimShape, PrimSource, Primitive};
pub use super::prims::Prims;

/// Scenes with at most this many primitives skip the BVH.
pub const SMALL_SCENE: usize = 16;

/// Per-shape data the intersection routine needs.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShapeGeom {
    /// Normals point inward (Mitsuba's `flip_normals`).
    pub flip_normals: bool,
    /// Ignore vertex normals: shade with the geometric normal.
    pub face_normals: bool,
}

impl ShapeGeom {
    /// The shape's normal for the surface normal `n`: `n`, or `-n` with `flip_normals`.
    #[inline(always)]
    pub fn orient(&self, n: Vec3) -> Vec3 {
        if self.flip_normals { -n } else { n }
    }
}

/// Primitives, meshes and the BVH over them.
pub struct Geometry {
    pub prims: Prims,
    pub meshes: Vec<Mesh>,
    /// The rectangles [`PrimKind::Rectangle`] points into.
    pub rects: Vec<Rectangle>,
    pub shapes: Vec<ShapeGeom>,
    bvh: Option<Bvh8>,
    /// Seconds spent building the BVH.
    pub build_seconds: f64,
}

impl Geometry {
    /// Builds the BVH over the primitives (kept in their order: hits name them by their
    /// index into `prims`). Scenes of at most [`SMALL_SCENE`] primitives are tested
    /// exhaustively: cheaper than any traversal. Errors only for a tree deeper than the
    /// traversal supports ([`Bvh8::build`]).
    pub fn build(
        prims: Prims,
        meshes: Vec<Mesh>,
        rects: Vec<Rectangle>,
        shapes: Vec<ShapeGeom>,
    ) -> Result<Self, String> {
        let start = std::time::Instant::now();
        let source = PrimSource {
            prims: &prims,
            meshes: &meshes,
            rects: &rects,
        };
        let bvh = if prims.len() <= SMALL_SCENE {
            None
        } else {
            Some(Bvh8::build(source)?)
        };
        Ok(Self {
            prims,
            meshes,
            rects,
            shapes,
            bvh,
            build_seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// [`Geometry::build`] from primitives given with their data (triangles name their
    /// mesh and index; rectangles are stored in [`Geometry::rects`]): for tests and
    /// benchmarks.
    pub fn from_shapes(
        prims: Vec<(PrimShape, u32)>,
        meshes: Vec<Mesh>,
        shapes: Vec<ShapeGeom>,
    ) -> Result<Self, String> {
        let mut rects = Vec::new();
        let prims = prims
            .into_iter()
            .map(|(p, shape)| {
                let kind = match p {
                    PrimShape::Sphere(s) => PrimKind::Sphere(s),
                    PrimShape::Triangle(t) => PrimKind::Triangle {
                        mesh: t.mesh,
                        index: t.index,
                    },
                    PrimShape::Rectangle(r) => {
                        rects.push(r);
                        PrimKind::Rectangle(rects.len() as u32 - 1)
                    }
                };
                Primitive { kind, shape }
            })
            .collect();
        Self::build(prims, meshes, rects, shapes)
    }

    /// What the primitive indices of this geometry point into.
    pub fn source(&self) -> PrimSource<'_> {
        PrimSource {
            prims: &self.prims,
            meshes: &self.meshes,
            rects: &self.rects,
        }
    }

    /// Primitive `i` with its data.
    #[inline(always)]
    pub fn shape_of(&self, i: u32) -> PrimShape {
        self.source().shape_of(i)
    }

    /// Bytes of the BVH (nodes and leaf blocks), 0 without one.
    pub fn bvh_memory_bytes(&self) -> usize {
        self.bvh.as_ref().map_or(0, Bvh8::memory_bytes)
    }

    /// The BVH's surface area heuristic cost ([`Bvh8::sah_cost`]; 0 without a BVH).
    pub fn bvh_sah_cost(&self) -> f64 {
        self.bvh.as_ref().map_or(0.0, Bvh8::sah_cost)
    }

    /// Bytes of the primitive list and the meshes' vertex data.
    pub fn primitive_memory_bytes(&self) -> usize {
        use std::mem::size_of;
        self.prims.memory_bytes()
            + self.rects.len() * size_of::<Rectangle>()
            + self
                .meshes
                .iter()
                .map(|m| {
                    m.positions.len() * size_of::<Vec3>()
                        + m.normals.len() * size_of::<Vec3>()
                        + m.texcoords.len() * size_of::<Vec2>()
                        + m.indices.len() * size_of::<[u32; 3]>()
                })
                .sum::<usize>()
    }

    /// Closest hit: (t, primitive index), without computing the local geometry.
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<(f32, u32)> {
        match self.bvh.as_ref() {
            Some(bvh) => bvh.closest(ray),
            None => self.closest_brute_force(ray),
        }
    }

    /// [`Geometry::closest`] of each ray, appended to `out`, bit for bit the same. With a
    /// BVH, ray by ray ([`Bvh8::closest`]); small scenes test `LANES` rays at a time
    /// against each primitive in SIMD lanes ([`super::kernels`]), loaded from the rays'
    /// columns.
    pub fn closest_many(&self, rays: &Rays, out: &mut Vec<Option<(f32, u32)>>) {
        if let Some(bvh) = &self.bvh {
            for first in (0..rays.len()).step_by(LANES) {
                let recip = slab_reciprocal_lanes(rays, first);
                let n = (rays.len() - first).min(LANES);
                out.extend((0..n).map(|k| bvh.closest_inlined(&rays.get(first + k), recip[k])));
            }
            return;
        }
        for first in (0..rays.len()).step_by(LANES) {
            let n = (rays.len() - first).min(LANES);
            let (mut lanes, skip) = rays.lanes(first);
            let mut best = u32xn::splat(u32::MAX);
            for j in 0..self.prims.len() {
                let t = self.shape_of(j as u32).intersect_lanes(&lanes);
                // A lane's skipped primitive counts as a miss, as in `closest_brute_force`.
                let not_skipped = f32xn::from_bits(!skip.simd_eq(u32xn::splat(j as u32)));
                let closer = t.simd_lt(lanes.tmax) & not_skipped;
                lanes.tmax = simd::sel(closer, t, lanes.tmax);
                best = closer.to_bits().select(u32xn::splat(j as u32), best);
            }
            let (t, best) = (lanes.tmax.to_array(), best.to_array());
            out.extend((0..n).map(|k| (best[k] != u32::MAX).then_some((t[k], best[k]))));
        }
    }

    /// [`Geometry::closest_many`] of coherent rays (each run of eight consecutive rays
    /// leaving one point, or nearby points, in nearby directions: a camera's rays through a
    /// pixel), the same answers up to ties between primitives hit at the same distance or
    /// a few ulps apart: with a BVH, eight rays at a time as a packet
    /// ([`super::bvh8_packet`]).
    pub fn closest_many_coherent(&self, rays: &Rays, out: &mut Vec<Option<(f32, u32)>>) {
        let Some(bvh) = &self.bvh else {
            return self.closest_many(rays, out);
        };
        let whole = rays.len() / WIDTH * WIDTH;
        for first in (0..whole).step_by(WIDTH) {
            let (lanes, skip) = rays.packet(first);
            let (t, prim) = bvh.closest_packet(&lanes, skip);
            let (t, prim) = (t.to_array(), prim.to_array());
            out.extend((0..WIDTH).map(|k| (prim[k] != u32::MAX).then_some((t[k], prim[k]))));
        }
        out.extend((whole..rays.len()).map(|i| bvh.closest(&rays.get(i))));
    }

    /// [`Geometry::occluded`] of each ray, appended to `out`, the same answers: ray by ray
    /// through the BVH, or in small scenes `LANES` rays at a time per primitive in SIMD lanes
    /// (as [`Geometry::closest_many`]).
    pub fn occluded_many(&self, rays: &Rays, out: &mut Vec<bool>) {
        if let Some(bvh) = &self.bvh {
            for first in (0..rays.len()).step_by(LANES) {
                let recip = slab_reciprocal_lanes(rays, first);
                let n = (rays.len() - first).min(LANES);
                out.extend((0..n).map(|k| bvh.occluded_inlined(&rays.get(first + k), recip[k])));
            }
            return;
        }
        for first in (0..rays.len()).step_by(LANES) {
            let n = (rays.len() - first).min(LANES);
            let (lanes, skip) = rays.lanes(first);
            let mut hit = f32xn::splat(0.0);
            for j in 0..self.prims.len() {
                let t = self.shape_of(j as u32).intersect_lanes(&lanes);
                let not_skipped = f32xn::from_bits(!skip.simd_eq(u32xn::splat(j as u32)));
                hit |= t.simd_lt(lanes.tmax) & not_skipped;
                if hit.all() {
                    break;
                }
            }
            let hit = hit.to_array();
            out.extend(hit[..n].iter().map(|&h| h != 0.0));
        }
    }

    /// [`Geometry::interaction`] of many hits, in order, into `out`: hit (i, t, prim) of ray
    /// i of `rays`. `out` is resized to the hits' count and its old contents overwritten (a
    /// reused queue is not zeroed first). Hits on spheres and on mesh triangles are
    /// computed a lane vector at a time in SIMD lanes ([`Sphere::surface_of`],
    /// [`triangle_surface`]: their square roots and divisions are a long dependency chain
    /// per hit), bit for bit the same; hits on rectangles one by one.
    pub fn interactions_many(&self, rays: &Rays, hits: &[(u32, f32, u32)], out: &mut Interactions) {
        out.resize(hits.len());
        // Hits on spheres and on triangles gather into lane batches of their kind.
        let (mut spheres, mut triangles) = (LaneBatch::default(), LaneBatch::default());
        for (h, &(i, t, prim)) in hits.iter().enumerate() {
            let primitive = self.prims.get(prim);
            match primitive.kind {
                PrimKind::Sphere(_) => {
                    if let Some(full) = spheres.push(h) {
                        self.sphere_interactions(rays, hits, &full, out);
                    }
                }
                PrimKind::Triangle { .. } => {
                    if let Some(full) = triangles.push(h) {
                        self.triangle_interactions(rays, hits, &full, out);
                    }
                }
                PrimKind::Rectangle(_) => {
                    let mut it = Interaction::ZERO;
                    self.interaction_of(&rays.get(i as usize), t, prim, primitive, &mut it);
                    out.set(h, &it);
                }
            }
        }
        if !spheres.rest().is_empty() {
            self.sphere_interactions(rays, hits, spheres.rest(), out);
        }
        if !triangles.rest().is_empty() {
            self.triangle_interactions(rays, hits, triangles.rest(), out);
        }
    }

    /// The interactions of up to `LANES` hits `which` (indices into `hits` and `out`), all on
    /// mesh triangles, in SIMD lanes: [`triangle_surface`] of the corners each lane reads,
    /// bit for bit [`Geometry::interaction`].
    fn triangle_interactions(
        &self,
        rays: &Rays,
        hits: &[(u32, f32, u32)],
        which: &[usize],
        out: &mut Interactions,
    ) {
        let n = which.len();
        debug_assert!((1..=LANES).contains(&n), "{n} hits for one lane vector");
        let hit = |k: usize| hits[which[k.min(n - 1)]];
        let (lanes, _) = rays.lanes_at(|k| hit(k).0 as usize);
        let corners = simd::lanes(|k| {
            let prim = hit(k).2;
            let primitive = self.prims.get(prim);
            match primitive.kind {
                PrimKind::Triangle { mesh, index } => {
                    let sg = self.shapes[primitive.shape as usize];
                    self.corners(&Triangle::new(mesh, &self.meshes[mesh as usize], index), sg)
                }
                _ => unreachable!("triangle hits only"),
            }
        });
        let TriangleSurface {
            p,
            ng,
            ns,
            dpdu,
            uv,
        } = triangle_surface(lanes.o, lanes.d, &Corners::lanes(&corners));
        let [p, ng, ns, dpdu] = [p, ng, ns, dpdu].map(|v| v.to_array());
        let [u, v] = uv.map(|c| c.to_array());
        for (k, &h) in which.iter().enumerate() {
            let (_, t, prim) = hits[h];
            let shape = self.prims.get(prim).shape;
            let sg = self.shapes[shape as usize];
            let it = Interaction {
                t,
                p: p[k],
                ng: sg.orient(ng[k]),
                ns: sg.orient(ns[k]),
                dpdu: dpdu[k],
                uv: Vec2::new(u[k], v[k]),
                shape,
                prim,
                exit: Vec3::ZERO,
            };
            out.set(h, &it);
        }
    }

    /// The interactions of up to `LANES` hits `which` (indices into `hits` and `out`), all on
    /// spheres, in SIMD lanes.
    fn sphere_interactions(
        &self,
        rays: &Rays,
        hits: &[(u32, f32, u32)],
        which: &[usize],
        out: &mut Interactions,
    ) {
        let n = which.len();
        let hit = |k: usize| hits[which[k.min(n - 1)]];
        let (lanes, _) = rays.lanes_at(|k| hit(k).0 as usize);
        let (o, d) = (lanes.o, lanes.d);
        let t = f32xn::new(simd::lanes(|k| hit(k).1));
        let cr = simd::rows4(|k| match &self.prims.get(hit(k).2).kind {
            PrimKind::Sphere(s) => [s.center.x, s.center.y, s.center.z, s.radius],
            _ => unreachable!("sphere hits only"),
        });
        // Ray::at: o + d t.
        let (p, nrm, dpdu) = Sphere::surface_of(o + d * t, V3::new(cr[0], cr[1], cr[2]), cr[3]);
        let (p, nrm, dpdu) = (p.to_array(), nrm.to_array(), dpdu.to_array());
        for (k, &h) in which.iter().enumerate() {
            let (_, t, prim) = hits[h];
            let shape = self.prims.get(prim).shape;
            let nk = nrm[k];
            let oriented = self.shapes[shape as usize].orient(nk);
            let it = Interaction {
                t,
                p: p[k],
                ng: oriented,
                ns: oriented,
                dpdu: dpdu[k],
                uv: Vec2::ZERO,
                shape,
                prim,
                exit: nk,
            };
            out.set(h, &it);
        }
    }

    /// Closest hit with its local geometry.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Interaction> {
        let (t, id) = self.closest(ray)?;
        Some(self.interaction(ray, t, id))
    }

    /// True when anything blocks the ray within (tmin, tmax).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        match &self.bvh {
            None => (0..self.prims.len() as u32)
                .any(|i| i != ray.skip && self.shape_of(i).intersect(ray) < ray.tmax),
            Some(bvh) => bvh.occluded(ray),
        }
    }

    /// Brute-force closest hit over all primitives (small scenes, and tests).
    #[inline]
    pub fn closest_brute_force(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        let mut r = *ray;
        for i in 0..self.prims.len() {
            if i as u32 == ray.skip {
                continue;
            }
            let t = self.shape_of(i as u32).intersect(&r);
            if t < r.tmax {
                r.tmax = t;
                best = Some((t, i as u32));
            }
        }
        best
    }

    /// Local geometry of a hit found by [`Geometry::closest`].
    #[inline]
    pub fn interaction(&self, ray: &Ray, t: f32, prim: u32) -> Interaction {
        let mut it = Interaction::ZERO;
        self.interaction_of(ray, t, prim, self.prims.get(prim), &mut it);
        it
    }

    /// [`Geometry::interaction`] of primitive `prim`, already looked up as `primitive`,
    /// written field by field into `it` (every field is set). Inlined (spheres and
    /// rectangles here; triangles out of line). It matches on the primitive's kind and
    /// reads a rectangle in place: the by-value copy of [`PrimSource::shape_of_primitive`]
    /// is stored to the stack and read back by loads that straddle its stores, which
    /// stalls store forwarding on every rectangle hit.
    #[inline(always)]
    fn interaction_of(
        &self,
        ray: &Ray,
        t: f32,
        prim: u32,
        primitive: Primitive,
        it: &mut Interaction,
    ) {
        let shape = primitive.shape;
        let sg = self.shapes[shape as usize];
        it.t = t;
        it.shape = shape;
        it.prim = prim;
        match primitive.kind {
            PrimKind::Sphere(s) => {
                let (pos, n, dpdu) = s.surface(ray.at(t));
                it.p = pos;
                it.ng = sg.orient(n);
                it.ns = sg.orient(n);
                it.dpdu = dpdu;
                it.uv = Vec2::ZERO;
                it.exit = n;
            }
            PrimKind::Rectangle(r) => {
                let r = &self.rects[r as usize];
                let uv = r.uv(ray.at(t));
                it.p = r.point(uv);
                it.ng = sg.orient(r.n);
                it.ns = sg.orient(r.n);
                it.dpdu = r.tangent();
                it.uv = uv;
                it.exit = Vec3::ZERO;
            }
            PrimKind::Triangle { mesh, index } => {
                let tri = Triangle::new(mesh, &self.meshes[mesh as usize], index);
                let (pos, ng, ns, dpdu, uv) = self.triangle_geometry(ray.o, ray.d, &tri, sg);
                it.p = pos;
                it.ng = sg.orient(ng);
                it.ns = sg.orient(ns);
                it.dpdu = dpdu;
                it.uv = uv;
                it.exit = Vec3::ZERO;
            }
        }
    }

    /// Position, geometric and shading normals, tangent and texture coordinates of a hit
    /// on a mesh triangle by the ray from `o` along `d` (passed by value: the ray may be
    /// one just read from columns, [`super::Rays::get`]): [`triangle_surface`] of one hit.
    #[inline(never)]
    fn triangle_geometry(
        &self,
        o: Vec3,
        d: Vec3,
        tri: &Triangle,
        sg: ShapeGeom,
    ) -> (Vec3, Vec3, Vec3, Vec3, Vec2) {
        let TriangleSurface {
            p,
            ng,
            ns,
            dpdu,
            uv: [u, v],
        } = triangle_surface(V3::from(o), V3::from(d), &self.corners(tri, sg));
        (p.into(), ng.into(), ns.into(), dpdu.into(), Vec2::new(u, v))
    }

    /// What [`triangle_surface`] reads of triangle `tri` of a shape with `sg`: its vertex
    /// and edges, its vertex normals where the shape shades with them, its texture
    /// coordinates where the mesh has them.
    #[inline(always)]
    fn corners(&self, tri: &Triangle, sg: ShapeGeom) -> Corners<f32> {
        let mesh = &self.meshes[tri.mesh as usize];
        let idx = mesh.indices[tri.index as usize];
        let smooth = !sg.face_normals && !mesh.normals.is_empty();
        let textured = !mesh.texcoords.is_empty();
        Corners {
            p0: tri.p0.into(),
            e1: tri.e1.into(),
            e2: tri.e2.into(),
            normals: idx.map(|k| match smooth {
                true => mesh.normals[k as usize].into(),
                false => V3::new(0.0, 0.0, 0.0),
            }),
            texcoords: idx.map(|k| match textured {
                true => mesh.texcoords[k as usize].to_array(),
                false => [0.0; 2],
            }),
            smooth,
            textured,
        }
    }

    /// True when queries go through the BVH (more than [`SMALL_SCENE`] primitives).
    pub fn has_bvh(&self) -> bool {
        self.bvh.is_some()
    }
}

/// Indices of hits of one kind, gathered a lane vector at a time.
#[derive(Default)]
struct LaneBatch {
    idx: [usize; LANES],
    n: usize,
}

impl LaneBatch {
    /// Adds hit `h`; when that fills a lane vector, returns it and starts the next.
    #[inline(always)]
    fn push(&mut self, h: usize) -> Option<[usize; LANES]> {
        self.idx[self.n] = h;
        self.n += 1;
        (self.n == LANES).then(|| {
            self.n = 0;
            self.idx
        })
    }

    /// The hits gathered since the last full lane vector.
    fn rest(&self) -> &[usize] {
        &self.idx[..self.n]
    }
}

/// The BVH's [`slab_reciprocal`]s of the directions of rays `first..first + LANES` (past
/// the end, the last ray's), computed in lanes: per ray, those of its x, y and z.
#[inline(always)]
fn slab_reciprocal_lanes(rays: &Rays, first: usize) -> [[f32; 3]; LANES] {
    let d = rays.dirs().load(first);
    let [x, y, z] = [d.x, d.y, d.z].map(|c| slab_reciprocal(c).to_array());
    simd::lanes(|k| [x[k], y[k], z[k]])
}

/// What the local geometry of hits on mesh triangles reads, for one hit or lanes of hits:
/// the triangle's vertex `p0` and edges, its three vertex normals where the shape shades
/// with them (`smooth`; zero elsewhere) and its texture coordinates where the mesh has
/// them (`textured`; zero elsewhere).
struct Corners<F: Arith> {
    p0: V3<F>,
    e1: V3<F>,
    e2: V3<F>,
    normals: [V3<F>; 3],
    texcoords: [[F; 2]; 3],
    smooth: F::Mask,
    textured: F::Mask,
}

impl Corners<f32xn> {
    /// One lane per hit.
    #[inline(always)]
    fn lanes(c: &[Corners<f32>; LANES]) -> Self {
        let f = |g: fn(&Corners<f32>) -> f32| f32xn::new(simd::lanes(|k| g(&c[k])));
        let v3 = |g: fn(&Corners<f32>) -> V3<f32>| {
            let v: [V3<f32>; LANES] = simd::lanes(|k| g(&c[k]));
            V3::new(
                f32xn::new(v.map(|v| v.x)),
                f32xn::new(v.map(|v| v.y)),
                f32xn::new(v.map(|v| v.z)),
            )
        };
        Corners {
            p0: v3(|c| c.p0),
            e1: v3(|c| c.e1),
            e2: v3(|c| c.e2),
            normals: [
                v3(|c| c.normals[0]),
                v3(|c| c.normals[1]),
                v3(|c| c.normals[2]),
            ],
            texcoords: [
                [f(|c| c.texcoords[0][0]), f(|c| c.texcoords[0][1])],
                [f(|c| c.texcoords[1][0]), f(|c| c.texcoords[1][1])],
                [f(|c| c.texcoords[2][0]), f(|c| c.texcoords[2][1])],
            ],
            smooth: simd::mask_from_bools(simd::lanes(|k| c[k].smooth)),
            textured: simd::mask_from_bools(simd::lanes(|k| c[k].textured)),
        }
    }
}

/// The local geometry of hits on mesh triangles by rays from `o` along `d`, written once
/// for one hit and for lanes: position, geometric and shading normals, tangent along the
/// first edge and texture coordinates (before the shape's `flip_normals`). The barycentrics
/// are Möller-Trumbore's over the whole line (a third each where the line misses it,
/// which a hit the traversal found does not), the position is recomputed from them (a few
/// ULPs of the vertices), the shading normal is the normalized interpolation of the vertex
/// normals, and the geometric normal turns to its side (pbrt-v4's rule: the file's normals
/// say where the outside is).
#[inline(always)]
fn triangle_surface<F: Arith>(o: V3<F>, d: V3<F>, c: &Corners<F>) -> TriangleSurface<F> {
    let (zero, one) = (F::of(0.0), F::of(1.0));
    let origin = V3::new(zero, zero, zero);
    let q = kernels::moller_trumbore(o, d, c.p0, c.e1, c.e2);
    let on_line = kernels::triangle_hit(q, F::of(f64::NEG_INFINITY), F::of(f64::INFINITY));
    let third = F::of((1.0f32 / 3.0) as f64);
    let (b1, b2) = (select(on_line, q.u, third), select(on_line, q.v, third));
    let w = [one - b1 - b2, b1, b2];
    let face = c.e1.cross(c.e2).unit_or(origin);
    let n = (0..3).fold(origin, |a, k| a + c.normals[k] * w[k]);
    let len2 = n.length_squared();
    let interpolated = c.smooth & gt(len2, zero);
    let ns = select_v3(interpolated, n * (one / sqrt(len2)), face);
    let ng = select_v3(interpolated & lt(face.dot(ns), zero), -face, face);
    let uv: [F; 2] = std::array::from_fn(|a| {
        let t = (0..3).fold(zero, |s, k| s + c.texcoords[k][a] * w[k]);
        select(c.textured, t, [b1, b2][a])
    });
    TriangleSurface {
        p: c.p0 + c.e1 * b1 + c.e2 * b2,
        ng,
        ns,
        dpdu: c.e1.unit_or(origin),
        uv,
    }
}

/// [`triangle_surface`]'s result: position, geometric and shading normals, tangent and
/// texture coordinates.
struct TriangleSurface<F> {
    p: V3<F>,
    ng: V3<F>,
    ns: V3<F>,
    dpdu: V3<F>,
    uv: [F; 2],
}
