//! Piecewise-constant 1D and 2D distributions for importance sampling (the inversion
//! method; pbrt-v4 `PiecewiseConstant1D/2D`, Mitsuba `DiscreteDistribution2D`), written
//! from the textbook construction: a CDF per row and a marginal CDF over rows.

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
        let du = if width > 0.0 { (u - self.cdf[i]) / width } else { 0.5 };
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

/// A piecewise-constant density on [0, 1)^2 over an `nu` x `nv` grid (row-major, v rows).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    pub fn new(values: &[f32], nu: usize, nv: usize) -> Self {
        assert_eq!(values.len(), nu * nv);
        let conditional: Vec<_> = (0..nv)
            .map(|v| Distribution1D::new(&values[v * nu..(v + 1) * nu]))
            .collect();
        let row_integrals: Vec<f32> = (0..nv)
            .map(|v| {
                values[v * nu..(v + 1) * nu]
                    .iter()
                    .map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 })
                    .sum::<f32>()
                    / nu as f32
            })
            .collect();
        Self {
            conditional,
            marginal: Distribution1D::new(&row_integrals),
        }
    }

    /// Samples (u, v) in [0, 1)^2 with its density.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pdf_v, row) = self.marginal.sample(u.y);
        let (x, pdf_u, _) = self.conditional[row].sample(u.x);
        (Vec2::new(x, v), pdf_v * pdf_u)
    }

    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        let nv = self.conditional.len();
        let row = ((p.y * nv as f32) as usize).min(nv - 1);
        self.marginal.pdf(p.y) * self.conditional[row].pdf(p.x)
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
                acc += d.pdf(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
            }
        }
        assert!((acc / (n * n) as f32 - 1.0).abs() < 1e-3);
    }
}
