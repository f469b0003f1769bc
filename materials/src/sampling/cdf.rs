//! Discrete distributions sampled by CDF inversion, monotone in `u` so that
//! low-discrepancy samples keep their stratification: [`Discrete1D`] picks one of `n`
//! cells in proportion to its value (the discrete half of pbrt-v4's
//! `PiecewiseConstant1D`; area-light triangle selection), and [`Cdf2D`] picks a cell of a
//! 2D grid by a marginal CDF over rows and a conditional CDF within the row (pbrt-v4's
//! `PiecewiseConstant2D`; the tabulated samplers of measured BRDFs). Both invert their
//! CDFs with the same two-level search ([`invert`]).

use glam::Vec2;

/// A discrete distribution over `n` cells, each drawn with probability proportional to
/// its value.
#[derive(Clone, Debug)]
pub struct Discrete1D {
    /// n + 1 entries, 0 to 1 (uniform for all-zero values).
    cdf: Vec<f32>,
    /// Block summary of `cdf` for [`invert`] (see [`coarse_into`]).
    coarse: Vec<f32>,
}

impl Discrete1D {
    /// From non-negative cell values (negative and non-finite ones count as zero). An
    /// all-zero (or empty) list becomes uniform (a single cell when empty).
    pub fn new(values: &[f32]) -> Self {
        let mut cdf = Vec::with_capacity(values.len().max(1) + 1);
        if values.is_empty() {
            cdf_into([0.0f64].into_iter(), &mut cdf);
        } else {
            cdf_into(values.iter().map(|&v| v as f64), &mut cdf);
        }
        let mut coarse = Vec::new();
        coarse_into(&cdf, &mut coarse);
        Self { cdf, coarse }
    }

    /// Picks a cell with probability proportional to its value: (index, probability,
    /// `u` rescaled to [0, 1) within the cell, for reuse).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let (i, ur) = invert(&self.cdf, &self.coarse, u);
        (i, self.cdf[i + 1] - self.cdf[i], ur)
    }
}

/// Sampling of the cells of an `nu` x `nv` grid (row-major, v rows) in proportion to their
/// values by CDF inversion: the row from the marginal CDF, then the column from that row's
/// conditional CDF (pbrt-v4's `PiecewiseConstant2D`, Mitsuba 3's `DiscreteDistribution2D`).
/// The map from `u` to the cell and the position within it is monotone in each coordinate,
/// so stratified and low-discrepancy samples stay stratified over the cells (Walker's alias
/// method, O(1) but scattering neighbouring `u` over distant cells, cost 4.6x the image
/// MSE of env-map renders at 64 spp; docs/performance.md). The density is left to the
/// caller.
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

    /// Cells are drawn in proportion to their values, never an empty one, with their
    /// probability; all-zero and empty lists are uniform.
    #[test]
    fn discrete_draws_cells_in_proportion() {
        let vals = [0.0, 1.0, 3.0, 0.0];
        let d = Discrete1D::new(&vals);
        let m = 1000;
        let mut counts = [0u32; 4];
        for k in 0..m {
            let u = (k as f32 + 0.5) / m as f32;
            let (i, p, ur) = d.sample(u);
            assert!(
                (p - vals[i] / 4.0).abs() < 1e-6,
                "cell {i}: probability {p}"
            );
            assert!((0.0..1.0).contains(&ur));
            counts[i] += 1;
        }
        assert_eq!(counts, [0, 250, 750, 0]);
        let all_zero = Discrete1D::new(&[0.0, 0.0]);
        assert_eq!(all_zero.sample(0.3), (0, 0.5, 0.6));
        assert_eq!(Discrete1D::new(&[]).sample(0.3), (0, 1.0, 0.3));
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
}
