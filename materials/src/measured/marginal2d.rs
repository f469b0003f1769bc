//! A parameterized, piecewise-bilinear 2D distribution on [0, 1]^2 (the continuous
//! `Marginal2D` of Mitsuba 3's `distr_2d.h`, after Jakob, "An Improved Visible Normal
//! Sampling Routine for the Beckmann Distribution"/Dupuy and Jakob 2018): a grid of
//! `w` x `h` nodes at u = (x / (w - 1), y / (h - 1)) per slice of its parameters, the
//! density bilinear between nodes and linearly interpolated between parameter slices.
//! Sampling inverts a marginal CDF over rows and a conditional CDF within the row, both
//! exact for the bilinear interpolant (trapezoids accumulated in f64), so `sample`,
//! `invert` and `eval` agree.

/// The distribution of one table (with `sampling`, normalized to integrate to one per slice).
#[derive(Clone, Debug)]
pub struct Marginal2D {
    w: usize,
    h: usize,
    params: Vec<Vec<f32>>,
    strides: Vec<usize>,
    data: Vec<f32>,
    cond: Vec<f32>,
    marg: Vec<f32>,
}

/// Parameter blend: slice offset and per-parameter weights.
struct Blend {
    offset: usize,
    weights: Vec<(f32, f32)>,
}

impl Marginal2D {
    pub fn memory_bytes(&self) -> usize {
        (self.data.len() + self.cond.len() + self.marg.len()) * 4
    }

    /// `data` holds the slices (last parameter fastest), each `h` rows of `w` values.
    /// With `sampling`, each slice is normalized and its CDFs built.
    pub fn new(data: &[f32], w: usize, h: usize, params: Vec<Vec<f32>>, sampling: bool) -> Self {
        assert!(w >= 2 && h >= 2);
        let mut strides = vec![0usize; params.len()];
        let mut s = 1usize;
        for d in (0..params.len()).rev() {
            strides[d] = if params[d].len() > 1 { s } else { 0 };
            s *= params[d].len();
        }
        let slices = params.iter().map(|p| p.len()).product::<usize>().max(1);
        assert_eq!(data.len(), slices * w * h);
        let mut out = Self {
            w,
            h,
            params,
            strides,
            data: data.to_vec(),
            cond: Vec::new(),
            marg: Vec::new(),
        };
        if sampling {
            out.cond = vec![0.0; slices * h * (w - 1)];
            out.marg = vec![0.0; slices * (h - 1)];
            for sl in 0..slices {
                let d = &data[sl * w * h..(sl + 1) * w * h];
                let mut rows = vec![0.0f64; h];
                for y in 0..h {
                    let mut acc = 0.0f64;
                    for x in 0..w - 1 {
                        acc +=
                            0.5 / (w - 1) as f64 * (d[y * w + x] as f64 + d[y * w + x + 1] as f64);
                        out.cond[sl * h * (w - 1) + y * (w - 1) + x] = acc as f32;
                    }
                    rows[y] = acc;
                }
                let mut acc = 0.0f64;
                for y in 0..h - 1 {
                    acc += 0.5 / (h - 1) as f64 * (rows[y] + rows[y + 1]);
                    out.marg[sl * (h - 1) + y] = acc as f32;
                }
                let norm = if acc > 0.0 { (1.0 / acc) as f32 } else { 0.0 };
                for v in &mut out.cond[sl * h * (w - 1)..(sl + 1) * h * (w - 1)] {
                    *v *= norm;
                }
                for v in &mut out.marg[sl * (h - 1)..(sl + 1) * (h - 1)] {
                    *v *= norm;
                }
                for v in &mut out.data[sl * w * h..(sl + 1) * w * h] {
                    *v *= norm;
                }
            }
        }
        out
    }

    fn blend(&self, p: &[f32]) -> Blend {
        let mut offset = 0;
        let mut weights = Vec::with_capacity(self.params.len());
        for (d, vals) in self.params.iter().enumerate() {
            let n = vals.len();
            if n <= 1 {
                weights.push((1.0, 0.0));
                continue;
            }
            let x = p[d];
            let mut i = n - 1;
            for (k, &v) in vals.iter().enumerate().skip(1) {
                if v >= x {
                    i = k;
                    break;
                }
            }
            let i = i - 1;
            let t = ((x - vals[i]) / (vals[i + 1] - vals[i])).clamp(0.0, 1.0);
            weights.push((1.0 - t, t));
            offset += self.strides[d] * i;
        }
        Blend { offset, weights }
    }

    /// Value of `arr` (per-slice size `n`) at local index `i`, blended over the parameters.
    fn lookup(&self, arr: &[f32], n: usize, b: &Blend, i: usize) -> f32 {
        fn rec(m: &Marginal2D, arr: &[f32], n: usize, b: &Blend, d: usize, i: usize) -> f32 {
            if d == 0 {
                return arr[b.offset * n + i];
            }
            let (w0, w1) = b.weights[d - 1];
            let s = m.strides[d - 1];
            let a = rec(m, arr, n, b, d - 1, i);
            if w1 == 0.0 || s == 0 {
                return a * w0;
            }
            let c = rec(m, arr, n, b, d - 1, i + s * n);
            a.mul_add(w0, c * w1)
        }
        rec(self, arr, n, b, self.params.len(), i)
    }

    #[inline]
    fn lerp(a: f32, b: f32, t: f32) -> f32 {
        b.mul_add(t, (-a).mul_add(t, a))
    }

    /// The (normalized) density at u.
    pub fn eval(&self, u: [f32; 2], p: &[f32]) -> f32 {
        let b = self.blend(p);
        let (w, h) = (self.w, self.h);
        let px = u[0].clamp(0.0, 1.0) * (w - 1) as f32;
        let py = u[1].clamp(0.0, 1.0) * (h - 1) as f32;
        let ox = (px as usize).min(w - 2);
        let oy = (py as usize).min(h - 2);
        let (fx, fy) = (px - ox as f32, py - oy as f32);
        let i = oy * w + ox;
        let n = w * h;
        let v00 = self.lookup(&self.data, n, &b, i);
        let v10 = self.lookup(&self.data, n, &b, i + 1);
        let v01 = self.lookup(&self.data, n, &b, i + w);
        let v11 = self.lookup(&self.data, n, &b, i + w + 1);
        Self::lerp(Self::lerp(v00, v10, fx), Self::lerp(v01, v11, fx), fy)
    }

    fn sample_segment(u: f32, inv_w: f32, v0: f32, v1: f32) -> f32 {
        let nonconst = (v0 - v1).abs() > 1e-4 * (v0 + v1);
        let div = if nonconst { v0 - v1 } else { v0 + v1 };
        let mut u = u * 2.0 * inv_w;
        if nonconst {
            u = v0 - (v0 * v0 + u * (v1 - v0)).max(0.0).sqrt();
        }
        if div != 0.0 { u / div } else { u }
    }

    /// Warps a uniform sample to the distribution: (u, density).
    pub fn sample(&self, xi: [f32; 2], p: &[f32]) -> ([f32; 2], f32) {
        let b = self.blend(p);
        let (w, h) = (self.w, self.h);
        let eps = f32::EPSILON / 2.0;
        let (mut x, mut y) = (xi[0].clamp(eps, 1.0 - eps), xi[1].clamp(eps, 1.0 - eps));
        let nm = h - 1;
        let nc = h * (w - 1);
        // Row: first r with marg[r] >= y.
        let mut row = h - 2;
        for r in 0..h - 1 {
            if self.lookup(&self.marg, nm, &b, r) >= y {
                row = r;
                break;
            }
        }
        if row > 0 {
            y -= self.lookup(&self.marg, nm, &b, row - 1);
        }
        let r0 = self.lookup(&self.cond, nc, &b, row * (w - 1) + w - 2);
        let r1 = self.lookup(&self.cond, nc, &b, (row + 1) * (w - 1) + w - 2);
        let ty = Self::sample_segment(y, (h - 1) as f32, r0, r1);
        x *= Self::lerp(r0, r1, ty);
        let c = |k: usize| {
            Self::lerp(
                self.lookup(&self.cond, nc, &b, row * (w - 1) + k),
                self.lookup(&self.cond, nc, &b, (row + 1) * (w - 1) + k),
                ty,
            )
        };
        let mut col = w - 2;
        for k in 0..w - 1 {
            if c(k) >= x {
                col = k;
                break;
            }
        }
        if col > 0 {
            x -= c(col - 1);
        }
        let n = w * h;
        let i = row * w + col;
        let v00 = self.lookup(&self.data, n, &b, i);
        let v10 = self.lookup(&self.data, n, &b, i + 1);
        let v01 = self.lookup(&self.data, n, &b, i + w);
        let v11 = self.lookup(&self.data, n, &b, i + w + 1);
        let c0 = Self::lerp(v00, v01, ty);
        let c1 = Self::lerp(v10, v11, ty);
        let tx = Self::sample_segment(x, (w - 1) as f32, c0, c1);
        let inv = [1.0 / (w - 1) as f32, 1.0 / (h - 1) as f32];
        (
            [(col as f32 + tx) * inv[0], (row as f32 + ty) * inv[1]],
            Self::lerp(c0, c1, tx),
        )
    }

    /// The uniform sample that `sample` maps to u, and the density at u.
    pub fn invert(&self, u: [f32; 2], p: &[f32]) -> ([f32; 2], f32) {
        let b = self.blend(p);
        let (w, h) = (self.w, self.h);
        let ux = u[0].clamp(0.0, 1.0) * (w - 1) as f32;
        let uy = u[1].clamp(0.0, 1.0) * (h - 1) as f32;
        let px = (ux as usize).min(w - 2);
        let py = (uy as usize).min(h - 2);
        let (fx, fy) = (ux - px as f32, uy - py as f32);
        let n = w * h;
        let i = py * w + px;
        let v00 = self.lookup(&self.data, n, &b, i);
        let v10 = self.lookup(&self.data, n, &b, i + 1);
        let v01 = self.lookup(&self.data, n, &b, i + w);
        let v11 = self.lookup(&self.data, n, &b, i + w + 1);
        let c0 = Self::lerp(v00, v01, fy);
        let c1 = Self::lerp(v10, v11, fy);
        let pdf = Self::lerp(c0, c1, fx);
        let nc = h * (w - 1);
        let nm = h - 1;
        let mut x = fx * Self::lerp(c0, c1, 0.5 * fx) * (1.0 / (w - 1) as f32);
        if px > 0 {
            x += Self::lerp(
                self.lookup(&self.cond, nc, &b, py * (w - 1) + px - 1),
                self.lookup(&self.cond, nc, &b, (py + 1) * (w - 1) + px - 1),
                fy,
            );
        }
        let r0 = self.lookup(&self.cond, nc, &b, py * (w - 1) + w - 2);
        let r1 = self.lookup(&self.cond, nc, &b, (py + 1) * (w - 1) + w - 2);
        let rl = Self::lerp(r0, r1, fy);
        if rl > 0.0 {
            x /= rl;
        }
        let mut y = fy * Self::lerp(r0, r1, 0.5 * fy) * (1.0 / (h - 1) as f32);
        if py > 0 {
            y += self.lookup(&self.marg, nm, &b, py - 1);
        }
        ([x, y], pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_invert_and_eval_agree() {
        // Two parameter slices of a 5 x 4 table.
        let mut data = Vec::new();
        for s in 0..2 {
            for y in 0..4 {
                for x in 0..5 {
                    data.push(1.0 + (x * (s + 1)) as f32 + (y * y) as f32 * 0.5);
                }
            }
        }
        let m = Marginal2D::new(&data, 5, 4, vec![vec![0.0, 1.0]], true);
        for k in 0..200 {
            let xi = [
                ((k as f32) * 0.618_034).fract(),
                ((k as f32) * 0.414_213).fract(),
            ];
            let p = [((k as f32) * 0.1).fract()];
            let (u, pdf) = m.sample(xi, &p);
            let (xi2, pdf2) = m.invert(u, &p);
            assert!(
                (xi2[0] - xi[0]).abs() < 1e-4 && (xi2[1] - xi[1]).abs() < 1e-4,
                "{xi:?} -> {u:?} -> {xi2:?}"
            );
            assert!((pdf - pdf2).abs() < 1e-4 * pdf && (pdf - m.eval(u, &p)).abs() < 1e-4 * pdf);
        }
        // The density integrates to one.
        let n = 400;
        let mut acc = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                acc += m.eval(
                    [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32],
                    &[0.3],
                ) as f64;
            }
        }
        assert!((acc / (n * n) as f64 - 1.0).abs() < 1e-3);
    }
}
