//! Discrete and piecewise-constant distributions for importance sampling: a 1D
//! distribution by CDF inversion (the textbook construction of pbrt-v4's
//! `PiecewiseConstant1D`), Walker's alias method (Vose's construction) for O(1) sampling of
//! cells, and 2D grids sampled row by row with alias tables. Used by environment maps and
//! by the tabulated samplers of measured BRDFs.

use glam::Vec2;

/// A piecewise-constant density on [0, 1) with `n` equal cells.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
}

impl Distribution1D {
    /// From non-negative cell values. An all-zero (or empty) function becomes uniform.
    pub fn new(values: &[f32]) -> Self {
        let n = values.len().max(1);
        let mut func: Vec<f32> = values
            .iter()
            .map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 })
            .collect();
        if func.is_empty() {
            func.push(0.0);
        }
        let mut cdf = vec![0.0f32; n + 1];
        let mut acc = 0.0f64;
        for i in 0..n {
            acc += func[i] as f64 / n as f64;
            cdf[i + 1] = acc as f32;
        }
        let integral = acc as f32;
        if integral > 0.0 {
            for c in &mut cdf[1..] {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
            func.iter_mut().for_each(|f| *f = 1.0);
        }
        cdf[n] = 1.0;
        Self {
            func,
            cdf,
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
        // Last cell whose CDF start is <= u, skipping empty cells.
        let i = (self.cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            (u - self.cdf[i]) / width
        } else {
            0.5
        };
        let x = ((i as f32 + du.clamp(0.0, 1.0)) / n as f32).min(1.0 - f32::EPSILON / 2.0);
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
        let n = self.func.len();
        let i = (self.cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1);
        let p = self.cdf[i + 1] - self.cdf[i];
        let ur = if p > 0.0 {
            ((u - self.cdf[i]) / p).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.5
        };
        (i, p, ur)
    }

    /// Probability of cell i.
    pub fn cell_probability(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }
}

/// Walker's alias method (Vose's O(n) construction) over several rows of `n` cells
/// stored flat: picks cell i of a row with probability proportional to its weight in
/// O(1) and one memory access, and returns the sample rescaled within the cell.
#[derive(Clone, Debug)]
pub struct AliasTable {
    n: usize,
    /// Per cell: probability of keeping it (rather than jumping to its alias), alias.
    entries: Vec<(f32, u32)>,
}

impl AliasTable {
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.entries.len() * std::mem::size_of::<(f32, u32)>()
    }

    /// One row from non-negative weights (all zero: uniform).
    pub fn new(weights: &[f32]) -> Self {
        Self::rows(weights, weights.len().max(1))
    }

    /// Rows of `n` cells each, from row-major non-negative weights; an all-zero row is
    /// uniform.
    pub fn rows(weights: &[f32], n: usize) -> Self {
        let mut entries = Vec::with_capacity(weights.len());
        for row in weights.chunks(n) {
            let sum: f64 = row
                .iter()
                .map(|&w| {
                    if w.is_finite() {
                        w.max(0.0) as f64
                    } else {
                        0.0
                    }
                })
                .sum();
            let mut scaled: Vec<f64> = if sum > 0.0 {
                row.iter()
                    .map(|&w| {
                        if w.is_finite() {
                            w.max(0.0) as f64 * n as f64 / sum
                        } else {
                            0.0
                        }
                    })
                    .collect()
            } else {
                vec![1.0; n]
            };
            let base = entries.len();
            entries.extend((0..n as u32).map(|i| (1.0f32, i)));
            let (mut small, mut large): (Vec<usize>, Vec<usize>) =
                (0..n).partition(|&i| scaled[i] < 1.0);
            while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
                entries[base + s] = (scaled[s] as f32, l as u32);
                scaled[l] -= 1.0 - scaled[s];
                if scaled[l] < 1.0 {
                    large.pop();
                    small.push(l);
                }
            }
            // Leftovers (rounding) keep themselves with probability 1.
        }
        Self { n, entries }
    }

    /// (cell within `row`, u rescaled to [0, 1) within the choice).
    #[inline]
    pub fn sample_row(&self, row: usize, u: f32) -> (usize, f32) {
        let n = self.n;
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        let frac = (x - i as f32).clamp(0.0, 1.0);
        let (k, alias) = self.entries[row * n + i];
        if frac < k {
            (i, (frac / k).min(1.0 - f32::EPSILON / 2.0))
        } else {
            (
                alias as usize,
                ((frac - k) / (1.0 - k)).clamp(0.0, 1.0 - f32::EPSILON / 2.0),
            )
        }
    }

    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        self.sample_row(0, u)
    }
}

/// O(1) sampling of the cells of an `nu` x `nv` grid (row-major, v rows) in proportion
/// to their values: an alias table over rows, then one over the cells of the row. The
/// density is left to the caller (see [`Distribution2D`]).
#[derive(Clone, Debug)]
pub struct Alias2D {
    pub nu: usize,
    pub nv: usize,
    rows: AliasTable,
    cols: AliasTable,
}

impl Alias2D {
    pub fn memory_bytes(&self) -> usize {
        self.rows.memory_bytes() + self.cols.memory_bytes()
    }

    /// From non-negative cell values (an all-zero grid is uniform). Returns the table and
    /// the mean cell value (1 for an all-zero grid).
    pub fn new(values: &[f32], nu: usize, nv: usize) -> (Self, f64) {
        assert_eq!(values.len(), nu * nv);
        let clean = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
        let row_sums: Vec<f32> = values
            .chunks(nu)
            .map(|r| r.iter().map(|&v| clean(v) as f64).sum::<f64>() as f32)
            .collect();
        let mean = row_sums.iter().map(|&v| v as f64).sum::<f64>() / (nu * nv) as f64;
        let t = Self {
            nu,
            nv,
            rows: AliasTable::new(&row_sums),
            cols: AliasTable::rows(values, nu),
        };
        (t, if mean > 0.0 { mean } else { 1.0 })
    }

    /// (column, row, position within the cell in [0, 1)^2).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (usize, usize, Vec2) {
        let (row, ry) = self.rows.sample(u.y);
        let (col, rx) = self.cols.sample_row(row, u.x);
        (col, row, Vec2::new(rx, ry))
    }
}

/// A piecewise-constant density on [0, 1)^2 over an `nu` x `nv` grid, sampled with
/// [`Alias2D`].
#[derive(Clone, Debug)]
pub struct Distribution2D {
    table: Alias2D,
    /// Cell values divided by their mean: the density of each cell.
    density: Vec<f32>,
}

impl Distribution2D {
    /// From non-negative cell values; an all-zero function becomes uniform.
    pub fn new(values: &[f32], nu: usize, nv: usize) -> Self {
        let (table, mean) = Alias2D::new(values, nu, nv);
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

    #[test]
    fn alias_table_matches_weights() {
        let w = [1.0, 0.0, 5.0, 2.0];
        let t = AliasTable::new(&w);
        let mut c = [0u32; 4];
        let n = 80000;
        for k in 0..n {
            let (i, r) = t.sample((k as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&r));
            c[i] += 1;
        }
        for i in 0..4 {
            assert!((c[i] as f32 / n as f32 - w[i] / 8.0).abs() < 1e-3, "{c:?}");
        }
    }
}
