//! A parameterized, piecewise-bilinear 2D distribution on [0, 1]^2 (the continuous
//! `Marginal2D` of Mitsuba 3's `distr_2d.h`, after Jakob, "An Improved Visible Normal
//! Sampling Routine for the Beckmann Distribution"/Dupuy and Jakob 2018): a grid of
//! `w` x `h` nodes at u = (x / (w - 1), y / (h - 1)) per slice of its parameters, the
//! density bilinear between nodes and linearly interpolated between parameter slices.
//! Sampling inverts a marginal CDF over rows and a conditional CDF within the row, both
//! exact for the bilinear interpolant (trapezoids accumulated in f64), so `sample`,
//! `invert` and `eval` agree.
//!
//! As in Mitsuba, a query first finds its parameter slices and their weights once
//! ([`Marginal2D::slices`], Mitsuba's `interpolate_weights`), and every table read of the
//! query then blends those slices with a fixed number of fused multiply-adds
//! ([`Slices::at`]); the CDFs are inverted by binary search. Queries that share their
//! parameters and parameter grid (the RGL tables of one `wo`) share one [`Slices`].
//! A table may hold several values per node (`channels`: the RGL colour table keeps r, g
//! and b of a node side by side, so that one patch lookup reads all three).

use crate::math::{Num, abs, clamp, eq, gt, lt, maximum, mul_add, select, sqrt};

/// At most this many parameters take part in the interpolation (parameters with a single
/// value select their slice and cost nothing).
pub const MAX_PARAMS: usize = 2;

/// The distribution of one table (with `sampling`, normalized to integrate to one per slice).
#[derive(Clone, Debug)]
pub struct Marginal2D {
    w: usize,
    h: usize,
    channels: usize,
    params: Vec<Vec<f32>>,
    strides: Vec<usize>,
    data: Vec<f32>,
    cond: Vec<f32>,
    marg: Vec<f32>,
}

/// The parameter slices a query reads and their weights: the first slice, and per
/// interpolated parameter (in parameter order) its stride in slices and its weights
/// (1 - t, t). Found once per query by [`Marginal2D::slices`]; over [`Num`], for one
/// query (f32) or one query per lane.
#[derive(Clone, Copy, Debug)]
pub struct Slices<T: Num> {
    first: T::Int,
    dims: usize,
    stride: [i32; MAX_PARAMS],
    weight: [(T, T); MAX_PARAMS],
}

impl<T: Num> Slices<T> {
    /// The only slice of a table without parameters.
    pub fn none() -> Self {
        Self {
            first: T::int(0),
            dims: 0,
            stride: [0; MAX_PARAMS],
            weight: [(T::of(1.0), T::of(0.0)); MAX_PARAMS],
        }
    }

    /// Entry `i` of a table `arr` of `n` entries per slice, blended over the slices as
    /// Mitsuba's `lookup` does: the last parameter outermost, `fmadd(v0, w0, v1 * w1)`.
    #[inline(always)]
    pub fn at(&self, arr: &[f32], n: usize, i: T::Int) -> T {
        let n = n as i32;
        let b = self.first * T::int(n) + i;
        match self.dims {
            0 => T::gather(arr, b),
            1 => self.inner(arr, n, b),
            _ => {
                let (w0, w1) = self.weight[1];
                let far = self.inner(arr, n, b + T::int(self.stride[1] * n));
                mul_add(self.inner(arr, n, b), w0, far * w1)
            }
        }
    }

    /// [`Slices::at`] of the four entries `i..i + 4` (a node of a four-channel table): in
    /// lanes one 16-byte load per lane and slice, transposed, instead of four gathers.
    #[inline(always)]
    pub fn at4(&self, arr: &[f32], n: usize, i: T::Int) -> [T; 4] {
        let n = n as i32;
        let b = self.first * T::int(n) + i;
        match self.dims {
            0 => T::gather4(arr, b),
            1 => self.inner4(arr, n, b),
            _ => {
                let (w0, w1) = self.weight[1];
                let near = self.inner4(arr, n, b);
                let far = self.inner4(arr, n, b + T::int(self.stride[1] * n));
                [0, 1, 2, 3].map(|c| mul_add(near[c], w0, far[c] * w1))
            }
        }
    }

    #[inline(always)]
    fn inner4(&self, arr: &[f32], n: i32, j: T::Int) -> [T; 4] {
        let (w0, w1) = self.weight[0];
        let near = T::gather4(arr, j);
        let far = T::gather4(arr, j + T::int(self.stride[0] * n));
        [0, 1, 2, 3].map(|c| mul_add(near[c], w0, far[c] * w1))
    }

    /// The blend over the first interpolated parameter at entries `j`.
    #[inline(always)]
    fn inner(&self, arr: &[f32], n: i32, j: T::Int) -> T {
        let (w0, w1) = self.weight[0];
        let far = T::gather(arr, j + T::int(self.stride[0] * n));
        mul_add(T::gather(arr, j), w0, far * w1)
    }
}

/// Index of the first of `n` values `v(0)`, .., `v(n - 1)` (non-decreasing) that is at
/// least `x`, or `n - 1` when none is: the linear scan's answer by binary search (the
/// iteration count depends on `n` only, so lanes take the same probes).
#[inline(always)]
pub fn first_at_least<T: Num>(n: usize, x: T, v: impl Fn(T::Int) -> T) -> T::Int {
    // The answer (n: none) lies in [base, base + size] (Khuong and Morin's branch-free
    // lower bound).
    let (mut base, mut size) = (T::int(0), n);
    while size > 1 {
        let half = size / 2;
        let next = base + T::int(half as i32);
        base = T::int_select(lt(v(next), x), next, base);
        size -= half;
    }
    let below = T::int_select(lt(v(base), x), T::int(1), T::int(0));
    T::int_min(base + below, T::int(n as i32 - 1))
}

#[inline(always)]
fn lerp<T: Num>(a: T, b: T, t: T) -> T {
    mul_add(b, t, mul_add(-a, t, a))
}

impl Marginal2D {
    pub fn memory_bytes(&self) -> usize {
        (self.data.len() + self.cond.len() + self.marg.len()) * 4
    }

    /// `data` holds the slices (last parameter fastest), each `h` rows of `w` values.
    /// With `sampling`, each slice is normalized and its CDFs built.
    pub fn new(data: &[f32], w: usize, h: usize, params: Vec<Vec<f32>>, sampling: bool) -> Self {
        let mut out = Self::with_channels(data, w, h, 1, params);
        if sampling {
            out.build_cdfs();
        }
        out
    }

    /// A table of `channels` values per node (node-major: the values of a node side by
    /// side), for evaluation only ([`Marginal2D::eval_channels`]).
    pub fn with_channels(
        data: &[f32],
        w: usize,
        h: usize,
        channels: usize,
        params: Vec<Vec<f32>>,
    ) -> Self {
        assert!(w >= 2 && h >= 2 && channels >= 1);
        assert!(
            params.iter().filter(|p| p.len() > 1).count() <= MAX_PARAMS,
            "at most {MAX_PARAMS} interpolated parameters"
        );
        let mut strides = vec![0usize; params.len()];
        let mut s = 1usize;
        for d in (0..params.len()).rev() {
            strides[d] = if params[d].len() > 1 { s } else { 0 };
            s *= params[d].len();
        }
        let slices = params.iter().map(|p| p.len()).product::<usize>().max(1);
        assert_eq!(data.len(), slices * w * h * channels);
        Self {
            w,
            h,
            channels,
            params,
            strides,
            data: data.to_vec(),
            cond: Vec::new(),
            marg: Vec::new(),
        }
    }

    /// Normalizes each slice and builds its conditional and marginal CDFs.
    fn build_cdfs(&mut self) {
        let (w, h) = (self.w, self.h);
        let slices = self.data.len() / (w * h);
        self.cond = vec![0.0; slices * h * (w - 1)];
        self.marg = vec![0.0; slices * (h - 1)];
        for sl in 0..slices {
            let d = &mut self.data[sl * w * h..(sl + 1) * w * h];
            let cond = &mut self.cond[sl * h * (w - 1)..(sl + 1) * h * (w - 1)];
            let marg = &mut self.marg[sl * (h - 1)..(sl + 1) * (h - 1)];
            let mut rows = vec![0.0f64; h];
            for y in 0..h {
                let mut acc = 0.0f64;
                for x in 0..w - 1 {
                    acc += 0.5 / (w - 1) as f64 * (d[y * w + x] as f64 + d[y * w + x + 1] as f64);
                    cond[y * (w - 1) + x] = acc as f32;
                }
                rows[y] = acc;
            }
            let mut acc = 0.0f64;
            for y in 0..h - 1 {
                acc += 0.5 / (h - 1) as f64 * (rows[y] + rows[y + 1]);
                marg[y] = acc as f32;
            }
            let norm = if acc > 0.0 { (1.0 / acc) as f32 } else { 0.0 };
            for v in cond.iter_mut().chain(marg.iter_mut()).chain(d.iter_mut()) {
                *v *= norm;
            }
        }
    }

    /// The node values (normalized when the table was built for sampling), slices one
    /// after the other, each `h` rows of `w` nodes of `channels` values.
    pub fn values(&self) -> &[f32] {
        &self.data
    }

    /// The slices and weights of parameters `p` (Mitsuba's `interpolate_weights`): per
    /// parameter the interval [v_i, v_i+1] of its values that holds p (the first or last
    /// one beyond them) and t = (p - v_i) / (v_i+1 - v_i) clamped to [0, 1].
    pub fn slices<T: Num>(&self, p: &[T]) -> Slices<T> {
        let mut s = Slices::none();
        for (d, vals) in self.params.iter().enumerate() {
            let n = vals.len();
            if n <= 1 {
                continue;
            }
            let x = p[d];
            let i = first_at_least(n - 1, x, |k| T::gather(vals, k + T::int(1)));
            let (v0, v1) = (T::gather(vals, i), T::gather(vals, i + T::int(1)));
            let t = clamp((x - v0) / (v1 - v0), T::of(0.0), T::of(1.0));
            s.first = s.first + i * T::int(self.strides[d] as i32);
            s.stride[s.dims] = self.strides[d] as i32;
            s.weight[s.dims] = (T::of(1.0) - t, t);
            s.dims += 1;
        }
        s
    }

    /// The patch of u (clamped to the square): its lower-left node (x, y) and the
    /// fractions of u within it.
    #[inline(always)]
    fn patch<T: Num>(&self, u: [T; 2]) -> (T::Int, T::Int, T, T) {
        let (w, h) = (self.w, self.h);
        let (zero, one) = (T::of(0.0), T::of(1.0));
        let px = clamp(u[0], zero, one) * T::of((w - 1) as f64);
        let py = clamp(u[1], zero, one) * T::of((h - 1) as f64);
        let ox = T::int_min(px.trunc_int(), T::int(w as i32 - 2));
        let oy = T::int_min(py.trunc_int(), T::int(h as i32 - 2));
        (ox, oy, px - T::of_int(ox), py - T::of_int(oy))
    }

    /// The (normalized) density at u in the slices of a query.
    #[inline]
    pub fn eval_in<T: Num>(&self, u: [T; 2], sl: &Slices<T>) -> T {
        self.eval_channels::<T, 1>(u, sl)[0]
    }

    /// The `C` values of the bilinear interpolant at u in the slices of a query (each as
    /// [`Marginal2D::eval_in`] computes it for a table of one channel; four-channel tables
    /// by [`Slices::at4`]).
    #[inline]
    pub fn eval_channels<T: Num, const C: usize>(&self, u: [T; 2], sl: &Slices<T>) -> [T; C] {
        assert_eq!(C, self.channels);
        let (ox, oy, fx, fy) = self.patch(u);
        let n = self.w * self.h * C;
        let i = (oy * T::int(self.w as i32) + ox) * T::int(C as i32);
        let (c1, row) = (T::int(C as i32), T::int((self.w * C) as i32));
        let mut out = [T::of(0.0); C];
        if C == 4 {
            let (v00, v10) = (sl.at4(&self.data, n, i), sl.at4(&self.data, n, i + c1));
            let (v01, v11) = (
                sl.at4(&self.data, n, i + row),
                sl.at4(&self.data, n, i + row + c1),
            );
            for (c, o) in out.iter_mut().enumerate() {
                *o = lerp(lerp(v00[c], v10[c], fx), lerp(v01[c], v11[c], fx), fy);
            }
            return out;
        }
        for (c, o) in out.iter_mut().enumerate() {
            let at = |k: T::Int| sl.at(&self.data, n, k + T::int(c as i32));
            let (v00, v10) = (at(i), at(i + c1));
            let (v01, v11) = (at(i + row), at(i + row + c1));
            *o = lerp(lerp(v00, v10, fx), lerp(v01, v11, fx), fy);
        }
        out
    }

    /// The fraction of a segment of width 1 / `inv_w` and end values `v0`, `v1` whose
    /// (linear) density integrates to `u`.
    #[inline(always)]
    fn sample_segment<T: Num>(u: T, inv_w: f32, v0: T, v1: T) -> T {
        let zero = T::of(0.0);
        let nonconst = gt(abs(v0 - v1), T::of(1e-4) * (v0 + v1));
        let div = select(nonconst, v0 - v1, v0 + v1);
        let u = u * T::of(2.0) * T::of(inv_w as f64);
        let u = select(
            nonconst,
            v0 - sqrt(maximum(v0 * v0 + u * (v1 - v0), zero)),
            u,
        );
        select(!eq(div, zero), u / div, u)
    }

    /// Warps a uniform sample to the distribution: (u, density).
    pub fn sample(&self, xi: [f32; 2], p: &[f32]) -> ([f32; 2], f32) {
        self.sample_in(xi, &self.slices(p))
    }

    /// [`Marginal2D::sample`] in the slices of a query.
    pub fn sample_in<T: Num>(&self, xi: [T; 2], b: &Slices<T>) -> ([T; 2], T) {
        let (w, h) = (self.w, self.h);
        let eps = f32::EPSILON / 2.0;
        let (lo, hi) = (T::of(eps as f64), T::of((1.0 - eps) as f64));
        let (mut x, mut y) = (clamp(xi[0], lo, hi), clamp(xi[1], lo, hi));
        let (nm, nc) = (h - 1, h * (w - 1));
        let (one, zero, fzero) = (T::int(1), T::int(0), T::of(0.0));
        // Row: the first r with marg[r] >= y.
        let row = first_at_least(h - 1, y, |r| b.at(&self.marg, nm, r));
        let prev = b.at(&self.marg, nm, T::int_max(row - one, zero));
        y = select(gt(T::of_int(row), fzero), y - prev, y);
        let wm1 = T::int(w as i32 - 1);
        let (row0, row1) = (row * wm1, (row + one) * wm1);
        let last = T::int(w as i32 - 2);
        let r0 = b.at(&self.cond, nc, row0 + last);
        let r1 = b.at(&self.cond, nc, row1 + last);
        let ty = Self::sample_segment(y, (h - 1) as f32, r0, r1);
        x = x * lerp(r0, r1, ty);
        let c = |k: T::Int| {
            lerp(
                b.at(&self.cond, nc, row0 + k),
                b.at(&self.cond, nc, row1 + k),
                ty,
            )
        };
        let col = first_at_least(w - 1, x, c);
        let prev = c(T::int_max(col - one, zero));
        x = select(gt(T::of_int(col), fzero), x - prev, x);
        let n = w * h;
        let wi = T::int(w as i32);
        let i = row * wi + col;
        let v00 = b.at(&self.data, n, i);
        let v10 = b.at(&self.data, n, i + one);
        let v01 = b.at(&self.data, n, i + wi);
        let v11 = b.at(&self.data, n, i + wi + one);
        let c0 = lerp(v00, v01, ty);
        let c1 = lerp(v10, v11, ty);
        let tx = Self::sample_segment(x, (w - 1) as f32, c0, c1);
        let inv = [1.0 / (w - 1) as f32, 1.0 / (h - 1) as f32].map(|v| T::of(v as f64));
        (
            [
                (T::of_int(col) + tx) * inv[0],
                (T::of_int(row) + ty) * inv[1],
            ],
            lerp(c0, c1, tx),
        )
    }

    /// The uniform sample that [`Marginal2D::sample_in`] maps to u, and the density at
    /// u, in the slices of a query.
    pub fn invert_in<T: Num>(&self, u: [T; 2], b: &Slices<T>) -> ([T; 2], T) {
        let (w, h) = (self.w, self.h);
        let (px, py, fx, fy) = self.patch(u);
        let (one, zero, fzero) = (T::int(1), T::int(0), T::of(0.0));
        let n = w * h;
        let wi = T::int(w as i32);
        let i = py * wi + px;
        let v00 = b.at(&self.data, n, i);
        let v10 = b.at(&self.data, n, i + one);
        let v01 = b.at(&self.data, n, i + wi);
        let v11 = b.at(&self.data, n, i + wi + one);
        let c0 = lerp(v00, v01, fy);
        let c1 = lerp(v10, v11, fy);
        let pdf = lerp(c0, c1, fx);
        let (nc, nm) = (h * (w - 1), h - 1);
        let half = T::of(0.5);
        let mut x = fx * lerp(c0, c1, half * fx) * T::of((1.0 / (w - 1) as f32) as f64);
        let wm1 = T::int(w as i32 - 1);
        let (row0, row1) = (py * wm1, (py + one) * wm1);
        let left = T::int_max(px - one, zero);
        let before = lerp(
            b.at(&self.cond, nc, row0 + left),
            b.at(&self.cond, nc, row1 + left),
            fy,
        );
        x = select(gt(T::of_int(px), fzero), x + before, x);
        let last = T::int(w as i32 - 2);
        let r0 = b.at(&self.cond, nc, row0 + last);
        let r1 = b.at(&self.cond, nc, row1 + last);
        let rl = lerp(r0, r1, fy);
        x = select(gt(rl, fzero), x / rl, x);
        let mut y = fy * lerp(r0, r1, half * fy) * T::of((1.0 / (h - 1) as f32) as f64);
        let above = b.at(&self.marg, nm, T::int_max(py - one, zero));
        y = select(gt(T::of_int(py), fzero), y + above, y);
        ([x, y], pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{LANES, f32xn};

    /// Two parameter slices of a 5 x 4 table.
    fn table() -> Marginal2D {
        let mut data = Vec::new();
        for s in 0..2 {
            for y in 0..4 {
                for x in 0..5 {
                    data.push(1.0 + (x * (s + 1)) as f32 + (y * y) as f32 * 0.5);
                }
            }
        }
        Marginal2D::new(&data, 5, 4, vec![vec![0.0, 1.0]], true)
    }

    #[test]
    fn sample_invert_and_eval_agree() {
        let m = table();
        for k in 0..200 {
            let xi = [
                ((k as f32) * 0.618_034).fract(),
                ((k as f32) * 0.414_213).fract(),
            ];
            let p = [((k as f32) * 0.1).fract()];
            let (u, pdf) = m.sample(xi, &p);
            let (xi2, pdf2) = m.invert_in(u, &m.slices(&p));
            assert!(
                (xi2[0] - xi[0]).abs() < 1e-4 && (xi2[1] - xi[1]).abs() < 1e-4,
                "{xi:?} -> {u:?} -> {xi2:?}"
            );
            assert!(
                (pdf - pdf2).abs() < 1e-4 * pdf
                    && (pdf - m.eval_in(u, &m.slices(&p))).abs() < 1e-4 * pdf
            );
        }
        // The density integrates to one.
        let n = 400;
        let sl = m.slices(&[0.3]);
        let mut acc = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                acc += m.eval_in(
                    [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32],
                    &sl,
                ) as f64;
            }
        }
        assert!((acc / (n * n) as f64 - 1.0).abs() < 1e-3);
    }

    /// The binary search finds what a linear scan finds, for every length and every
    /// position of x among (repeated) values, and below and above all of them.
    #[test]
    fn first_at_least_equals_a_linear_scan() {
        let linear = |v: &[f32], x: f32| v.iter().position(|&a| a >= x).unwrap_or(v.len() - 1);
        for n in 1..40 {
            let v: Vec<f32> = (0..n).map(|k| (k / 3) as f32).collect();
            for x10 in -10..(n as i32 * 5) {
                let x = x10 as f32 * 0.1;
                assert_eq!(
                    first_at_least(n, x, |k| v[k as usize]) as usize,
                    linear(&v, x),
                    "n {n}, x {x}"
                );
            }
        }
    }

    /// Parameter slices: the interval holding p (the end ones beyond the values), the
    /// weights, and the blend of two parameters with the last outermost.
    #[test]
    fn slices_blend_the_neighbouring_parameter_values() {
        let m = Marginal2D::with_channels(
            &(0..3 * 4 * 4).map(|k| k as f32).collect::<Vec<_>>(),
            2,
            2,
            1,
            vec![vec![0.0, 1.0, 3.0], vec![10.0, 20.0, 30.0, 40.0]],
        );
        let s = m.slices(&[2.0, 25.0]);
        // Slice (1, 1) first; strides 4 (first parameter) and 1 (second).
        assert_eq!((s.first, s.dims, s.stride), (5, 2, [4, 1]));
        assert_eq!(s.weight, [(0.5, 0.5), (0.5, 0.5)]);
        // Entry 0 of slices 5, 9, 6, 10 (4 entries each): 20, 36, 24, 40 -> 30.
        assert_eq!(s.at(&m.data, 4, 0), 30.0);
        let below = m.slices(&[-1.0, 5.0]);
        assert_eq!((below.first, below.weight), (0, [(1.0, 0.0), (1.0, 0.0)]));
        let above = m.slices(&[9.0, 99.0]);
        assert_eq!((above.first, above.weight), (6, [(0.0, 1.0), (0.0, 1.0)]));
        // A one-value parameter takes no part.
        let one =
            Marginal2D::with_channels(&[0.0; 12], 2, 2, 1, vec![vec![0.5], vec![1.0, 2.0, 3.0]]);
        let s = one.slices(&[7.0, 2.5]);
        assert_eq!(
            (s.first, s.dims, s.stride[0], s.weight[0]),
            (1, 1, 1, (0.5, 0.5))
        );
    }

    /// Awkward inputs for the lane forms: nodes, edges, outside the square or the
    /// parameter range, NaN.
    fn awkward(k: usize) -> f32 {
        const SPECIAL: [f32; 10] = [
            0.0,
            1.0,
            -0.0,
            -0.3,
            1.7,
            0.5,
            0.25,
            f32::NAN,
            1e-9,
            0.999_999_9,
        ];
        if k.is_multiple_of(5) {
            SPECIAL[(k / 5) % SPECIAL.len()]
        } else {
            (k as f32 * 0.618_034 + 0.1).fract()
        }
    }

    /// The lane forms (slices, eval, channels, invert, sample) equal the scalar ones
    /// bit for bit, lane by lane, on a table of two interpolated parameters with constant
    /// and zero rows (the degenerate branches of the segment warp).
    #[test]
    fn lane_forms_equal_the_scalar_ones_bit_for_bit() {
        use crate::simd::lanes;
        let (w, h) = (7, 6);
        let params = vec![vec![0.0, 0.4, 1.0], vec![-1.0, 0.0, 2.0, 3.0]];
        let mut data = Vec::new();
        for s in 0..12 {
            for y in 0..h {
                for x in 0..w {
                    data.push(match (s + y) % 4 {
                        0 => 0.0,
                        1 => 2.5,
                        _ => ((s * 13 + y * 5 + x * 7) % 11) as f32 * 0.3,
                    });
                }
            }
        }
        let m = Marginal2D::new(&data, w, h, params, true);
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits();
        for round in 0..400 {
            let q = |j: usize| awkward(round * LANES * 6 + j);
            let p0 = lanes(|i| q(i * 6) * 1.4 - 0.2);
            let p1 = lanes(|i| q(i * 6 + 1) * 5.0 - 1.5);
            let u = lanes(|i| [q(i * 6 + 2), q(i * 6 + 3)]);
            let xi = lanes(|i| [q(i * 6 + 4), q(i * 6 + 5)]);
            let sl8 = m.slices(&[f32xn::new(p0), f32xn::new(p1)]);
            let u8 = [f32xn::new(u.map(|v| v[0])), f32xn::new(u.map(|v| v[1]))];
            let xi8 = [f32xn::new(xi.map(|v| v[0])), f32xn::new(xi.map(|v| v[1]))];
            let e = m.eval_in(u8, &sl8).to_array();
            let (iv, ip) = m.invert_in(u8, &sl8);
            let (sv, sp) = m.sample_in(xi8, &sl8);
            for i in 0..LANES {
                let sl = m.slices(&[p0[i], p1[i]]);
                let ctx = format!("p ({}, {}), u {:?}, xi {:?}", p0[i], p1[i], u[i], xi[i]);
                assert!(same(e[i], m.eval_in(u[i], &sl)), "eval {ctx}");
                let (v, p) = m.invert_in(u[i], &sl);
                assert!(same(iv[0].to_array()[i], v[0]), "invert x {ctx}");
                assert!(same(iv[1].to_array()[i], v[1]), "invert y {ctx}");
                assert!(same(ip.to_array()[i], p), "invert pdf {ctx}");
                let (v, p) = m.sample_in(xi[i], &sl);
                assert!(same(sv[0].to_array()[i], v[0]), "sample x {ctx}");
                assert!(same(sv[1].to_array()[i], v[1]), "sample y {ctx}");
                assert!(same(sp.to_array()[i], p), "sample pdf {ctx}");
            }
        }
    }

    /// The binary search in lanes finds what the one-query search finds.
    #[test]
    fn first_at_least_in_lanes_equals_the_one_query_search() {
        use crate::simd::lanes;
        for n in 1..40 {
            let v: Vec<f32> = (0..n).map(|k| (k / 3) as f32).collect();
            for x10 in (-10..(n as i32 * 5)).step_by(8) {
                let xs = lanes(|i| (x10 + i as i32) as f32 * 0.1);
                let got = first_at_least(n, f32xn::new(xs), |k| crate::simd::gather(&v, k));
                let got = got.to_array();
                for i in 0..LANES {
                    let one = first_at_least(n, xs[i], |k| v[k as usize]);
                    assert_eq!(got[i], one, "n {n}");
                }
            }
        }
    }

    /// A table of several channels per node evaluates each channel as a one-channel table
    /// of that channel does, bit for bit, one query at a time and `LANES` (three channels by
    /// gathers, four by transposed loads), with one and two interpolated parameters.
    #[test]
    fn channels_evaluate_as_separate_tables() {
        fn check<const C: usize>(params: Vec<Vec<f32>>) {
            use crate::simd::lanes;
            let (w, h) = (6, 5);
            let slices: usize = params.iter().map(Vec::len).product();
            let value = |s: usize, y: usize, x: usize, c: usize| {
                ((s * 31 + y * 7 + x * 3 + c * 11) % 17) as f32 * 0.37 - 1.0
            };
            let mut interleaved = Vec::new();
            for s in 0..slices {
                for y in 0..h {
                    for x in 0..w {
                        for c in 0..C {
                            interleaved.push(value(s, y, x, c));
                        }
                    }
                }
            }
            let table = Marginal2D::with_channels(&interleaved, w, h, C, params.clone());
            let single: Vec<Marginal2D> = (0..C)
                .map(|c| {
                    let mut d = Vec::new();
                    for s in 0..slices {
                        for y in 0..h {
                            for x in 0..w {
                                d.push(value(s, y, x, c));
                            }
                        }
                    }
                    Marginal2D::new(&d, w, h, params.clone(), false)
                })
                .collect();
            for round in 0..100 {
                let q = |j: usize| awkward(round * 32 + j);
                let u = lanes(|i| [q(4 * i) * 1.2 - 0.1, q(4 * i + 1)]);
                let p = lanes(|i| [q(4 * i + 2) * 1.4 - 0.2, q(4 * i + 3) * 3.0]);
                let p8 = [f32xn::new(p.map(|p| p[0])), f32xn::new(p.map(|p| p[1]))];
                let sl8 = table.slices(&p8[..params.len()]);
                let u8 = [f32xn::new(u.map(|u| u[0])), f32xn::new(u.map(|u| u[1]))];
                let got8 = table.eval_channels::<_, C>(u8, &sl8);
                for i in 0..LANES {
                    let p = &p[i][..params.len()];
                    let got = table.eval_channels::<_, C>(u[i], &table.slices(p));
                    for c in 0..C {
                        let want = single[c].eval_in(u[i], &single[c].slices(p)).to_bits();
                        assert_eq!(got[c].to_bits(), want, "{C} channels: {u:?} {p:?}");
                        assert_eq!(
                            got8[c].to_array()[i].to_bits(),
                            want,
                            "lanes, {C}: {u:?} {p:?}"
                        );
                    }
                }
            }
        }
        check::<3>(vec![vec![0.0, 0.7, 1.0]]);
        check::<4>(vec![vec![0.0, 0.7, 1.0]]);
        check::<4>(vec![vec![0.0, 0.7, 1.0], vec![0.5, 1.0, 2.5]]);
        check::<4>(vec![]);
    }
}
