//! All primitives of a scene under one BVH ([`Bvh8`]: eight-wide nodes and leaf blocks
//! tested in SIMD lanes) for closest-hit and occlusion queries, the local geometry of
//! hits, and the batched forms of these queries that the wavefront integrator calls.

use super::bvh8::Bvh8;
use super::kernels::V3;
use super::{Interaction, Interactions, Mesh, Ray, Rays, Rectangle, Sphere, Triangle};
use glam::{Vec2, Vec3};
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
            out.extend((0..rays.len()).map(|i| bvh.closest_inlined(&rays.get(i))));
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

    /// [`Geometry::occluded`] of each ray, appended to `out`, the same answers: ray by ray
    /// through the BVH, or in small scenes `LANES` rays at a time per primitive in SIMD lanes
    /// (as [`Geometry::closest_many`]).
    pub fn occluded_many(&self, rays: &Rays, out: &mut Vec<bool>) {
        if let Some(bvh) = &self.bvh {
            out.extend((0..rays.len()).map(|i| bvh.occluded_inlined(&rays.get(i))));
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
    /// reused queue is not zeroed first). Hits on spheres are computed a lane vector at a
    /// time in SIMD lanes ([`Sphere::surface_of`]: its square roots and divisions are a long
    /// dependency chain per hit), bit for bit the same; other hits one by one.
    pub fn interactions_many(&self, rays: &Rays, hits: &[(u32, f32, u32)], out: &mut Interactions) {
        out.resize(hits.len());
        let mut spheres = [0usize; LANES];
        let mut n = 0;
        for (h, &(i, t, prim)) in hits.iter().enumerate() {
            let primitive = self.prims.get(prim);
            if matches!(primitive.kind, PrimKind::Sphere(_)) {
                spheres[n] = h;
                n += 1;
                if n == LANES {
                    self.sphere_interactions(rays, hits, &spheres, out);
                    n = 0;
                }
            } else {
                let mut it = Interaction::ZERO;
                self.interaction_of(&rays.get(i as usize), t, prim, primitive, &mut it);
                out.set(h, &it);
            }
        }
        if n > 0 {
            self.sphere_interactions(rays, hits, &spheres[..n], out);
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
            let oriented = if self.shapes[shape as usize].flip_normals {
                -nk
            } else {
                nk
            };
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
        let orient = |n: Vec3| if sg.flip_normals { -n } else { n };
        it.t = t;
        it.shape = shape;
        it.prim = prim;
        match primitive.kind {
            PrimKind::Sphere(s) => {
                let (pos, n, dpdu) = s.surface(ray.at(t));
                it.p = pos;
                it.ng = orient(n);
                it.ns = orient(n);
                it.dpdu = dpdu;
                it.uv = Vec2::ZERO;
                it.exit = n;
            }
            PrimKind::Rectangle(r) => {
                let r = &self.rects[r as usize];
                let uv = r.uv(ray.at(t));
                it.p = r.point(uv);
                it.ng = orient(r.n);
                it.ns = orient(r.n);
                it.dpdu = r.tangent();
                it.uv = uv;
                it.exit = Vec3::ZERO;
            }
            PrimKind::Triangle { mesh, index } => {
                let tri = Triangle::new(mesh, &self.meshes[mesh as usize], index);
                let (pos, ng, ns, dpdu, uv) = self.triangle_geometry(ray.o, ray.d, &tri, sg);
                it.p = pos;
                it.ng = orient(ng);
                it.ns = orient(ns);
                it.dpdu = dpdu;
                it.uv = uv;
                it.exit = Vec3::ZERO;
            }
        }
    }

    /// Position, geometric and shading normals, tangent and texture coordinates of a hit
    /// on a mesh triangle by the ray from `o` along `d` (passed by value: the ray may be
    /// one just read from columns, [`super::Rays::get`]).
    #[inline(never)]
    fn triangle_geometry(
        &self,
        o: Vec3,
        d: Vec3,
        tri: &Triangle,
        sg: ShapeGeom,
    ) -> (Vec3, Vec3, Vec3, Vec3, Vec2) {
        let b = tri
            .intersect_bary(&Ray {
                tmin: f32::NEG_INFINITY,
                tmax: f32::INFINITY,
                ..Ray::new(o, d)
            })
            .map(|(_, b)| b)
            .unwrap_or(Vec2::splat(1.0 / 3.0));
        let mesh = &self.meshes[tri.mesh as usize];
        let idx = mesh.indices[tri.index as usize];
        let mut ng = tri.normal();
        let w = [1.0 - b.x - b.y, b.x, b.y];
        let mut ns = ng;
        if !sg.face_normals && !mesh.normals.is_empty() {
            let n = idx
                .iter()
                .zip(w)
                .fold(Vec3::ZERO, |a, (&k, wk)| a + mesh.normals[k as usize] * wk);
            if n.length_squared() > 0.0 {
                ns = n.normalize();
                // The file's normals say where the outside is (pbrt-v4's rule).
                if ng.dot(ns) < 0.0 {
                    ng = -ng;
                }
            }
        }
        let uv = if mesh.texcoords.is_empty() {
            b
        } else {
            idx.iter().zip(w).fold(Vec2::ZERO, |a, (&k, wk)| {
                a + mesh.texcoords[k as usize] * wk
            })
        };
        (tri.point(b), ng, ns, tri.e1.normalize_or_zero(), uv)
    }

    /// True when queries go through the BVH (more than [`SMALL_SCENE`] primitives).
    pub fn has_bvh(&self) -> bool {
        self.bvh.is_some()
    }
}
