//! Closest hits of coherent rays (a camera's rays through one pixel or a few neighbouring
//! ones) traversed through the BVH8 eight at a time, one ray per SIMD lane: a packet
//! (Wald, Slusallek, Benthin and Wagner, "Interactive Rendering with Coherent Ray
//! Tracing", 2001; the packet half of Embree's hybrid traversal, Wald et al., "Embree: A
//! Kernel Framework for Efficient CPU Ray Tracing", 2014, section 4). Rays that take the
//! same way through the tree share each node's loads, the control flow of its box tests
//! and the stack, where [`Bvh8::closest`] pays them per ray.
//!
//! Each child box is tested against the eight rays with the same operations, lane by
//! lane, as the one-ray test tests one ray against eight children (the near plane chosen
//! by the sign of the direction, one fused multiply-subtract per plane, pbrt-v4's
//! conservative far distance), and each leaf primitive against the eight rays with the
//! same kernels. So every ray enters the same boxes and finds the same distances as it
//! would alone, and a ray tests the primitives of the leaves it enters only. Only the
//! order in which the packet visits children (nearest first by its nearest ray) differs.
//! That can change the answer only between primitives hit at the same distance or a few
//! ulps apart (where a box whose rounded entry distance lies beyond a hit found elsewhere
//! is culled in one order and not in the other).

use super::bvh8::{Bvh8, INDEX_MASK, INNER, KIND_SHIFT, Node, STACK};
use super::bvh8::{SPHERES, TRIANGLES, WIDTH, slab_reciprocal, slab_test};
use super::kernels::{self, RayLanes, V3};
use lobe_materials::simd::sel;
use std::mem::MaybeUninit;
use wide::{f32x8, u32x8};

/// Eight rays in lanes, prepared for box tests: the one-ray form's quantities per lane.
struct PacketBoxes {
    inv: [f32x8; 3],
    o_inv: [f32x8; 3],
    /// Lanes whose direction component's sign bit is set (negative zero included, as the
    /// one-ray test's `is_sign_negative`), per axis.
    negative: [f32x8; 3],
    tmin: f32x8,
}

impl PacketBoxes {
    #[inline(always)]
    fn new(r: &RayLanes<f32x8>) -> Self {
        let d = [r.d.x, r.d.y, r.d.z];
        let o = [r.o.x, r.o.y, r.o.z];
        let inv = d.map(slab_reciprocal);
        Self {
            o_inv: [0, 1, 2].map(|a| o[a] * inv[a]),
            inv,
            negative: d.map(f32x8::is_sign_negative),
            tmin: r.tmin,
        }
    }

    /// Entry distances of the eight rays into child `k` of `node`, and the mask of the
    /// lanes that enter it before their `tmax`.
    #[inline(always)]
    fn test(&self, node: &Node, k: usize, tmax: f32x8) -> (f32x8, f32x8) {
        let bound = |a: usize, side: usize| f32x8::splat(node.bounds[a][side].as_array()[k]);
        // The near bound is the upper one where the direction is negative.
        let near = [0, 1, 2].map(|a| sel(self.negative[a], bound(a, 1), bound(a, 0)));
        let far = [0, 1, 2].map(|a| sel(self.negative[a], bound(a, 0), bound(a, 1)));
        slab_test(near, far, (&self.inv, &self.o_inv), (self.tmin, tmax))
    }
}

/// A packet's stack entry: a child reference and each ray's entry distance (NaN for the
/// rays that do not enter it, so that no later `tmax` makes them test it).
type PacketEntry = (u32, f32x8);

/// The smallest lane of `v` that is not NaN.
#[inline(always)]
fn min_lane(v: f32x8) -> f32 {
    v.as_array().iter().fold(f32::INFINITY, |m, &x| m.min(x))
}

impl Bvh8 {
    /// Closest hits of the eight rays `rays` (skipping primitive `skip` of each): per lane
    /// the distance and primitive, or `tmax` and `u32::MAX` where the ray hits nothing
    /// before its `tmax`. The answers of [`Bvh8::closest`], ray by ray (up to ties).
    pub(super) fn closest_packet(&self, rays: &RayLanes<f32x8>, skip: u32x8) -> (f32x8, u32x8) {
        let boxes = PacketBoxes::new(rays);
        let mut tmax = rays.tmax;
        let mut best = u32x8::splat(u32::MAX);
        let mut stack = [MaybeUninit::<PacketEntry>::uninit(); STACK];
        stack[0].write((0, f32x8::splat(f32::NEG_INFINITY)));
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below `sp` were written by the pushes.
            let (r, t_enter) = unsafe { stack[sp].assume_init() };
            let active = t_enter.simd_le(tmax);
            if !active.any() {
                continue;
            }
            if r >> KIND_SHIFT == INNER {
                sp = self.push_packet_children(&mut stack, sp, r, &boxes, active, tmax);
            } else {
                self.packet_leaf(r, rays, skip, active, &mut tmax, &mut best);
            }
        }
        (tmax, best)
    }

    /// Pushes the children of inner node `r` that some `active` ray enters, the nearest
    /// (by its nearest ray) on top; returns the new stack size.
    #[inline(always)]
    fn push_packet_children(
        &self,
        stack: &mut [MaybeUninit<PacketEntry>; STACK],
        mut sp: usize,
        r: u32,
        boxes: &PacketBoxes,
        active: f32x8,
        tmax: f32x8,
    ) -> usize {
        let node = &self.nodes[r as usize];
        let first = sp;
        let mut keys = [0.0f32; WIDTH];
        for k in 0..WIDTH {
            let (tn, hit) = boxes.test(node, k, tmax);
            let hit = hit & active;
            if !hit.any() {
                continue;
            }
            let tn = sel(hit, tn, f32x8::splat(f32::NAN));
            let key = min_lane(tn);
            // Insertion into the pushed run, kept in decreasing distance.
            let mut j = sp;
            while j > first && keys[j - 1 - first] < key {
                stack[j] = stack[j - 1];
                keys[j - first] = keys[j - 1 - first];
                j -= 1;
            }
            stack[j].write((node.child[k], tn));
            keys[j - first] = key;
            sp += 1;
        }
        sp
    }

    /// Tests the `active` rays of `lanes` (their range's end: `tmax`) against every
    /// primitive of leaf block `leaf`, keeping in `tmax` and `best` each ray's nearest hit
    /// not skipped.
    #[inline(always)]
    fn packet_leaf(
        &self,
        leaf: u32,
        lanes: &RayLanes<f32x8>,
        skip: u32x8,
        active: f32x8,
        tmax: &mut f32x8,
        best: &mut u32x8,
    ) {
        let i = (leaf & INDEX_MASK) as usize;
        let kind = leaf >> KIND_SHIFT;
        let ids = match kind {
            TRIANGLES => self.tris[i].id,
            SPHERES => self.spheres[i].id,
            _ => self.rects[i].id,
        };
        let ids = ids.to_array();
        for k in 0..WIDTH {
            // Unused lanes repeat the block's last primitive.
            if k > 0 && ids[k] == ids[k - 1] {
                break;
            }
            let lane = |v: V3<f32x8>| {
                let a = |c: f32x8| f32x8::splat(c.as_array()[k]);
                V3::new(a(v.x), a(v.y), a(v.z))
            };
            let r = RayLanes {
                tmax: *tmax,
                ..*lanes
            };
            let t = match kind {
                TRIANGLES => {
                    let b = &self.tris[i];
                    kernels::triangle(&r, lane(b.p0), lane(b.e1), lane(b.e2))
                }
                SPHERES => {
                    let b = &self.spheres[i];
                    let radius = f32x8::splat(b.radius.as_array()[k]);
                    kernels::sphere(&r, lane(b.center), radius)
                }
                _ => {
                    let b = &self.rects[i];
                    kernels::rectangle(&r, lane(b.corner), lane(b.n), lane(b.du), lane(b.dv))
                }
            };
            let id = u32x8::splat(ids[k]);
            let kept = !f32x8::from_bits(id.simd_eq(skip));
            let closer = t.simd_lt(*tmax) & kept & active;
            *tmax = sel(closer, t, *tmax);
            *best = closer.to_bits().select(id, *best);
        }
    }
}
