//! The numeric abstraction that lets each formula be written once and evaluated in f64
//! (fitting), f32 (rendering, one query) and lanes of f32 (rendering, [`crate::simd::f32xn`]):
//! [`Num`], with masks and [`select`] in the manner of Dr.Jit's `dr::select` (Mitsuba 3
//! writes each BSDF once over one `Float` type the same way). A formula over [`Num`] that
//! branches computes both sides and selects, so its lanes give bit for bit what its scalar
//! instantiation gives. The transcendental functions are `fastmath`'s in f32 and in lanes
//! (written once over [`Single`], so that the two agree bit for bit), the C library's in
//! f64. Its arithmetic, comparisons and `select` are [`Arith`], which lanes of either width
//! (`f32x8`, `f32x16`) also implement, for the geometry kernels that serve both. [`Real`] is
//! the scalar subset (f32, f64) over num-traits' `Float`, and [`V3`] the one 3-vector.

use crate::simd::{f32xn, i32xn};
use num_traits::{Float, FloatConst};
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Shl, Shr, Sub};

/// The arithmetic of a number: one f32 or f64, or lanes of f32 of either width `wide`
/// offers on x86 (`f32x8`, `f32x16`; [`f32xn`] is one of them). Comparisons give an
/// [`Arith::Mask`] (a bool, or a lane mask: all bits set where true) that [`select`] reads.
/// The geometry kernels are written over it alone, since they serve two lane widths (one
/// ray against a BVH8 leaf block of eight primitives, `f32x8`, and [`f32xn`] rays against
/// one primitive); the models over [`Num`], which adds the elementary functions and table
/// lookups. The methods carry a `num_` prefix so that they never shadow `Float`'s on a
/// [`Real`]; formulas call the free functions ([`select`], [`minimum`], [`maximum`], [`le`],
/// [`lt`], [`gt`], [`ge`], [`eq`], [`abs`], [`sqrt`], [`exp`], [`ln`], [`powf`], [`acos`],
/// [`asin`], [`atan2`], [`sin_cos`], [`floor`], [`to_degrees`], [`copysign`], [`mul_add`],
/// [`clamp`], [`all`]) and the index methods (`T::int`, `T::gather`, ...) directly.
pub trait Arith:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A per-value condition.
    type Mask: Copy
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// The constant `x`, rounded to the type's precision (every lane `x as f32`).
    fn of(x: f64) -> Self;
    fn num_select(m: Self::Mask, t: Self, f: Self) -> Self;
    fn num_min(self, o: Self) -> Self;
    fn num_max(self, o: Self) -> Self;
    fn num_le(self, o: Self) -> Self::Mask;
    fn num_lt(self, o: Self) -> Self::Mask;
    fn num_eq(self, o: Self) -> Self::Mask;
    /// The square root (IEEE, as `f32::sqrt`).
    fn num_sqrt(self) -> Self;
    /// Neither infinite nor NaN.
    fn num_is_finite(self) -> Self::Mask;
    /// |x|.
    fn num_abs(self) -> Self;
    /// The magnitude of `self` with the sign bit of `sign`.
    fn num_copysign(self, sign: Self) -> Self;
    /// Whether the condition holds everywhere (every lane).
    fn mask_all(m: Self::Mask) -> bool;
}

/// A number a formula is written over: one f32 or f64, or [`f32xn`] lanes; [`Arith`]'s
/// operations and the elementary functions, and [`Num::Int`], the index type of table
/// lookups (i32, or i32 lanes), with gathers from f32 tables.
pub trait Num: Arith {
    /// e^x: [`crate::fastmath::exp`] in f32 and lanes, the C library's in f64.
    fn num_exp(self) -> Self;
    /// acos x, as [`Num::num_exp`]: [`crate::fastmath::acos`] in f32.
    fn num_acos(self) -> Self;
    /// x^y, as [`Num::num_exp`]: [`crate::fastmath::powf`] in f32.
    fn num_powf(self, y: Self) -> Self;
    /// (sin x, cos x) for |x| up to a few pi: [`crate::fastmath::sin_cos_moderate`] in f32
    /// and lanes, the C library's in f64.
    fn num_sin_cos(self) -> (Self, Self);
    /// atan2(self, x) in [-pi, pi]: [`crate::fastmath::atan2`] in f32, the C library's
    /// in f64.
    fn num_atan2(self, x: Self) -> Self;
    /// asin x, as [`Num::num_exp`]: [`crate::fastmath::asin`] in f32.
    fn num_asin(self) -> Self;
    /// ln x, as [`Num::num_exp`]: [`crate::fastmath::ln`] in f32.
    fn num_ln(self) -> Self;
    /// The largest integer not above `self` (`f32::floor`).
    fn num_floor(self) -> Self;
    /// Radians to degrees: times 180 / pi (in f32 and lanes the quotient of the f32
    /// constants, in f64 `f64::to_degrees`).
    fn num_to_degrees(self) -> Self;
    /// `self * a + b` with one rounding (`f32::mul_add`; [`crate::simd::fmadd`] in lanes).
    fn num_mul_add(self, a: Self, b: Self) -> Self;
    /// An index per value (one i32, or [`crate::simd::i32xn`] lanes), for table lookups.
    type Int: Copy
        + Add<Output = Self::Int>
        + Sub<Output = Self::Int>
        + Mul<Output = Self::Int>
        + BitAnd<Output = Self::Int>
        + BitOr<Output = Self::Int>
        + BitXor<Output = Self::Int>
        + Shl<i32, Output = Self::Int>
        + Shr<i32, Output = Self::Int>;
    /// The index `i` (in every lane).
    fn int(i: i32) -> Self::Int;
    /// The smaller index (per lane).
    fn int_min(a: Self::Int, b: Self::Int) -> Self::Int;
    /// The larger index (per lane).
    fn int_max(a: Self::Int, b: Self::Int) -> Self::Int;
    /// `a < b` (per lane).
    fn int_lt(a: Self::Int, b: Self::Int) -> Self::Mask;
    /// `a == b` (per lane).
    fn int_eq(a: Self::Int, b: Self::Int) -> Self::Mask;
    /// `f(i)` per lane: records of `N` values looked up by index, one lane's record in
    /// each lane.
    fn gather_by<const N: usize>(i: Self::Int, f: impl Fn(usize) -> [f32; N]) -> [Self; N];
    /// `a` where `m` holds, else `b` (per lane).
    fn int_select(m: Self::Mask, a: Self::Int, b: Self::Int) -> Self::Int;
    /// `self` truncated toward zero to an index, saturating at i32's range, NaN giving 0
    /// (Rust's `as i32`, and `wide`'s `trunc_int` in lanes).
    fn trunc_int(self) -> Self::Int;
    /// The index as a number.
    fn of_int(i: Self::Int) -> Self;
    /// `table[i]` (per lane); an index outside the table panics.
    fn gather(table: &[f32], i: Self::Int) -> Self;
    /// `table[i..i + 4]` as four values (per lane): a node of a four-channel table.
    fn gather4(table: &[f32], i: Self::Int) -> [Self; 4];
}

/// `t` where `m` holds, else `f` (per lane).
#[inline(always)]
pub fn select<T: Arith>(m: T::Mask, t: T, f: T) -> T {
    T::num_select(m, t, f)
}

/// `a` where `m` holds, else `b`, per component (per lane).
#[inline(always)]
pub fn select_v3<T: Arith>(m: T::Mask, a: V3<T>, b: V3<T>) -> V3<T> {
    V3::new(
        select(m, a.x, b.x),
        select(m, a.y, b.y),
        select(m, a.z, b.z),
    )
}
/// The smaller of `a` and `b` (per lane, `wide`'s rule in every form: `a` where `b` is NaN,
/// else `b` where `a` is NaN or the two are equal).
#[inline(always)]
pub fn minimum<T: Arith>(a: T, b: T) -> T {
    a.num_min(b)
}
/// The larger of `a` and `b` (as [`minimum`]).
#[inline(always)]
pub fn maximum<T: Arith>(a: T, b: T) -> T {
    a.num_max(b)
}
/// `a <= b`.
#[inline(always)]
pub fn le<T: Arith>(a: T, b: T) -> T::Mask {
    a.num_le(b)
}
/// `a < b`.
#[inline(always)]
pub fn lt<T: Arith>(a: T, b: T) -> T::Mask {
    a.num_lt(b)
}
/// `a > b`.
#[inline(always)]
pub fn gt<T: Arith>(a: T, b: T) -> T::Mask {
    b.num_lt(a)
}
/// `a >= b`.
#[inline(always)]
pub fn ge<T: Arith>(a: T, b: T) -> T::Mask {
    b.num_le(a)
}
/// Neither infinite nor NaN ([`Arith::num_is_finite`]).
#[inline(always)]
pub fn is_finite<T: Arith>(x: T) -> T::Mask {
    x.num_is_finite()
}
/// `x` clamped to [`lo`, `hi`], NaN staying NaN (as `f32::clamp`).
#[inline(always)]
pub fn clamp<T: Arith>(x: T, lo: T, hi: T) -> T {
    let x = select(lt(x, lo), lo, x);
    select(gt(x, hi), hi, x)
}
/// |x|.
#[inline(always)]
pub fn abs<T: Arith>(x: T) -> T {
    x.num_abs()
}
/// (sin x, cos x) ([`Num::num_sin_cos`]).
#[inline(always)]
pub fn sin_cos<T: Num>(x: T) -> (T, T) {
    x.num_sin_cos()
}
/// asin x ([`Num::num_asin`]).
#[inline(always)]
pub fn asin<T: Num>(x: T) -> T {
    x.num_asin()
}
/// atan2(y, x) ([`Num::num_atan2`]).
#[inline(always)]
pub fn atan2<T: Num>(y: T, x: T) -> T {
    y.num_atan2(x)
}
/// `a == b`.
#[inline(always)]
pub fn eq<T: Arith>(a: T, b: T) -> T::Mask {
    a.num_eq(b)
}
/// e^x ([`Num::num_exp`]).
#[inline(always)]
pub fn exp<T: Num>(x: T) -> T {
    x.num_exp()
}
/// acos x ([`Num::num_acos`]).
#[inline(always)]
pub fn acos<T: Num>(x: T) -> T {
    x.num_acos()
}
/// The square root ([`Arith::num_sqrt`]).
#[inline(always)]
pub fn sqrt<T: Arith>(x: T) -> T {
    x.num_sqrt()
}
/// x^y ([`Num::num_powf`]).
#[inline(always)]
pub fn powf<T: Num>(x: T, y: T) -> T {
    x.num_powf(y)
}
/// ln x ([`Num::num_ln`]).
#[inline(always)]
pub fn ln<T: Num>(x: T) -> T {
    x.num_ln()
}
/// The magnitude of `x` with the sign bit of `sign` ([`Arith::num_copysign`]).
#[inline(always)]
pub fn copysign<T: Arith>(x: T, sign: T) -> T {
    x.num_copysign(sign)
}
/// `a * b + c` with one rounding ([`Num::num_mul_add`]).
#[inline(always)]
pub fn mul_add<T: Num>(a: T, b: T, c: T) -> T {
    a.num_mul_add(b, c)
}
/// Radians to degrees ([`Num::num_to_degrees`]).
#[inline(always)]
pub fn to_degrees<T: Num>(x: T) -> T {
    x.num_to_degrees()
}
/// The largest integer not above `x` ([`Num::num_floor`]).
#[inline(always)]
pub fn floor<T: Num>(x: T) -> T {
    x.num_floor()
}
/// Whether `m` holds in every lane ([`Arith::mask_all`]).
#[inline(always)]
pub fn all<T: Arith>(m: T::Mask) -> bool {
    T::mask_all(m)
}

macro_rules! scalar_num {
    ($t:ty, exp: $exp:path, powf: $powf:path, acos: $acos:path, sin_cos: $sin_cos:path, atan2: $atan2:path, asin: $asin:path, ln: $ln:path, degrees: $deg:expr) => {
        impl Arith for $t {
            type Mask = bool;
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn num_select(m: bool, t: Self, f: Self) -> Self {
                if m { t } else { f }
            }
            // `wide`'s rule, which the lanes follow: the first operand where the second is
            // NaN; else the second where the first is NaN or the two are equal (so
            // `maximum(-0.0, 0.0)` is 0.0 in every form; `f32::max` gives -0.0 in some
            // builds and +0.0 in others).
            #[inline(always)]
            fn num_min(self, o: Self) -> Self {
                if o.is_nan() || self < o { self } else { o }
            }
            #[inline(always)]
            fn num_max(self, o: Self) -> Self {
                if o.is_nan() || o < self { self } else { o }
            }
            #[inline(always)]
            fn num_le(self, o: Self) -> bool {
                self <= o
            }
            #[inline(always)]
            fn num_lt(self, o: Self) -> bool {
                self < o
            }
            #[inline(always)]
            fn num_eq(self, o: Self) -> bool {
                self == o
            }
            #[inline(always)]
            fn num_sqrt(self) -> Self {
                self.sqrt()
            }
            #[inline(always)]
            fn num_is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn num_abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn num_copysign(self, sign: Self) -> Self {
                <$t>::copysign(self, sign)
            }
            #[inline(always)]
            fn mask_all(m: bool) -> bool {
                m
            }
        }
        impl Num for $t {
            #[inline(always)]
            fn num_exp(self) -> Self {
                $exp(self)
            }
            #[inline(always)]
            fn num_acos(self) -> Self {
                $acos(self)
            }
            #[inline(always)]
            fn num_powf(self, y: Self) -> Self {
                $powf(self, y)
            }
            #[inline(always)]
            fn num_sin_cos(self) -> (Self, Self) {
                $sin_cos(self)
            }
            #[inline(always)]
            fn num_atan2(self, x: Self) -> Self {
                $atan2(self, x)
            }
            #[inline(always)]
            fn num_asin(self) -> Self {
                $asin(self)
            }
            #[inline(always)]
            fn num_ln(self) -> Self {
                $ln(self)
            }
            #[inline(always)]
            fn num_mul_add(self, a: Self, b: Self) -> Self {
                <$t>::mul_add(self, a, b)
            }
            #[inline(always)]
            fn num_floor(self) -> Self {
                <$t>::floor(self)
            }
            #[inline(always)]
            fn num_to_degrees(self) -> Self {
                $deg(self)
            }
            type Int = i32;
            #[inline(always)]
            fn int(i: i32) -> i32 {
                i
            }
            #[inline(always)]
            fn int_min(a: i32, b: i32) -> i32 {
                a.min(b)
            }
            #[inline(always)]
            fn int_max(a: i32, b: i32) -> i32 {
                a.max(b)
            }
            #[inline(always)]
            fn int_lt(a: i32, b: i32) -> bool {
                a < b
            }
            #[inline(always)]
            fn int_eq(a: i32, b: i32) -> bool {
                a == b
            }
            #[inline(always)]
            fn gather_by<const N: usize>(i: i32, f: impl Fn(usize) -> [f32; N]) -> [Self; N] {
                f(i as usize).map(|v| v as $t)
            }
            #[inline(always)]
            fn int_select(m: bool, a: i32, b: i32) -> i32 {
                if m { a } else { b }
            }
            #[inline(always)]
            fn trunc_int(self) -> i32 {
                self as i32
            }
            #[inline(always)]
            fn of_int(i: i32) -> Self {
                i as $t
            }
            #[inline(always)]
            fn gather(table: &[f32], i: i32) -> Self {
                table[i as usize] as $t
            }
            #[inline(always)]
            fn gather4(table: &[f32], i: i32) -> [Self; 4] {
                let i = i as usize;
                let r = &table[i..i + 4];
                [r[0] as $t, r[1] as $t, r[2] as $t, r[3] as $t]
            }
        }
    };
}
// f32 (rendering) takes `fastmath`'s functions, which the lane instantiation also takes
// (one code, so one value and lanes agree bit for bit); f64 (fitting) the C library's.
scalar_num!(
    f32,
    exp: crate::fastmath::exp,
    powf: crate::fastmath::powf,
    acos: crate::fastmath::acos,
    sin_cos: crate::fastmath::sin_cos_moderate,
    atan2: crate::fastmath::atan2,
    asin: crate::fastmath::asin,
    ln: crate::fastmath::ln,
    degrees: |x: f32| x * (180.0 / std::f32::consts::PI)
);
scalar_num!(
    f64,
    exp: f64::exp,
    powf: f64::powf,
    acos: f64::acos,
    sin_cos: f64::sin_cos,
    atan2: f64::atan2,
    asin: f64::asin,
    ln: f64::ln,
    degrees: f64::to_degrees
);

// One code for both widths of lanes (the BVH8 leaf blocks are eight wide in every build).
macro_rules! lane_arith {
    ($($t:ty),*) => {$(
        impl Arith for $t {
            type Mask = $t;
            #[inline(always)]
            fn of(x: f64) -> Self {
                <$t>::splat(x as f32)
            }
            #[inline(always)]
            fn num_select(m: Self, t: Self, f: Self) -> Self {
                wide::Select::<$t>::select(m, t, f)
            }
            #[inline(always)]
            fn num_min(self, o: Self) -> Self {
                self.min(o)
            }
            #[inline(always)]
            fn num_max(self, o: Self) -> Self {
                self.max(o)
            }
            #[inline(always)]
            fn num_le(self, o: Self) -> Self {
                self.simd_le(o)
            }
            #[inline(always)]
            fn num_lt(self, o: Self) -> Self {
                self.simd_lt(o)
            }
            #[inline(always)]
            fn num_eq(self, o: Self) -> Self {
                self.simd_eq(o)
            }
            #[inline(always)]
            fn num_sqrt(self) -> Self {
                self.sqrt()
            }
            #[inline(always)]
            fn num_is_finite(self) -> Self {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn num_abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn num_copysign(self, sign: Self) -> Self {
                // The sign bit alone, in the lanes' unsigned type.
                let bit = <$t>::splat(-0.0).to_bits();
                <$t>::from_bits((self.to_bits() & !bit) | (sign.to_bits() & bit))
            }
            #[inline(always)]
            fn mask_all(m: Self) -> bool {
                m.all()
            }
        }
    )*};
}
lane_arith!(wide::f32x8, wide::f32x16);

impl Num for f32xn {
    #[inline(always)]
    fn num_exp(self) -> Self {
        crate::fastmath::exp(self)
    }
    #[inline(always)]
    fn num_acos(self) -> Self {
        crate::fastmath::acos(self)
    }
    #[inline(always)]
    fn num_powf(self, y: Self) -> Self {
        crate::fastmath::powf(self, y)
    }
    #[inline(always)]
    fn num_sin_cos(self) -> (Self, Self) {
        crate::fastmath::sin_cos_moderate(self)
    }
    #[inline(always)]
    fn num_atan2(self, x: Self) -> Self {
        crate::fastmath::atan2(self, x)
    }
    #[inline(always)]
    fn num_asin(self) -> Self {
        crate::fastmath::asin(self)
    }
    #[inline(always)]
    fn num_ln(self) -> Self {
        crate::fastmath::ln(self)
    }
    #[inline(always)]
    fn num_mul_add(self, a: Self, b: Self) -> Self {
        crate::simd::fmadd(self, a, b)
    }
    #[inline(always)]
    fn num_floor(self) -> Self {
        f32xn::floor(self)
    }
    #[inline(always)]
    fn num_to_degrees(self) -> Self {
        self * f32xn::splat(180.0 / std::f32::consts::PI)
    }
    type Int = i32xn;
    #[inline(always)]
    fn int(i: i32) -> i32xn {
        i32xn::splat(i)
    }
    #[inline(always)]
    fn int_min(a: i32xn, b: i32xn) -> i32xn {
        a.min(b)
    }
    #[inline(always)]
    fn int_max(a: i32xn, b: i32xn) -> i32xn {
        a.max(b)
    }
    #[inline(always)]
    fn int_lt(a: i32xn, b: i32xn) -> Self {
        wide::bytemuck::cast(a.simd_lt(b))
    }
    #[inline(always)]
    fn int_eq(a: i32xn, b: i32xn) -> Self {
        wide::bytemuck::cast(a.simd_eq(b))
    }
    #[inline(always)]
    fn gather_by<const N: usize>(i: i32xn, f: impl Fn(usize) -> [f32; N]) -> [Self; N] {
        let i = i.to_array();
        let rows = crate::simd::lanes(|k| f(i[k] as usize));
        std::array::from_fn(|c| f32xn::new(crate::simd::lanes(|k| rows[k][c])))
    }
    #[inline(always)]
    fn int_select(m: Self, a: i32xn, b: i32xn) -> i32xn {
        wide::Select::<i32xn>::select(m, a, b)
    }
    #[inline(always)]
    fn trunc_int(self) -> i32xn {
        f32xn::trunc_int(self)
    }
    #[inline(always)]
    fn of_int(i: i32xn) -> Self {
        crate::simd::float_of(i)
    }
    #[inline(always)]
    fn gather(table: &[f32], i: i32xn) -> Self {
        crate::simd::gather(table, i)
    }
    #[inline(always)]
    fn gather4(table: &[f32], i: i32xn) -> [Self; 4] {
        // One bounds check for all lanes, in lanes: 0 <= i <= len - 4.
        let last = i32xn::splat(table.len().min(i32::MAX as usize) as i32 - 4);
        let outside: f32xn = wide::bytemuck::cast(i.simd_lt(i32xn::splat(0)) | i.simd_gt(last));
        assert!(!outside.any(), "gather4 beyond a table of {}", table.len());
        let i = i.to_array();
        crate::simd::rows4(|k| {
            let j = i[k] as usize;
            // SAFETY: j + 4 <= table.len() for every lane, checked above.
            unsafe { table.get_unchecked(j..j + 4).try_into().unwrap_unchecked() }
        })
    }
}

/// Single precision, one value or lanes (f32, [`f32xn`]): what the approximations of
/// [`crate::fastmath`] need beyond [`Num`], the bits of a value as an index (i32 or i32
/// lanes, shifts arithmetic) and constants taken as f32 literals (no rounding through f64).
pub trait Single: Num {
    /// Every lane `x`.
    fn of32(x: f32) -> Self;
    /// Rounded to the nearest integer, ties to even.
    fn round_ties_even(self) -> Self;
    /// The bits of `self`, reinterpreted as an index.
    fn to_bits(self) -> Self::Int;
    /// The value of bits `i`.
    fn from_bits(i: Self::Int) -> Self;
    /// -1 where `m` holds, else 0 (per lane).
    fn mask_int(m: Self::Mask) -> Self::Int;
    /// `f` of each lane's `M` values, its `N` results in lanes: a step that only exists
    /// one value at a time (a lookup in a scalar table, a per-lane solve in f64) inside a
    /// formula written over lanes.
    fn per_lane<const M: usize, const N: usize>(
        x: [Self; M],
        f: impl Fn([f32; M]) -> [f32; N],
    ) -> [Self; N];
}

impl Single for f32 {
    #[inline(always)]
    fn of32(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn round_ties_even(self) -> Self {
        f32::round_ties_even(self)
    }
    #[inline(always)]
    fn to_bits(self) -> i32 {
        f32::to_bits(self) as i32
    }
    #[inline(always)]
    fn from_bits(i: i32) -> Self {
        f32::from_bits(i as u32)
    }
    #[inline(always)]
    fn mask_int(m: bool) -> i32 {
        -(m as i32)
    }
    #[inline(always)]
    fn per_lane<const M: usize, const N: usize>(
        x: [f32; M],
        f: impl Fn([f32; M]) -> [f32; N],
    ) -> [f32; N] {
        f(x)
    }
}

impl Single for f32xn {
    #[inline(always)]
    fn of32(x: f32) -> Self {
        f32xn::splat(x)
    }
    #[inline(always)]
    fn round_ties_even(self) -> Self {
        f32xn::round_ties_even(self)
    }
    #[inline(always)]
    fn to_bits(self) -> i32xn {
        wide::bytemuck::cast(f32xn::to_bits(self))
    }
    #[inline(always)]
    fn from_bits(i: i32xn) -> Self {
        f32xn::from_bits(wide::bytemuck::cast(i))
    }
    #[inline(always)]
    fn mask_int(m: Self) -> i32xn {
        wide::bytemuck::cast(m)
    }
    #[inline(always)]
    fn per_lane<const M: usize, const N: usize>(
        x: [Self; M],
        f: impl Fn([f32; M]) -> [f32; N],
    ) -> [Self; N] {
        let mut cols = [[0.0f32; crate::simd::LANES]; M];
        for j in 0..M {
            cols[j] = x[j].to_array();
        }
        let mut out = [[0.0f32; crate::simd::LANES]; N];
        for k in 0..crate::simd::LANES {
            let mut lane = [0.0f32; M];
            for j in 0..M {
                lane[j] = cols[j][k];
            }
            let r = f(lane);
            for c in 0..N {
                out[c][k] = r[c];
            }
        }
        let mut v = [f32xn::splat(0.0); N];
        for c in 0..N {
            v[c] = f32xn::new(out[c]);
        }
        v
    }
}

/// A floating-point scalar: f32 or f64.
pub trait Real: Num + Float + FloatConst + std::fmt::Debug + Send + Sync + 'static {
    /// Converts a constant.
    fn c(x: f64) -> Self;
    fn to_f64(self) -> f64;
    /// Complementary error function (libm, the musl port).
    fn erfc(self) -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn c(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn erfc(self) -> Self {
        libm::erfcf(self)
    }
}

impl Real for f64 {
    #[inline(always)]
    fn c(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn erfc(self) -> Self {
        libm::erfc(self)
    }
}

/// A 3-vector over an [`Arith`]: one f32 or f64 vector, or lanes of vectors, one component
/// per register ([`crate::simd::Vec3xN`], and the geometry kernels' rays and leaf blocks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl<T: Arith> V3<T> {
    #[inline(always)]
    pub fn new(x: T, y: T, z: T) -> Self {
        Self { x, y, z }
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn length_squared(self) -> T {
        self.dot(self)
    }
    /// `self / |self|` (as `self * (1 / sqrt(|self|^2))`), for a vector known not to be
    /// zero or infinite.
    #[inline(always)]
    pub fn unit(self) -> Self {
        self * (T::of(1.0) / sqrt(self.length_squared()))
    }
    /// `self / |self|` as glam's `normalize_or_zero` computes it, `fallback` where that is
    /// zero (the reciprocal length not finite and positive).
    #[inline(always)]
    pub fn unit_or(self, fallback: Self) -> Self {
        let rcp = T::of(1.0) / sqrt(self.length_squared());
        let ok = is_finite(rcp) & gt(rcp, T::of(0.0));
        let n = self * rcp;
        V3::new(
            select(ok, n.x, fallback.x),
            select(ok, n.y, fallback.y),
            select(ok, n.z, fallback.z),
        )
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
}

impl<T: Real> V3<T> {
    #[inline(always)]
    pub fn length(self) -> T {
        self.dot(self).sqrt()
    }
    /// Unit vector, or None for a zero or non-finite vector.
    #[inline(always)]
    pub fn normalize(self) -> Option<Self> {
        let l2 = self.length_squared();
        if l2 > T::zero() && l2.is_finite() {
            Some(self * (T::one() / l2.sqrt()))
        } else {
            None
        }
    }
}

impl<T: Arith> Add for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<T: Arith> Sub for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl<T: Arith> Mul<T> for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: T) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}
impl<T: Arith> Div<T> for V3<T> {
    type Output = Self;
    /// Each component divided by `s` (as glam's `Vec3 / f32`).
    #[inline(always)]
    fn div(self, s: T) -> Self {
        Self::new(self.x / s, self.y / s, self.z / s)
    }
}
impl<T: Arith> Neg for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

impl From<glam::Vec3> for V3<f32> {
    #[inline(always)]
    fn from(v: glam::Vec3) -> Self {
        V3::new(v.x, v.y, v.z)
    }
}
impl From<glam::DVec3> for V3<f64> {
    #[inline(always)]
    fn from(v: glam::DVec3) -> Self {
        V3::new(v.x, v.y, v.z)
    }
}
impl From<V3<f32>> for glam::Vec3 {
    #[inline(always)]
    fn from(v: V3<f32>) -> Self {
        glam::Vec3::new(v.x, v.y, v.z)
    }
}

impl V3<f64> {
    pub fn into_f32(self) -> V3<f32> {
        V3::new(self.x as f32, self.y as f32, self.z as f32)
    }
}

/// The half vector of two directions on the upper hemisphere (None if they cancel).
#[inline(always)]
pub fn half<T: Real>(wo: V3<T>, wi: V3<T>) -> Option<V3<T>> {
    (wo + wi).normalize()
}

/// Marsaglia's xorshift64 from `seed` (non-zero): a fixed stream of pseudo-random 64-bit
/// values for tests' random points, the same in every run.
#[cfg(test)]
pub(crate) fn xorshift64(mut seed: u64) -> impl FnMut() -> u64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    }
}
