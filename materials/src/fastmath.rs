//! Branch-free f32 `sin_cos`, `atan2`, `acos` and `asin` for the hot paths (env-map
//! lookups and sampling, direction warps, measured-BRDF coordinates, the analytic lobes'
//! half-vector sampling), a few times faster than the C library's.
//!
//! Each is a Cody-Waite range reduction followed by the minimax polynomials of Cephes'
//! single-precision `sinf`/`cosf`, `atanf` and `asinf` (S. L. Moshier, "Methods and
//! Programs for Mathematical Functions", 1989; the same approximations Dr.Jit, and so
//! Mitsuba 3, uses). Written with selects ([`select`]) instead of branches, so that no
//! branch mispredicts on random arguments, the core can overlap consecutive calls, and
//! loops of them vectorize. Accuracy, checked against
//! f64 over dense grids by the tests below: absolute error under 2.5e-7 for `sin_cos`
//! (|x| <= 1e4; larger arguments fall back to the C library), under 4e-7 for `acos`
//! (below 2 ulp of its result near pi) and `asin`, relative error under 4e-7 for
//! `atan2`. NaN inputs give NaN.
//!
//! [`xn`] has lane forms of the same functions on `wide`'s AVX vectors, for the
//! renderer's SIMD batches: the same operations lane by lane, so each lane equals the
//! scalar function bit for bit (tested), and batched and one-at-a-time renders agree
//! exactly. The other SIMD building blocks (lane types, transposes, selects, gathers) are
//! in [`crate::simd`].

// The coefficients are Cephes' published decimal values, kept as printed.
#![allow(clippy::excessive_precision)]

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Beyond this |x| the three-part reduction of `sin_cos` loses accuracy.
const SIN_COS_REDUCTION_LIMIT: f32 = 1.0e4;

/// (sin x, cos x).
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    if !(x.abs() <= SIN_COS_REDUCTION_LIMIT) {
        // Huge (or NaN) arguments: the C library's exact reduction.
        return x.sin_cos();
    }
    sin_cos_moderate(x)
}

/// (sin x, cos x) for |x| <= 1e4 (inaccurate beyond), without the branch to the C
/// library, so that loops of it vectorize.
#[inline]
pub fn sin_cos_moderate(x: f32) -> (f32, f32) {
    // x = k pi/2 + r, |r| <= pi/4, with pi/2 split in three parts (Cephes' DP1..DP3
    // doubled) so that k * part is exact.
    let k = (x * std::f32::consts::FRAC_2_PI).round_ties_even();
    let r = ((x - k * 1.570_312_5) - k * 4.837_512_969_970_703e-4) - k * 7.549_789_948_768_648e-8;
    let z = r * r;
    let s = r + r * z * ((-1.951_529_589_1e-4 * z + 8.332_160_873_6e-3) * z - 1.666_665_461_1e-1);
    let c = 1.0 - 0.5 * z
        + z * z
            * ((2.443_315_711_809_948e-5 * z - 1.388_731_625_493_765e-3) * z
                + 4.166_664_568_298_827e-2);
    let q = (k as i32) & 3;
    let (s1, c1) = if q & 1 == 0 { (s, c) } else { (c, s) };
    let sin = if q & 2 == 0 { s1 } else { -s1 };
    let cos = if (q + 1) & 2 == 0 { c1 } else { -c1 };
    (sin, cos)
}

/// `if c { a } else { b }` by bit masks, kept branch-free: for choices a branch predictor
/// cannot learn (which half of a random square a point falls in), where a mispredicted
/// branch costs more than computing both sides. The mask goes through `black_box` since
/// the compiler otherwise turns the masks back into a branch.
#[inline(always)]
pub fn select(c: bool, a: f32, b: f32) -> f32 {
    let m = std::hint::black_box(0u32.wrapping_sub(c as u32));
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// atan(t) for t in [0, 1].
#[inline]
fn atan_unit(t: f32) -> f32 {
    // Above tan(pi/8), atan t = pi/4 + atan((t - 1) / (t + 1)).
    let big = t > 0.414_213_57;
    let x = if big { (t - 1.0) / (t + 1.0) } else { t };
    let z = x * x;
    let p = (((8.053_744_495_38e-2 * z - 1.387_768_560_32e-1) * z + 1.997_771_064_78e-1) * z
        - 3.333_294_915_39e-1)
        * z
        * x
        + x;
    if big { p + FRAC_PI_4 } else { p }
}

/// atan2(y, x) in [-pi, pi], with the C library's signs and special cases for finite
/// inputs (atan2(±0, +0) = ±0, atan2(±0, -0) = ±pi).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let t = if hi > 0.0 { lo / hi } else { 0.0 };
    let mut a = atan_unit(t);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x.is_sign_negative() {
        a = PI - a;
    }
    let a = a.copysign(y);
    if x.is_nan() || y.is_nan() {
        f32::NAN
    } else {
        a
    }
}

/// asin(x) for x in [0, 1].
#[inline]
fn asin_unit(x: f32) -> f32 {
    let big = x > 0.5;
    let z = if big { 0.5 * (1.0 - x) } else { x * x };
    let s = if big { z.sqrt() } else { x };
    let p = ((((4.216_319_904_8e-2 * z + 2.418_131_104_9e-2) * z + 4.547_002_599_8e-2) * z
        + 7.495_300_268_6e-2)
        * z
        + 1.666_675_242_2e-1)
        * z
        * s
        + s;
    if big { FRAC_PI_2 - 2.0 * p } else { p }
}

/// asin(x) for x in [-1, 1] (NaN outside, as the C library).
#[inline]
pub fn asin(x: f32) -> f32 {
    let r = asin_unit(x.abs()).copysign(x);
    if x.abs() <= 1.0 { r } else { f32::NAN }
}

/// acos(x) for x in [-1, 1] (NaN outside, as the C library).
#[inline]
pub fn acos(x: f32) -> f32 {
    let a = FRAC_PI_2 - asin_unit(x.abs());
    let r = if x < 0.0 { PI - a } else { a };
    if x.abs() <= 1.0 { r } else { f32::NAN }
}

/// Bounds of [`exp`]: above, +inf (ln of the largest f32); below, 0 (under half the
/// smallest subnormal).
const EXP_OVER: f32 = 88.722_84;
const EXP_UNDER: f32 = -103.972_08;

/// 2^n for an integer n in [-252, 254] as two normal factors (so that subnormal results
/// are rounded once, in the last product).
#[inline(always)]
fn pow2_halves(n: i32) -> (f32, f32) {
    let n1 = n >> 1;
    let n2 = n - n1;
    let f = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
    (f(n1), f(n2))
}

/// e^x: Cephes `expf` (x = n ln 2 + r with ln 2 in two parts, a degree-6 polynomial in r,
/// times 2^n); relative error under 1.5e-7 (tested), subnormal results included, +inf above
/// ln(f32::MAX), 0 far below, NaN for NaN.
#[inline]
pub fn exp(x: f32) -> f32 {
    let xc = x.clamp(-104.0, 88.8);
    let n = (xc * std::f32::consts::LOG2_E + 0.5).floor();
    let r = xc - n * 0.693_359_375 - n * -2.121_944_40e-4;
    let z = r * r;
    let p = (((((1.987_569_150_0e-4 * r + 1.398_199_950_7e-3) * r + 8.333_451_907_3e-3) * r
        + 4.166_579_589_4e-2)
        * r
        + 1.666_666_545_9e-1)
        * r
        + 5.000_000_120_1e-1)
        * z
        + r
        + 1.0;
    let (s1, s2) = pow2_halves(n as i32);
    let y = p * s1 * s2;
    if x > EXP_OVER {
        f32::INFINITY
    } else if x < EXP_UNDER {
        0.0
    } else {
        y
    }
}

/// ln x: Cephes `logf` (x = m 2^e with m in [sqrt(1/2), sqrt(2)), a degree-9 polynomial in
/// m - 1); absolute error under 1.2e-7 near 1 and relative error under 1.2e-7 elsewhere
/// (tested), subnormal inputs included; -inf at 0, NaN below 0 and for NaN, +inf at +inf.
#[inline]
pub fn ln(x: f32) -> f32 {
    let sub = x < f32::MIN_POSITIVE;
    let xs = if sub { x * 8_388_608.0 } else { x };
    let bits = xs.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 126 - if sub { 23 } else { 0 };
    // The mantissa in [0.5, 1).
    let m = f32::from_bits((bits & 0x807f_ffff) | 0x3f00_0000);
    let small = m < std::f32::consts::FRAC_1_SQRT_2;
    let e = e - small as i32;
    let t = if small { m + m - 1.0 } else { m - 1.0 };
    let z = t * t;
    let y = ((((((((7.037_683_629_2e-2 * t - 1.151_461_031_0e-1) * t + 1.167_699_874_0e-1)
        * t
        - 1.242_014_084_6e-1)
        * t
        + 1.424_932_278_7e-1)
        * t
        - 1.666_805_766_5e-1)
        * t
        + 2.000_071_476_5e-1)
        * t
        - 2.499_999_399_3e-1)
        * t
        + 3.333_333_117_4e-1)
        * t
        * z;
    let ef = e as f32;
    let y = y + -2.121_944_40e-4 * ef;
    let y = y + -0.5 * z;
    let r = t + y + 0.693_359_375 * ef;
    if x > 0.0 && x < f32::INFINITY {
        r
    } else if x == 0.0 {
        f32::NEG_INFINITY
    } else if x == f32::INFINITY {
        x
    } else {
        f32::NAN
    }
}

/// x^y for x >= 0 as e^(y ln x) ([`exp`], [`ln`]): 1 when y = 0, 0 or +inf at x = 0, NaN
/// for x < 0. The relative error grows with |y ln x|: about 1e-7 (|y ln x| + 2), so under
/// 1e-5 wherever the result is above 1e-38 (tested).
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    let r = exp(y * ln(x));
    if y == 0.0 { 1.0 } else { r }
}

/// Lane forms of the functions above ([`sin_cos_moderate`], [`atan2`], [`acos`],
/// [`asin`]) on `wide`'s AVX vectors: the same operations in the same order on each
/// lane, so every lane's result equals the scalar function's bit for bit (tested below),
/// and batched lookups agree exactly with one-at-a-time ones.
pub mod xn {
    use crate::simd::sel;
    use crate::simd::{f32xn, i32xn, u32xn};
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    const SIGN: u32 = 0x8000_0000;

    /// [`super::sin_cos_moderate`] per lane.
    #[inline(always)]
    pub fn sin_cos_moderate(x: f32xn) -> (f32xn, f32xn) {
        let k = (x * f32xn::splat(std::f32::consts::FRAC_2_PI)).round_ties_even();
        let r = ((x - k * f32xn::splat(1.570_312_5)) - k * f32xn::splat(4.837_512_969_970_703e-4))
            - k * f32xn::splat(7.549_789_948_768_648e-8);
        let z = r * r;
        let s = r + r
            * z
            * ((f32xn::splat(-1.951_529_589_1e-4) * z + f32xn::splat(8.332_160_873_6e-3)) * z
                - f32xn::splat(1.666_665_461_1e-1));
        let c = f32xn::splat(1.0) - f32xn::splat(0.5) * z
            + z * z
                * ((f32xn::splat(2.443_315_711_809_948e-5) * z
                    - f32xn::splat(1.388_731_625_493_765e-3))
                    * z
                    + f32xn::splat(4.166_664_568_298_827e-2));
        // The quadrant; `k as i32` of the scalar form is 0 for NaN, and so is this.
        let q: u32xn = wide::bytemuck::cast(k.trunc_int());
        let odd = f32xn::from_bits((q & u32xn::splat(1)).simd_eq(u32xn::splat(1)));
        let (s1, c1) = (sel(odd, c, s), sel(odd, s, c));
        let neg_s = (q & u32xn::splat(2)) << 30;
        let neg_c = ((q + u32xn::splat(1)) & u32xn::splat(2)) << 30;
        (
            f32xn::from_bits(s1.to_bits() ^ neg_s),
            f32xn::from_bits(c1.to_bits() ^ neg_c),
        )
    }

    #[inline(always)]
    fn atan_unit(t: f32xn) -> f32xn {
        let one = f32xn::splat(1.0);
        let big = t.simd_gt(f32xn::splat(0.414_213_57));
        let x = sel(big, (t - one) / (t + one), t);
        let z = x * x;
        let p = (((f32xn::splat(8.053_744_495_38e-2) * z - f32xn::splat(1.387_768_560_32e-1)) * z
            + f32xn::splat(1.997_771_064_78e-1))
            * z
            - f32xn::splat(3.333_294_915_39e-1))
            * z
            * x
            + x;
        sel(big, p + f32xn::splat(FRAC_PI_4), p)
    }

    /// [`super::atan2`] per lane.
    #[inline(always)]
    pub fn atan2(y: f32xn, x: f32xn) -> f32xn {
        let (ax, ay) = (x.abs(), y.abs());
        let (lo, hi) = (ax.min(ay), ax.max(ay));
        let zero = f32xn::splat(0.0);
        let t = sel(hi.simd_gt(zero), lo / hi, zero);
        let mut a = atan_unit(t);
        a = sel(ay.simd_gt(ax), f32xn::splat(FRAC_PI_2) - a, a);
        a = sel(x.is_sign_negative(), f32xn::splat(PI) - a, a);
        let sign = u32xn::splat(SIGN);
        let a = f32xn::from_bits((a.to_bits() & !sign) | (y.to_bits() & sign));
        sel(x.is_nan() | y.is_nan(), f32xn::splat(f32::NAN), a)
    }

    #[inline(always)]
    fn asin_unit(x: f32xn) -> f32xn {
        let big = x.simd_gt(f32xn::splat(0.5));
        let z = sel(big, f32xn::splat(0.5) * (f32xn::splat(1.0) - x), x * x);
        let s = sel(big, z.sqrt(), x);
        let p = ((((f32xn::splat(4.216_319_904_8e-2) * z + f32xn::splat(2.418_131_104_9e-2)) * z
            + f32xn::splat(4.547_002_599_8e-2))
            * z
            + f32xn::splat(7.495_300_268_6e-2))
            * z
            + f32xn::splat(1.666_675_242_2e-1))
            * z
            * s
            + s;
        sel(big, f32xn::splat(FRAC_PI_2) - f32xn::splat(2.0) * p, p)
    }

    /// [`super::pow2_halves`] per lane.
    #[inline(always)]
    fn pow2_halves(n: i32xn) -> (f32xn, f32xn) {
        let n1 = n >> 1;
        let n2 = n - n1;
        let f = |k: i32xn| f32xn::from_bits(wide::bytemuck::cast((k + i32xn::splat(127)) << 23));
        (f(n1), f(n2))
    }

    /// [`super::exp`] per lane.
    #[inline(always)]
    pub fn exp(x: f32xn) -> f32xn {
        let s = f32xn::splat;
        let xc = crate::simd::clamp(x, -104.0, 88.8);
        let n = (xc * s(std::f32::consts::LOG2_E) + s(0.5)).floor();
        let r = xc - n * s(0.693_359_375) - n * s(-2.121_944_40e-4);
        let z = r * r;
        let p = (((((s(1.987_569_150_0e-4) * r + s(1.398_199_950_7e-3)) * r
            + s(8.333_451_907_3e-3))
            * r
            + s(4.166_579_589_4e-2))
            * r
            + s(1.666_666_545_9e-1))
            * r
            + s(5.000_000_120_1e-1))
            * z
            + r
            + s(1.0);
        // `n as i32` of the scalar form is 0 for NaN, and so is this.
        let (s1, s2) = pow2_halves(n.trunc_int());
        let y = p * s1 * s2;
        let y = sel(x.simd_lt(s(super::EXP_UNDER)), s(0.0), y);
        sel(x.simd_gt(s(super::EXP_OVER)), s(f32::INFINITY), y)
    }

    /// [`super::ln`] per lane.
    #[inline(always)]
    pub fn ln(x: f32xn) -> f32xn {
        let s = f32xn::splat;
        let sub = x.simd_lt(s(f32::MIN_POSITIVE));
        let xs = sel(sub, x * s(8_388_608.0), x);
        let bits: i32xn = wide::bytemuck::cast(xs.to_bits());
        let sub_i: i32xn = wide::bytemuck::cast(sub);
        // `sub_i` is -1 where set: 23 of it is the scaling's exponent.
        let e = ((bits >> 23) & i32xn::splat(0xff)) - i32xn::splat(126) + sub_i * i32xn::splat(23);
        let m = f32xn::from_bits(
            (xs.to_bits() & crate::simd::u32xn::splat(0x807f_ffff))
                | crate::simd::u32xn::splat(0x3f00_0000),
        );
        let small = m.simd_lt(s(std::f32::consts::FRAC_1_SQRT_2));
        let small_i: i32xn = wide::bytemuck::cast(small);
        let e = e + small_i;
        let t = sel(small, m + m - s(1.0), m - s(1.0));
        let z = t * t;
        let y = ((((((((s(7.037_683_629_2e-2) * t - s(1.151_461_031_0e-1)) * t
            + s(1.167_699_874_0e-1))
            * t
            - s(1.242_014_084_6e-1))
            * t
            + s(1.424_932_278_7e-1))
            * t
            - s(1.666_805_766_5e-1))
            * t
            + s(2.000_071_476_5e-1))
            * t
            - s(2.499_999_399_3e-1))
            * t
            + s(3.333_333_117_4e-1))
            * t
            * z;
        let ef = crate::simd::float_of(e);
        let y = y + s(-2.121_944_40e-4) * ef;
        let y = y + s(-0.5) * z;
        let r = t + y + s(0.693_359_375) * ef;
        let inf = s(f32::INFINITY);
        let normal = x.simd_gt(s(0.0)) & x.simd_lt(inf);
        let r = sel(normal, r, s(f32::NAN));
        let r = sel(x.simd_eq(s(0.0)), s(f32::NEG_INFINITY), r);
        sel(x.simd_eq(inf), inf, r)
    }

    /// [`super::powf`] per lane.
    #[inline(always)]
    pub fn powf(x: f32xn, y: f32xn) -> f32xn {
        let r = exp(y * ln(x));
        sel(y.simd_eq(f32xn::splat(0.0)), f32xn::splat(1.0), r)
    }

    /// [`super::asin`] per lane.
    #[inline(always)]
    pub fn asin(x: f32xn) -> f32xn {
        let sign = u32xn::splat(SIGN);
        let a = asin_unit(x.abs());
        let r = f32xn::from_bits((a.to_bits() & !sign) | (x.to_bits() & sign));
        sel(
            x.abs().simd_le(f32xn::splat(1.0)),
            r,
            f32xn::splat(f32::NAN),
        )
    }

    /// [`super::acos`] per lane.
    #[inline(always)]
    pub fn acos(x: f32xn) -> f32xn {
        let a = f32xn::splat(FRAC_PI_2) - asin_unit(x.abs());
        let r = sel(x.simd_lt(f32xn::splat(0.0)), f32xn::splat(PI) - a, a);
        sel(
            x.abs().simd_le(f32xn::splat(1.0)),
            r,
            f32xn::splat(f32::NAN),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::LANES;

    #[test]
    fn sin_cos_matches_f64() {
        let mut worst = 0.0f64;
        let n = 400_000;
        for i in 0..=n {
            let x = -1.0e4 + 2.0e4 * i as f64 / n as f64;
            let xf = x as f32;
            let (s, c) = sin_cos(xf);
            let (se, ce) = (xf as f64).sin_cos();
            worst = worst.max((s as f64 - se).abs()).max((c as f64 - ce).abs());
        }
        for i in 0..=n {
            let xf = -7.0 + 14.0 * i as f32 / n as f32;
            let (s, c) = sin_cos(xf);
            let (se, ce) = (xf as f64).sin_cos();
            worst = worst.max((s as f64 - se).abs()).max((c as f64 - ce).abs());
        }
        assert!(worst < 2.5e-7, "sin_cos error {worst:e}");
        // Exact at 0; fallback for huge and NaN inputs.
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        let (s, c) = sin_cos(3.0e6);
        assert!((s - 3.0e6f32.sin()).abs() < 1e-6 && (c - 3.0e6f32.cos()).abs() < 1e-6);
        assert!(sin_cos(f32::NAN).0.is_nan() && sin_cos(f32::INFINITY).1.is_nan());
    }

    #[test]
    fn atan2_matches_f64() {
        let mut worst = 0.0f64;
        let n = 1000;
        for i in 0..=n {
            for j in 0..=n {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = 1e-3 + 10.0 * j as f64 / n as f64;
                let (y, x) = ((r * a.sin()) as f32, (r * a.cos()) as f32);
                let e = (y as f64).atan2(x as f64);
                let g = atan2(y, x) as f64;
                worst = worst.max((g - e).abs() / e.abs().max(1e-30));
            }
        }
        assert!(worst < 4e-7, "atan2 relative error {worst:e}");
        for (y, x) in [
            (0.0f32, 0.0f32),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (1.0, 0.0),
            (-1.0, 0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (1e-30, 1e30),
            (1e30, -1e-30),
        ] {
            let (g, e) = (atan2(y, x), y.atan2(x));
            assert!(
                (g - e).abs() <= 1e-7 * e.abs().max(1e-30)
                    && g.is_sign_negative() == e.is_sign_negative(),
                "atan2({y}, {x}) = {g}, expected {e}"
            );
        }
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }

    #[test]
    fn acos_matches_f64() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..=n {
            let x = (-1.0 + 2.0 * i as f64 / n as f64) as f32;
            worst = worst.max((acos(x) as f64 - (x as f64).acos()).abs());
        }
        // Next to +-1, where acos is steepest.
        let mut x = 1.0f32;
        for _ in 0..4096 {
            x = f32::from_bits(x.to_bits() - 1);
            worst = worst.max((acos(x) as f64 - (x as f64).acos()).abs());
            worst = worst.max((acos(-x) as f64 - (-x as f64).acos()).abs());
        }
        assert!(worst < 4e-7, "acos error {worst:e}");
        assert_eq!(acos(1.0), 0.0);
        assert!((acos(-1.0) - PI).abs() <= f32::EPSILON * PI);
        assert!(acos(1.0 + 1e-6).is_nan() && acos(f32::NAN).is_nan());
    }
    #[test]
    fn asin_matches_f64() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..=n {
            let x = (-1.0 + 2.0 * i as f64 / n as f64) as f32;
            worst = worst.max((asin(x) as f64 - (x as f64).asin()).abs());
        }
        let mut x = 1.0f32;
        for _ in 0..4096 {
            x = f32::from_bits(x.to_bits() - 1);
            worst = worst.max((asin(x) as f64 - (x as f64).asin()).abs());
            worst = worst.max((asin(-x) as f64 - (-x as f64).asin()).abs());
        }
        assert!(worst < 4e-7, "asin error {worst:e}");
        assert_eq!(asin(0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(asin(-0.0).to_bits(), (-0.0f32).to_bits());
        assert!((asin(1.0) - FRAC_PI_2).abs() <= f32::EPSILON);
        assert!(asin(1.0 + 1e-6).is_nan() && asin(f32::NAN).is_nan());
    }

    #[test]
    fn exp_matches_f64() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..=n {
            let x = -87.0 + 175.7 * i as f64 / n as f64;
            let xf = x as f32;
            let e = (xf as f64).exp();
            worst = worst.max((exp(xf) as f64 - e).abs() / e);
        }
        assert!(worst < 1.5e-7, "exp relative error {worst:e}");
        // Subnormal results: within one subnormal step (1.4e-45) and a few ulps.
        for i in 0..=10_000 {
            let xf = -103.9 + 16.9 * i as f32 / 10_000.0;
            let e = (xf as f64).exp();
            let g = exp(xf) as f64;
            assert!(
                (g - e).abs() <= 1.5e-45 + 4e-7 * e,
                "exp({xf}) = {g:e}, expected {e:e}"
            );
        }
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(89.0), f32::INFINITY);
        assert_eq!(exp(f32::INFINITY), f32::INFINITY);
        assert_eq!(exp(-105.0), 0.0);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert!(exp(f32::NAN).is_nan());
    }

    #[test]
    fn ln_matches_f64() {
        let mut worst = 0.0f64;
        let mut x = f32::from_bits(1);
        // Every 997th f32 from the smallest subnormal to the largest finite one.
        while x < f32::MAX {
            let e = (x as f64).ln();
            let err = (ln(x) as f64 - e).abs() / e.abs().max(1.0);
            worst = worst.max(err);
            x = f32::from_bits(x.to_bits() + 997);
        }
        // Next to 1, where ln is tiny.
        for i in 1..100_000 {
            for x in [1.0 + i as f32 * 1e-7, 1.0 - i as f32 * 6e-8] {
                let e = (x as f64).ln();
                worst = worst.max((ln(x) as f64 - e).abs() / e.abs().max(1.0));
                assert!((ln(x) as f64 - e).abs() <= 2e-7 * e.abs(), "ln({x})");
            }
        }
        assert!(worst < 1.2e-7, "ln error {worst:e}");
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(ln(0.0), f32::NEG_INFINITY);
        assert_eq!(ln(f32::INFINITY), f32::INFINITY);
        assert!(ln(-1.0).is_nan() && ln(f32::NAN).is_nan() && ln(-0.0) == f32::NEG_INFINITY);
    }

    #[test]
    fn powf_matches_f64() {
        let mut worst = 0.0f64;
        for i in 0..=2000 {
            let x = (i as f32 / 2000.0).max(1e-6);
            for y in [
                0.01f32, 0.5, 1.0, 2.0, 7.3, 30.0, 300.0, 6630.0, 1e4, 1e6, 1e7, -0.5, -3.0,
            ] {
                let e = (x as f64).powf(y as f64);
                if !(1e-38..=1e38).contains(&e) {
                    continue;
                }
                let rel = (powf(x, y) as f64 - e).abs() / e;
                worst = worst.max(rel);
            }
        }
        assert!(worst < 1e-5, "powf relative error {worst:e}");
        assert_eq!(powf(0.3, 0.0), 1.0);
        assert_eq!(powf(0.0, 0.0), 1.0);
        assert_eq!(powf(1.0, 1e7), 1.0);
        assert_eq!(powf(0.0, 2.5), 0.0);
        assert_eq!(powf(0.0, -2.5), f32::INFINITY);
        assert!(powf(-0.5, 2.0).is_nan());
        assert_eq!(powf(0.999, 1e9), 0.0);
    }

    /// The lane forms equal the scalar functions bit for bit.
    #[test]
    fn lane_forms_equal_the_scalar_forms_bit_for_bit() {
        use crate::simd::f32xn;
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        let mut xs: Vec<f32> = (0..=400_000)
            .map(|i| -1.0e4 + 2.0e4 * i as f32 / 400_000.0)
            .collect();
        xs.extend((0..=200_000).map(|i| -7.0 + 14.0 * i as f32 / 200_000.0));
        xs.extend((0..=200_000).map(|i| -1.0 + 2.0 * i as f32 / 200_000.0));
        xs.extend([
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            1.0 + f32::EPSILON,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-30,
            -1e-30,
            1e30,
            f32::from_bits(1),
            1e-40,
            f32::MIN_POSITIVE,
            f32::MAX,
            8872.3,
            -10397.5,
            0.999_999,
        ]);
        let ys: Vec<f32> = xs.iter().rev().copied().collect();
        for (xc, yc) in xs.chunks(LANES).zip(ys.chunks(LANES)) {
            let mut xa = [0.0f32; LANES];
            let mut ya = [0.0f32; LANES];
            xa[..xc.len()].copy_from_slice(xc);
            ya[..yc.len()].copy_from_slice(yc);
            let (x, y) = (f32xn::new(xa), f32xn::new(ya));
            let (s, c) = xn::sin_cos_moderate(x);
            let (s, c) = (s.to_array(), c.to_array());
            let at = xn::atan2(y, x).to_array();
            let ac = xn::acos(x).to_array();
            let asn = xn::asin(x).to_array();
            let ex = xn::exp(x * f32xn::splat(0.01)).to_array();
            let lg = xn::ln(x).to_array();
            let pw = xn::powf(x.abs(), y).to_array();
            for i in 0..LANES {
                if xa[i].abs() <= 1.0e4 {
                    let (se, ce) = sin_cos_moderate(xa[i]);
                    assert!(same(s[i], se) && same(c[i], ce), "sin_cos({})", xa[i]);
                }
                assert!(
                    same(at[i], atan2(ya[i], xa[i])),
                    "atan2({}, {})",
                    ya[i],
                    xa[i]
                );
                assert!(same(ac[i], acos(xa[i])), "acos({})", xa[i]);
                assert!(same(asn[i], asin(xa[i])), "asin({})", xa[i]);
                assert!(same(ex[i], exp(xa[i] * 0.01)), "exp({})", xa[i] * 0.01);
                assert!(same(lg[i], ln(xa[i])), "ln({})", xa[i]);
                let (px, py) = (xa[i].abs(), ya[i]);
                assert!(same(pw[i], powf(px, py)), "powf({px}, {py})");
            }
        }
    }
}
