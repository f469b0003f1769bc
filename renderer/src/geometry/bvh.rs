//! All primitives of a scene under one BVH: obvhs builds a binary BVH with PLOC
//! (Meister and Bittner 2018) plus reinsertion, converts it to a compressed 8-wide BVH
//! (Ylitie et al. 2017), and traverses it for closest-hit and occlusion queries.

use super::{Interaction, Mesh, Ray, Rectangle, Sphere, Triangle};
use glam::{Vec2, Vec3, Vec3A};
use lobe_materials::simd;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::{Boundable, BvhBuildParams};
use std::time::Duration;
use wide::{f32x8, u32x8};

/// The shape of one primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimKind {
    Sphere(Sphere),
    Triangle(Triangle),
    Rectangle(Rectangle),
}

/// A BVH primitive and the scene shape it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primitive {
    pub kind: PrimKind,
    pub shape: u32,
}

impl Primitive {
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> f32 {
        match &self.kind {
            PrimKind::Sphere(s) => s.intersect(ray),
            PrimKind::Triangle(t) => t.intersect(ray),
            PrimKind::Rectangle(r) => r.intersect(ray),
        }
    }
}

impl Boundable for Primitive {
    fn aabb(&self) -> Aabb {
        let (lo, hi) = match &self.kind {
            PrimKind::Sphere(s) => (
                s.center - Vec3::splat(s.radius),
                s.center + Vec3::splat(s.radius),
            ),
            PrimKind::Triangle(t) => {
                let (a, b, c) = (t.p0, t.p0 + t.e1, t.p0 + t.e2);
                (a.min(b).min(c), a.max(b).max(c))
            }
            PrimKind::Rectangle(r) => {
                let pts = [
                    r.corner,
                    r.corner + r.eu,
                    r.corner + r.ev,
                    r.corner + r.eu + r.ev,
                ];
                let lo = pts.iter().fold(Vec3::INFINITY, |a, p| a.min(*p));
                let hi = pts.iter().fold(Vec3::NEG_INFINITY, |a, p| a.max(*p));
                (lo, hi)
            }
        };
        // Pad flat boxes a little so axis-aligned rectangles and triangles have volume.
        let pad = (hi - lo).max_element().max(1e-3) * 1e-5;
        Aabb::new(
            Vec3A::from(lo - Vec3::splat(pad)),
            Vec3A::from(hi + Vec3::splat(pad)),
        )
    }
}

/// Scenes with at most this many primitives skip the BVH.
pub const SMALL_SCENE: usize = 4;

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
    pub prims: Vec<Primitive>,
    pub meshes: Vec<Mesh>,
    pub shapes: Vec<ShapeGeom>,
    bvh: Option<CwBvh>,
}

impl Geometry {
    /// Builds the BVH. Primitives are reordered to the BVH's leaf order. Scenes of at most
    /// [`SMALL_SCENE`] primitives are tested exhaustively: cheaper than any traversal.
    pub fn build(prims: Vec<Primitive>, meshes: Vec<Mesh>, shapes: Vec<ShapeGeom>) -> Self {
        if prims.len() <= SMALL_SCENE {
            return Self {
                prims,
                meshes,
                shapes,
                bvh: None,
            };
        }
        let bvh = obvhs::cwbvh::builder::build_cwbvh(
            &prims,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let ordered: Vec<Primitive> = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        Self {
            prims: ordered,
            meshes,
            shapes,
            bvh: Some(bvh),
        }
    }

    fn bvh_ray(ray: &Ray) -> BvhRay {
        BvhRay::new(Vec3A::from(ray.o), Vec3A::from(ray.d), ray.tmin, ray.tmax)
    }

    /// Closest hit: (t, primitive index), without computing the local geometry.
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<(f32, u32)> {
        let Some(bvh) = self.bvh.as_ref() else {
            return self.closest_brute_force(ray);
        };
        let mut hit = RayHit::none();
        let mut r = *ray;
        let found = bvh.ray_traverse(Self::bvh_ray(ray), &mut hit, |br, id| {
            if id as u32 == ray.skip {
                return f32::INFINITY;
            }
            r.tmax = br.tmax;
            self.prims[id].intersect(&r)
        });
        found.then_some((hit.t, hit.primitive_id))
    }

    /// [`Geometry::closest`] of the rays `rays[i]` for each `i` in `idx`, appended to
    /// `out`, bit for bit the same. Small scenes of spheres alone (no BVH) test eight rays
    /// at a time against each sphere in SIMD lanes ([`Sphere::intersect_x8`]); other
    /// scenes go ray by ray.
    pub fn closest_many(&self, rays: &[Ray], idx: &[u32], out: &mut Vec<Option<(f32, u32)>>) {
        if !self.spheres_only() {
            out.extend(idx.iter().map(|&i| self.closest(&rays[i as usize])));
            return;
        }
        for ic in idx.chunks(8) {
            let n = ic.len();
            let (o, d, tmin, mut tmax, skip) =
                Self::ray_lanes(|k| &rays[ic[k.min(n - 1)] as usize]);
            let mut best = u32x8::splat(u32::MAX);
            for (j, p) in self.prims.iter().enumerate() {
                let PrimKind::Sphere(s) = &p.kind else {
                    unreachable!("spheres only")
                };
                let t = s.intersect_x8(o, d, tmin, tmax);
                // A lane's skipped primitive counts as a miss, as in `closest_brute_force`.
                let not_skipped = f32x8::from_bits(!skip.simd_eq(u32x8::splat(j as u32)));
                let closer = t.simd_lt(tmax) & not_skipped;
                tmax = simd::sel(closer, t, tmax);
                best = closer.to_bits().select(u32x8::splat(j as u32), best);
            }
            let (t, best) = (tmax.to_array(), best.to_array());
            out.extend((0..n).map(|k| (best[k] != u32::MAX).then_some((t[k], best[k]))));
        }
    }

    /// [`Geometry::occluded`] of each ray, appended to `out`, the same answers: small
    /// scenes of spheres alone test eight rays at a time per sphere in SIMD lanes (as
    /// [`Geometry::closest_many`]); other scenes go ray by ray.
    pub fn occluded_many(&self, rays: &[Ray], out: &mut Vec<bool>) {
        if !self.spheres_only() {
            out.extend(rays.iter().map(|r| self.occluded(r)));
            return;
        }
        for rc in rays.chunks(8) {
            let n = rc.len();
            let (o, d, tmin, tmax, skip) = Self::ray_lanes(|k| &rc[k.min(n - 1)]);
            let mut hit = f32x8::splat(0.0);
            for (j, p) in self.prims.iter().enumerate() {
                let PrimKind::Sphere(s) = &p.kind else {
                    unreachable!("spheres only")
                };
                let t = s.intersect_x8(o, d, tmin, tmax);
                let not_skipped = f32x8::from_bits(!skip.simd_eq(u32x8::splat(j as u32)));
                hit |= t.simd_lt(tmax) & not_skipped;
            }
            let hit = hit.to_array();
            out.extend(hit[..n].iter().map(|&h| h != 0.0));
        }
    }

    /// [`Geometry::interaction`] of many hits, appended to `out` in order: hit (i, t, prim)
    /// of ray `rays[i]`. Scenes of spheres alone compute eight at a time in SIMD lanes
    /// ([`Sphere::surface_x8`]: its square roots and divisions are a long dependency chain
    /// per hit), bit for bit the same; other scenes go hit by hit.
    pub fn interactions_many(
        &self,
        rays: &[Ray],
        hits: &[(u32, f32, u32)],
        out: &mut Vec<Interaction>,
    ) {
        if !self.spheres_only() {
            for &(i, t, prim) in hits {
                out.push(Interaction::ZERO);
                let it = out.last_mut().expect("just pushed");
                self.interaction_into(&rays[i as usize], t, prim, it);
            }
            return;
        }
        for hc in hits.chunks(8) {
            let n = hc.len();
            let hit = |k: usize| hc[k.min(n - 1)];
            let (o, d, _, _, _) = Self::ray_lanes(|k| &rays[hit(k).0 as usize]);
            let t = f32x8::new(simd::lanes(|k| hit(k).1));
            let cr = simd::rows4(|k| match &self.prims[hit(k).2 as usize].kind {
                PrimKind::Sphere(s) => [s.center.x, s.center.y, s.center.z, s.radius],
                _ => unreachable!("spheres only"),
            });
            // Ray::at: o + d t.
            let at = [o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t];
            let (p, nrm, dpdu) = Sphere::surface_x8(at, [cr[0], cr[1], cr[2]], cr[3]);
            let (p, nrm, dpdu) = (simd::arrays3(p), simd::arrays3(nrm), simd::arrays3(dpdu));
            for (k, &(_, t, prim)) in hc.iter().enumerate() {
                let shape = self.prims[prim as usize].shape;
                let v = |a: &[[f32; 8]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
                let nk = v(&nrm);
                let oriented = if self.shapes[shape as usize].flip_normals {
                    -nk
                } else {
                    nk
                };
                out.push(Interaction {
                    t,
                    p: v(&p),
                    ng: oriented,
                    ns: oriented,
                    dpdu: v(&dpdu),
                    uv: Vec2::ZERO,
                    shape,
                    prim,
                    exit: nk,
                });
            }
        }
    }

    /// No BVH, and every primitive a sphere: the case the SIMD batch queries handle.
    fn spheres_only(&self) -> bool {
        self.bvh.is_none()
            && self
                .prims
                .iter()
                .all(|p| matches!(p.kind, PrimKind::Sphere(_)))
    }

    /// Eight rays in SIMD lanes, `ray(k)` in lane k: origins, directions, tmin, tmax,
    /// skipped primitives. A ray's first 32 bytes are two rows of four floats (o, d.x and
    /// d.y, d.z, tmin, tmax), read as two 4x8 transposes.
    #[inline(always)]
    fn ray_lanes<'a>(
        ray: impl Fn(usize) -> &'a Ray,
    ) -> ([f32x8; 3], [f32x8; 3], f32x8, f32x8, u32x8) {
        let a = simd::transpose4x8(&simd::lanes(|k| {
            let r = ray(k);
            [r.o.x, r.o.y, r.o.z, r.d.x]
        }));
        let b = simd::transpose4x8(&simd::lanes(|k| {
            let r = ray(k);
            [r.d.y, r.d.z, r.tmin, r.tmax]
        }));
        (
            [a[0], a[1], a[2]],
            [a[3], b[0], b[1]],
            b[2],
            b[3],
            u32x8::new(simd::lanes(|k| ray(k).skip)),
        )
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
            None => self
                .prims
                .iter()
                .enumerate()
                .any(|(i, p)| i as u32 != ray.skip && p.intersect(ray) < ray.tmax),
            Some(bvh) => !bvh.ray_traverse_miss(Self::bvh_ray(ray), |_, id| {
                if id as u32 == ray.skip {
                    f32::INFINITY
                } else {
                    self.prims[id].intersect(ray)
                }
            }),
        }
    }

    /// Brute-force closest hit over all primitives (small scenes, and tests).
    #[inline]
    pub fn closest_brute_force(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        let mut r = *ray;
        for (i, p) in self.prims.iter().enumerate() {
            if i as u32 == ray.skip {
                continue;
            }
            let t = p.intersect(&r);
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
        self.interaction_into(ray, t, prim, &mut it);
        it
    }

    /// [`Geometry::interaction`] written field by field into `it` (every field is set):
    /// [`Geometry::interactions_many`] fills its list in place this way, with no copy of
    /// a whole record through the stack. Inlined (spheres and rectangles here; triangles out of
    /// line).
    #[inline(always)]
    pub fn interaction_into(&self, ray: &Ray, t: f32, prim: u32, it: &mut Interaction) {
        let p = &self.prims[prim as usize];
        let sg = self.shapes[p.shape as usize];
        let orient = |n: Vec3| if sg.flip_normals { -n } else { n };
        it.t = t;
        it.shape = p.shape;
        it.prim = prim;
        match &p.kind {
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
                let uv = r.uv(ray.at(t));
                it.p = r.point(uv);
                it.ng = orient(r.n);
                it.ns = orient(r.n);
                it.dpdu = r.eu.normalize();
                it.uv = uv;
                it.exit = Vec3::ZERO;
            }
            PrimKind::Triangle(tri) => {
                let (pos, ng, ns, dpdu, uv) = self.triangle_geometry(ray, tri, sg);
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
    /// on a mesh triangle.
    #[inline(never)]
    fn triangle_geometry(
        &self,
        ray: &Ray,
        tri: &Triangle,
        sg: ShapeGeom,
    ) -> (Vec3, Vec3, Vec3, Vec3, Vec2) {
        let b = tri
            .intersect_bary(&Ray {
                tmin: f32::NEG_INFINITY,
                tmax: f32::INFINITY,
                ..*ray
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
