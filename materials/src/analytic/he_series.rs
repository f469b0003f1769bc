//! The series of He et al.'s directional-diffuse term (He, Torrance, Sillion and Greenberg
//! 1991, eq. 78, Westin's reading), tabulated for fitting and rendering:
//!
//!   S(g, e) = sum_{m >= 1} g^m exp(-g) / (m! m) exp(-e / m),
//!
//! with g = (2 pi sigma (cos theta_i + cos theta_o) / lambda)^2 and e = pi^2 tau^2
//! |(wi + wo)_xy|^2 / lambda^2. Summed term by term it costs one exponential per term, up to
//! 64 terms per channel, and it dominated the time of fitting He to MERL-like tables. Here
//! it is tabulated (as F = S / g, smooth down to g = 0) once on a grid of g in [0, 40.5]
//! (step 0.1: He sums the series while the smallest channel g, red's, is at most 19, so
//! blue's is at most 40.1) and u = sqrt(e) in [0, 60] (step 0.05), with the exact partial derivatives
//! F_g, F_u and F_gu at each node (summed with the same Poisson recurrence), and evaluated
//! by bicubic Hermite interpolation, which is C1 (smooth finite-difference gradients) and
//! of fourth order. Beyond u = 60 every term is below exp(-56) times its Poisson weight
//! (the series itself stops at 64 terms), so S is taken as 0.
//!
//! Error bound (tested against the summed series on a dense set of points and on random
//! ones): |S_table(g, e) - S(g, e)| <= [`TABLE_ERROR_BOUND`] * S(g, 0), i.e. relative to
//! the lobe's own peak at the same elevations (the specular direction, e = 0), which is
//! how the Eq. (1) metric weighs it.

use crate::math::{Single, le, maximum, select, sqrt};
use std::ops::{Add, Mul, Neg, Sub};
use std::sync::LazyLock;

/// Largest g of the table: He sums the series while the red channel's g is at most 19,
/// and the blue channel's g is then up to 19 (0.645 / 0.444)^2 = 40.1.
pub const G_MAX: f64 = 40.5;
/// Largest u = sqrt(e) of the table; S is 0 beyond it (relative to its peak, < 1e-24).
pub const U_MAX: f64 = 60.0;
const G_STEP: f64 = 0.1;
const U_STEP: f64 = 0.05;
const G_NODES: usize = 406;
const U_NODES: usize = 1201;
/// Terms of the summed series at most (as He's direct evaluation).
pub const MAX_TERMS: usize = 64;

/// The tested bound of the table's error, relative to S(g, 0).
pub const TABLE_ERROR_BOUND: f64 = 5e-7;

/// F = S / g and its partial derivatives at one (g, u) node. The table holds F, not S:
/// S(g, e) ~ g exp(-e) for small g, which a cubic in g follows only to a relative 1e-5
/// near g = 0, while F(0, u) = exp(-u^2) is as smooth as the rest.
#[derive(Clone, Copy, Default)]
struct Node {
    f: f64,
    f_g: f64,
    f_u: f64,
    f_gu: f64,
}

/// F = S / g and its derivatives in g and u = sqrt(e), every term up to [`MAX_TERMS`]:
/// F = sum_m P(m - 1; g) / m^2 exp(-u^2 / m) with the Poisson weights
/// P(k; g) = g^k exp(-g) / k!, whose derivative in g is P(k - 1) - P(k).
fn node(g: f64, u: f64) -> Node {
    let mut n = Node::default();
    let (mut p_before, mut p) = (0.0, (-g).exp()); // P(m - 2), P(m - 1)
    for m in 1..=MAX_TERMS {
        let mf = m as f64;
        let (c, c_g) = (p / (mf * mf), (p_before - p) / (mf * mf));
        let b = (-u * u / mf).exp();
        let b_u = -2.0 * u / mf * b;
        n.f += c * b;
        n.f_g += c_g * b;
        n.f_u += c * b_u;
        n.f_gu += c_g * b_u;
        (p_before, p) = (p, p * g / mf);
        // Past the Poisson peak the weights only fall: the rest of the terms is below
        // 1e-18 against F >= 1e-3 (F(g, 0) > 1 / (g + 1)^2 here).
        if mf > g && p_before < 1e-18 {
            break;
        }
    }
    n
}

/// The summed series S(g, e), every term up to [`MAX_TERMS`]: the reference the table is
/// tested against.
pub fn summed(g: f64, e: f64) -> f64 {
    g * node(g, e.max(0.0).sqrt()).f
}

struct Table {
    /// Row-major: g index, then u index.
    nodes: Vec<Node>,
}

static TABLE: LazyLock<Table> = LazyLock::new(|| {
    use rayon::prelude::*;
    let nodes = (0..G_NODES * U_NODES)
        .into_par_iter()
        .map(|k| node((k / U_NODES) as f64 * G_STEP, (k % U_NODES) as f64 * U_STEP))
        .collect();
    Table { nodes }
});

/// Cubic Hermite basis at t in [0, 1]: (value at 0, slope at 0, value at 1, slope at 1),
/// for f64 (fitting), f32 and f32 lanes (the render path) alike, with the constants 1, 2
/// and 3 of the type.
#[inline(always)]
fn hermite<T>(t: T, [one, two, three]: [T; 3]) -> [T; 4]
where
    T: Copy + Add<Output = T> + Sub<Output = T> + Mul<Output = T> + Neg<Output = T>,
{
    let t2 = t * t;
    let t3 = t2 * t;
    [
        two * t3 - three * t2 + one,
        t3 - two * t2 + t,
        -two * t3 + three * t2,
        t3 - t2,
    ]
}

/// The table in f32 for rendering ([`tabulated_single`]): per node F and its derivatives
/// scaled by the steps, [F, G_STEP F_g, U_STEP F_u, G_STEP U_STEP F_gu], one 16-byte read.
static TABLE32: LazyLock<Vec<[f32; 4]>> = LazyLock::new(|| {
    TABLE
        .nodes
        .iter()
        .map(|n| {
            [
                n.f as f32,
                (G_STEP * n.f_g) as f32,
                (U_STEP * n.f_u) as f32,
                (G_STEP * U_STEP * n.f_gu) as f32,
            ]
        })
        .collect()
});

/// Builds the tables now if they are not built yet (they are otherwise built at the first
/// [`tabulated`] or [`tabulated_single`] call).
pub fn build_table() {
    LazyLock::force(&TABLE);
    LazyLock::force(&TABLE32);
}

/// S(g, e) from the f32 table, one value or lanes (the render path: within
/// [`super::he::RENDER_ERROR_BOUND`] of the f64 lobe, tested there), for 0 <= g <=
/// [`G_MAX`] and e >= 0, 0 for u = sqrt(e) >= [`U_MAX`]. Other values read a clamped cell of
/// the table and get a finite value or NaN the caller discards (the lobe sums the series
/// only where every channel's g is within the table).
#[inline(always)]
pub fn tabulated_single<T: Single>(g: T, e: T) -> T {
    let s = T::of32;
    let u = sqrt(maximum(e, s(0.0)));
    let (gs, us) = (g * s((1.0 / G_STEP) as f32), u * s((1.0 / U_STEP) as f32));
    let index =
        |x: T, top: usize| T::int_min(T::int_max(x.trunc_int(), T::int(0)), T::int(top as i32));
    let (i, j) = (index(gs, G_NODES - 2), index(us, U_NODES - 2));
    let consts = [s(1.0), s(2.0), s(3.0)];
    let (hg, hu) = (
        hermite(gs - T::of_int(i), consts),
        hermite(us - T::of_int(j), consts),
    );
    let k = i * T::int(U_NODES as i32) + j;
    let t = &*TABLE32;
    let mut sum = s(0.0);
    for (di, (wg, wg_d)) in [(0, (hg[0], hg[1])), (1, (hg[2], hg[3]))] {
        for (dj, (wu, wu_d)) in [(0, (hu[0], hu[1])), (1, (hu[2], hu[3]))] {
            // k <= (G_NODES - 2) U_NODES + U_NODES - 2 (clamped above), so k + offset is
            // within the table.
            let node = k + T::int((di * U_NODES + dj) as i32);
            let [f, f_g, f_u, f_gu] = T::gather4(t.as_flattened(), node * T::int(4));
            sum = sum + (wg * (wu * f + wu_d * f_u) + wg_d * (wu * f_g + wu_d * f_gu));
        }
    }
    let v = g * maximum(sum, s(0.0));
    select(le(s(U_MAX as f32), u), s(0.0), v)
}

/// S(g, e) from the table, for 0 <= g <= [`G_MAX`] (None outside, or for a non-finite
/// argument: the caller sums the series).
#[inline]
pub fn tabulated(g: f64, e: f64) -> Option<f64> {
    if !((0.0..=G_MAX).contains(&g) && e >= 0.0) {
        return None;
    }
    let u = e.sqrt();
    if u >= U_MAX {
        return Some(0.0);
    }
    let (gs, us) = (g / G_STEP, u / U_STEP);
    let i = (gs as usize).min(G_NODES - 2);
    let j = (us as usize).min(U_NODES - 2);
    let consts = [1.0, 2.0, 3.0];
    let (hg, hu) = (
        hermite(gs - i as f64, consts),
        hermite(us - j as f64, consts),
    );
    let t = &TABLE.nodes;
    let mut sum = 0.0;
    for (di, wg) in [(0, (hg[0], hg[1])), (1, (hg[2], hg[3]))] {
        let row = (i + di) * U_NODES + j;
        for (dj, wu) in [(0, (hu[0], hu[1])), (1, (hu[2], hu[3]))] {
            let n = &t[row + dj];
            sum += wg.0 * (wu.0 * n.f + wu.1 * U_STEP * n.f_u)
                + wg.1 * G_STEP * (wu.0 * n.f_g + wu.1 * U_STEP * n.f_gu);
        }
    }
    Some(g * sum.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worst error of the table relative to S(g, 0) over the given points.
    fn worst(points: impl Iterator<Item = (f64, f64)>) -> (f64, (f64, f64)) {
        let mut worst = (0.0, (0.0, 0.0));
        for (g, u) in points {
            let e = u * u;
            let peak = summed(g, 0.0);
            if peak <= 0.0 {
                continue;
            }
            let err = (tabulated(g, e).unwrap() - summed(g, e)).abs() / peak;
            if err > worst.0 {
                worst = (err, (g, e));
            }
        }
        worst
    }

    #[test]
    fn the_table_is_within_its_bound_of_the_summed_series() {
        // Cell midpoints and quarter points (where interpolation errs most) over the whole
        // table, on a sub-grid.
        let mid = (0..G_NODES - 1).step_by(3).flat_map(|i| {
            (0..U_NODES - 1).step_by(7).flat_map(move |j| {
                [(0.5, 0.5), (0.25, 0.75), (0.75, 0.25)]
                    .map(|(a, b)| ((i as f64 + a) * G_STEP, (j as f64 + b) * U_STEP))
            })
        });
        let (err, at) = worst(mid);
        assert!(err <= TABLE_ERROR_BOUND, "error {err:e} at (g, e) = {at:?}");
        // Random points, the small g and e where the first terms dominate included.
        let mut bits = crate::math::xorshift64(0x2545f4914f6cdd1d);
        let mut next = move || (bits() >> 11) as f64 / (1u64 << 53) as f64;
        let random: Vec<(f64, f64)> = (0..20_000)
            .map(|k| {
                let g = if k % 4 == 0 {
                    next() * 0.5
                } else {
                    next() * G_MAX
                };
                let u = if k % 3 == 0 {
                    next() * 3.0
                } else {
                    next() * U_MAX
                };
                (g, u)
            })
            .collect();
        let (err, at) = worst(random.into_iter());
        assert!(err <= TABLE_ERROR_BOUND, "error {err:e} at (g, e) = {at:?}");
        // At the nodes it is the series.
        let s = summed(7.0, 4.0);
        assert!((tabulated(7.0, 4.0).unwrap() - s).abs() <= 1e-14 * s);
    }

    #[test]
    fn outside_the_table_the_caller_sums_and_far_out_it_is_zero() {
        assert_eq!(tabulated(G_MAX + 0.5, 1.0), None);
        assert_eq!(tabulated(f64::NAN, 1.0), None);
        assert_eq!(tabulated(5.0, f64::NAN), None);
        assert_eq!(tabulated(5.0, U_MAX * U_MAX), Some(0.0));
        let far = summed(G_MAX, U_MAX * U_MAX);
        assert!(far <= 1e-24 * summed(G_MAX, 0.0), "{far}");
    }
}
