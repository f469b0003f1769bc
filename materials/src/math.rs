//! The small float abstraction that lets each model's formula be written once and
//! evaluated in f32 (rendering) and f64 (fitting): [`Real`] over num-traits' `Float`
//! (with `exp_r`, `powf_r`, `acos_r`: `fastmath`'s in f32, whose lane forms the
//! models' SIMD kernels use), and a minimal generic 3-vector [`V3`].

use num_traits::{Float, FloatConst};
use std::ops::{Add, Mul, Neg, Sub};

/// A floating-point scalar: f32 or f64.
pub trait Real: Float + FloatConst + std::fmt::Debug + Send + Sync + 'static {
    /// Converts a constant.
    fn c(x: f64) -> Self;
    fn to_f64(self) -> f64;
    /// Complementary error function (libm, the musl port).
    fn erfc(self) -> Self;
    /// e^x: the C library's in f64 (fitting), [`crate::fastmath::exp`] in f32 (rendering:
    /// the function whose lane form the SIMD kernels use, so that they equal the
    /// scalar models bit for bit).
    fn exp_r(self) -> Self;
    /// x^y, as [`Real::exp_r`]: [`crate::fastmath::powf`] in f32.
    fn powf_r(self, y: Self) -> Self;
    /// acos x, as [`Real::exp_r`]: [`crate::fastmath::acos`] in f32.
    fn acos_r(self) -> Self;
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
    #[inline(always)]
    fn exp_r(self) -> Self {
        crate::fastmath::exp(self)
    }
    #[inline(always)]
    fn powf_r(self, y: Self) -> Self {
        crate::fastmath::powf(self, y)
    }
    #[inline(always)]
    fn acos_r(self) -> Self {
        crate::fastmath::acos(self)
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
    #[inline(always)]
    fn exp_r(self) -> Self {
        self.exp()
    }
    #[inline(always)]
    fn powf_r(self, y: Self) -> Self {
        self.powf(y)
    }
    #[inline(always)]
    fn acos_r(self) -> Self {
        self.acos()
    }
}

/// A 3-vector over a [`Real`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl<T: Real> V3<T> {
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
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
}

impl<T: Real> Add for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<T: Real> Sub for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl<T: Real> Mul<T> for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: T) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}
impl<T: Real> Neg for V3<T> {
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
