//! The renderer's acceleration structure: an eight-wide BVH traversed one ray at a time
//! with the eight children of a node tested in SIMD lanes (Wald, Benthin and Boulos,
//! "Getting Rid of Packets: Efficient SIMD Single-Ray Traversal using Multi-branching
//! BVHs", 2008; the layout of Embree's BVH8), whose leaves hold up to eight primitives of
//! one kind in lanes (triangles, spheres, rectangles), intersected together with the same
//! operations, lane by lane, as the scalar tests of [`Triangle`], [`Sphere`] and
//! [`Rectangle`] (so a hit's distance is bit for bit the scalar one).
//!
//! Coherent rays (the camera's) are traversed eight at a time instead, by
//! [`super::bvh8_packet`], with the same box test ([`slab_test`]). Built by
//! [`super::bvh8_build`] from a binary BVH. Child boxes are tested with
//! pbrt-v4's conservative slab test (the far distance scaled by 1 + 2 gamma(3), Pharr,
//! Jakob and Humphreys, "Physically Based Rendering", 4th ed., section 6.8.2), and children
//! are visited nearest first.
//!
//! Memory: 224 bytes per node and 320 (triangles), 160 (spheres) or 416 (rectangles)
//! bytes per leaf block, reported by [`Bvh8::memory_bytes`].

use super::Ray;
use super::kernels::{self, RayLanes, V3};
use super::primitive::PrimSource;
#[cfg(doc)]
use super::{Rectangle, Sphere, Triangle};
use lobe_materials::math::{Arith, abs, copysign, lt, select};
use lobe_materials::simd::sel;
use std::mem::MaybeUninit;
use wide::{f32x8, u32x8};

/// Children of a node, and primitives of a leaf block: eight f32 lanes (`f32x8`) in every
/// build, whatever the lane count of the batched stages ([`lobe_materials::simd::LANES`]).
pub(super) const WIDTH: usize = 8;
/// Traversal stack entries: visiting a node takes one child off the stack (or, when it is
/// the only one hit, visits it without the stack) and puts at most seven others on it, so
/// a tree of depth d needs at most 7 d + 1; [`Bvh8::build`] refuses deeper trees.
pub(super) const STACK: usize = 256;
pub(super) const MAX_DEPTH: usize = (STACK - 1) / (WIDTH - 1);

/// Kind of a child reference (its top two bits); the other 30 bits are an index into
/// `nodes` or into the block array of that kind.
pub(super) const INNER: u32 = 0;
pub(super) const TRIANGLES: u32 = 1;
pub(super) const SPHERES: u32 = 2;
pub(super) const RECTANGLES: u32 = 3;
pub(super) const KIND_SHIFT: u32 = 30;
pub(super) const INDEX_MASK: u32 = (1 << KIND_SHIFT) - 1;

/// 1 + 2 gamma(3), pbrt-v4's factor making the far slab distance conservative.
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Eight child boxes in lanes (`bounds[axis][0]` lower, `[1]` upper; empty slots have
/// lower +inf and upper -inf, so no ray hits them) and their references.
#[derive(Clone, Copy)]
#[repr(C)]
pub(super) struct Node {
    pub(super) bounds: [[f32x8; 2]; 3],
    pub(super) child: [u32; WIDTH],
}

/// Up to eight triangles in lanes (vertex p0 and edges e1, e2 per axis) and their
/// primitive indices; unused lanes repeat a used one.
#[derive(Clone, Copy)]
#[repr(C)]
pub(super) struct TriBlock {
    pub(super) p0: V3<f32x8>,
    pub(super) e1: V3<f32x8>,
    pub(super) e2: V3<f32x8>,
    pub(super) id: u32x8,
}

#[derive(Clone, Copy)]
#[repr(C)]
pub(super) struct SphereBlock {
    pub(super) center: V3<f32x8>,
    pub(super) radius: f32x8,
    pub(super) id: u32x8,
}

#[derive(Clone, Copy)]
#[repr(C)]
pub(super) struct RectBlock {
    pub(super) corner: V3<f32x8>,
    pub(super) n: V3<f32x8>,
    pub(super) du: V3<f32x8>,
    pub(super) dv: V3<f32x8>,
    pub(super) id: u32x8,
}

/// A ray prepared for box tests: safe reciprocal direction and origin times it in all
/// lanes (a slab distance is then one fused multiply-subtract), which bound of each axis
/// is the near one, and the range.
struct BoxRay {
    o_inv: [f32x8; 3],
    inv: [f32x8; 3],
    near: [usize; 3],
    tmin: f32x8,
}

impl BoxRay {
    /// From the ray and the [`slab_reciprocal`]s of its direction's components.
    #[inline(always)]
    fn new(ray: &Ray, reciprocal: [f32; 3]) -> Self {
        let inv = reciprocal.map(f32x8::splat);
        let near = ray.d.to_array().map(|c| usize::from(c.is_sign_negative()));
        let o = ray.o.to_array();
        Self {
            o_inv: [0, 1, 2].map(|a| f32x8::splat(o[a]) * inv[a]),
            inv,
            near,
            tmin: f32x8::splat(ray.tmin),
        }
    }

    /// Entry distances of the eight child boxes and the mask of those the ray enters
    /// before `tmax`.
    #[inline(always)]
    fn test(&self, node: &Node, tmax: f32) -> (f32x8, u32) {
        let (n, f) = (self.near, self.near.map(|s| 1 - s));
        let (tn, hit) = slab_test(
            [0, 1, 2].map(|a| node.bounds[a][n[a]]),
            [0, 1, 2].map(|a| node.bounds[a][f[a]]),
            (&self.inv, &self.o_inv),
            (self.tmin, f32x8::splat(tmax)),
        );
        (tn, hit.to_bitmask())
    }
}

/// The slab test of eight boxes and rays, lane by lane (eight children against one ray, or
/// one child against eight rays: the same operations either way): per axis the box's
/// `near` and `far` bound (the upper one is near where the direction is negative), the
/// ray's [`slab_reciprocal`]s `inv` of its direction and its origin times them, `o_inv`,
/// and its range. Returns the entry distances and the mask of the lanes whose ray enters
/// its box before `tmax`.
#[inline(always)]
pub(super) fn slab_test(
    near: [f32x8; 3],
    far: [f32x8; 3],
    (inv, o_inv): (&[f32x8; 3], &[f32x8; 3]),
    (tmin, tmax): (f32x8, f32x8),
) -> (f32x8, f32x8) {
    // bound * inv - o * inv, fused where the target has FMA (the far distance's
    // conservative factor covers either rounding).
    let slab = |bound: f32x8, a: usize| bound.mul_sub(inv[a], o_inv[a]);
    let tn = slab(near[0], 0)
        .fast_max(slab(near[1], 1))
        .fast_max(slab(near[2], 2).fast_max(tmin));
    let tf = slab(far[0], 0)
        .fast_min(slab(far[1], 1))
        .fast_min(slab(far[2], 2));
    let tf = (tf * f32x8::splat(FAR_SCALE)).fast_min(tmax);
    (tn, tn.simd_le(tf))
}

/// The reciprocal of a ray direction's component `c` (one, or lanes of them) for the slab
/// test: a zero component gets a tiny one of the same sign, so that the reciprocals are
/// finite and the slab distances free of 0 * inf (Embree's rule).
#[inline(always)]
pub(super) fn slab_reciprocal<T: Arith>(c: T) -> T {
    let tiny = T::of(1e-30);
    T::of(1.0) / select(lt(abs(c), tiny), copysign(tiny, c), c)
}

/// [`slab_reciprocal`] of each component of `d`.
#[inline(always)]
fn slab_reciprocals(d: glam::Vec3) -> [f32; 3] {
    d.to_array().map(slab_reciprocal)
}

/// A ray splatted into SIMD lanes for leaf tests, and the primitive it skips.
struct LaneRay {
    o: V3<f32x8>,
    d: V3<f32x8>,
    tmin: f32x8,
    skip: u32x8,
}

impl LaneRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        Self {
            o: kernels::splat3(ray.o),
            d: kernels::splat3(ray.d),
            tmin: f32x8::splat(ray.tmin),
            skip: u32x8::splat(ray.skip),
        }
    }

    #[inline(always)]
    fn with_tmax(&self, tmax: f32x8) -> RayLanes<f32x8> {
        RayLanes {
            o: self.o,
            d: self.d,
            tmin: self.tmin,
            tmax,
        }
    }
}

/// The nearest lane of `t` below `tmax` whose primitive is not skipped: (t, primitive).
/// Ties go to the lowest lane.
#[inline(always)]
fn nearest_lane(t: f32x8, id: u32x8, skip: u32x8, tmax: f32) -> Option<(f32, u32)> {
    let skipped = f32x8::from_bits(id.simd_eq(skip));
    let t = sel(skipped, f32x8::splat(f32::INFINITY), t);
    let mask = t.simd_lt(f32x8::splat(tmax)).to_bitmask();
    if mask == 0 {
        return None;
    }
    let ts = t.to_array();
    let ids = id.to_array();
    let mut best = mask.trailing_zeros() as usize;
    let mut m = mask & (mask - 1);
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        if ts[k] < ts[best] {
            best = k;
        }
        m &= m - 1;
    }
    Some((ts[best], ids[best]))
}

/// Whether any lane of `t` is below `tmax` for a primitive that is not skipped.
#[inline(always)]
fn any_lane(t: f32x8, id: u32x8, skip: u32x8, tmax: f32) -> bool {
    let kept = !f32x8::from_bits(id.simd_eq(skip));
    (t.simd_lt(f32x8::splat(tmax)) & kept).any()
}

/// The eight-wide BVH over a scene's primitives (indices into the slice it was built from).
pub struct Bvh8 {
    pub(super) nodes: Vec<Node>,
    pub(super) tris: Vec<TriBlock>,
    pub(super) spheres: Vec<SphereBlock>,
    pub(super) rects: Vec<RectBlock>,
    pub(super) depth: usize,
}

/// A traversal stack entry: a child reference and the distance at which the ray enters it.
type Entry = (u32, f32);

impl Bvh8 {
    /// Builds the tree over the primitives of `source` (at least one)
    /// ([`super::bvh8_build`]). Errors when the tree would be deeper than the traversal
    /// stack allows (not seen on any real scene: an SAH tree of a billion primitives is
    /// about 12 levels deep).
    pub fn build(source: PrimSource) -> Result<Self, String> {
        super::bvh8_build::build(source)
    }

    /// Bytes held by the nodes and leaf blocks.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        self.nodes.len() * size_of::<Node>()
            + self.tris.len() * size_of::<TriBlock>()
            + self.spheres.len() * size_of::<SphereBlock>()
            + self.rects.len() * size_of::<RectBlock>()
    }

    /// Levels of inner nodes.
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Nodes and leaf blocks (triangles, spheres, rectangles).
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        (
            self.nodes.len(),
            self.tris.len(),
            self.spheres.len(),
            self.rects.len(),
        )
    }

    /// The tree's surface area heuristic cost (Goldsmith and Salmon 1987; MacDonald and
    /// Booth 1990): the expected number of eight-wide tests (a node's boxes, or a leaf
    /// block's primitives, each one test) for a ray that crosses the root's box, each box
    /// taken as hit with the probability of its area over the root's. A measure of the
    /// tree's quality free of timing noise: lower is faster to traverse.
    pub fn sah_cost(&self) -> f64 {
        // Half the surface area of the box lo..hi; 0 for an empty slot (lower +inf, upper
        // -inf), which no ray hits.
        let half_area = |lo: [f32; 3], hi: [f32; 3]| -> f64 {
            let e: [f64; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) as f64);
            match e.iter().all(|x| *x >= 0.0) {
                true => e[0] * e[1] + e[1] * e[2] + e[2] * e[0],
                false => 0.0,
            }
        };
        let lanes = |n: &Node, side: usize| -> [[f32; WIDTH]; 3] {
            std::array::from_fn(|a| n.bounds[a][side].to_array())
        };
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        let (lo, hi) = (lanes(root, 0), lanes(root, 1));
        let root_lo = lo.map(|l| l.iter().copied().fold(f32::INFINITY, f32::min));
        let root_hi = hi.map(|h| h.iter().copied().fold(f32::NEG_INFINITY, f32::max));
        let root_area = half_area(root_lo, root_hi).max(f64::MIN_POSITIVE);
        let children: f64 = self
            .nodes
            .iter()
            .map(|n| {
                let (lo, hi) = (lanes(n, 0), lanes(n, 1));
                (0..WIDTH)
                    .map(|k| half_area(lo.map(|l| l[k]), hi.map(|h| h[k])))
                    .sum::<f64>()
            })
            .sum();
        1.0 + children / root_area
    }

    /// Distances to the primitives of leaf block `r` (infinity where missed).
    #[inline(always)]
    fn leaf(&self, leaf: u32, ray: &LaneRay, tmax: f32x8) -> (f32x8, u32x8) {
        let i = (leaf & INDEX_MASK) as usize;
        let r = ray.with_tmax(tmax);
        match leaf >> KIND_SHIFT {
            TRIANGLES => {
                let b = &self.tris[i];
                (kernels::triangle(&r, b.p0, b.e1, b.e2), b.id)
            }
            SPHERES => {
                let b = &self.spheres[i];
                (kernels::sphere(&r, b.center, b.radius), b.id)
            }
            _ => {
                let b = &self.rects[i];
                (kernels::rectangle(&r, b.corner, b.n, b.du, b.dv), b.id)
            }
        }
    }

    /// Closest hit (t, primitive index) within the ray's range, skipping `ray.skip`.
    pub fn closest(&self, ray: &Ray) -> Option<(f32, u32)> {
        self.closest_inlined(ray, slab_reciprocals(ray.d))
    }

    /// [`Bvh8::closest`], inlined into the batched query, so that a ray read from columns
    /// ([`super::Rays::get`]) stays in registers (by reference, after its nine scalar
    /// stores, it stalls on store forwarding), with its direction's [`slab_reciprocal`]s
    /// (which the batched query computes a lane vector of rays at a time, so that their
    /// divisions are off each ray's critical path).
    #[inline(always)]
    pub(super) fn closest_inlined(&self, ray: &Ray, reciprocal: [f32; 3]) -> Option<(f32, u32)> {
        let boxes = BoxRay::new(ray, reciprocal);
        let lanes = LaneRay::new(ray);
        let mut tmax = ray.tmax;
        let mut best = None;
        let mut stack = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut sp = 0;
        // The reference being visited (the root first): a node's only hit child is visited
        // next without a round trip through the stack; of several, the nearest is popped.
        let mut r = 0;
        loop {
            if r >> KIND_SHIFT == INNER {
                let node = &self.nodes[r as usize];
                let (tn, mask) = boxes.test(node, tmax);
                if mask != 0 && mask & (mask - 1) == 0 {
                    // One child hit (the common case deep in the tree): visit it next.
                    r = node.child[mask.trailing_zeros() as usize];
                    continue;
                }
                sp = Self::push_nearest_last(&mut stack, sp, node, tn, mask);
            } else {
                let (t, id) = self.leaf(r, &lanes, f32x8::splat(tmax));
                if let Some((t, id)) = nearest_lane(t, id, lanes.skip, tmax) {
                    tmax = t;
                    best = Some((t, id));
                }
            }
            // The next entry the ray still enters before its nearest hit so far.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: entries below `sp` were written by the pushes.
                let (next, t_enter) = unsafe { stack[sp].assume_init() };
                if t_enter <= tmax {
                    r = next;
                    break;
                }
            }
        }
    }

    /// Pushes the hit children of `node` (those of `mask`: none, or two or more) so that
    /// the nearest is on top; returns the new stack size.
    #[inline(always)]
    fn push_nearest_last(
        stack: &mut [MaybeUninit<Entry>; STACK],
        mut sp: usize,
        node: &Node,
        tn: f32x8,
        mut mask: u32,
    ) -> usize {
        let tn = tn.to_array();
        let first = sp;
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            // Insertion into the pushed run, kept in decreasing distance.
            let e = (node.child[k], tn[k]);
            let mut j = sp;
            // SAFETY: entries first..sp were written in this loop.
            while j > first && unsafe { stack[j - 1].assume_init() }.1 < e.1 {
                stack[j] = stack[j - 1];
                j -= 1;
            }
            stack[j].write(e);
            sp += 1;
        }
        sp
    }

    /// Whether anything not skipped blocks the ray within (tmin, tmax).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_inlined(ray, slab_reciprocals(ray.d))
    }

    /// [`Bvh8::occluded`], inlined into the batched query (as [`Bvh8::closest_inlined`]).
    #[inline(always)]
    pub(super) fn occluded_inlined(&self, ray: &Ray, reciprocal: [f32; 3]) -> bool {
        let boxes = BoxRay::new(ray, reciprocal);
        let lanes = LaneRay::new(ray);
        let tmax = f32x8::splat(ray.tmax);
        let mut stack = [MaybeUninit::<u32>::uninit(); STACK];
        stack[0].write(0);
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below `sp` were written by the pushes below.
            let r = unsafe { stack[sp].assume_init() };
            if r >> KIND_SHIFT != INNER {
                let (t, id) = self.leaf(r, &lanes, tmax);
                if any_lane(t, id, lanes.skip, ray.tmax) {
                    return true;
                }
                continue;
            }
            let node = &self.nodes[r as usize];
            let (_, mut mask) = boxes.test(node, ray.tmax);
            while mask != 0 {
                let k = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                stack[sp].write(node.child[k]);
                sp += 1;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::super::bvh8_build::Draft;
    use super::super::primitive::{PrimKind, Primitive};
    use super::super::{Rectangle, Sphere};
    use super::*;
    use glam::Vec3;

    /// The slab reciprocals follow Embree's rule (a component under 1e-30 in magnitude
    /// becomes 1e-30 of its sign), one component or lanes of them, bit for bit.
    #[test]
    fn slab_reciprocals_replace_zero_components() {
        let rule = |c: f32| {
            let c = if c.abs() < 1e-30 {
                1e-30f32.copysign(c)
            } else {
                c
            };
            1.0 / c
        };
        let cases = [
            0.0f32,
            -0.0,
            1e-31,
            -1e-31,
            1e-30,
            -1e-30,
            1.5e-30,
            0.25,
            -3.0,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-40,
            -1e-40,
            f32::NAN,
        ];
        for c in cases {
            assert_eq!(slab_reciprocal(c).to_bits(), rule(c).to_bits(), "{c:e}");
        }
        assert_eq!(slab_reciprocal(0.0f32), 1e30);
        assert_eq!(slab_reciprocal(-0.0f32), -1e30);
        use lobe_materials::simd::{LANES, f32xn};
        for chunk in cases.chunks(LANES) {
            let lanes = slab_reciprocal(f32xn::new(lobe_materials::simd::padded(chunk)));
            for (k, &c) in chunk.iter().enumerate() {
                assert_eq!(
                    lanes.to_array()[k].to_bits(),
                    rule(c).to_bits(),
                    "{c:e} in lanes"
                );
            }
        }
    }

    /// Every lane of each block kind equals the scalar test of its primitive bit for bit,
    /// hits and misses, across ranges, grazing rays and degenerate primitives.
    #[test]
    fn block_tests_match_the_scalar_tests() {
        let mut seed = 1u64;
        let mut f = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 40) as f32) / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut v = |s: f32| Vec3::new(f(), f(), f()) * s;
        let mut mesh = super::super::Mesh {
            positions: (0..24).map(|_| v(1.0)).collect(),
            indices: (0..8).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect(),
            ..Default::default()
        };
        // Triangle 5 degenerate (its third vertex on the line of its first edge).
        let p = &mut mesh.positions;
        p[17] = p[15] + (p[16] - p[15]) * 2.0;
        let mut prims = vec![];
        for k in 0..8 {
            prims.push(Primitive {
                kind: PrimKind::Triangle { mesh: 0, index: k },
                shape: 0,
            });
        }
        for k in 0..8 {
            prims.push(Primitive {
                kind: PrimKind::Sphere(Sphere {
                    center: v(1.0),
                    radius: 0.2 + 0.1 * k as f32,
                }),
                shape: 0,
            });
        }
        let mut rects = vec![];
        for k in 0..8 {
            let m = glam::Mat4::from_translation(v(1.0))
                * glam::Mat4::from_axis_angle(v(1.0).normalize(), k as f32);
            rects.push(Rectangle::from_transform(&m).unwrap());
            prims.push(Primitive {
                kind: PrimKind::Rectangle(k),
                shape: 0,
            });
        }
        let meshes = [mesh];
        let prims: super::super::prims::Prims = prims.into_iter().collect();
        let source = PrimSource {
            prims: &prims,
            meshes: &meshes,
            rects: &rects,
        };
        let mut draft = Draft::empty();
        let ids: Vec<u32> = (0..24).collect();
        let blocks = [
            draft.leaf_block(TRIANGLES, &ids[0..8]),
            draft.leaf_block(SPHERES, &ids[8..16]),
            draft.leaf_block(RECTANGLES, &ids[16..24]),
        ];
        let bvh = draft.finish(source);
        let mut hits = 0;
        for i in 0..4000 {
            let o = v(3.0);
            let d = if i % 7 == 0 {
                Vec3::X * v(1.0).x
            } else {
                v(1.0) - o
            };
            let ray = Ray {
                tmin: if i % 3 == 0 { 0.5 } else { 0.0 },
                tmax: if i % 5 == 0 { 2.0 } else { f32::INFINITY },
                ..Ray::new(o, d)
            };
            let lanes = LaneRay::new(&ray);
            for &b in &blocks {
                let (t, id) = bvh.leaf(b, &lanes, f32x8::splat(ray.tmax));
                for (k, (&t, &id)) in t.to_array().iter().zip(&id.to_array()).enumerate() {
                    let want = source.shape_of(id).intersect(&ray);
                    assert_eq!(t.to_bits(), want.to_bits(), "lane {k} of {b:#x}, {ray:?}");
                    hits += usize::from(t.is_finite());
                }
            }
        }
        assert!(hits > 2000, "the test must hit things ({hits} hits)");
    }
}
