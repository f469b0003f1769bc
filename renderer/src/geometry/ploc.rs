//! The binary BVH builder: PLOC, parallel locally-ordered clustering (Meister and Bittner,
//! "Parallel Locally-Ordered Clustering for Bounding Volume Hierarchy Construction", IEEE
//! TVCG 2018), over boxes already in Morton order, and that order itself ([`MortonGrid`]).
//!
//! Each round, every cluster finds, among the [`SEARCH_RADIUS`] clusters on either side of
//! it in the order, the one whose union with it has the smallest surface area; clusters
//! that pick each other merge, the merged cluster taking the left one's place. The first
//! [`NARROW_ROUNDS`] rounds look at the next cluster only, as obvhs's `fast_build` does
//! (radius 6, threshold 2): they hold most of the clusters, and neighbours that agree at
//! once are most of the merges. The builder is sequential: the chunked build
//! (`bvh8_build`) runs one chunk per core, so the tree does not depend on the thread count.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use wide::bytemuck::cast;
use wide::{f32x8, u32x8};

/// Clusters on either side that a cluster compares itself with (after the first rounds;
/// at most [`WIDTH`]).
const SEARCH_RADIUS: usize = 6;

/// Rounds that compare each cluster with its next neighbour only.
const NARROW_ROUNDS: usize = 2;

/// A grid of 2^21 cells per axis over a box, in which a point's Morton code (63 bits, its
/// coordinates' bits interleaved) orders points along a Z curve. The code's top 30 bits are
/// the code of the same point on the grid of 2^10 cells per axis, so an order by the coarse
/// code is refined by sorting each run of equal coarse codes by the fine one.
#[derive(Clone, Copy, Debug)]
pub(super) struct MortonGrid {
    min: Vec3A,
    cells_per_unit: Vec3A,
}

/// Bits per axis of the fine code.
const FINE_BITS: u32 = 21;

/// Bits of the fine code below the coarse code's (10 bits per axis).
pub(super) const COARSE_SHIFT: u32 = 3 * (FINE_BITS - 10);

impl MortonGrid {
    /// The grid over `bounds` (degenerate axes get one cell).
    pub(super) fn new(bounds: &Aabb) -> Self {
        let extent = (bounds.max - bounds.min).max(Vec3A::splat(f32::MIN_POSITIVE));
        MortonGrid {
            min: bounds.min,
            cells_per_unit: Vec3A::splat((1u32 << FINE_BITS) as f32) / extent,
        }
    }

    /// The 63-bit Morton code of `p`'s cell (points outside the box are clamped to it).
    #[inline(always)]
    pub(super) fn code(&self, p: Vec3A) -> u64 {
        let [x, y, z] = self.cell(p);
        obvhs::ploc::morton::morton_encode_u64(x, y, z)
    }

    /// `code(p) >> COARSE_SHIFT`: the 30-bit code of `p`'s cell on the grid of 2^10 cells
    /// per axis, at a third of the cost.
    #[inline(always)]
    pub(super) fn coarse_code(&self, p: Vec3A) -> u32 {
        let [x, y, z] = self.cell(p).map(|q| (q >> (FINE_BITS - 10)) as u16);
        obvhs::ploc::morton::morton_encode_u32(x, y, z)
    }

    /// The coordinates of `p`'s cell.
    #[inline(always)]
    fn cell(&self, p: Vec3A) -> [u32; 3] {
        let top = ((1u32 << FINE_BITS) - 1) as f32;
        let q = ((p - self.min) * self.cells_per_unit).clamp(Vec3A::ZERO, Vec3A::splat(top));
        [q.x as u32, q.y as u32, q.z as u32]
    }
}

/// The permutation that puts `boxes` in the Morton order of their centres (ties in index
/// order, so the order is unique).
pub(super) fn morton_sorted(boxes: &[Aabb]) -> Vec<u32> {
    let centres = boxes
        .iter()
        .fold(Aabb::empty(), |mut a, b| *a.extend(b.center()));
    let grid = MortonGrid::new(&centres);
    let mut keys: Vec<(u64, u32)> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| (grid.code(b.center()), i as u32))
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| k.1).collect()
}

/// A binary tree over `boxes` (in Morton order, at least one) by PLOC: leaf `i` holds box
/// `i` (`primitive_indices` is `0..n`); the root is node 0, and an inner node's children
/// are the adjacent nodes `first_index` and `first_index + 1`, after it in the array.
pub(super) fn ploc(boxes: &[Aabb]) -> Bvh2 {
    let n = boxes.len();
    let mut nodes = vec![Bvh2Node::default(); (2 * n).saturating_sub(1)];
    let mut clusters = Clusters::with_len(n);
    for (i, b) in boxes.iter().enumerate() {
        clusters.set(i, b, [1, i as u32]);
    }
    let mut next = Clusters::with_len(n);
    let mut nearest = vec![0u32; n];
    let mut areas = Default::default();
    let mut free = nodes.len();
    let mut round = 0;
    while clusters.len > 1 {
        let radius = match round < NARROW_ROUNDS {
            true => 1,
            false => SEARCH_RADIUS,
        };
        find_nearest(&clusters, radius, &mut areas, &mut nearest);
        let mut kept = 0;
        for i in 0..clusters.len {
            let j = nearest[i] as usize;
            if nearest[j] as usize != i {
                next.set(kept, &clusters.aabb(i), clusters.node[i]);
                kept += 1;
            } else if i < j {
                free -= 2;
                let (a, b) = (clusters.aabb(i), clusters.aabb(j));
                nodes[free] = clusters.bvh2_node(i);
                nodes[free + 1] = clusters.bvh2_node(j);
                next.set(kept, &a.union(&b), [0, free as u32]);
                kept += 1;
            }
        }
        next.len = kept;
        std::mem::swap(&mut clusters, &mut next);
        round += 1;
    }
    nodes[0] = clusters.bvh2_node(0);
    Bvh2 {
        nodes,
        primitive_indices: (0..n as u32).collect(),
        ..Bvh2::default()
    }
}

/// The clusters of a PLOC round, their boxes as columns (min x, y, z, max x, y, z), each
/// followed by [`PAD`] slots so that the eight clusters after any one load as one vector,
/// and each one's node as obvhs's `(prim_count, first_index)`: a leaf `(1, primitive)`,
/// an inner node `(0, left child)`.
struct Clusters {
    columns: [Vec<f32>; 6],
    node: Vec<[u32; 2]>,
    len: usize,
}

/// Clusters whose nearest neighbours are found in one step, and the most clusters a
/// cluster compares itself with on either side.
const WIDTH: usize = 8;

/// Padding of [`Clusters`]' columns and of [`find_nearest`]'s areas.
const PAD: usize = 2 * WIDTH;

impl Clusters {
    /// Room for `len` clusters.
    fn with_len(len: usize) -> Self {
        Clusters {
            columns: std::array::from_fn(|_| vec![0.0; len + PAD]),
            node: vec![[0; 2]; len],
            len,
        }
    }

    #[inline(always)]
    fn set(&mut self, k: usize, b: &Aabb, node: [u32; 2]) {
        let [x0, y0, z0, x1, y1, z1] = &mut self.columns;
        (x0[k], y0[k], z0[k]) = (b.min.x, b.min.y, b.min.z);
        (x1[k], y1[k], z1[k]) = (b.max.x, b.max.y, b.max.z);
        self.node[k] = node;
    }

    #[inline(always)]
    fn aabb(&self, k: usize) -> Aabb {
        let [x0, y0, z0, x1, y1, z1] = &self.columns;
        Aabb::new(
            Vec3A::new(x0[k], y0[k], z0[k]),
            Vec3A::new(x1[k], y1[k], z1[k]),
        )
    }

    #[inline(always)]
    fn bvh2_node(&self, k: usize) -> Bvh2Node {
        let [count, index] = self.node[k];
        Bvh2Node::new(self.aabb(k), count, index)
    }

    /// The boxes of clusters `from..from + WIDTH` (`from` below the length).
    #[inline(always)]
    fn boxes(&self, from: usize) -> [f32x8; 6] {
        let [x0, y0, z0, x1, y1, z1] = &self.columns;
        [
            lanes(x0, from),
            lanes(y0, from),
            lanes(z0, from),
            lanes(x1, from),
            lanes(y1, from),
            lanes(z1, from),
        ]
    }
}

/// `WIDTH` values of `column` from `at`.
#[inline(always)]
fn lanes(column: &[f32], at: usize) -> f32x8 {
    f32x8::new(column[at..at + WIDTH].try_into().unwrap())
}

/// Half the surface area of each lane's union of two boxes ([`Columns::boxes`]).
#[inline(always)]
fn union_area(a: &[f32x8; 6], b: &[f32x8; 6]) -> f32x8 {
    let dx = a[3].max(b[3]) - a[0].min(b[0]);
    let dy = a[4].max(b[4]) - a[1].min(b[1]);
    let dz = a[5].max(b[5]) - a[2].min(b[2]);
    (dx + dy) * dz + dx * dy
}

/// For each of `clusters`, the cluster within `radius` (at most [`WIDTH`]) places of it
/// whose union with it has the least surface area (`nearest`, ties to the lower index).
/// Eight clusters at a time: first each one's union with each of the `radius` after it
/// (`areas[d - 1][PAD + i]` for cluster `i` and `i + d`, infinite past the last), then
/// each one's choice among its neighbours in index order. A cluster whose every cost is
/// infinite or NaN keeps a neighbour, so the last two clusters always pick each other and
/// each round merges at least one pair.
fn find_nearest(
    clusters: &Clusters,
    radius: usize,
    areas: &mut [Vec<f32>; WIDTH],
    nearest: &mut [u32],
) {
    let m = clusters.len;
    let lane = u32x8::new([0, 1, 2, 3, 4, 5, 6, 7]);
    let inf = f32x8::splat(f32::INFINITY);
    for a in &mut areas[..radius] {
        a.clear();
        a.resize(m + 2 * PAD, f32::INFINITY);
    }
    for start in (0..m).step_by(WIDTH) {
        let here = clusters.boxes(start);
        let i = lane + u32x8::splat(start as u32);
        for (d, a) in (1..).zip(&mut areas[..radius]) {
            let valid = (i + u32x8::splat(d)).simd_lt(u32x8::splat(m as u32));
            let c = union_area(&here, &clusters.boxes(start + d as usize));
            let c = cast::<_, f32x8>(valid).select(c, inf);
            a[PAD + start..PAD + start + WIDTH].copy_from_slice(&c.to_array());
        }
    }
    for start in (0..m).step_by(WIDTH) {
        let i = lane + u32x8::splat(start as u32);
        // The neighbour of last resort: the next cluster, the last one's previous.
        let last = i.simd_eq(u32x8::splat(m as u32 - 1));
        let mut best = last.select(i - u32x8::splat(1), i + u32x8::splat(1));
        let mut least = inf;
        let mut consider = |c: f32x8, j: u32x8| {
            let nearer = c.simd_lt(least);
            least = nearer.select(c, least);
            best = cast::<_, u32x8>(nearer).select(j, best);
        };
        for d in (1..=radius).rev() {
            consider(
                lanes(&areas[d - 1], PAD + start - d),
                i - u32x8::splat(d as u32),
            );
        }
        for d in 1..=radius {
            consider(
                lanes(&areas[d - 1], PAD + start),
                i + u32x8::splat(d as u32),
            );
        }
        let n = WIDTH.min(m - start);
        nearest[start..start + n].copy_from_slice(&best.to_array()[..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(x: f32, y: f32, z: f32) -> Aabb {
        let p = Vec3A::new(x, y, z);
        Aabb::new(p, p + Vec3A::ONE)
    }

    /// Every leaf's box reached once from the root, and every inner box the union of its
    /// children's.
    fn check_tree(bvh2: &Bvh2, boxes: &[Aabb]) {
        let mut seen = vec![0; boxes.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &bvh2.nodes[i];
            if node.is_leaf() {
                assert_eq!(node.prim_count, 1);
                let p = bvh2.primitive_indices[node.first_index as usize] as usize;
                seen[p] += 1;
                assert_eq!(node.aabb(), &boxes[p]);
                continue;
            }
            let l = node.first_index as usize;
            assert!(l > i, "children after their parent");
            let u = bvh2.nodes[l].aabb().union(bvh2.nodes[l + 1].aabb());
            assert_eq!(node.aabb(), &u);
            stack.extend([l, l + 1]);
        }
        assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
    }

    #[test]
    fn ploc_covers_every_box_once() {
        for n in [1, 2, 3, 7, 100, 1000] {
            let boxes: Vec<Aabb> = (0..n)
                .map(|i| {
                    let f = i as f32;
                    unit_box((f * 0.37).sin() * 9.0, (f * 1.3).cos() * 9.0, f * 0.01)
                })
                .collect();
            let order = morton_sorted(&boxes);
            let sorted: Vec<Aabb> = order.iter().map(|&i| boxes[i as usize]).collect();
            let bvh2 = ploc(&sorted);
            assert_eq!(bvh2.nodes.len(), 2 * n - 1);
            check_tree(&bvh2, &sorted);
        }
    }

    #[test]
    fn ploc_pairs_the_nearest_boxes_first() {
        // Two tight pairs far apart: each pair is a subtree under the root.
        let boxes = [
            unit_box(0.0, 0.0, 0.0),
            unit_box(0.5, 0.0, 0.0),
            unit_box(50.0, 0.0, 0.0),
            unit_box(50.5, 0.0, 0.0),
        ];
        let bvh2 = ploc(&boxes);
        check_tree(&bvh2, &boxes);
        let root = &bvh2.nodes[0];
        let kids = [root.first_index as usize, root.first_index as usize + 1];
        let mut spans: Vec<f32> = kids
            .iter()
            .map(|&k| bvh2.nodes[k].aabb().diagonal().x)
            .collect();
        spans.sort_by(f32::total_cmp);
        assert_eq!(spans, [1.5, 1.5]);
    }

    #[test]
    fn ploc_ends_with_nan_costs() {
        let nan = Aabb::new(Vec3A::splat(f32::NAN), Vec3A::splat(f32::NAN));
        let bvh2 = ploc(&[nan; 5]);
        assert_eq!(bvh2.nodes.len(), 9);
    }

    #[test]
    fn the_code_interleaves_the_cells_bits() {
        let grid = MortonGrid::new(&Aabb::new(Vec3A::ZERO, Vec3A::splat(2.0)));
        assert_eq!(grid.code(Vec3A::ZERO), 0);
        assert_eq!(grid.code(Vec3A::splat(2.0)), (1 << 63) - 1);
        // The top cell along one axis sets every third bit.
        assert_eq!(grid.code(Vec3A::new(2.0, 0.0, 0.0)), 0x1249_2492_4924_9249);
        assert_eq!(grid.code(Vec3A::new(1.0, 0.0, 0.0)), 1 << 60);
        let xs: Vec<u64> = (0..100)
            .map(|i| grid.code(Vec3A::X * i as f32 * 0.02))
            .collect();
        assert!(xs.windows(2).all(|w| w[0] < w[1]));
    }

    /// The boxes of a displaced grid's triangles, `2 * side * side` of them.
    fn terrain(side: usize) -> Vec<Aabb> {
        let h = |x: f32, y: f32| (x * 0.3).sin() * (y * 0.2).cos() * 2.0;
        let p = |x: f32, y: f32| Vec3A::new(x, y, h(x, y));
        let mut boxes = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let (x, y) = (x as f32, y as f32);
                for [a, b, c] in [
                    [p(x, y), p(x + 1.0, y), p(x, y + 1.0)],
                    [p(x + 1.0, y), p(x + 1.0, y + 1.0), p(x, y + 1.0)],
                ] {
                    boxes.push(Aabb::new(a.min(b).min(c), a.max(b).max(c)));
                }
            }
        }
        boxes
    }

    /// The summed surface area of a tree's inner nodes: its SAH cost but for the leaves,
    /// which are the same in every tree over the same boxes.
    fn inner_area(bvh2: &Bvh2) -> f64 {
        let inner = bvh2.nodes.iter().filter(|n| !n.is_leaf());
        inner.map(|n| n.aabb().half_area() as f64).sum()
    }

    #[test]
    fn ploc_is_as_good_as_obvhs_ploc() {
        let boxes = terrain(100);
        let order = morton_sorted(&boxes);
        let sorted: Vec<Aabb> = order.iter().map(|&i| boxes[i as usize]).collect();
        let ours = ploc(&sorted);
        check_tree(&ours, &sorted);
        let theirs = obvhs::ploc::PlocBuilder::with_capacity(boxes.len()).build(
            obvhs::ploc::PlocSearchDistance::Low,
            &boxes,
            (0..boxes.len() as u32).collect(),
            obvhs::ploc::SortPrecision::U64,
            NARROW_ROUNDS,
        );
        let ratio = inner_area(&ours) / inner_area(&theirs);
        assert!(ratio < 1.01, "lobe's PLOC tree costs {ratio} of obvhs's");
        // In a scrambled order PLOC's neighbours are far apart: a much worse tree.
        let n = boxes.len();
        let scrambled: Vec<Aabb> = (0..n).map(|i| boxes[i * 7919 % n]).collect();
        let worse = inner_area(&ploc(&scrambled)) / inner_area(&theirs);
        assert!(worse > 1.5, "{ratio} {worse}");
    }

    #[test]
    fn morton_order_refines_by_the_fine_code() {
        let boxes = terrain(30);
        let order = morton_sorted(&boxes);
        let centres = boxes
            .iter()
            .fold(Aabb::empty(), |mut a, b| *a.extend(b.center()));
        let grid = MortonGrid::new(&centres);
        let codes: Vec<u64> = order
            .iter()
            .map(|&i| grid.code(boxes[i as usize].center()))
            .collect();
        assert!(codes.windows(2).all(|w| w[0] <= w[1]));
        let coarse: Vec<u64> = codes.iter().map(|c| c >> COARSE_SHIFT).collect();
        assert!(coarse.windows(2).all(|w| w[0] <= w[1]));
    }
}
