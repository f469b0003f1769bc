//! Discrete and piecewise-constant distributions for importance sampling, all by monotone
//! warps so that low-discrepancy samples keep their stratification: a 1D distribution
//! (the textbook construction of pbrt-v4's `PiecewiseConstant1D`), 2D grids sampled by a
//! marginal and per-row conditional CDFs (area-light selection, the tabulated samplers of
//! measured BRDFs), and hierarchical sample warping of a 2D grid (Clarberg et al. 2005,
//! "Wavelet Importance Sampling"; Mitsuba 3's `Hierarchical2D`) for environment maps.

use crate::simd;
use glam::Vec2;
use wide::{f32x8, u32x8};

/// A piecewise-constant density on [0, 1) with `n` equal cells.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    /// Block summary of `cdf` for [`invert`] (see [`coarse_into`]).
    coarse: Vec<f32>,
    integral: f32,
}

impl Distribution1D {
    /// From non-negative cell values. An all-zero (or empty) function becomes uniform.
    pub fn new(values: &[f32]) -> Self {
        let clean = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
        let mut func: Vec<f32> = values.iter().map(|&v| clean(v)).collect();
        if func.is_empty() {
            func.push(0.0);
        }
        let n = func.len();
        let mut cdf = Vec::with_capacity(n + 1);
        let sum = cdf_into(func.iter().map(|&v| v as f64), &mut cdf);
        let integral = (sum / n as f64) as f32;
        if !(integral > 0.0) {
            func.iter_mut().for_each(|f| *f = 1.0);
        }
        let mut coarse = Vec::new();
        coarse_into(&cdf, &mut coarse);
        Self {
            func,
            cdf,
            coarse,
            integral: if integral > 0.0 { integral } else { 1.0 },
        }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Integral of the function over [0, 1).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Samples x in [0, 1): returns (x, density at x, cell index).
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        let (i, du) = invert(&self.cdf, &self.coarse, u);
        let x = ((i as f32 + du) / n as f32).min(1.0 - f32::EPSILON / 2.0);
        (x, self.func[i] / self.integral, i)
    }

    /// Density at x in [0, 1).
    #[inline]
    pub fn pdf(&self, x: f32) -> f32 {
        let n = self.func.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        self.func[i] / self.integral
    }

    /// Picks a cell with probability proportional to its value: (index, probability,
    /// `u` rescaled to [0, 1) within the cell, for reuse).
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let (i, ur) = invert(&self.cdf, &self.coarse, u);
        (i, self.cell_probability(i), ur)
    }

    /// Probability of cell i.
    pub fn cell_probability(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }
}

/// Sampling of the cells of an `nu` x `nv` grid (row-major, v rows) in proportion to their
/// values by CDF inversion: the row from the marginal CDF, then the column from that row's
/// conditional CDF (pbrt-v4's `PiecewiseConstant2D`, Mitsuba 3's `DiscreteDistribution2D`).
/// The map from `u` to the cell and the position within it is monotone in each coordinate,
/// so stratified and low-discrepancy samples stay stratified over the cells (Walker's alias
/// method, O(1) but scattering neighbouring `u` over distant cells, cost 4.6x the image
/// MSE of env-map renders at 64 spp; docs/performance.md). The density is left to the
/// caller (see [`Distribution2D`]).
#[derive(Clone, Debug)]
pub struct Cdf2D {
    pub nu: usize,
    pub nv: usize,
    /// nv + 1 entries, 0 to 1.
    marginal: Vec<f32>,
    /// nv rows of nu + 1 entries, each 0 to 1 (uniform for an all-zero row).
    conditional: Vec<f32>,
    /// Block summaries ([`coarse_into`]) of `marginal` and of each row of `conditional`
    /// (`coarse_stride` entries per row).
    coarse_marginal: Vec<f32>,
    coarse_conditional: Vec<f32>,
    coarse_stride: usize,
}

/// Normalized running sums of `values` (cleaned: negative and non-finite count as zero)
/// into `out` (len + 1 entries, first 0, last exactly 1; uniform when all are zero).
/// Summed in f64 so long rows keep their small cells.
fn cdf_into(values: impl ExactSizeIterator<Item = f64>, out: &mut Vec<f32>) -> f64 {
    let n = values.len();
    let start = out.len();
    out.push(0.0);
    let mut acc = 0.0f64;
    let mut sums = Vec::with_capacity(n);
    for v in values {
        acc += if v.is_finite() { v.max(0.0) } else { 0.0 };
        sums.push(acc);
    }
    for (i, s) in sums.into_iter().enumerate() {
        out.push(if acc > 0.0 {
            (s / acc) as f32
        } else {
            (i + 1) as f32 / n as f32
        });
    }
    out[start + n] = 1.0;
    acc
}

/// Entries of a CDF per block of the two-level search in [`invert`].
const BLOCK: usize = 16;

/// Appends the block summary of `cdf` to `out`: the last entry of each block of
/// [`BLOCK`] entries (the final block may be short).
fn coarse_into(cdf: &[f32], out: &mut Vec<f32>) {
    out.extend(cdf.chunks(BLOCK).map(|b| b[b.len() - 1]));
}

/// How many entries of `s` are <= u: compares with no branch and no dependent load, which
/// the compiler vectorizes.
#[inline]
fn count_le(s: &[f32], u: f32) -> usize {
    s.iter().map(|&c| (c <= u) as u32).sum::<u32>() as usize
}

/// Index of the cell of `cdf` (n + 1 entries, non-decreasing) holding `u`, skipping empty
/// cells, and `u` rescaled within it to [0, 1). `coarse` is the block summary of `cdf`
/// ([`coarse_into`]): the number of entries <= u is found by counting the blocks that
/// end at or below `u` and then the entries of the next block, two short vector scans
/// instead of a binary search's chain of dependent loads (a 512-entry row takes two steps
/// instead of nine), with the same result.
#[inline]
fn invert(cdf: &[f32], coarse: &[f32], u: f32) -> (usize, f32) {
    let start = count_le(coarse, u) * BLOCK;
    let n = cdf.len() - 1;
    let below = if start < cdf.len() {
        start + count_le(&cdf[start..(start + BLOCK).min(cdf.len())], u)
    } else {
        cdf.len()
    };
    let i = below.saturating_sub(1).min(n - 1);
    let width = cdf[i + 1] - cdf[i];
    let r = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
    } else {
        0.5
    };
    (i, r)
}

impl Cdf2D {
    pub fn memory_bytes(&self) -> usize {
        (self.marginal.len()
            + self.conditional.len()
            + self.coarse_marginal.len()
            + self.coarse_conditional.len())
            * 4
    }

    /// From non-negative cell values (an all-zero grid is uniform). Returns the table and
    /// the mean cell value (1 for an all-zero grid).
    pub fn new(values: &[f32], nu: usize, nv: usize) -> (Self, f64) {
        assert!(nu > 0 && nv > 0);
        assert_eq!(values.len(), nu * nv);
        let mut conditional = Vec::with_capacity(nv * (nu + 1));
        let row_sums: Vec<f64> = values
            .chunks(nu)
            .map(|r| cdf_into(r.iter().map(|&v| v as f64), &mut conditional))
            .collect();
        let mut marginal = Vec::with_capacity(nv + 1);
        let total = cdf_into(row_sums.into_iter(), &mut marginal);
        let mean = total / (nu * nv) as f64;
        let mut coarse_marginal = Vec::new();
        coarse_into(&marginal, &mut coarse_marginal);
        let coarse_stride = (nu + 1).div_ceil(BLOCK);
        let mut coarse_conditional = Vec::with_capacity(nv * coarse_stride);
        for row in conditional.chunks(nu + 1) {
            coarse_into(row, &mut coarse_conditional);
        }
        let t = Self {
            nu,
            nv,
            marginal,
            conditional,
            coarse_marginal,
            coarse_conditional,
            coarse_stride,
        };
        (t, if mean > 0.0 { mean } else { 1.0 })
    }

    /// (column, row, position within the cell in [0, 1)^2).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (usize, usize, Vec2) {
        let (row, ry) = invert(&self.marginal, &self.coarse_marginal, u.y);
        let k = row * (self.nu + 1);
        let c = row * self.coarse_stride;
        let (col, rx) = invert(
            &self.conditional[k..k + self.nu + 1],
            &self.coarse_conditional[c..c + self.coarse_stride],
            u.x,
        );
        (col, row, Vec2::new(rx, ry))
    }
}

/// One level of a [`Hierarchy2D`]: `w` x `h` (both even) values stored in 2x2 packets, so
/// that the four children of a node of the next coarser level are one contiguous read.
#[derive(Clone, Debug)]
struct Level {
    /// Packets per row (half the padded width).
    packets_per_row: usize,
    /// One 2x2 packet per node of the next coarser level: [top-left, top-right,
    /// bottom-left, bottom-right] (one 16-byte load, one bounds check).
    data: Vec<[f32; 4]>,
}

impl Level {
    #[inline(always)]
    fn packet(&self, x: usize, y: usize) -> [f32; 4] {
        self.data[y * self.packets_per_row + x]
    }
}

/// Hierarchical sample warping of a grid of cell masses (McCool and Harwood 1997,
/// Clarberg et al. 2005, "Wavelet Importance Sampling", Sec. 4; the scheme of Mitsuba 3's
/// `Hierarchical2D`): a MIP pyramid of sums is descended from its 2x2 root, and at each
/// level one coordinate of the sample picks the row of the 2x2 block and the other the
/// column within it, each then rescaled to [0, 1). The cells are drawn with the same
/// probabilities as [`Cdf2D`] (mass over total), but nearby samples land in nearby cells
/// at every scale, where rows-then-columns inversion sends two samples either side of a row
/// boundary to unrelated columns: low-discrepancy point sets keep their 2D stratification
/// through the warp, which lowers the variance of env-map light sampling (sphere-envmap,
/// light samples only at 64 spp: 1.9x lower than with [`Cdf2D`]).
#[derive(Clone, Debug)]
pub struct Hierarchy2D {
    pub nu: usize,
    pub nv: usize,
    /// Finest first: level 0 holds the cells (zero-padded to even dimensions), each next
    /// level the sums of 2x2 blocks of the one before, the last is a single packet.
    levels: Vec<Level>,
}

impl Hierarchy2D {
    /// From non-negative cell values (negative and non-finite ones count as zero; an
    /// all-zero grid is uniform). Returns the hierarchy and the mean cell value (1 for an
    /// all-zero grid).
    pub fn new(values: &[f32], nu: usize, nv: usize) -> (Self, f64) {
        assert!(nu > 0 && nv > 0);
        assert_eq!(values.len(), nu * nv);
        let clean = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
        let total: f64 = values.iter().map(|&v| clean(v) as f64).sum();
        let uniform = !(total > 0.0);
        // The logical size of the current level and its values, row-major.
        let (mut w, mut h) = (nu, nv);
        let mut cur: Vec<f32> = values
            .iter()
            .map(|&v| if uniform { 1.0 } else { clean(v) })
            .collect();
        let mut levels = Vec::new();
        loop {
            let (pw, ph) = (w.div_ceil(2), h.div_ceil(2));
            let mut data = vec![[0.0f32; 4]; pw * ph];
            let mut next = vec![0.0f32; pw * ph];
            for y in 0..h {
                for x in 0..w {
                    let v = cur[y * w + x];
                    data[(y / 2) * pw + x / 2][(y % 2) * 2 + x % 2] = v;
                    next[(y / 2) * pw + x / 2] += v;
                }
            }
            levels.push(Level {
                packets_per_row: pw,
                data,
            });
            if pw == 1 && ph == 1 {
                break;
            }
            (w, h, cur) = (pw, ph, next);
        }
        let mean = if uniform {
            1.0
        } else {
            total / (nu * nv) as f64
        };
        (Self { nu, nv, levels }, mean)
    }

    pub fn memory_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.data.len() * 16).sum()
    }

    /// (column, row, position within the cell in [0, 1)^2).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (usize, usize, Vec2) {
        let (mut x, mut y) = (0u32, 0u32);
        let (mut ux, mut uy) = (u.x.clamp(0.0, ONE_MINUS_EPS), u.y.clamp(0.0, ONE_MINUS_EPS));
        for level in self.levels.iter().rev() {
            let (right, lower);
            (right, lower, ux, uy) = descend(level.packet(x as usize, y as usize), ux, uy);
            x = 2 * x + right;
            y = 2 * y + lower;
        }
        let (x, y) = ((x as usize).min(self.nu - 1), (y as usize).min(self.nv - 1));
        (x, y, Vec2::new(ux, uy))
    }

    /// [`Hierarchy2D::sample`] of eight points at once, bit for bit the same, level by
    /// level in SIMD lanes (their independent memory reads overlap): (columns, rows,
    /// positions within the cells).
    #[inline]
    pub fn sample_x8(&self, ux: f32x8, uy: f32x8) -> (u32x8, u32x8, f32x8, f32x8) {
        self.sample_x8s([ux], [uy])[0]
    }

    /// [`Hierarchy2D::sample_x8`] of `N` groups of eight points, descended side by side:
    /// each level's reads and arithmetic for one group are independent of the others',
    /// so the core overlaps `N` dependency chains (a descent is one long chain of loads,
    /// divisions and selects per group). Bit for bit `sample_x8` of each group.
    #[inline(always)]
    pub fn sample_x8s<const N: usize>(
        &self,
        ux: [f32x8; N],
        uy: [f32x8; N],
    ) -> [(u32x8, u32x8, f32x8, f32x8); N] {
        let mut x = [u32x8::splat(0); N];
        let mut y = [u32x8::splat(0); N];
        let mut ux = ux.map(|u| simd::clamp(u, 0.0, ONE_MINUS_EPS));
        let mut uy = uy.map(|u| simd::clamp(u, 0.0, ONE_MINUS_EPS));
        let one = u32x8::splat(1);
        for level in self.levels.iter().rev() {
            for j in 0..N {
                let q = if let [p] = level.data.as_slice() {
                    // The root: one packet for every lane.
                    [
                        f32x8::splat(p[0]),
                        f32x8::splat(p[1]),
                        f32x8::splat(p[2]),
                        f32x8::splat(p[3]),
                    ]
                } else {
                    let idx = (y[j] * u32x8::splat(level.packets_per_row as u32) + x[j]).to_array();
                    simd::transpose4x8(&simd::lanes(|i| level.data[idx[i] as usize]))
                };
                let (right, lower);
                (right, lower, ux[j], uy[j]) = descend_x8(q, ux[j], uy[j]);
                x[j] = (x[j] << 1) + (right.to_bits() & one);
                y[j] = (y[j] << 1) + (lower.to_bits() & one);
            }
        }
        let (mx, my) = (
            u32x8::splat(self.nu as u32 - 1),
            u32x8::splat(self.nv as u32 - 1),
        );
        std::array::from_fn(|j| (x[j].min(mx), y[j].min(my), ux[j], uy[j]))
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// One step of [`Hierarchy2D::sample`]: in a 2x2 block `p` = [top-left, top-right,
/// bottom-left, bottom-right], picks the row with `uy` and the column within it with `ux`,
/// never a child of zero mass, and rescales both to [0, 1): (right, lower, ux', uy').
/// Written with selects only (no branch), so that [`Hierarchy2D::sample_x8`]
/// vectorizes.
#[inline(always)]
fn descend(p: [f32; 4], ux: f32, uy: f32) -> (u32, u32, f32, f32) {
    let (r0, r1) = (p[0] + p[1], p[2] + p[3]);
    let ty = uy * (r0 + r1);
    let lower = (ty >= r0) & (r1 > 0.0) | (r0 <= 0.0);
    let c0 = if lower { p[2] } else { p[0] };
    let c1 = if lower { p[3] } else { p[1] };
    let dy = if lower { r1 } else { r0 };
    let tx = ux * dy;
    let right = (tx >= c0) & (c1 > 0.0) | (c0 <= 0.0);
    let dx = if right { c1 } else { c0 };
    // Blocks of zero mass are never picked; dy or dx is zero only for NaN input, which
    // then keeps its sample as it is.
    let ny = if dy > 0.0 {
        ((ty - if lower { r0 } else { 0.0 }) / dy).clamp(0.0, ONE_MINUS_EPS)
    } else {
        uy
    };
    let nx = if dx > 0.0 {
        ((tx - if right { c0 } else { 0.0 }) / dx).clamp(0.0, ONE_MINUS_EPS)
    } else {
        ux
    };
    (right as u32, lower as u32, nx, ny)
}

/// [`descend`] in eight lanes, with the same operations: (right, lower) as lane masks.
#[inline(always)]
fn descend_x8(p: [f32x8; 4], ux: f32x8, uy: f32x8) -> (f32x8, f32x8, f32x8, f32x8) {
    let zero = f32x8::splat(0.0);
    let (r0, r1) = (p[0] + p[1], p[2] + p[3]);
    let ty = uy * (r0 + r1);
    let lower = (ty.simd_ge(r0) & r1.simd_gt(zero)) | r0.simd_le(zero);
    let c0 = simd::sel(lower, p[2], p[0]);
    let c1 = simd::sel(lower, p[3], p[1]);
    let dy = simd::sel(lower, r1, r0);
    let tx = ux * dy;
    let right = (tx.simd_ge(c0) & c1.simd_gt(zero)) | c0.simd_le(zero);
    let dx = simd::sel(right, c1, c0);
    let ny = simd::sel(
        dy.simd_gt(zero),
        simd::clamp((ty - simd::sel(lower, r0, zero)) / dy, 0.0, ONE_MINUS_EPS),
        uy,
    );
    let nx = simd::sel(
        dx.simd_gt(zero),
        simd::clamp((tx - simd::sel(right, c0, zero)) / dx, 0.0, ONE_MINUS_EPS),
        ux,
    );
    (right, lower, nx, ny)
}

/// A piecewise-constant density on [0, 1)^2 over an `nu` x `nv` grid, sampled with
/// [`Cdf2D`].
#[derive(Clone, Debug)]
pub struct Distribution2D {
    table: Cdf2D,
    /// Cell values divided by their mean: the density of each cell.
    density: Vec<f32>,
}

impl Distribution2D {
    /// From non-negative cell values; an all-zero function becomes uniform.
    pub fn new(values: &[f32], nu: usize, nv: usize) -> Self {
        let (table, mean) = Cdf2D::new(values, nu, nv);
        let all_zero = !values.iter().any(|&v| v.is_finite() && v > 0.0);
        let density = values
            .iter()
            .map(|&v| {
                if all_zero {
                    1.0
                } else if v.is_finite() {
                    (v.max(0.0) as f64 / mean) as f32
                } else {
                    0.0
                }
            })
            .collect();
        Self { table, density }
    }

    /// Samples (u, v) in [0, 1)^2 with its density.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (nu, nv) = (self.table.nu, self.table.nv);
        let (col, row, r) = self.table.sample(u);
        let p = Vec2::new(
            (col as f32 + r.x) / nu as f32,
            (row as f32 + r.y) / nv as f32,
        );
        (
            p.min(Vec2::splat(1.0 - f32::EPSILON / 2.0)),
            self.density[row * nu + col],
        )
    }

    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        let (nu, nv) = (self.table.nu, self.table.nv);
        let col = ((p.x * nu as f32) as usize).min(nu - 1);
        let row = ((p.y * nv as f32) as usize).min(nv - 1);
        self.density[row * nu + col]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two-level search finds the same cell as a binary search, for lengths around
    /// the block size, empty runs, u at entries exactly, 0, 1 and NaN.
    #[test]
    fn two_level_search_equals_binary_search() {
        let mut h = 0x9e37_79b9_u32;
        let mut next = || {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            h
        };
        for n in [1usize, 2, 15, 16, 17, 31, 32, 33, 64, 100, 511, 512, 513] {
            for _ in 0..8 {
                let vals: Vec<f64> = (0..n)
                    .map(|_| {
                        if next() % 4 == 0 {
                            0.0
                        } else {
                            (next() % 1000) as f64
                        }
                    })
                    .collect();
                let mut cdf = Vec::new();
                cdf_into(vals.into_iter(), &mut cdf);
                let mut coarse = Vec::new();
                coarse_into(&cdf, &mut coarse);
                let mut us: Vec<f32> = cdf.clone();
                us.extend((0..200).map(|_| (next() >> 8) as f32 / 16_777_216.0));
                us.extend([0.0, 1.0, 1.0 - f32::EPSILON / 2.0, f32::NAN, -0.5, 2.0]);
                for u in us {
                    let i = cdf
                        .partition_point(|&c| c <= u)
                        .saturating_sub(1)
                        .min(n - 1);
                    let (j, r) = invert(&cdf, &coarse, u);
                    assert_eq!(i, j, "n {n}, u {u}");
                    assert!(u.is_nan() || (0.0..1.0).contains(&r), "n {n}, u {u}: r {r}");
                }
            }
        }
    }

    #[test]
    fn one_d_inverts_its_cdf() {
        let d = Distribution1D::new(&[0.0, 1.0, 3.0, 0.0]);
        assert!((d.integral() - 1.0).abs() < 1e-6);
        for k in 0..100 {
            let u = (k as f32 + 0.5) / 100.0;
            let (x, pdf, i) = d.sample(u);
            assert!(i == 1 || i == 2, "empty cells are never chosen");
            assert!((pdf - d.pdf(x)).abs() < 1e-5);
        }
        let all_zero = Distribution1D::new(&[0.0, 0.0]);
        assert!((all_zero.pdf(0.3) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn two_d_density_integrates_to_one() {
        let vals: Vec<f32> = (0..12).map(|i| (i % 5) as f32).collect();
        let d = Distribution2D::new(&vals, 4, 3);
        let n = 200;
        let mut acc = 0.0;
        for i in 0..n {
            for j in 0..n {
                acc += d.pdf(Vec2::new(
                    (i as f32 + 0.5) / n as f32,
                    (j as f32 + 0.5) / n as f32,
                ));
            }
        }
        assert!((acc / (n * n) as f32 - 1.0).abs() < 1e-3);
        // Sampled points land in proportion to the cell values.
        let mut counts = [0u32; 12];
        let m = 256;
        for i in 0..m {
            for j in 0..m {
                let (p, pdf) = d.sample(Vec2::new(
                    (i as f32 + 0.5) / m as f32,
                    (j as f32 + 0.5) / m as f32,
                ));
                assert!((pdf - d.pdf(p)).abs() < 1e-5);
                counts[(p.y * 3.0) as usize * 4 + (p.x * 4.0) as usize] += 1;
            }
        }
        let total: f32 = vals.iter().sum();
        for k in 0..12 {
            let expect = vals[k] / total * (m * m) as f32;
            assert!(
                (counts[k] as f32 - expect).abs() <= 0.01 * (m * m) as f32,
                "cell {k}: {} vs {expect}",
                counts[k]
            );
        }
    }

    /// CDF inversion is monotone: a larger u.y never picks an earlier row, a larger u.x
    /// never an earlier column of the same row, and positions within cells grow with u.
    /// This is what keeps stratified samples stratified over the cells.
    #[test]
    fn two_d_sampling_is_monotone() {
        let vals: Vec<f32> = (0..40)
            .map(|i| {
                if i % 7 == 3 {
                    0.0
                } else {
                    (i * 37 % 11) as f32
                }
            })
            .collect();
        let (t, _) = Cdf2D::new(&vals, 8, 5);
        let m = 400;
        for i in 0..m {
            let ux = (i as f32 + 0.5) / m as f32;
            let mut last = (0usize, 0.0f32);
            for j in 0..m {
                let (_, row, r) = t.sample(Vec2::new(ux, (j as f32 + 0.5) / m as f32));
                assert!((row, r.y) >= last, "row order at u = ({ux}, {j})");
                last = (row, r.y);
            }
        }
        for j in 0..m {
            let uy = (j as f32 + 0.5) / m as f32;
            let mut last = (0usize, 0.0f32);
            let row0 = t.sample(Vec2::new(0.0, uy)).1;
            for i in 0..m {
                let (col, row, r) = t.sample(Vec2::new((i as f32 + 0.5) / m as f32, uy));
                assert_eq!(row, row0);
                assert!((col, r.x) >= last, "column order at u = ({i}, {uy})");
                assert!(vals[row * 8 + col] > 0.0, "an empty cell was drawn");
                last = (col, r.x);
            }
        }
    }

    fn masses(nu: usize, nv: usize) -> Vec<f32> {
        (0..nu * nv)
            .map(|i| {
                if i % 7 == 3 {
                    0.0
                } else {
                    ((i * 7919) % 101) as f32 + 0.5
                }
            })
            .collect()
    }

    /// The hierarchical warp draws every cell with probability mass / total (a stratified
    /// grid of samples, so the counts are exact up to the grid's resolution), never an
    /// empty cell, on grids of odd and power-of-two sizes and thin ones; an all-zero grid
    /// is uniform.
    #[test]
    fn hierarchy_draws_cells_in_proportion_to_mass() {
        for (nu, nv) in [
            (1, 1),
            (2, 2),
            (5, 3),
            (1, 7),
            (7, 1),
            (8, 4),
            (13, 6),
            (16, 9),
        ] {
            for zero in [false, true] {
                let vals = if zero {
                    vec![0.0; nu * nv]
                } else {
                    masses(nu, nv)
                };
                let (t, mean) = Hierarchy2D::new(&vals, nu, nv);
                let total: f64 = if zero {
                    (nu * nv) as f64
                } else {
                    vals.iter().map(|&v| v as f64).sum()
                };
                assert!((mean * (nu * nv) as f64 - total).abs() < 1e-6 * total);
                let m = 512;
                let mut counts = vec![0u32; nu * nv];
                for i in 0..m {
                    for j in 0..m {
                        let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                        let (x, y, r) = t.sample(u);
                        assert!(
                            x < nu
                                && y < nv
                                && (0.0..1.0).contains(&r.x)
                                && (0.0..1.0).contains(&r.y)
                        );
                        counts[y * nu + x] += 1;
                    }
                }
                for k in 0..nu * nv {
                    let w = if zero { 1.0 } else { vals[k] as f64 };
                    let expect = w / total * (m * m) as f64;
                    assert!(
                        (counts[k] as f64 - expect).abs()
                            <= 0.002 * (m * m) as f64 + 2.0 * m as f64,
                        "{nu}x{nv} cell {k}: {} draws, expected {expect}",
                        counts[k]
                    );
                    if w == 0.0 {
                        assert_eq!(counts[k], 0, "{nu}x{nv}: empty cell {k} drawn");
                    }
                }
            }
        }
    }

    /// Over a uniform power-of-two grid the warp is the identity (the cell and position in
    /// it are those of u itself), so it adds no distortion to a stratified point set.
    #[test]
    fn hierarchy_of_uniform_grid_is_identity() {
        let (t, _) = Hierarchy2D::new(&[1.0; 32 * 8], 32, 8);
        for k in 0..5000 {
            let u = Vec2::new(
                (k as f32 * 0.618_034).fract(),
                (k as f32 * 0.754_878).fract(),
            );
            let (x, y, r) = t.sample(u);
            let p = Vec2::new((x as f32 + r.x) / 32.0, (y as f32 + r.y) / 8.0);
            assert!((p - u).abs().max_element() < 1e-5, "{u} -> {p}");
        }
    }

    /// Lanes give bit for bit the single-sample result, including 0, 1 and NaN input
    /// (which must not panic).
    #[test]
    fn hierarchy_lanes_equal_single_samples() {
        let vals = masses(37, 19);
        let (t, _) = Hierarchy2D::new(&vals, 37, 19);
        for k in 0..300 {
            let u: [Vec2; 8] = std::array::from_fn(|i| {
                let j = (k * 8 + i) as f32;
                match k {
                    0 => Vec2::new(i as f32 / 7.0, 1.0 - i as f32 / 7.0),
                    1 => Vec2::new(f32::NAN, i as f32 / 8.0),
                    _ => Vec2::new((j * 0.618_034).fract(), (j * 0.754_878).fract()),
                }
            });
            let (cx, cy, fx, fy) =
                t.sample_x8(f32x8::new(u.map(|v| v.x)), f32x8::new(u.map(|v| v.y)));
            let (cx, cy, fx, fy) = (cx.to_array(), cy.to_array(), fx.to_array(), fy.to_array());
            for i in 0..8 {
                let lane = (cx[i] as usize, cy[i] as usize, Vec2::new(fx[i], fy[i]));
                assert_eq!(format!("{lane:?}"), format!("{:?}", t.sample(u[i])));
                assert!(vals[lane.1 * 37 + lane.0] > 0.0 || u[i].is_nan());
            }
        }
    }
}
