//! The linear part of the fit (Ngan et al. 2005, section 3.3): for fixed lobe shapes, the
//! colours that minimize Eq. (1) solve, per channel, a non-negative linear least-squares
//! problem in at most three unknowns (diffuse and one or two specular colours). With so few
//! unknowns the exact solution is found by solving the normal equations on every subset of
//! active variables and keeping the best feasible one (the Karush-Kuhn-Tucker point).
//! A colour above [`MAX_COLOUR`] is not feasible either: it is a lobe whose peak no bin
//! samples, scaled up until its far tail reaches the data (seen: a Lafortune lobe of
//! colour 1e34 on 4-degree bins), which no renderer or report should get.

/// The largest colour the solve returns (normalized lobes' colours are their albedo, below
/// a few units; lobe refuses a material colour above 1e12).
pub const MAX_COLOUR: f64 = 1e6;

/// Normal equations of one channel: A x = b with the constant c = sum w R^2 cos^2.
#[derive(Clone, Copy, Debug, Default)]
pub struct Gram {
    pub n: usize,
    pub a: [[f64; 3]; 3],
    pub b: [f64; 3],
    pub c: f64,
}

impl Gram {
    /// The normal equations of `n` unknowns (at most 3).
    pub fn new(n: usize) -> Self {
        assert!(n <= 3, "a Gram of {n} unknowns; at most 3");
        Self {
            n,
            ..Default::default()
        }
    }

    /// Adds one sample: basis values `f` (at least n of them; n at most 3), target `r`,
    /// weight `w`.
    #[inline]
    pub fn add(&mut self, f: &[f64], r: f64, w: f64) {
        let mut basis = [0.0; 3];
        basis[..self.n].copy_from_slice(&f[..self.n]);
        match self.n {
            0 => self.accumulate::<0>(&basis, r, w),
            1 => self.accumulate::<1>(&basis, r, w),
            2 => self.accumulate::<2>(&basis, r, w),
            _ => self.accumulate::<3>(&basis, r, w),
        }
    }

    /// Adds samples (basis values, of which the first n count; target; weight) in order:
    /// the sums of [`Gram::add`] one sample at a time, kept in a local copy for the run
    /// (the compiler holds it in registers: with a fixed count no sum goes through memory,
    /// where a masked store would keep the next sample's load waiting).
    pub fn add_all(&mut self, samples: impl IntoIterator<Item = ([f64; 3], f64, f64)>) {
        debug_assert!(self.n <= 3, "a Gram of {} unknowns; at most 3", self.n);
        match self.n {
            0 => self.accumulate_all::<0>(samples),
            1 => self.accumulate_all::<1>(samples),
            2 => self.accumulate_all::<2>(samples),
            _ => self.accumulate_all::<3>(samples),
        }
    }

    /// [`Gram::add_all`] of a Gram of `N` unknowns.
    #[inline(always)]
    fn accumulate_all<const N: usize>(
        &mut self,
        samples: impl IntoIterator<Item = ([f64; 3], f64, f64)>,
    ) {
        let mut sums = *self;
        for (f, r, w) in samples {
            sums.accumulate::<N>(&f, r, w);
        }
        *self = sums;
    }

    /// The normal equations' terms of one sample, for `N` unknowns.
    #[inline(always)]
    fn accumulate<const N: usize>(&mut self, f: &[f64; 3], r: f64, w: f64) {
        for j in 0..N {
            self.b[j] += w * f[j] * r;
            for k in 0..N {
                self.a[j][k] += w * f[j] * f[k];
            }
        }
        self.c += w * r * r;
    }

    pub fn merge(mut self, o: &Gram) -> Gram {
        for j in 0..self.n {
            self.b[j] += o.b[j];
            for k in 0..self.n {
                self.a[j][k] += o.a[j][k];
            }
        }
        self.c += o.c;
        self
    }

    /// The non-negative minimizer and the residual sum w (r - f.x)^2.
    pub fn solve_nonnegative(&self) -> ([f64; 3], f64) {
        let mut best = ([0.0; 3], self.c.max(0.0));
        for mask in 1u32..(1 << self.n) {
            let idx: Vec<usize> = (0..self.n).filter(|&j| mask & (1 << j) != 0).collect();
            let m = idx.len();
            // Gaussian elimination with partial pivoting on the m x m subsystem.
            let mut mat = [[0.0f64; 4]; 3];
            for (r, &j) in idx.iter().enumerate() {
                for (s, &k) in idx.iter().enumerate() {
                    mat[r][s] = self.a[j][k];
                }
                mat[r][m] = self.b[j];
            }
            let mut ok = true;
            for col in 0..m {
                let piv = (col..m)
                    .max_by(|&x, &y| mat[x][col].abs().total_cmp(&mat[y][col].abs()))
                    .expect("non-empty");
                if mat[piv][col].abs() < 1e-300 {
                    ok = false;
                    break;
                }
                mat.swap(col, piv);
                let pivot_row = mat[col];
                for (r, row) in mat.iter_mut().enumerate().take(m) {
                    if r != col {
                        let f = row[col] / pivot_row[col];
                        for (x, p) in row.iter_mut().zip(pivot_row).skip(col).take(m + 1 - col) {
                            *x -= f * p;
                        }
                    }
                }
            }
            if !ok {
                continue;
            }
            let mut x = [0.0f64; 3];
            for (r, &j) in idx.iter().enumerate() {
                x[j] = mat[r][m] / mat[r][r];
            }
            if idx.iter().any(|&j| !(x[j] >= 0.0 && x[j] <= MAX_COLOUR)) {
                continue;
            }
            // Residual at the subset optimum: c - b.x.
            let res = (self.c - idx.iter().map(|&j| self.b[j] * x[j]).sum::<f64>()).max(0.0);
            if res < best.1 {
                best = (x, res);
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_non_negative_coefficients() {
        // r = 2 f0 + 0.5 f1 exactly.
        let mut g = Gram::new(2);
        for k in 0..50 {
            let f = [1.0, (k as f64 * 0.3).sin().abs()];
            g.add(&f, 2.0 * f[0] + 0.5 * f[1], 1.0 + k as f64 * 0.01);
        }
        let (x, res) = g.solve_nonnegative();
        assert!((x[0] - 2.0).abs() < 1e-9 && (x[1] - 0.5).abs() < 1e-9 && res < 1e-12);
        // A target that wants a negative coefficient gets zero for it.
        let mut g = Gram::new(2);
        for k in 0..50 {
            let f = [1.0, k as f64 / 50.0];
            g.add(&f, 1.0 - f[1], 1.0);
        }
        let (x, _) = g.solve_nonnegative();
        assert!(x[1] == 0.0 && x[0] > 0.0);
        // A basis function that only reaches the target when scaled beyond MAX_COLOUR
        // (a lobe whose peak no sample sees) is left out.
        let mut g = Gram::new(2);
        for k in 0..50 {
            let f = [1.0, 1e-30 * (k as f64 + 1.0)];
            g.add(&f, 1.0 + 0.02 * (k as f64 + 1.0), 1.0);
        }
        let (x, res) = g.solve_nonnegative();
        assert!(x[1] == 0.0 && x[0] > 1.0 && res > 0.0, "{x:?}");
    }

    /// `add_all` and `add` are the sums of the normal equations' terms in sample order, bit
    /// for bit, for every count of unknowns.
    #[test]
    fn sums_are_the_terms_in_sample_order() {
        let sample = |k: usize| {
            let t = k as f64;
            (
                [(t * 0.7).sin(), 1.0 / (1.0 + t), (t * 0.13).cos() * 1e3],
                t.sqrt() - 2.0,
                0.5 + t,
            )
        };
        for n in 0..=3 {
            let (mut a, mut b, mut c) = ([[0.0f64; 3]; 3], [0.0f64; 3], 0.0f64);
            for (f, r, w) in (0..200).map(sample) {
                for j in 0..n {
                    b[j] += w * f[j] * r;
                    for k in 0..n {
                        a[j][k] += w * f[j] * f[k];
                    }
                }
                c += w * r * r;
            }
            let (mut all, mut one) = (Gram::new(n), Gram::new(n));
            all.add_all((0..200).map(sample));
            (0..200)
                .map(sample)
                .for_each(|(f, r, w)| one.add(&f[..n], r, w));
            for g in [all, one] {
                let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&g.a.concat()), bits(&a.concat()), "n {n}");
                assert_eq!(bits(&g.b), bits(&b), "n {n}");
                assert_eq!(g.c.to_bits(), c.to_bits(), "n {n}");
            }
        }
    }

    #[test]
    #[should_panic(expected = "at most 3")]
    fn a_fourth_unknown_is_refused() {
        Gram::new(4);
    }
}
