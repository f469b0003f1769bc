//! The renderer's acceleration structure: an eight-wide BVH traversed one ray at a time
//! with the eight children of a node tested in SIMD lanes (Wald, Benthin and Boulos,
//! "Getting Rid of Packets: Efficient SIMD Single-Ray Traversal using Multi-branching
//! BVHs", 2008; the layout of Embree's BVH8), whose leaves hold up to eight primitives of
//! one kind in lanes (triangles, spheres, rectangles), intersected together with the same
//! operations, lane by lane, as the scalar tests of [`Triangle`], [`Sphere`] and
//! [`Rectangle`] (so a hit's distance is bit for bit the scalar one).
//!
//! Built from obvhs's binary BVH (PLOC, Meister and Bittner, "Parallel Locally-Ordered
//! Clustering for Bounding Volume Hierarchy Construction", 2018, with obvhs's `fast_build`
//! settings: a short PLOC search, a light reinsertion pass and SAH leaf collapse to at most
//! eight primitives) by collapsing it top-down: each node keeps
//! opening the inner child of largest surface area until it has eight children (Wald et
//! al. 2008, section 3). Child boxes are tested with pbrt-v4's conservative slab test
//! (the far distance scaled by 1 + 2 gamma(3), Pharr, Jakob and Humphreys, "Physically
//! Based Rendering", 4th ed., section 6.8.2), and children are visited nearest first.
//!
//! Memory: 224 bytes per node and 320 (triangles), 160 (spheres) or 416 (rectangles)
//! bytes per leaf block, reported by [`Bvh8::memory_bytes`].

use super::Ray;
use super::bvh::{PrimKind, PrimShape, PrimSource, Primitive};
use super::kernels::{self, RayLanes};
#[cfg(doc)]
use super::{Rectangle, Sphere, Triangle};
use lobe_materials::simd::sel;
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use std::mem::MaybeUninit;
use std::time::Duration;
use wide::{f32x8, u32x8};

/// Lanes of a node or a leaf block.
const LANES: usize = 8;
/// Traversal stack entries: a node pops one entry and pushes at most eight, so a tree of
/// depth d needs at most 7 d + 1; [`Bvh8::build`] refuses deeper trees.
const STACK: usize = 256;
const MAX_DEPTH: usize = (STACK - 1) / (LANES - 1);

/// Kind of a child reference (its top two bits); the other 30 bits are an index into
/// `nodes` or into the block array of that kind.
const INNER: u32 = 0;
const TRIANGLES: u32 = 1;
const SPHERES: u32 = 2;
const RECTANGLES: u32 = 3;
const KIND_SHIFT: u32 = 30;
const INDEX_MASK: u32 = (1 << KIND_SHIFT) - 1;

/// The cost of a traversal step relative to one primitive test in obvhs's leaf collapse
/// (its default 3 is for scalar leaves). A leaf block tests its eight primitives in one
/// SIMD step, so fuller leaves cost nothing: at 12 the collapse fills them (measured on the
/// million-triangle bench: leaf blocks and nodes 93 -> 70 MB, incoherent closest-hit
/// queries 20 % and occlusion queries 10 % faster, the same images bit for bit).
const COLLAPSE_TRAVERSAL_COST: f32 = 12.0;

/// Subtrees the collapse hands to the thread pool (its top levels are done first, one at a
/// time): enough for every core to stay busy as subtree sizes vary.
const PARALLEL_SUBTREES: usize = 64;

/// 1 + 2 gamma(3), pbrt-v4's factor making the far slab distance conservative.
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Eight child boxes in lanes (`bounds[axis][0]` lower, `[1]` upper; empty slots have
/// lower +inf and upper -inf, so no ray hits them) and their references.
#[derive(Clone, Copy)]
#[repr(C)]
struct Node {
    bounds: [[f32x8; 2]; 3],
    child: [u32; LANES],
}

/// Up to eight triangles in lanes (vertex p0 and edges e1, e2 per axis) and their
/// primitive indices; unused lanes repeat a used one.
#[derive(Clone, Copy)]
#[repr(C)]
struct TriBlock {
    p0: [f32x8; 3],
    e1: [f32x8; 3],
    e2: [f32x8; 3],
    id: u32x8,
}

#[derive(Clone, Copy)]
#[repr(C)]
struct SphereBlock {
    center: [f32x8; 3],
    radius: f32x8,
    id: u32x8,
}

#[derive(Clone, Copy)]
#[repr(C)]
struct RectBlock {
    corner: [f32x8; 3],
    n: [f32x8; 3],
    du: [f32x8; 3],
    dv: [f32x8; 3],
    id: u32x8,
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
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let d = ray.d.to_array();
        // A zero component gets a tiny one of the same sign: finite reciprocals keep the
        // slab distances free of 0 * inf (Embree's rule).
        let inv = d.map(|c| {
            let c = if c.abs() < 1e-30 {
                1e-30f32.copysign(c)
            } else {
                c
            };
            f32x8::splat(1.0 / c)
        });
        let near = d.map(|c| usize::from(c.is_sign_negative()));
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
        // bound * inv - o * inv, fused where the target has FMA (the far distance's
        // conservative factor covers either rounding).
        let slab = |a: usize, side: usize| node.bounds[a][side].mul_sub(self.inv[a], self.o_inv[a]);
        let (n, f) = (self.near, self.near.map(|s| 1 - s));
        let tn = slab(0, n[0])
            .fast_max(slab(1, n[1]))
            .fast_max(slab(2, n[2]).fast_max(self.tmin));
        let tf = slab(0, f[0])
            .fast_min(slab(1, f[1]))
            .fast_min(slab(2, f[2]));
        let tf = (tf * f32x8::splat(FAR_SCALE)).fast_min(f32x8::splat(tmax));
        (tn, tn.simd_le(tf).to_bitmask())
    }
}

/// A ray splatted into SIMD lanes for leaf tests, and the primitive it skips.
struct LaneRay {
    o: [f32x8; 3],
    d: [f32x8; 3],
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
    nodes: Vec<Node>,
    tris: Vec<TriBlock>,
    spheres: Vec<SphereBlock>,
    rects: Vec<RectBlock>,
    depth: usize,
}

/// A traversal stack entry: a child reference and the distance at which the ray enters it.
type Entry = (u32, f32);

impl Bvh8 {
    /// Builds the tree over `prims` (at least one). Errors when the tree would be deeper
    /// than the traversal stack allows (not seen on any real scene: an SAH tree of a
    /// billion primitives is about 12 levels deep).
    pub fn build(source: PrimSource) -> Result<Self, String> {
        // `fast_build` rather than `medium_build` (a longer PLOC search and two reinsertion
        // passes): the 4M-triangle build 3.4 -> 1.7 s, and the bench's incoherent queries
        // were not slower (docs/performance.md).
        let params = BvhBuildParams {
            max_prims_per_leaf: LANES as u32,
            collapse_traversal_cost: COLLAPSE_TRAVERSAL_COST,
            ..BvhBuildParams::fast_build()
        };
        let bvh2 = {
            use rayon::prelude::*;
            let boxes: Vec<obvhs::aabb::Aabb> = (0..source.prims.len() as u32)
                .into_par_iter()
                .map(|i| source.shape_of(i).aabb())
                .collect();
            obvhs::bvh2::builder::build_bvh2(&boxes, params, &mut Duration::default())
        };
        let mut out = Self {
            nodes: Vec::with_capacity(bvh2.nodes.len() / 6 + 1),
            tris: Vec::new(),
            spheres: Vec::new(),
            rects: Vec::new(),
            depth: 0,
        };
        out.collapse(&bvh2, source)?;
        Ok(out)
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

    /// Top-down collapse of the binary tree into eight-wide nodes: the top levels in
    /// breadth-first order until there are [`PARALLEL_SUBTREES`] subtrees to do, then
    /// those subtrees on all cores, each into a part of its own ([`Bvh8::subtree`]),
    /// appended in order. The tree is the same whatever the thread count.
    fn collapse(&mut self, bvh2: &Bvh2, source: PrimSource) -> Result<(), String> {
        use rayon::prelude::*;
        self.nodes.push(Self::empty_node());
        // (BVH2 node, BVH8 node to fill, depth of that node)
        let mut frontier = std::collections::VecDeque::from([(0usize, 0usize, 1usize)]);
        while let Some(item) = frontier.pop_front() {
            frontier.extend(self.fill(bvh2, source, item)?);
            if frontier.len() >= PARALLEL_SUBTREES {
                break;
            }
        }
        let frontier: Vec<_> = frontier.into();
        let parts = frontier
            .par_iter()
            .map(|&(n2, _, depth)| Self::subtree(bvh2, source, n2, depth))
            .collect::<Result<Vec<_>, String>>()?;
        // One allocation per array: growing them part by part would copy them again and
        // again.
        self.nodes
            .reserve_exact(parts.iter().map(|p| p.nodes.len()).sum());
        self.tris
            .reserve_exact(parts.iter().map(|p| p.tris.len()).sum());
        self.spheres
            .reserve_exact(parts.iter().map(|p| p.spheres.len()).sum());
        self.rects
            .reserve_exact(parts.iter().map(|p| p.rects.len()).sum());
        for (part, &(_, n8, _)) in parts.into_iter().zip(&frontier) {
            self.append(part, n8);
        }
        Ok(())
    }

    /// The BVH8 of the binary subtree at `n2`, whose root is at `depth`: its root is its
    /// node 0.
    fn subtree(bvh2: &Bvh2, source: PrimSource, n2: usize, depth: usize) -> Result<Self, String> {
        let mut part = Self {
            nodes: vec![Self::empty_node()],
            tris: Vec::new(),
            spheres: Vec::new(),
            rects: Vec::new(),
            depth: 0,
        };
        let mut work = vec![(n2, 0usize, depth)];
        while let Some(item) = work.pop() {
            work.extend(part.fill(bvh2, source, item)?);
        }
        Ok(part)
    }

    /// Appends `part` (from [`Bvh8::subtree`]), its root replacing node `at`, its other
    /// nodes and its leaf blocks after those already here, with its references moved.
    fn append(&mut self, part: Self, at: usize) {
        let offsets = [
            self.nodes.len() as u32,
            self.tris.len() as u32,
            self.spheres.len() as u32,
            self.rects.len() as u32,
        ];
        let moved = |r: u32| {
            let (kind, index) = (r >> KIND_SHIFT, r & INDEX_MASK);
            let index = match kind {
                // Node 0 is the root, stored at `at`; node j > 0 at offset + j - 1.
                INNER => offsets[0] + index - 1,
                _ => offsets[kind as usize] + index,
            };
            (kind << KIND_SHIFT) | index
        };
        let mut nodes = part.nodes.into_iter().map(|mut n| {
            n.child = n.child.map(|c| {
                // Empty slots keep their 0 (never visited: their boxes are empty).
                if c == 0 { 0 } else { moved(c) }
            });
            n
        });
        self.nodes[at] = nodes.next().expect("a part has its root");
        self.nodes.extend(nodes);
        self.tris.extend(part.tris);
        self.spheres.extend(part.spheres);
        self.rects.extend(part.rects);
        self.depth = self.depth.max(part.depth);
    }

    /// Fills BVH8 node `n8` with the children of BVH2 node `n2` (at `depth`): leaf blocks
    /// for its leaves, new empty nodes for its inner children, returned as work to do.
    fn fill(
        &mut self,
        bvh2: &Bvh2,
        source: PrimSource,
        (n2, n8, depth): (usize, usize, usize),
    ) -> Result<Vec<(usize, usize, usize)>, String> {
        self.depth = self.depth.max(depth);
        if depth > MAX_DEPTH {
            return Err(format!(
                "the BVH would be {depth} levels deep; at most {MAX_DEPTH} are supported"
            ));
        }
        let mut work = Vec::new();
        let mut slot = 0;
        for c in Self::open(bvh2, source.prims, n2) {
            let node = &bvh2.nodes[c];
            if node.is_leaf() {
                let first = node.first_index as usize;
                let ids = &bvh2.primitive_indices[first..first + node.prim_count as usize];
                let kinds = Self::kinds(source.prims, ids);
                if kinds.count_ones() == 1 {
                    // One kind (every leaf of a mesh): no grouping, and the binary leaf's
                    // box (the union of its primitives' boxes) is the block's.
                    let kind = [TRIANGLES, SPHERES, RECTANGLES][kinds.trailing_zeros() as usize];
                    let r = self.leaf_block(kind, source, ids);
                    let a = node.aabb();
                    self.set_child(n8, slot, r, a.min.into(), a.max.into());
                    slot += 1;
                    continue;
                }
                for (kind, group) in Self::by_kind(source.prims, ids) {
                    let (lo, hi) = Self::bounds(source, &group);
                    let r = self.leaf_block(kind, source, &group);
                    self.set_child(n8, slot, r, lo, hi);
                    slot += 1;
                }
            } else {
                let idx = self.nodes.len();
                self.nodes.push(Self::empty_node());
                let a = node.aabb();
                self.set_child(n8, slot, idx as u32, a.min.into(), a.max.into());
                slot += 1;
                work.push((c, idx, depth + 1));
            }
        }
        Ok(work)
    }

    /// The BVH2 nodes that become the children of BVH2 node `n`: its two children, then
    /// the inner child of largest surface area opened in turn while the slots (a leaf
    /// takes one per primitive kind in it) stay within eight. A leaf root is its own
    /// single child.
    fn open(bvh2: &Bvh2, prims: &[Primitive], n: usize) -> Vec<usize> {
        let root = &bvh2.nodes[n];
        if root.is_leaf() {
            return vec![n];
        }
        let slots = |c: usize| -> usize {
            let node = &bvh2.nodes[c];
            if node.is_leaf() {
                let first = node.first_index as usize;
                let ids = &bvh2.primitive_indices[first..first + node.prim_count as usize];
                Self::kinds(prims, ids).count_ones() as usize
            } else {
                1
            }
        };
        let left = root.first_index as usize;
        let mut children = vec![left, left + 1];
        let mut used: usize = children.iter().map(|&c| slots(c)).sum();
        loop {
            let pick = children
                .iter()
                .enumerate()
                .filter(|&(_, &c)| !bvh2.nodes[c].is_leaf())
                .map(|(i, &c)| (i, bvh2.nodes[c].aabb().half_area()))
                .filter(|&(i, _)| {
                    let l = bvh2.nodes[children[i]].first_index as usize;
                    used - 1 + slots(l) + slots(l + 1) <= LANES
                })
                .max_by(|a, b| a.1.total_cmp(&b.1));
            let Some((i, _)) = pick else {
                break;
            };
            let c = children.swap_remove(i);
            let l = bvh2.nodes[c].first_index as usize;
            used = used - 1 + slots(l) + slots(l + 1);
            children.push(l);
            children.push(l + 1);
        }
        children
    }

    /// The kinds among the primitives `ids`, one bit per kind (triangles 1, spheres 2,
    /// rectangles 4).
    fn kinds(prims: &[Primitive], ids: &[u32]) -> u32 {
        ids.iter().fold(0, |k, &id| {
            k | match prims[id as usize].kind {
                PrimKind::Triangle { .. } => 1,
                PrimKind::Sphere(_) => 2,
                PrimKind::Rectangle(_) => 4,
            }
        })
    }

    /// The primitives `ids` grouped by kind (triangles, spheres, rectangles; empty groups
    /// left out).
    fn by_kind(prims: &[Primitive], ids: &[u32]) -> Vec<(u32, Vec<u32>)> {
        let mut groups: [(u32, Vec<u32>); 3] =
            [(TRIANGLES, vec![]), (SPHERES, vec![]), (RECTANGLES, vec![])];
        for &id in ids {
            let g = match prims[id as usize].kind {
                PrimKind::Triangle { .. } => 0,
                PrimKind::Sphere(_) => 1,
                PrimKind::Rectangle(_) => 2,
            };
            groups[g].1.push(id);
        }
        groups.into_iter().filter(|g| !g.1.is_empty()).collect()
    }

    fn bounds(source: PrimSource, ids: &[u32]) -> ([f32; 3], [f32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for &id in ids {
            let b = source.shape_of(id).aabb();
            for a in 0..3 {
                lo[a] = lo[a].min(b.min[a]);
                hi[a] = hi[a].max(b.max[a]);
            }
        }
        (lo, hi)
    }

    fn empty_node() -> Node {
        Node {
            bounds: [[f32x8::splat(f32::INFINITY), f32x8::splat(f32::NEG_INFINITY)]; 3],
            child: [0; LANES],
        }
    }

    fn set_child(&mut self, node: usize, slot: usize, r: u32, lo: [f32; 3], hi: [f32; 3]) {
        let n = &mut self.nodes[node];
        for a in 0..3 {
            let mut l = n.bounds[a][0].to_array();
            let mut h = n.bounds[a][1].to_array();
            l[slot] = lo[a];
            h[slot] = hi[a];
            n.bounds[a] = [f32x8::new(l), f32x8::new(h)];
        }
        n.child[slot] = r;
    }

    /// Stores one leaf block of primitives of one kind (at most eight; unused lanes repeat
    /// the last primitive) and returns its reference.
    fn leaf_block(&mut self, kind: u32, source: PrimSource, ids: &[u32]) -> u32 {
        debug_assert!(!ids.is_empty() && ids.len() <= LANES);
        let lane = |k: usize| ids[k.min(ids.len() - 1)];
        let id = u32x8::new(std::array::from_fn(lane));
        // Each primitive's data once (a triangle's from its mesh).
        let shapes: [PrimShape; LANES] = std::array::from_fn(|k| source.shape_of(lane(k)));
        let v3 = |f: &dyn Fn(&PrimShape) -> glam::Vec3| -> [f32x8; 3] {
            let vs: [glam::Vec3; LANES] = std::array::from_fn(|k| f(&shapes[k]));
            [0, 1, 2].map(|a| f32x8::new(vs.map(|v| v[a])))
        };
        let index = match kind {
            TRIANGLES => {
                let tri = |p: &PrimShape| match p {
                    PrimShape::Triangle(t) => *t,
                    _ => unreachable!("grouped by kind"),
                };
                self.tris.push(TriBlock {
                    p0: v3(&|p| tri(p).p0),
                    e1: v3(&|p| tri(p).e1),
                    e2: v3(&|p| tri(p).e2),
                    id,
                });
                self.tris.len() - 1
            }
            SPHERES => {
                let sph = |p: &PrimShape| match p {
                    PrimShape::Sphere(s) => *s,
                    _ => unreachable!("grouped by kind"),
                };
                self.spheres.push(SphereBlock {
                    center: v3(&|p| sph(p).center),
                    radius: f32x8::new(std::array::from_fn(|k| sph(&shapes[k]).radius)),
                    id,
                });
                self.spheres.len() - 1
            }
            _ => {
                let rect = |p: &PrimShape| match p {
                    PrimShape::Rectangle(r) => *r,
                    _ => unreachable!("grouped by kind"),
                };
                self.rects.push(RectBlock {
                    corner: v3(&|p| rect(p).corner),
                    n: v3(&|p| rect(p).n),
                    du: v3(&|p| rect(p).du()),
                    dv: v3(&|p| rect(p).dv()),
                    id,
                });
                self.rects.len() - 1
            }
        };
        (kind << KIND_SHIFT) | index as u32
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
        let boxes = BoxRay::new(ray);
        let lanes = LaneRay::new(ray);
        let mut tmax = ray.tmax;
        let mut best = None;
        let mut stack = [MaybeUninit::<Entry>::uninit(); STACK];
        stack[0].write((0, ray.tmin));
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below `sp` were written by the pushes below.
            let (r, t_enter) = unsafe { stack[sp].assume_init() };
            if t_enter > tmax {
                continue;
            }
            if r >> KIND_SHIFT != INNER {
                let (t, id) = self.leaf(r, &lanes, f32x8::splat(tmax));
                if let Some((t, id)) = nearest_lane(t, id, lanes.skip, tmax) {
                    tmax = t;
                    best = Some((t, id));
                }
                continue;
            }
            let node = &self.nodes[r as usize];
            let (tn, mask) = boxes.test(node, tmax);
            sp = Self::push_nearest_last(&mut stack, sp, node, tn, mask);
        }
        best
    }

    /// Pushes the hit children of `node` so that the nearest is on top; returns the new
    /// stack size.
    #[inline(always)]
    fn push_nearest_last(
        stack: &mut [MaybeUninit<Entry>; STACK],
        mut sp: usize,
        node: &Node,
        tn: f32x8,
        mut mask: u32,
    ) -> usize {
        let tn = tn.to_array();
        if mask.count_ones() <= 1 {
            // No child or one (the common case deep in the tree): no ordering to do.
            if mask != 0 {
                let k = mask.trailing_zeros() as usize;
                stack[sp].write((node.child[k], tn[k]));
                sp += 1;
            }
            return sp;
        }
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
        let boxes = BoxRay::new(ray);
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
    use super::super::{Rectangle, Sphere};
    use super::*;
    use glam::Vec3;

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
        let source = PrimSource {
            prims: &prims,
            meshes: &meshes,
            rects: &rects,
        };
        let mut bvh = Bvh8 {
            nodes: vec![],
            tris: vec![],
            spheres: vec![],
            rects: vec![],
            depth: 0,
        };
        let ids: Vec<u32> = (0..24).collect();
        let blocks = [
            bvh.leaf_block(TRIANGLES, source, &ids[0..8]),
            bvh.leaf_block(SPHERES, source, &ids[8..16]),
            bvh.leaf_block(RECTANGLES, source, &ids[16..24]),
        ];
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
