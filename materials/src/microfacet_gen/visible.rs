//! Visible-normal sampling of a tabulated distribution of normals (the proposal of the
//! `sampled-microfacet` lobe, [`super::Table`]).
//!
//! The generator's value is rho = p(h) F / (4 g(wo) g(wi)) and g(wo) = int (wo.h)+ p(h) dw
//! normalizes the distribution of normals visible from wo, p(h) (wo.h)+ / g(wo) (Heitz
//! and d'Eon 2014 for analytic distributions): drawing h from it leaves the weight
//! f cos / p = F cos(theta_i) / g(wi), at most F. Drawing h from p(h) h_z instead (every
//! facet, visible or not) leaves a factor h_z / (wo.h), which at grazing `wo` wastes most
//! samples on facets turned away from it.
//!
//! The table's fine structure is drawn exactly and only the smooth factor
//! (wo.h)+ / h_z is approximated: the grid's cells are grouped into blocks of about
//! 32 x 32 per side; a block is drawn with probability its mass of p(h) h_z times
//! (v.c)+ / c_z at its mass centroid c, for the view v of the nearest of 24 x 24
//! (theta_o, phi_o) directions ([`view`]). A small floor keeps every block with mass
//! reachable, so the estimator stays unbiased; a view that no block faces draws blocks by
//! mass alone. Within the block a cell is drawn in proportion to its mass and a point of
//! the cell by its bilinear density. The density of h is then
//! p(h) h_z P(block | wo) / mass(block), exactly.

use super::table::node_index;
use crate::sampling::warp::bilinear;
use crate::simd::{self, MaskN, Vec3xN, f32xn, gather, i32xn, sel};
use glam::DVec3;

/// Blocks per side of the grid (at most; fewer for tables of fewer cells).
const BLOCKS: usize = 32;
/// View directions the block probabilities are tabulated for: theta_o nodes over
/// [0, 90] degrees, phi_o nodes over [0, 360).
const THETA_NODES: usize = 24;
const PHI_NODES: usize = 24;
/// The smallest block weight, relative to the mass-weighted mean weight of a view.
const FLOOR: f64 = 0.02;

/// Block probabilities per view and cell probabilities per block.
#[derive(Clone, Debug)]
pub(super) struct VisibleSampler {
    /// Nodes per side of the table.
    n: usize,
    /// Cells per block side.
    side: usize,
    /// Blocks per side.
    blocks: usize,
    /// Per view, the inclusive CDF of its blocks (row-major), ending at 1.
    block_cdf: Vec<f32>,
    /// 1 / (mass of the block x the area of a cell), 0 for blocks without mass.
    inv_mass: Vec<f32>,
    /// Per block, the inclusive CDF of its `side` x `side` cells (row-major), ending at 1.
    cell_cdf: Vec<f32>,
}

/// The view direction of node (t, f). Views are indexed without trigonometry: theta_o
/// nodes are uniform in sqrt(1 - cos(theta_o)) (nearly uniform in theta_o, 0 to 90
/// degrees), phi_o nodes uniform in the diamond angle ([`diamond_angle`]).
fn view(t: usize, f: usize) -> DVec3 {
    let s = t as f64 / (THETA_NODES - 1) as f64;
    let z = (1.0 - s * s).max(0.0087);
    let a = f as f64 * 4.0 / PHI_NODES as f64;
    let r = a.fract();
    let (x, y) = match a as usize {
        0 => (1.0 - r, r),
        1 => (-r, 1.0 - r),
        2 => (r - 1.0, -r),
        _ => (r, r - 1.0),
    };
    let l = (x * x + y * y).sqrt();
    let st = (1.0 - z * z).sqrt();
    DVec3::new(st * x / l, st * y / l, z)
}

/// The diamond angle of (x, y) in [0, 4): monotone in the azimuth, 0 along +x, 1 along
/// +y, 2 along -x, 3 along -y; 0 at the origin.
#[inline(always)]
fn diamond_angle(x: f32xn, y: f32xn) -> f32xn {
    let s = f32xn::splat;
    let zero = s(0.0);
    let sum = x.abs() + y.abs();
    let r = sel(sum.simd_gt(zero), y / sum, zero);
    let upper = sel(x.simd_ge(zero), r, s(2.0) - r);
    let lower = sel(x.simd_lt(zero), s(2.0) - r, s(4.0) + r);
    sel(y.simd_ge(zero), upper, lower)
}

/// Inclusive running sums of `v` normalized to end at 1 (all zero: uniform).
fn inclusive_cdf(v: &[f64], out: &mut Vec<f32>) {
    let total: f64 = v.iter().sum();
    let mut acc = 0.0;
    for (k, x) in v.iter().enumerate() {
        acc += x;
        out.push(if total > 0.0 {
            (acc / total) as f32
        } else {
            (k + 1) as f32 / v.len() as f32
        });
    }
    *out.last_mut().unwrap() = 1.0;
}

impl VisibleSampler {
    /// For a table of `n` x `n` nodes from the masses of its (n - 1)^2 cells (the means of
    /// their corners, row-major).
    pub(super) fn new(n: usize, masses: &[f32]) -> Self {
        let m = n - 1;
        let side = m.div_ceil(BLOCKS);
        let blocks = m.div_ceil(side);
        let cell = 2.0 / m as f64;
        let mut cell_cdf = Vec::with_capacity(blocks * blocks * side * side);
        let mut mass = vec![0.0f64; blocks * blocks];
        let mut centroid = vec![(0.0f64, 0.0f64); blocks * blocks];
        let mut within = Vec::with_capacity(side * side);
        for b in 0..blocks * blocks {
            within.clear();
            let (bx, by) = (b % blocks, b / blocks);
            for k in 0..side * side {
                let (i, j) = (bx * side + k % side, by * side + k / side);
                let w = if i < m && j < m {
                    masses[j * m + i] as f64
                } else {
                    0.0
                };
                within.push(w);
                mass[b] += w;
                let (x, y) = (
                    -1.0 + (i as f64 + 0.5) * cell,
                    -1.0 + (j as f64 + 0.5) * cell,
                );
                centroid[b].0 += w * x;
                centroid[b].1 += w * y;
            }
            inclusive_cdf(&within, &mut cell_cdf);
        }
        let facing: Vec<Option<DVec3>> = (0..blocks * blocks)
            .map(|b| {
                (mass[b] > 0.0).then(|| {
                    let (x, y) = (centroid[b].0 / mass[b], centroid[b].1 / mass[b]);
                    let r2 = (x * x + y * y).min(0.9975);
                    let z = (1.0 - r2).sqrt();
                    // (v.c) / c_z = v.(c / c_z).
                    DVec3::new(x / z, y / z, 1.0)
                })
            })
            .collect();
        let mut block_cdf = Vec::with_capacity(THETA_NODES * PHI_NODES * blocks * blocks);
        let mut weight = vec![0.0f64; blocks * blocks];
        let total: f64 = mass.iter().sum();
        for t in 0..THETA_NODES {
            for f in 0..PHI_NODES {
                let v = view(t, f);
                for (w, c) in weight.iter_mut().zip(&facing) {
                    *w = c.map_or(0.0, |c| v.dot(c).max(0.0));
                }
                let mean = weight.iter().zip(&mass).map(|(w, m)| w * m).sum::<f64>() / total;
                for (w, m) in weight.iter_mut().zip(&mass) {
                    // No block faces the view: the blocks by mass alone.
                    *w = if mean > 0.0 {
                        m * w.max(FLOOR * mean)
                    } else {
                        *m
                    };
                }
                inclusive_cdf(&weight, &mut block_cdf);
            }
        }
        let inv_mass = mass
            .iter()
            .map(|&m| {
                if m > 0.0 {
                    (1.0 / (m * cell * cell)) as f32
                } else {
                    0.0
                }
            })
            .collect();
        VisibleSampler {
            n,
            side,
            blocks,
            block_cdf,
            inv_mass,
            cell_cdf,
        }
    }

    pub(super) fn memory_bytes(&self) -> usize {
        (self.block_cdf.len() + self.inv_mass.len() + self.cell_cdf.len()) * 4
    }

    /// The first offset of the view's block CDF for `wo` (nearest tabulated view).
    #[inline(always)]
    fn view_offset(&self, wo: Vec3xN) -> i32xn {
        let s = f32xn::splat;
        let zero = s(0.0);
        let below = (s(1.0) - wo.z).max(zero).min(s(1.0)).sqrt();
        let t = (below * s((THETA_NODES - 1) as f32) + s(0.5)).trunc_int();
        let a = diamond_angle(wo.x, wo.y) * s(PHI_NODES as f32 / 4.0) + s(0.5);
        let f = a.trunc_int();
        let f = sel(
            f.simd_ge(i32xn::splat(PHI_NODES as i32)),
            i32xn::splat(0),
            f,
        );
        let clamp = |v: i32xn, n: usize| v.max(i32xn::splat(0)).min(i32xn::splat(n as i32 - 1));
        let view = clamp(t, THETA_NODES) * i32xn::splat(PHI_NODES as i32) + clamp(f, PHI_NODES);
        view * i32xn::splat((self.blocks * self.blocks) as i32)
    }

    /// The probability of block `b` under the view at `offset`, over the block's mass
    /// times a cell's area.
    #[inline(always)]
    fn block_density(&self, offset: i32xn, b: i32xn) -> f32xn {
        let zero = i32xn::splat(0);
        let hi = simd::gather(&self.block_cdf, offset + b);
        let below = b.simd_gt(zero);
        let lo = simd::gather(&self.block_cdf, offset + (b - i32xn::splat(1)).max(zero));
        let lo = sel(
            f32xn::from_bits(wide::bytemuck::cast(below)),
            lo,
            f32xn::splat(0.0),
        );
        (hi - lo) * simd::gather(&self.inv_mass, b)
    }

    /// The density (solid angle of h) of [`VisibleSampler::sample`] seen from `wo`, given
    /// p(h) `p_h`: p(h) h_z P(block | wo) / mass(block).
    #[inline(always)]
    pub(super) fn pdf(&self, wo: Vec3xN, h: Vec3xN, p_h: f32xn) -> f32xn {
        let s = f32xn::splat;
        let half_span = s((self.n - 1) as f32 / 2.0);
        let cell = |c: f32xn| node_index((c + s(1.0)) * half_span, self.n - 2);
        let (bx, by) = (div(cell(h.x), self.side), div(cell(h.y), self.side));
        let b = by * i32xn::splat(self.blocks as i32) + bx;
        let p = p_h * h.z * self.block_density(self.view_offset(wo), b);
        sel(h.z.simd_le(s(0.0)), s(0.0), p)
    }

    /// Half vectors seen from `wo` from uniforms (`ux`, `uy`), and the mask of the lanes
    /// where one was drawn (a bilinear patch can leak past the rim), reading the
    /// table's node values `p` for the point within the cell; `N` lane vectors side by
    /// side, each bit for bit its own call, so that the core overlaps their chains of
    /// dependent reads.
    #[inline(always)]
    pub(super) fn sample<const N: usize>(
        &self,
        p: &[f32],
        wo: [Vec3xN; N],
        ux: [f32xn; N],
        uy: [f32xn; N],
    ) -> [(Vec3xN, MaskN); N] {
        let s = f32xn::splat;
        let offset = wo.map(|w| self.view_offset(w));
        let nb = self.blocks * self.blocks;
        let blocks = invert(&self.block_cdf, offset, nb, ux);
        let cells = self.side * self.side;
        let base = blocks.map(|(b, _)| b * i32xn::splat(cells as i32));
        let cells = invert(&self.cell_cdf, base, cells, uy);
        std::array::from_fn(|g| {
            let ((b, ux), (c, uy)) = (blocks[g], cells[g]);
            let (by, cy) = (div(b, self.blocks), div(c, self.side));
            let (nb, side) = (
                i32xn::splat(self.blocks as i32),
                i32xn::splat(self.side as i32),
            );
            let (bx, cx) = (b - by * nb, c - cy * side);
            let (cx, cy) = (bx * side + cx, by * side + cy);
            let n = self.n as i32;
            let k = cy * i32xn::splat(n) + cx;
            let at = |o: i32| simd::gather(p, k + i32xn::splat(o));
            let (fx, fy) = bilinear(ux, uy, [at(0), at(1), at(n), at(n + 1)]);
            let inv = s(1.0 / (self.n - 1) as f32);
            let coordinate = |c: i32xn, f: f32xn| s(2.0) * ((simd::float_of(c) + f) * inv) - s(1.0);
            let (x, y) = (coordinate(cx, fx), coordinate(cy, fy));
            let r2 = x * x + y * y;
            let drawn = r2.simd_lt(s(1.0));
            let z = sel(drawn, s(1.0) - r2, s(0.0)).sqrt();
            (Vec3xN::new(x, y, z), drawn)
        })
    }
}

/// a / d rounded down per lane, for 0 <= a < 2^22 (exact in f32).
#[inline(always)]
fn div(a: i32xn, d: usize) -> i32xn {
    ((simd::float_of(a) + f32xn::splat(0.5)) * f32xn::splat(1.0 / d as f32)).trunc_int()
}

/// The first of the `n` inclusive CDF values `cdf[offset + k]` (non-decreasing, ending
/// at one) above `u`, per lane, and `u` remapped to [0, 1) within that entry's step; `N`
/// lane vectors side by side.
#[inline(always)]
fn invert<const N: usize>(
    cdf: &[f32],
    offset: [i32xn; N],
    n: usize,
    u: [f32xn; N],
) -> [(i32xn, f32xn); N] {
    let mut base = [i32xn::splat(0); N];
    let mut size = n;
    // The answer lies in [base, base + size): entries at or below u are skipped. Three
    // independent probes split the range in four, halving the chain of dependent reads;
    // every lane keeps the last quarter's length, which holds each of the others.
    while size >= 4 {
        let q = size / 4;
        for g in 0..N {
            let first = offset[g] + base[g] - i32xn::splat(1);
            let (a, b, c) = (
                gather(cdf, first + i32xn::splat(q as i32)),
                gather(cdf, first + i32xn::splat(2 * q as i32)),
                gather(cdf, first + i32xn::splat(3 * q as i32)),
            );
            // A skipped probe is -1 in its mask: minus their sum counts them.
            let mask = |v: f32xn| -> i32xn { wide::bytemuck::cast(v.simd_le(u[g])) };
            let skipped = mask(a) + mask(b) + mask(c);
            base[g] -= skipped * i32xn::splat(q as i32);
        }
        size -= 3 * q;
    }
    while size > 1 {
        let half = size / 2;
        for g in 0..N {
            let next = base[g] + i32xn::splat(half as i32 - 1);
            let skip = gather(cdf, offset[g] + next).simd_le(u[g]);
            base[g] = sel(wide::bytemuck::cast(skip), next + i32xn::splat(1), base[g]);
        }
        size -= half;
    }
    std::array::from_fn(|g| {
        let k = base[g].min(i32xn::splat(n as i32 - 1));
        let zero = i32xn::splat(0);
        let hi = gather(cdf, offset[g] + k);
        let lo = gather(cdf, offset[g] + (k - i32xn::splat(1)).max(zero));
        let first = f32xn::from_bits(wide::bytemuck::cast(k.simd_eq(zero)));
        let lo = sel(first, f32xn::splat(0.0), lo);
        let r = ((u[g] - lo) / (hi - lo)).max(f32xn::splat(0.0));
        let r = sel(r.is_finite(), r, f32xn::splat(0.0));
        (k, r.min(f32xn::splat(1.0 - f32::EPSILON / 2.0)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Inversion skips entries of zero probability, even at u on a step's edge, and
    /// remaps u within the chosen step.
    #[test]
    fn inversion_never_draws_an_entry_without_probability() {
        let cdf = [0.0f32, 0.0, 0.25, 0.25, 0.25, 1.0, 1.0];
        let us = [0.0f32, 0.1, 0.25, 0.5, 0.999_999];
        let expected = [(2, 0.0), (2, 0.4), (5, 0.0), (5, 1.0 / 3.0), (5, 1.0)];
        for (&u, &(k, r)) in us.iter().zip(&expected) {
            let [(got, rem)] = invert(&cdf, [i32xn::splat(0)], cdf.len(), [f32xn::splat(u)]);
            assert_eq!(got.to_array()[0], k, "u = {u}");
            assert!((rem.to_array()[0] - r).abs() < 1e-5, "u = {u}: {rem:?}");
        }
    }

    /// Every block with mass is reachable from every view (the floor), and blocks without
    /// mass never are.
    #[test]
    fn every_block_with_mass_has_probability_from_every_view() {
        let (n, m) = (65usize, 64usize);
        // Mass only in the cells of the left half.
        let masses: Vec<f32> = (0..m * m)
            .map(|k| if k % m < m / 2 { 1.0 } else { 0.0 })
            .collect();
        let v = VisibleSampler::new(n, &masses);
        let nb = v.blocks * v.blocks;
        for view in v.block_cdf.chunks(nb) {
            for b in 0..nb {
                let p = view[b] - if b > 0 { view[b - 1] } else { 0.0 };
                let left = (b % v.blocks) * v.side < m / 2;
                assert_eq!(p > 0.0, left, "block {b}: probability {p}");
            }
        }
    }
}
