//! Construction of the renderer's BVH8 ([`Bvh8`]): a binary BVH by PLOC ([`ploc`]: Meister
//! and Bittner, "Parallel Locally-Ordered Clustering for Bounding Volume Hierarchy
//! Construction", 2018) over the primitives in Morton order, improved by obvhs's
//! reinsertion pass, every subtree of at most eight primitives a leaf
//! ([`leaves_of_small_subtrees`]), collapsed top-down into eight-wide nodes: each node keeps
//! opening the inner child of largest surface area until it has eight children (Wald et al. 2008,
//! section 3), and the leaves among a node's children are packed into as few blocks of
//! eight lanes as fit ([`pack`]: blocks held 5.9 triangles on average, 6.2 packed; the
//! 4M-triangle bench's leaf blocks 216 -> 205 MB).
//!
//! Big scenes are built in chunks of the Morton order, each chunk's binary tree collapsed
//! and freed before the next ([`Draft::build_chunked`], after Ganestam et al., "Bonsai",
//! JCGT 2015), and the tree is first drafted with primitive indices in its leaf blocks:
//! their vertex data are fetched once, into arrays allocated at their final size
//! ([`Draft::finish`]). So the build never holds a whole-scene set of obvhs's buffers or
//! two copies of the leaf blocks. The tree is the same whatever the thread count.

use super::bvh8::{
    Bvh8, INDEX_MASK, INNER, KIND_SHIFT, MAX_DEPTH, Node, RECTANGLES, RectBlock, SPHERES,
    SphereBlock, TRIANGLES, TriBlock, WIDTH,
};
use super::kernels::V3;
use super::ploc::{COARSE_SHIFT, MortonGrid, morton_sorted, ploc};
use super::primitive::{PrimKind, PrimShape, PrimSource};
use super::prims::Prims;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use wide::{f32x8, u32x8};

/// Primitives per chunk of a big scene's build ([`Draft::build_chunked`]): a chunk's build
/// buffers stay small, and a scene of a few chunks still spreads over all cores.
const CHUNK: usize = 1 << 16;

/// Subtrees of each chunk's binary tree that the top-level build sees.
const CUT: usize = 16;

/// Subtrees the collapse hands to the thread pool (its top levels are done first, one at a
/// time): enough for every core to stay busy as subtree sizes vary.
const PARALLEL_SUBTREES: usize = 64;

/// How the binary trees split their primitives.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Splits {
    /// PLOC ([`ploc`]) and obvhs's reinsertion ([`binary_tree`]).
    Ploc,
    /// Object medians along the widest axis of the centres ([`median_splits`]): balanced,
    /// so never deeper than log2 of the primitive count.
    Median,
}

/// The BVH8 over the primitives of `source` (at least one). Scenes of up to [`CHUNK`]
/// primitives get one binary tree; bigger ones are built in chunks. PLOC's tree over many
/// primitives that share one box (duplicated geometry) is a chain, as its merges tie:
/// when that makes the tree deeper than the traversal stack allows, it is built again
/// with median splits.
pub fn build(source: PrimSource) -> Result<Bvh8, String> {
    build_with(source, Splits::Ploc).or_else(|_| build_with(source, Splits::Median))
}

fn build_with(source: PrimSource, splits: Splits) -> Result<Bvh8, String> {
    // What the mesh readers freed, back to the system before the build's peak.
    crate::memory::release_freed();
    let order = morton_order(source);
    let draft = if source.prims.len() > CHUNK {
        let draft = Draft::build_chunked(source, order, splits)?;
        // The chunks' freed parts, before the leaf blocks take their final memory.
        crate::memory::release_freed();
        draft
    } else {
        let bvh2 = Draft::binary(source, &order.ids, &order.grid, splits, true);
        let mut draft = Draft::empty();
        draft.collapse(&bvh2, source)?;
        draft
    };
    let bvh = draft.finish(source);
    // The drafts' arrays, freed as the leaf blocks were filled.
    crate::memory::release_freed();
    Ok(bvh)
}

/// A BVH8 being built: its nodes, and its leaf blocks as the primitive indices in their
/// lanes (triangles, spheres, rectangles).
pub(super) struct Draft {
    nodes: Vec<Node>,
    blocks: [Vec<[u32; WIDTH]>; 3],
    depth: usize,
}

impl Draft {
    /// The finished tree: each leaf block's primitive data fetched (a triangle's from its
    /// mesh) on all cores, into arrays of their final size.
    pub(super) fn finish(self, source: PrimSource) -> Bvh8 {
        let [tris, spheres, rects] = self.blocks;
        let v3 = |vs: [glam::Vec3; WIDTH]| {
            let [x, y, z] = [0, 1, 2].map(|a| f32x8::new(vs.map(|v| v[a])));
            V3::new(x, y, z)
        };
        Bvh8 {
            nodes: self.nodes,
            tris: fetch(source, &tris, |s, id| {
                // [p0, e1, e2][axis][lane], filled lane by lane.
                let mut v = [[[0.0; WIDTH]; 3]; 3];
                for (lane, p) in s.iter().enumerate() {
                    let PrimShape::Triangle(t) = p else {
                        unreachable!("grouped by kind")
                    };
                    for (k, p) in [t.p0, t.e1, t.e2].into_iter().enumerate() {
                        (v[k][0][lane], v[k][1][lane], v[k][2][lane]) = (p.x, p.y, p.z);
                    }
                }
                let [p0, e1, e2] = v.map(|axes| {
                    let [x, y, z] = axes.map(f32x8::new);
                    V3::new(x, y, z)
                });
                TriBlock { p0, e1, e2, id }
            }),
            spheres: fetch(source, &spheres, |s, id| {
                let s = s.map(|p| match p {
                    PrimShape::Sphere(s) => s,
                    _ => unreachable!("grouped by kind"),
                });
                SphereBlock {
                    center: v3(s.map(|s| s.center)),
                    radius: f32x8::new(s.map(|s| s.radius)),
                    id,
                }
            }),
            rects: fetch(source, &rects, |s, id| {
                let r = s.map(|p| match p {
                    PrimShape::Rectangle(r) => r,
                    _ => unreachable!("grouped by kind"),
                });
                RectBlock {
                    corner: v3(r.map(|r| r.corner)),
                    n: v3(r.map(|r| r.n)),
                    du: v3(r.map(|r| r.du())),
                    dv: v3(r.map(|r| r.dv())),
                    id,
                }
            }),
            depth: self.depth,
        }
    }

    pub(super) fn empty() -> Self {
        Self {
            nodes: Vec::new(),
            blocks: Default::default(),
            depth: 0,
        }
    }

    /// The binary tree over the primitives `ids`, which are in the coarse Morton order of
    /// `grid` ([`morton_order`]; its leaves name them by their index into `source.prims`),
    /// its subtrees of at most [`WIDTH`] primitives made leaves ([`leaves_of_small_subtrees`]). The
    /// order is first refined to the grid's fine codes ([`refined_order`]), which PLOC
    /// needs: the coarse grid holds several primitives per cell.
    fn binary(
        source: PrimSource,
        ids: &[u32],
        grid: &MortonGrid,
        splits: Splits,
        suspect: bool,
    ) -> Bvh2 {
        use rayon::prelude::*;
        let boxes: Vec<Aabb> = ids.par_iter().map(|&i| source.shape_of(i).aabb()).collect();
        let order = refined_order(&boxes, grid);
        let sorted: Vec<Aabb> = order.iter().map(|&k| boxes[k as usize]).collect();
        drop(boxes);
        let mut bvh2 = binary_tree(&sorted, splits, suspect);
        leaves_of_small_subtrees(&mut bvh2);
        for p in &mut bvh2.primitive_indices {
            *p = ids[order[*p as usize] as usize];
        }
        bvh2
    }

    /// The tree of a big scene, built in chunks so that no step holds more than a chunk's
    /// build buffers (in the manner of Ganestam et al., "Bonsai: Rapid Bounding Volume
    /// Hierarchy Generation using Mini Trees", JCGT 2015): the primitives in Morton order
    /// ([`morton_order`]) are cut into chunks of [`CHUNK`]; each chunk, on its own core,
    /// gets a binary tree, cut into its [`CUT`] largest subtrees, each collapsed to a BVH8
    /// part while the chunk's binary tree is freed; a top-level binary tree over the
    /// parts' boxes is collapsed in turn, and the parts are appended under it. The chunks
    /// are fixed by the Morton order, so the tree is the same whatever the thread count.
    fn build_chunked(
        source: PrimSource,
        order: MortonOrder,
        splits: Splits,
    ) -> Result<Self, String> {
        use rayon::prelude::*;
        let grid = order.grid;
        let parts: Vec<(Aabb, Self)> = order
            .ids
            .par_chunks(CHUNK)
            .zip(order.runs)
            .map(|(ids, run)| {
                let bvh2 = Self::binary(source, ids, &grid, splits, run > PILE);
                cut(&bvh2, CUT)
                    .into_iter()
                    .map(|n2| {
                        let mut part = Self::subtree(&bvh2, source, n2, 1)?;
                        part.shrink_to_fit();
                        Ok((*bvh2.nodes[n2].aabb(), part))
                    })
                    .collect::<Result<Vec<_>, String>>()
            })
            .collect::<Result<Vec<_>, String>>()?
            .into_iter()
            .flatten()
            .collect();
        drop(order.ids);
        let top = {
            let boxes: Vec<Aabb> = parts.iter().map(|p| p.0).collect();
            let order = morton_sorted(&boxes);
            let sorted: Vec<Aabb> = order.iter().map(|&k| boxes[k as usize]).collect();
            let mut top = binary_tree(&sorted, splits, true);
            for p in &mut top.primitive_indices {
                *p = order[*p as usize];
            }
            top
        };
        let mut out = Self::empty();
        let joints = out.collapse_top(&top)?;
        out.reserve_for(parts.iter().map(|p| &p.1));
        for ((_, part), (at, depth)) in parts.into_iter().zip(joints) {
            let levels = depth - 1 + part.depth;
            if levels > MAX_DEPTH {
                return Err(too_deep(levels));
            }
            let mut part = part;
            part.depth = levels;
            out.append(part, at);
        }
        Ok(out)
    }

    /// Collapses the top-level tree of [`Draft::build_chunked`], whose leaves hold one part
    /// each, into eight-wide nodes; returns, for each part in order, the empty node its
    /// root will replace and that node's depth.
    fn collapse_top(&mut self, top: &Bvh2) -> Result<Vec<(usize, usize)>, String> {
        let mut joints = vec![(0, 0); top.primitive_indices.len()];
        self.nodes.push(Self::empty_node());
        let mut work = vec![(0usize, 0usize, 1usize)];
        while let Some((n2, n8, depth)) = work.pop() {
            if depth > MAX_DEPTH {
                return Err(too_deep(depth));
            }
            self.depth = self.depth.max(depth);
            for (slot, c) in Self::open(top, |_| 1, n2).into_iter().enumerate() {
                let node = &top.nodes[c];
                let idx = self.nodes.len();
                self.nodes.push(Self::empty_node());
                let a = node.aabb();
                self.set_child(n8, slot, idx as u32, a.min.into(), a.max.into());
                if node.is_leaf() {
                    let part = top.primitive_indices[node.first_index as usize];
                    joints[part as usize] = (idx, depth + 1);
                } else {
                    work.push((c, idx, depth + 1));
                }
            }
        }
        Ok(joints)
    }

    fn shrink_to_fit(&mut self) {
        self.nodes.shrink_to_fit();
        self.blocks.iter_mut().for_each(Vec::shrink_to_fit);
    }

    /// Room for the nodes and blocks of `parts`, allocated once: growing the arrays part
    /// by part would copy them again and again.
    fn reserve_for<'a>(&mut self, parts: impl Iterator<Item = &'a Draft> + Clone) {
        self.nodes
            .reserve_exact(parts.clone().map(|p| p.nodes.len()).sum());
        for k in 0..3 {
            self.blocks[k].reserve_exact(parts.clone().map(|p| p.blocks[k].len()).sum());
        }
    }

    /// Top-down collapse of the binary tree into eight-wide nodes: the top levels in
    /// breadth-first order until there are [`PARALLEL_SUBTREES`] subtrees to do, then
    /// those subtrees on all cores, each into a part of its own ([`Draft::subtree`]),
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
        self.reserve_for(parts.iter());
        for (part, &(_, n8, _)) in parts.into_iter().zip(&frontier) {
            self.append(part, n8);
        }
        Ok(())
    }

    /// The BVH8 of the binary subtree at `n2`, whose root is at `depth`: its root is its
    /// node 0.
    fn subtree(bvh2: &Bvh2, source: PrimSource, n2: usize, depth: usize) -> Result<Self, String> {
        let mut part = Self::empty();
        part.nodes.push(Self::empty_node());
        let mut work = vec![(n2, 0usize, depth)];
        while let Some(item) = work.pop() {
            work.extend(part.fill(bvh2, source, item)?);
        }
        Ok(part)
    }

    /// Appends `part` (from [`Draft::subtree`]), its root replacing node `at`, its other
    /// nodes and its leaf blocks after those already here, with its references moved.
    fn append(&mut self, part: Self, at: usize) {
        let offsets = [
            self.nodes.len() as u32,
            self.blocks[0].len() as u32,
            self.blocks[1].len() as u32,
            self.blocks[2].len() as u32,
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
        for (mine, theirs) in self.blocks.iter_mut().zip(part.blocks) {
            mine.extend(theirs);
        }
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
            return Err(too_deep(depth));
        }
        let mut work = Vec::new();
        let mut leaves = Vec::new();
        let mut slot = 0;
        for c in Self::open(
            bvh2,
            |ids| Self::kinds(source.prims, ids).count_ones() as usize,
            n2,
        ) {
            let node = &bvh2.nodes[c];
            if node.is_leaf() {
                let first = node.first_index as usize;
                let ids = &bvh2.primitive_indices[first..first + node.prim_count as usize];
                let kinds = Self::kinds(source.prims, ids);
                if kinds.count_ones() == 1 {
                    // One kind (every leaf of a mesh): no grouping, and the binary leaf's
                    // box (the union of its primitives' boxes) is the block's.
                    let kind = [TRIANGLES, SPHERES, RECTANGLES][kinds.trailing_zeros() as usize];
                    let a = node.aabb();
                    leaves.push(Leaf {
                        kind,
                        ids: ids.to_vec(),
                        lo: a.min.into(),
                        hi: a.max.into(),
                    });
                    continue;
                }
                for (kind, ids) in Self::by_kind(source.prims, ids) {
                    let (lo, hi) = Self::bounds(source, &ids);
                    leaves.push(Leaf { kind, ids, lo, hi });
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
        for leaf in pack(leaves) {
            let r = self.leaf_block(leaf.kind, &leaf.ids);
            self.set_child(n8, slot, r, leaf.lo, leaf.hi);
            slot += 1;
        }
        Ok(work)
    }

    /// The BVH2 nodes that become the children of BVH2 node `n`: its two children, then
    /// the inner child of largest surface area opened in turn while the slots (a leaf
    /// takes one per primitive kind in it) stay within eight. A leaf root is its own
    /// single child.
    fn open(bvh2: &Bvh2, leaf_slots: impl Fn(&[u32]) -> usize, n: usize) -> Vec<usize> {
        let root = &bvh2.nodes[n];
        if root.is_leaf() {
            return vec![n];
        }
        let slots = |c: usize| -> usize {
            let node = &bvh2.nodes[c];
            if node.is_leaf() {
                let first = node.first_index as usize;
                leaf_slots(&bvh2.primitive_indices[first..first + node.prim_count as usize])
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
                    used - 1 + slots(l) + slots(l + 1) <= WIDTH
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
    fn kinds(prims: &Prims, ids: &[u32]) -> u32 {
        ids.iter().fold(0, |k, &id| {
            k | match prims.get(id).kind {
                PrimKind::Triangle { .. } => 1,
                PrimKind::Sphere(_) => 2,
                PrimKind::Rectangle(_) => 4,
            }
        })
    }

    /// The primitives `ids` grouped by kind (triangles, spheres, rectangles; empty groups
    /// left out).
    fn by_kind(prims: &Prims, ids: &[u32]) -> Vec<(u32, Vec<u32>)> {
        let mut groups: [(u32, Vec<u32>); 3] =
            [(TRIANGLES, vec![]), (SPHERES, vec![]), (RECTANGLES, vec![])];
        for &id in ids {
            let g = match prims.get(id).kind {
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
            child: [0; WIDTH],
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

    /// Records one leaf block of primitives of one kind (at most eight; unused lanes repeat
    /// the last primitive; [`Draft::finish`] fetches their data) and returns its reference.
    pub(super) fn leaf_block(&mut self, kind: u32, ids: &[u32]) -> u32 {
        debug_assert!(!ids.is_empty() && ids.len() <= WIDTH);
        // Distinct primitives: a packet's leaf test stops at the first repeat.
        debug_assert!((1..ids.len()).all(|k| !ids[..k].contains(&ids[k])));
        let blocks = &mut self.blocks[kind as usize - 1];
        blocks.push(std::array::from_fn(|k| ids[k.min(ids.len() - 1)]));
        (kind << KIND_SHIFT) | (blocks.len() - 1) as u32
    }
}

/// The leaf blocks of the drafted `blocks` (their primitives' ids), each made by `make`
/// from its primitives' data and ids, on all cores into an array of its final size.
fn fetch<B: Send>(
    source: PrimSource,
    blocks: &[[u32; WIDTH]],
    make: impl Fn([PrimShape; WIDTH], u32x8) -> B + Sync,
) -> Vec<B> {
    use rayon::prelude::*;
    blocks
        .par_iter()
        .map(|ids| make(ids.map(|i| source.shape_of(i)), u32x8::new(*ids)))
        .collect()
}

/// A leaf block to be: primitives of one kind and their box.
struct Leaf {
    kind: u32,
    ids: Vec<u32>,
    lo: [f32; 3],
    hi: [f32; 3],
}

/// The leaves of one node packed into fewer blocks: first fit in decreasing size, leaves
/// of one kind sharing a block (its box their union) while they fit in its lanes. The
/// binary tree's leaf collapse only joins two sibling leaves; a node's leaves are close in
/// space too, and fuller blocks take less memory and fewer leaf tests.
fn pack(mut leaves: Vec<Leaf>) -> Vec<Leaf> {
    leaves.sort_by_key(|l| std::cmp::Reverse(l.ids.len()));
    let mut blocks: Vec<Leaf> = Vec::with_capacity(leaves.len());
    for leaf in leaves {
        let room = blocks
            .iter_mut()
            .find(|b| b.kind == leaf.kind && b.ids.len() + leaf.ids.len() <= WIDTH);
        match room {
            Some(b) => {
                b.ids.extend_from_slice(&leaf.ids);
                for a in 0..3 {
                    b.lo[a] = b.lo[a].min(leaf.lo[a]);
                    b.hi[a] = b.hi[a].max(leaf.hi[a]);
                }
            }
            None => blocks.push(leaf),
        }
    }
    blocks
}

/// Primitives sharing one box beyond which PLOC is built on median splits instead: PLOC's
/// merges tie among identical boxes, so a pile of `k` of them takes `k` rounds over the
/// whole chunk (70000 coincident triangles: 30 s rather than 30 ms).
const PILE: usize = 64;

/// Whether more than [`PILE`] of `boxes` are identical.
fn piled(boxes: &[Aabb]) -> bool {
    if boxes.len() <= PILE {
        return false;
    }
    let mut bits: Vec<[u32; 6]> = boxes
        .iter()
        .map(|b| {
            let (lo, hi) = (b.min.to_array(), b.max.to_array());
            [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(f32::to_bits)
        })
        .collect();
    bits.sort_unstable();
    bits.chunk_by(|a, b| a == b).any(|run| run.len() > PILE)
}

/// Nodes whose reinsertion obvhs's optimizer tries, as a fraction of the tree's nodes
/// (obvhs's `fast_build` setting; its `medium_build`, a longer PLOC search and two
/// reinsertion passes, built the 4M-triangle mesh in twice the time, and the bench's
/// incoherent queries were not faster).
const REINSERTION_BATCH: f32 = 0.02;

/// A binary tree over `boxes` (in Morton order) with one primitive per leaf (leaves name
/// their box's index), split as `splits` says, or at medians when `suspect` boxes turn out
/// piled ([`piled`]). PLOC's tree ([`ploc`]) then gets obvhs's reinsertion pass (Meister
/// et al., "Parallel Reinsertion for Bounding Volume Hierarchy Optimization", 2018).
fn binary_tree(boxes: &[Aabb], splits: Splits, suspect: bool) -> Bvh2 {
    let splits = match suspect && piled(boxes) {
        true => Splits::Median,
        false => splits,
    };
    match splits {
        Splits::Ploc => {
            let mut bvh2 = ploc(boxes);
            ReinsertionOptimizer::default().run(&mut bvh2, REINSERTION_BATCH, None);
            bvh2
        }
        Splits::Median => median_splits(boxes),
    }
}

/// The positions of `boxes` (in the coarse Morton order of `grid`: ordered by their
/// centres' codes' top bits, [`COARSE_SHIFT`]) in the order of their centres' whole codes:
/// each run of equal coarse codes sorted by the fine code, ties by position.
fn refined_order(boxes: &[Aabb], grid: &MortonGrid) -> Vec<u32> {
    let codes: Vec<u64> = boxes.iter().map(|b| grid.code(b.center())).collect();
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    let mut start = 0;
    for run in codes.chunk_by(|a, b| a >> COARSE_SHIFT == b >> COARSE_SHIFT) {
        if run.len() > 1 {
            order[start..start + run.len()].sort_unstable_by_key(|&k| (codes[k as usize], k));
        }
        start += run.len();
    }
    order
}

/// A balanced binary tree over `boxes`, one per leaf: each node's boxes split at the median
/// of their centres along the axis where the centres spread widest (ties broken by index,
/// so the tree is unique).
fn median_splits(boxes: &[Aabb]) -> Bvh2 {
    let centre = |i: u32| boxes[i as usize].center();
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    let mut nodes = vec![obvhs::bvh2::node::Bvh2Node::default()];
    let mut work = vec![(0usize, 0usize, boxes.len())];
    while let Some((node, lo, hi)) = work.pop() {
        let ids = &mut order[lo..hi];
        let bounds = ids
            .iter()
            .fold(Aabb::empty(), |a, &i| a.union(&boxes[i as usize]));
        if ids.len() == 1 {
            nodes[node] = obvhs::bvh2::node::Bvh2Node::new(bounds, 1, lo as u32);
            continue;
        }
        let spread = ids
            .iter()
            .fold(Aabb::empty(), |mut a, &i| *a.extend(centre(i)));
        let axis = (spread.max - spread.min).max_position();
        let mid = ids.len() / 2;
        ids.select_nth_unstable_by(mid, |&a, &b| {
            centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
        });
        let left = nodes.len();
        nodes.extend([obvhs::bvh2::node::Bvh2Node::default(); 2]);
        nodes[node] = obvhs::bvh2::node::Bvh2Node::new(bounds, 0, left as u32);
        work.extend([(left, lo, lo + mid), (left + 1, lo + mid, hi)]);
    }
    Bvh2 {
        nodes,
        primitive_indices: order,
        ..Bvh2::default()
    }
}

/// Makes every subtree of `bvh2` that holds at most [`WIDTH`] primitives, and is not
/// inside a smaller such subtree, one leaf, its primitives in depth-first order (left
/// first). A leaf block tests its eight lanes in one SIMD step, so such a leaf always costs
/// less than the subtree: this is the SAH leaf collapse (as obvhs and madmann91's bvh run
/// it) at a traversal cost of [`WIDTH`] or more, where every collapse pays. (At obvhs's
/// default cost of 3, for scalar leaves, the million-triangle bench's leaf blocks and nodes
/// took 93 MB rather than 70, and its incoherent closest-hit queries were 20 % slower.)
/// obvhs's collapse at cost 12 makes the same leaves; this one skips its copies of the
/// whole tree (the 4M and 16M builds 5-9 % faster). The subtree's inner nodes stay in
/// `bvh2.nodes`, unreachable.
fn leaves_of_small_subtrees(bvh2: &mut Bvh2) {
    if bvh2.nodes.is_empty() {
        return;
    }
    let old = std::mem::take(&mut bvh2.primitive_indices);
    let mut indices = Vec::with_capacity(old.len());
    let nodes = &mut bvh2.nodes;
    // One post-order walk, left first: each subtree's primitives are appended to `indices`
    // in order, so they are the run from where they started (`start`, [`UNSEEN`] before
    // the node's children are walked); a subtree of at most WIDTH becomes a leaf over its
    // run. Inner nodes of a smaller subtree become leaves too, unreachable.
    const UNSEEN: u32 = u32::MAX;
    let mut stack = vec![(0usize, UNSEEN)];
    while let Some((i, start)) = stack.pop() {
        let n = nodes[i];
        let first = indices.len() as u32;
        if n.is_leaf() {
            let prims = n.first_index as usize..(n.first_index + n.prim_count) as usize;
            indices.extend_from_slice(&old[prims]);
            nodes[i].first_index = first;
        } else if start == UNSEEN {
            let l = n.first_index as usize;
            stack.extend([(i, first), (l + 1, UNSEEN), (l, UNSEEN)]);
        } else if first - start <= WIDTH as u32 {
            nodes[i].first_index = start;
            nodes[i].prim_count = first - start;
        }
    }
    bvh2.primitive_indices = indices;
}

/// The error of a tree deeper than the traversal stack allows.
fn too_deep(levels: usize) -> String {
    format!("the BVH would be {levels} levels deep; at most {MAX_DEPTH} are supported")
}

/// The primitives in the coarse Morton order of their box centres ([`morton_order`]).
struct MortonOrder {
    /// The primitives' indices in order.
    ids: Vec<u32>,
    /// Per chunk of [`CHUNK`] primitives, the longest run of equal coarse codes: an upper
    /// bound on how many of its primitives share one box.
    runs: Vec<usize>,
    /// The grid of the codes.
    grid: MortonGrid,
}

/// The primitives in the order of a Morton curve through their box centres, on the coarse
/// grid of 10 bits per axis ([`COARSE_SHIFT`]) over the box of the meshes' vertices and the
/// other primitives' centres, which holds every centre; ties in primitive order, so the
/// order is unique. Taking the box from the vertices lets each centre go straight into its
/// code, computed once and never stored (16M triangles: 0.41 -> 0.34 s). The coarse codes
/// and the indices sort as one 64-bit key.
fn morton_order(source: PrimSource) -> MortonOrder {
    use rayon::prelude::*;
    let n = source.prims.len() as u32;
    let vertices = source
        .meshes
        .par_iter()
        .flat_map(|m| m.positions.par_iter())
        .fold(Aabb::empty, |mut a, &p| *a.extend(p.into()))
        .reduce(Aabb::empty, |a, b| a.union(&b));
    let bounds = source
        .prims
        .singles()
        .map(|p| source.shape_of_primitive(p).aabb().center())
        .fold(vertices, |mut a, c| *a.extend(c));
    let grid = MortonGrid::new(&bounds);
    let mut keys: Vec<u64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let coarse = grid.coarse_code(source.shape_of(i).aabb().center());
            ((coarse as u64) << 32) | i as u64
        })
        .collect();
    // The keys are unique (the index in their low bits), so any sort gives one order; a
    // parallel radix sort (rdst, obvhs's own) takes half a comparison sort's time.
    {
        use rdst::RadixSort;
        keys.radix_sort_unstable();
    }
    let runs = keys
        .par_chunks(CHUNK)
        .map(|c| {
            c.chunk_by(|a, b| a >> 32 == b >> 32)
                .map(<[u64]>::len)
                .max()
                .unwrap_or(0)
        })
        .collect();
    MortonOrder {
        ids: keys.into_par_iter().map(|k| k as u32).collect(),
        runs,
        grid,
    }
}

/// The `count` subtrees of `bvh2` that a top-down cut ends with: starting from the root,
/// the inner node of largest surface area is replaced by its two children until there are
/// `count` or only leaves are left.
fn cut(bvh2: &Bvh2, count: usize) -> Vec<usize> {
    let mut nodes = vec![0usize];
    while nodes.len() < count {
        let pick = nodes
            .iter()
            .enumerate()
            .filter(|&(_, &n)| !bvh2.nodes[n].is_leaf())
            .max_by(|a, b| {
                let area = |n: usize| bvh2.nodes[n].aabb().half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(i, _)| i);
        let Some(i) = pick else { break };
        let left = bvh2.nodes[nodes[i]].first_index as usize;
        nodes[i] = left;
        nodes.insert(i + 1, left + 1);
    }
    nodes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(kind: u32, ids: std::ops::Range<u32>, x: f32) -> Leaf {
        Leaf {
            kind,
            ids: ids.collect(),
            lo: [x, 0.0, 0.0],
            hi: [x + 1.0, 1.0, 1.0],
        }
    }

    #[test]
    fn packing_fills_blocks_of_one_kind_and_keeps_every_primitive() {
        let leaves = vec![
            leaf(TRIANGLES, 0..5, 0.0),
            leaf(TRIANGLES, 5..8, 2.0),
            leaf(TRIANGLES, 8..14, 4.0),
            leaf(SPHERES, 14..16, 6.0),
            leaf(TRIANGLES, 16..18, 8.0),
        ];
        let blocks = pack(leaves);
        // First fit in decreasing size: 6 + 2, 5 + 3, and the spheres on their own.
        let mut shapes: Vec<(u32, Vec<u32>)> =
            blocks.iter().map(|b| (b.kind, b.ids.clone())).collect();
        shapes.sort();
        assert_eq!(
            shapes,
            vec![
                (TRIANGLES, vec![0, 1, 2, 3, 4, 5, 6, 7]),
                (TRIANGLES, vec![8, 9, 10, 11, 12, 13, 16, 17]),
                (SPHERES, vec![14, 15]),
            ]
        );
        let joined = blocks.iter().find(|b| b.ids[0] == 8).unwrap();
        assert_eq!(
            (joined.lo[0], joined.hi[0]),
            (4.0, 9.0),
            "the union of the boxes"
        );
        assert!(blocks.iter().all(|b| b.ids.len() <= WIDTH));
    }

    /// The leaves reachable from the root, in depth-first order (left first), each as its
    /// primitives in order.
    fn leaves(bvh2: &Bvh2) -> Vec<Vec<u32>> {
        let (mut out, mut stack) = (Vec::new(), vec![0usize]);
        while let Some(i) = stack.pop() {
            let n = &bvh2.nodes[i];
            match n.is_leaf() {
                true => {
                    let r = n.first_index as usize..(n.first_index + n.prim_count) as usize;
                    out.push(bvh2.primitive_indices[r].to_vec());
                }
                false => stack.extend([n.first_index as usize + 1, n.first_index as usize]),
            }
        }
        out
    }

    #[test]
    fn leaves_of_small_subtrees_are_the_sah_collapse_at_a_high_traversal_cost() {
        // Boxes of different sizes scattered in a cube, so that subtrees of every size occur.
        let boxes: Vec<Aabb> = (0..5000u64)
            .map(|i| {
                let u = |k: u64| {
                    use lobe_materials::sampling::random::{hash, unit};
                    unit(hash(i, k)) as f32
                };
                let c = glam::Vec3A::new(u(0), u(1), u(2)) * 10.0;
                let h = glam::Vec3A::splat(0.01 + 0.3 * u(3) * u(3));
                Aabb::new(c - h, c + h)
            })
            .collect();
        let built = binary_tree(&boxes, Splits::Ploc, false);
        let (mut ours, mut theirs) = (built.clone(), built);
        leaves_of_small_subtrees(&mut ours);
        obvhs::bvh2::leaf_collapser::collapse(&mut theirs, WIDTH as u32, 12.0);
        let got = leaves(&ours);
        assert_eq!(got, leaves(&theirs));
        assert!(got.iter().all(|l| !l.is_empty() && l.len() <= WIDTH));
        let mut all: Vec<u32> = got.concat();
        all.sort_unstable();
        assert_eq!(all, (0..5000).collect::<Vec<u32>>());
        // Fuller than obvhs's own leaves would be: most hold more than half a block.
        assert!(got.len() * 4 < 5000, "{} leaves", got.len());
    }
}
