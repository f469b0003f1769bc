//! Branch-free single-precision `sin_cos`, `atan2`, `acos`, `asin`, `exp`, `ln` and `powf`
//! for the hot paths (env-map lookups and sampling, direction warps, measured-BRDF
//! coordinates, the analytic lobes' half-vector sampling), a few times faster than the C
//! library's.
//!
//! Each is a Cody-Waite range reduction followed by the minimax polynomials of Cephes'
//! single-precision `sinf`/`cosf`, `atanf`, `asinf`, `expf` and `logf` (S. L. Moshier,
//! "Methods and Programs for Mathematical Functions", 1989; the same approximations Dr.Jit,
//! and so Mitsuba 3, uses). Each is written once over [`Single`] (one f32, or f32 lanes)
//! with selects instead of branches, so that a lane's result equals the scalar
//! instantiation's bit for bit (tested), batched and one-at-a-time renders agree exactly,
//! and no branch mispredicts on random arguments. Accuracy, checked against f64 over dense
//! grids by the tests below: absolute error under 2.5e-7 for `sin_cos` (|x| <= 1e4; larger
//! arguments fall back to the C library in [`sin_cos`]), under 4e-7 for `acos` (below 2 ulp
//! of its result near pi) and `asin`, relative error under 4e-7 for `atan2`. NaN inputs
//! give NaN.

// The coefficients are Cephes' published decimal values, kept as printed.
#![allow(clippy::excessive_precision)]

use crate::math::{Single, abs, copysign, eq, gt, le, lt, maximum, minimum, select, sqrt};
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

/// Whether `x` is NaN (per lane).
#[inline(always)]
fn is_nan<T: Single>(x: T) -> T::Mask {
    !eq(x, x)
}

/// (sin x, cos x) for |x| <= 1e4 (inaccurate beyond), without the branch to the C
/// library.
#[inline(always)]
pub fn sin_cos_moderate<T: Single>(x: T) -> (T, T) {
    let s = T::of32;
    // x = k pi/2 + r, |r| <= pi/4, with pi/2 split in three parts (Cephes' DP1..DP3
    // doubled) so that k * part is exact.
    let k = (x * s(std::f32::consts::FRAC_2_PI)).round_ties_even();
    let r = ((x - k * s(1.570_312_5)) - k * s(4.837_512_969_970_703e-4))
        - k * s(7.549_789_948_768_648e-8);
    let z = r * r;
    let sin = r + r
        * z
        * ((s(-1.951_529_589_1e-4) * z + s(8.332_160_873_6e-3)) * z - s(1.666_665_461_1e-1));
    let cos = s(1.0) - s(0.5) * z
        + z * z
            * ((s(2.443_315_711_809_948e-5) * z - s(1.388_731_625_493_765e-3)) * z
                + s(4.166_664_568_298_827e-2));
    // The quadrant (0 for NaN, as `trunc_int` gives).
    let q = k.trunc_int() & T::int(3);
    let odd = T::int_eq(q & T::int(1), T::int(1));
    let (s1, c1) = (select(odd, cos, sin), select(odd, sin, cos));
    let neg_s = (q & T::int(2)) << 30;
    let neg_c = ((q + T::int(1)) & T::int(2)) << 30;
    (
        T::from_bits(s1.to_bits() ^ neg_s),
        T::from_bits(c1.to_bits() ^ neg_c),
    )
}

/// `if c { a } else { b }` by bit masks, kept branch-free: for choices a branch predictor
/// cannot learn (which half of a random square a point falls in), where a mispredicted
/// branch costs more than computing both sides. The mask goes through `black_box` since
/// the compiler otherwise turns the masks back into a branch.
#[inline(always)]
pub fn select_branchless(c: bool, a: f32, b: f32) -> f32 {
    let m = std::hint::black_box(0u32.wrapping_sub(c as u32));
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// atan(t) for t in [0, 1].
#[inline(always)]
fn atan_unit<T: Single>(t: T) -> T {
    let s = T::of32;
    // Above tan(pi/8), atan t = pi/4 + atan((t - 1) / (t + 1)).
    let big = gt(t, s(0.414_213_57));
    let x = select(big, (t - s(1.0)) / (t + s(1.0)), t);
    let z = x * x;
    let p = (((s(8.053_744_495_38e-2) * z - s(1.387_768_560_32e-1)) * z + s(1.997_771_064_78e-1))
        * z
        - s(3.333_294_915_39e-1))
        * z
        * x
        + x;
    select(big, p + s(FRAC_PI_4), p)
}

/// atan2(y, x) in [-pi, pi], with the C library's signs and special cases for finite
/// inputs (atan2(±0, +0) = ±0, atan2(±0, -0) = ±pi).
#[inline(always)]
pub fn atan2<T: Single>(y: T, x: T) -> T {
    let s = T::of32;
    let (ax, ay) = (abs(x), abs(y));
    let (lo, hi) = (minimum(ax, ay), maximum(ax, ay));
    let t = select(gt(hi, s(0.0)), lo / hi, s(0.0));
    let a = atan_unit(t);
    let a = select(gt(ay, ax), s(FRAC_PI_2) - a, a);
    let x_negative = T::int_lt(x.to_bits(), T::int(0));
    let a = select(x_negative, s(PI) - a, a);
    let a = copysign(a, y);
    select(is_nan(x) | is_nan(y), s(f32::NAN), a)
}

/// asin(x) for x in [0, 1].
#[inline(always)]
fn asin_unit<T: Single>(x: T) -> T {
    let s = T::of32;
    let big = gt(x, s(0.5));
    let z = select(big, s(0.5) * (s(1.0) - x), x * x);
    let r = select(big, sqrt(z), x);
    let p = ((((s(4.216_319_904_8e-2) * z + s(2.418_131_104_9e-2)) * z + s(4.547_002_599_8e-2))
        * z
        + s(7.495_300_268_6e-2))
        * z
        + s(1.666_675_242_2e-1))
        * z
        * r
        + r;
    select(big, s(FRAC_PI_2) - s(2.0) * p, p)
}

/// asin(x) for x in [-1, 1] (NaN outside, as the C library).
#[inline(always)]
pub fn asin<T: Single>(x: T) -> T {
    let r = copysign(asin_unit(abs(x)), x);
    select(le(abs(x), T::of32(1.0)), r, T::of32(f32::NAN))
}

/// acos(x) for x in [-1, 1] (NaN outside, as the C library).
#[inline(always)]
pub fn acos<T: Single>(x: T) -> T {
    let s = T::of32;
    let a = s(FRAC_PI_2) - asin_unit(abs(x));
    let r = select(lt(x, s(0.0)), s(PI) - a, a);
    select(le(abs(x), s(1.0)), r, s(f32::NAN))
}

/// Bounds of [`exp`]: above, +inf (ln of the largest f32); below, 0 (just above ln of the
/// smallest normal f32, -87.3365, so that every result it keeps is normal).
const EXP_OVER: f32 = 88.722_84;
const EXP_FLUSH: f32 = -87.33;

/// 2^n for an integer n in [-252, 254] as two normal factors (so that no partial product
/// leaves the normal range).
#[inline(always)]
fn pow2_halves<T: Single>(n: T::Int) -> (T, T) {
    let n1 = n >> 1;
    let n2 = n - n1;
    let f = |k: T::Int| T::from_bits((k + T::int(127)) << 23);
    (f(n1), f(n2))
}

/// e^x: Cephes `expf` (x = n ln 2 + r with ln 2 in two parts, a degree-6 polynomial in r,
/// times 2^n); relative error under 1.5e-7 (tested), +inf above ln(f32::MAX), NaN for NaN,
/// and 0 below e^-87.33, next to the smallest normal f32 (as a CPU that flushes subnormals
/// to zero gives). For normal arguments above 1e-19 in magnitude no operation of it makes a
/// subnormal: on x86 cores each instruction whose result is subnormal takes a microcode
/// assist of about a hundred cycles, and the lobes call exp far into their tails (a Beckmann
/// lobe of m 0.12 at 60 degrees from its peak is e^-208), where the lanes gave such results
/// in most chunks.
#[inline(always)]
pub fn exp<T: Single>(x: T) -> T {
    let s = T::of32;
    let xc = crate::math::clamp(x, s(EXP_FLUSH), s(88.8));
    let n = crate::math::floor(xc * s(std::f32::consts::LOG2_E) + s(0.5));
    let r = xc - n * s(0.693_359_375) - n * s(-2.121_944_40e-4);
    let z = r * r;
    let p = (((((s(1.987_569_150_0e-4) * r + s(1.398_199_950_7e-3)) * r + s(8.333_451_907_3e-3))
        * r
        + s(4.166_579_589_4e-2))
        * r
        + s(1.666_666_545_9e-1))
        * r
        + s(5.000_000_120_1e-1))
        * z
        + r
        + s(1.0);
    // n is 0 for NaN (`trunc_int`), within [-126, 128] otherwise.
    let (s1, s2) = pow2_halves::<T>(n.trunc_int());
    let y = p * s1 * s2;
    let y = select(lt(x, s(EXP_FLUSH)), s(0.0), y);
    select(gt(x, s(EXP_OVER)), s(f32::INFINITY), y)
}

/// ln x: Cephes `logf` (x = m 2^e with m in [sqrt(1/2), sqrt(2)), a degree-9 polynomial in
/// m - 1); absolute error under 1.2e-7 near 1 and relative error under 1.2e-7 elsewhere
/// (tested), subnormal inputs included; -inf at 0, NaN below 0 and for NaN, +inf at +inf.
#[inline(always)]
pub fn ln<T: Single>(x: T) -> T {
    let s = T::of32;
    let sub = lt(x, s(f32::MIN_POSITIVE));
    let xs = select(sub, x * s(8_388_608.0), x);
    let bits = xs.to_bits();
    // `mask_int(sub)` is -1 where set: 23 of it is the scaling's exponent.
    let e = ((bits >> 23) & T::int(0xff)) - T::int(126) + T::mask_int(sub) * T::int(23);
    // The mantissa in [0.5, 1).
    let m = T::from_bits((bits & T::int(0x807f_ffff_u32 as i32)) | T::int(0x3f00_0000));
    let small = lt(m, s(std::f32::consts::FRAC_1_SQRT_2));
    let e = e + T::mask_int(small);
    let t = select(small, m + m - s(1.0), m - s(1.0));
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
    let ef = T::of_int(e);
    let y = y + s(-2.121_944_40e-4) * ef;
    let y = y + s(-0.5) * z;
    let r = t + y + s(0.693_359_375) * ef;
    let inf = s(f32::INFINITY);
    let r = select(gt(x, s(0.0)) & lt(x, inf), r, s(f32::NAN));
    let r = select(eq(x, s(0.0)), s(f32::NEG_INFINITY), r);
    select(eq(x, inf), inf, r)
}

/// x^y for x >= 0 as e^(y ln x) ([`exp`], [`ln`]): 1 when y = 0, 0 or +inf at x = 0, NaN
/// for x < 0, and 0 where the result is below e^-87.33 ([`exp`]). The relative error grows
/// with |y ln x|: about 1e-7 (|y ln x| + 2), so under 1e-5 wherever the result is above
/// 1.2e-38 (tested).
#[inline(always)]
pub fn powf<T: Single>(x: T, y: T) -> T {
    let r = exp(y * ln(x));
    select(eq(y, T::of32(0.0)), T::of32(1.0), r)
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
        // Next to the smallest normal: normal results, or 0 below it.
        for i in 0..=10_000 {
            let xf = -88.0 + 1.0 * i as f32 / 10_000.0;
            let e = (xf as f64).exp();
            let g = exp(xf);
            let expected = if xf < EXP_FLUSH { 0.0 } else { e };
            assert!(g == 0.0 || g.is_normal(), "exp({xf}) = {g:e} is subnormal");
            assert!(
                (g as f64 - expected).abs() <= 2e-7 * expected,
                "exp({xf}) = {g:e}, expected {expected:e}"
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
                if !(1.2e-38..=1e38).contains(&e) {
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

    /// The lane instantiation of each function equals its scalar instantiation bit for bit.
    #[test]
    fn lanes_equal_the_scalar_instantiation_bit_for_bit() {
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
            let (s, c) = sin_cos_moderate(x);
            let (s, c) = (s.to_array(), c.to_array());
            let at = atan2(y, x).to_array();
            let ac = acos(x).to_array();
            let asn = asin(x).to_array();
            let ex = exp(x * f32xn::splat(0.01)).to_array();
            let lg = ln(x).to_array();
            let pw = powf(x.abs(), y).to_array();
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
