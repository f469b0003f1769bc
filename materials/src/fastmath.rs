//! Branch-free f32 `sin_cos`, `atan2`, `acos` and `asin` for the hot paths (env-map
//! lookups and sampling, direction warps, measured-BRDF coordinates), a few times faster
//! than the C library's.
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
//! [`x8`] has eight-lane forms of the same functions on `wide`'s AVX vectors, for the
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

/// Eight-lane forms of the functions above ([`sin_cos_moderate`], [`atan2`], [`acos`],
/// [`asin`]) on `wide`'s AVX vectors: the same operations in the same order on each
/// lane, so every lane's result equals the scalar function's bit for bit (tested below),
/// and batched lookups agree exactly with one-at-a-time ones.
pub mod x8 {
    use crate::simd::sel;
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    use wide::{f32x8, u32x8};

    const SIGN: u32 = 0x8000_0000;

    /// [`super::sin_cos_moderate`] per lane.
    #[inline(always)]
    pub fn sin_cos_moderate(x: f32x8) -> (f32x8, f32x8) {
        let k = (x * f32x8::splat(std::f32::consts::FRAC_2_PI)).round_ties_even();
        let r = ((x - k * f32x8::splat(1.570_312_5)) - k * f32x8::splat(4.837_512_969_970_703e-4))
            - k * f32x8::splat(7.549_789_948_768_648e-8);
        let z = r * r;
        let s = r + r
            * z
            * ((f32x8::splat(-1.951_529_589_1e-4) * z + f32x8::splat(8.332_160_873_6e-3)) * z
                - f32x8::splat(1.666_665_461_1e-1));
        let c = f32x8::splat(1.0) - f32x8::splat(0.5) * z
            + z * z
                * ((f32x8::splat(2.443_315_711_809_948e-5) * z
                    - f32x8::splat(1.388_731_625_493_765e-3))
                    * z
                    + f32x8::splat(4.166_664_568_298_827e-2));
        // The quadrant; `k as i32` of the scalar form is 0 for NaN, and so is this.
        let q: u32x8 = wide::bytemuck::cast(k.trunc_int());
        let odd = f32x8::from_bits((q & u32x8::splat(1)).simd_eq(u32x8::splat(1)));
        let (s1, c1) = (sel(odd, c, s), sel(odd, s, c));
        let neg_s = (q & u32x8::splat(2)) << 30;
        let neg_c = ((q + u32x8::splat(1)) & u32x8::splat(2)) << 30;
        (
            f32x8::from_bits(s1.to_bits() ^ neg_s),
            f32x8::from_bits(c1.to_bits() ^ neg_c),
        )
    }

    #[inline(always)]
    fn atan_unit(t: f32x8) -> f32x8 {
        let one = f32x8::splat(1.0);
        let big = t.simd_gt(f32x8::splat(0.414_213_57));
        let x = sel(big, (t - one) / (t + one), t);
        let z = x * x;
        let p = (((f32x8::splat(8.053_744_495_38e-2) * z - f32x8::splat(1.387_768_560_32e-1)) * z
            + f32x8::splat(1.997_771_064_78e-1))
            * z
            - f32x8::splat(3.333_294_915_39e-1))
            * z
            * x
            + x;
        sel(big, p + f32x8::splat(FRAC_PI_4), p)
    }

    /// [`super::atan2`] per lane.
    #[inline(always)]
    pub fn atan2(y: f32x8, x: f32x8) -> f32x8 {
        let (ax, ay) = (x.abs(), y.abs());
        let (lo, hi) = (ax.min(ay), ax.max(ay));
        let zero = f32x8::splat(0.0);
        let t = sel(hi.simd_gt(zero), lo / hi, zero);
        let mut a = atan_unit(t);
        a = sel(ay.simd_gt(ax), f32x8::splat(FRAC_PI_2) - a, a);
        a = sel(x.is_sign_negative(), f32x8::splat(PI) - a, a);
        let sign = u32x8::splat(SIGN);
        let a = f32x8::from_bits((a.to_bits() & !sign) | (y.to_bits() & sign));
        sel(x.is_nan() | y.is_nan(), f32x8::splat(f32::NAN), a)
    }

    #[inline(always)]
    fn asin_unit(x: f32x8) -> f32x8 {
        let big = x.simd_gt(f32x8::splat(0.5));
        let z = sel(big, f32x8::splat(0.5) * (f32x8::splat(1.0) - x), x * x);
        let s = sel(big, z.sqrt(), x);
        let p = ((((f32x8::splat(4.216_319_904_8e-2) * z + f32x8::splat(2.418_131_104_9e-2)) * z
            + f32x8::splat(4.547_002_599_8e-2))
            * z
            + f32x8::splat(7.495_300_268_6e-2))
            * z
            + f32x8::splat(1.666_675_242_2e-1))
            * z
            * s
            + s;
        sel(big, f32x8::splat(FRAC_PI_2) - f32x8::splat(2.0) * p, p)
    }

    /// [`super::asin`] per lane.
    #[inline(always)]
    pub fn asin(x: f32x8) -> f32x8 {
        let sign = u32x8::splat(SIGN);
        let a = asin_unit(x.abs());
        let r = f32x8::from_bits((a.to_bits() & !sign) | (x.to_bits() & sign));
        sel(
            x.abs().simd_le(f32x8::splat(1.0)),
            r,
            f32x8::splat(f32::NAN),
        )
    }

    /// [`super::acos`] per lane.
    #[inline(always)]
    pub fn acos(x: f32x8) -> f32x8 {
        let a = f32x8::splat(FRAC_PI_2) - asin_unit(x.abs());
        let r = sel(x.simd_lt(f32x8::splat(0.0)), f32x8::splat(PI) - a, a);
        sel(
            x.abs().simd_le(f32x8::splat(1.0)),
            r,
            f32x8::splat(f32::NAN),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// The eight-lane forms equal the scalar functions bit for bit.
    #[test]
    fn x8_forms_are_bit_identical() {
        use wide::f32x8;
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
        ]);
        let ys: Vec<f32> = xs.iter().rev().copied().collect();
        for (xc, yc) in xs.chunks(8).zip(ys.chunks(8)) {
            let mut xa = [0.0f32; 8];
            let mut ya = [0.0f32; 8];
            xa[..xc.len()].copy_from_slice(xc);
            ya[..yc.len()].copy_from_slice(yc);
            let (x, y) = (f32x8::new(xa), f32x8::new(ya));
            let (s, c) = x8::sin_cos_moderate(x);
            let (s, c) = (s.to_array(), c.to_array());
            let at = x8::atan2(y, x).to_array();
            let ac = x8::acos(x).to_array();
            let asn = x8::asin(x).to_array();
            for i in 0..8 {
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
            }
        }
    }
}
