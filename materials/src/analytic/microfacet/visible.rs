//! Sampling the Beckmann distribution's *visible* normals: half vectors h drawn with the
//! density D_wo(h) = G1(wo) max(0, wo.h) D(h) / cos(theta_o) (Heitz and d'Eon, "Importance
//! Sampling Microfacet-Based BSDFs using the Distribution of Visible Normals", EGSR 2014),
//! so that the incident direction wi = reflect(wo, h) has the density
//! G1(wo) D(h) / (4 cos(theta_o)) (Walter et al. 2007, eq. 14). Against sampling D(h)
//! cos(theta_h), no sample goes to a facet that `wo` cannot see, which is where the
//! variance of glossy lobes at grazing `wo` (silhouettes, folds) comes from.
//!
//! The method, for roughness `m` (Beckmann's alpha):
//! 1. stretch `wo` to the configuration of roughness 1: (m wo.x, m wo.y, wo.z);
//! 2. draw the slope (x, y) of a visible facet there: y from the standard distribution of
//!    slopes, y = erfinv(2 u2 - 1); x from the visible slopes' marginal, whose CDF in the
//!    variable b = erf(x) is (1 + b + tan(theta) exp(-erfinv(b)^2) / sqrt(pi)) / (1 +
//!    erf(cot theta) + tan(theta) exp(-cot^2 theta) / sqrt(pi)), inverted by Newton steps
//!    kept inside a bisection interval (the numerical inversion of Jakob's Mitsuba and of
//!    pbrt-v3, which avoids the discontinuities of the paper's fitted inverse), from the
//!    initial guess of the fitted exponent 1 + t (-0.876 + t (0.4265 - 0.0594 t)) in
//!    theta = t; straight down (r = sqrt(-ln(1 - u1))) at normal incidence;
//! 3. rotate the slope to `wo`'s azimuth, unstretch it and make it a normal.
//!
//! Anisotropic roughness (mx, my) stretches and unstretches each axis by its own value.
//!
//! G1 is Smith's for Beckmann: 1 / (1 + Lambda), Lambda(a) = (erf(a) - 1) / 2 +
//! exp(-a^2) / (2 a sqrt(pi)), a = 1 / (m tan(theta_o)) (with m = |(mx cos phi_o, my sin
//! phi_o)| when anisotropic).
//!
//! One form over [`Num`] serves both paths: instantiated for one f32 and for lanes, it
//! makes one-at-a-time and batched sampling agree bit for bit. A lane's Newton iterate stops
//! changing once its CDF is within a tolerance of the target, and the loop ends when all
//! lanes have stopped, so a lane's result does not depend on its neighbours. `erf` is
//! Abramowitz and Stegun's 7.1.26 (absolute error under 1.5e-7) and `erfinv` Giles'
//! single-precision approximation ("Approximating the erfinv function", GPU Computing
//! Gems, 2011).

// The coefficients are the published decimal values, kept as printed.
#![allow(clippy::excessive_precision)]

use crate::math::{
    Num, V3, abs, acos, all, exp, gt, is_finite, le, ln, lt, maximum, powf, select, sin_cos, sqrt,
};

/// Newton steps of the marginal's inversion at most: from the fitted guess, 6 steps bring
/// the CDF within 1e-6 of the target everywhere (tested); most lanes stop earlier, once
/// within [`TOLERANCE`].
const NEWTON_STEPS: usize = 6;
/// The CDF error at which a lane's inversion stops.
const TOLERANCE: f64 = 2e-7;

/// erf(x) (Abramowitz and Stegun 7.1.26, odd extension).
#[inline(always)]
pub fn erf<T: Num>(x: T) -> T {
    let s = T::of;
    let a = abs(x);
    let t = s(1.0) / (s(1.0) + s(0.327_591_1) * a);
    let poly = ((((s(1.061_405_429) * t - s(1.453_152_027)) * t + s(1.421_413_741)) * t
        - s(0.284_496_736))
        * t
        + s(0.254_829_592))
        * t;
    let y = s(1.0) - poly * exp(-a * a);
    select(lt(x, s(0.0)), -y, y)
}

/// erfinv(x) for x in (-1, 1) (Giles' single-precision approximation).
#[inline(always)]
pub fn erfinv<T: Num>(x: T) -> T {
    let s = T::of;
    let w = -ln((s(1.0) - x) * (s(1.0) + x));
    let c = w - s(2.5);
    let central = [
        3.432_739_39e-7,
        -3.523_387_7e-6,
        -4.391_506_54e-6,
        2.185_808_7e-4,
        -1.253_725_03e-3,
        -4.177_681_64e-3,
        2.466_407_27e-1,
        1.501_409_41,
    ]
    .iter()
    .fold(s(2.810_226_36e-8), |p, &k| s(k) + p * c);
    // The tail (|x| above about 0.9966, w >= 5 or not a number) is evaluated only when
    // some lane takes it: a rare case, and the same value either way.
    let central_only = lt(w, s(5.0));
    if all::<T>(central_only) {
        return central * x;
    }
    let t = sqrt(w) - s(3.0);
    let tail = [
        1.009_505_58e-4,
        1.349_343_22e-3,
        -3.673_428_44e-3,
        5.739_507_73e-3,
        -7.622_461_3e-3,
        9.438_870_47e-3,
        1.001_674_06,
        2.832_976_82,
    ]
    .iter()
    .fold(s(-2.002_142_57e-4), |p, &k| s(k) + p * t);
    select(central_only, central, tail) * x
}

/// 1 / sqrt(pi) as its f32 rounding (the value every form uses).
const FRAC_1_SQRT_PI: f64 = 0.564_189_6_f32 as f64;

/// Smith's Lambda of the Beckmann distribution of roughness (`mx`, `my`) along the
/// tangent and bitangent for direction `w` (w.z > 0): Lambda at a = w.z / |(mx w.x, my w.y)|.
#[inline(always)]
pub fn beckmann_lambda_dir<T: Num>(mx: T, my: T, w: V3<T>) -> T {
    let (sx, sy) = (mx * w.x, my * w.y);
    lambda_of(w.z / sqrt(sx * sx + sy * sy))
}

/// Lambda(a) = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)).
#[inline(always)]
fn lambda_of<T: Num>(a: T) -> T {
    let s = T::of;
    let lambda = (erf(a) - s(1.0)) * s(0.5) + exp(-a * a) / (s(2.0) * a) * s(FRAC_1_SQRT_PI);
    // Straight up (a = inf) and far from grazing, nothing is masked.
    select(
        gt(a, s(9.0)) | !is_finite(a),
        s(0.0),
        maximum(lambda, s(0.0)),
    )
}

/// The slope (x, y) of a visible facet of the roughness-1 Beckmann distribution seen from
/// elevation cosine `cos_t` (in (0, 1]) and azimuth 0, from uniforms `u1`, `u2`.
#[inline(always)]
fn slope_11<T: Num>(cos_t: T, u1: T, u2: T) -> (T, T) {
    let s = T::of;
    let u1 = maximum(u1, s(1e-6));
    let sin_t = sqrt(maximum(s(1.0) - cos_t * cos_t, s(0.0)));
    let tan_t = sin_t / cos_t;
    let cot_t = cos_t / maximum(sin_t, s(1e-12));
    let (mut a, mut c) = (s(-1.0), erf(cot_t));
    let theta = acos(cos_t);
    let fit = s(1.0) + theta * (s(-0.876) + theta * (s(0.4265) - s(0.0594) * theta));
    let mut b = c - (s(1.0) + c) * powf(s(1.0) - u1, fit);
    let norm = s(1.0) / (s(1.0) + c + s(FRAC_1_SQRT_PI) * tan_t * exp(-cot_t * cot_t));
    // A lane whose CDF is within TOLERANCE of its target keeps that iterate; the loop ends
    // when every lane has, which leaves each lane's result what it would be alone.
    let mut done = lt(s(1.0), s(0.0));
    // erfinv of the last iterate evaluated: the slope x once every lane has stopped.
    let mut inv = b;
    for _ in 0..NEWTON_STEPS {
        // Outside the bracket (or NaN): bisect.
        let inside = le(a, b) & le(b, c);
        b = select(inside, b, s(0.5) * (a + c));
        inv = erfinv(b);
        let value = norm * (s(1.0) + b + s(FRAC_1_SQRT_PI) * tan_t * exp(-inv * inv)) - u1;
        let derivative = norm * (s(1.0) - inv * tan_t);
        done = done | le(abs(value), s(TOLERANCE));
        let above = gt(value, s(0.0));
        c = select(done | !above, c, b);
        a = select(done | above, a, b);
        b = select(done, b, b - value / derivative);
        if all::<T>(done) {
            break;
        }
    }
    // A lane that stopped kept its iterate, inside its bracket: erfinv(b) is `inv` when
    // all have (the same value as evaluating it again).
    let x = match all::<T>(done) {
        true => inv,
        false => {
            let inside = le(a, b) & le(b, c);
            erfinv(select(inside, b, s(0.5) * (a + c)))
        }
    };
    let y = erfinv(s(2.0) * maximum(u2, s(1e-6)) - s(1.0));
    // At normal incidence the visible slopes are the slopes: a 2D normal of variance 1/2
    // (computed only where some lane is there).
    let straight = gt(cos_t, s(0.9999));
    if all::<T>(!straight) {
        return (x, y);
    }
    let r = sqrt(-ln(s(1.0) - u1));
    let (sin_p, cos_p) = sin_cos(s(std::f32::consts::TAU as f64) * u2);
    (
        select(straight, r * cos_p, x),
        select(straight, r * sin_p, y),
    )
}

/// Half vectors of the Beckmann distribution of roughness (`mx`, `my`) along the tangent
/// and bitangent (equal for an isotropic one) visible from `wo` (in the local frame,
/// wo.z > 0), from uniforms (`u1`, `u2`) per lane.
#[inline(always)]
pub fn sample<T: Num>(mx: T, my: T, wo: V3<T>, u1: T, u2: T) -> V3<T> {
    let s = T::of;
    let stretched = V3::new(mx * wo.x, my * wo.y, wo.z).unit();
    let (sx, sy) = slope_11(stretched.z, u1, u2);
    let sin_t = sqrt(stretched.x * stretched.x + stretched.y * stretched.y);
    let flat = le(sin_t, s(1e-9));
    let cos_p = select(flat, s(1.0), stretched.x / sin_t);
    let sin_p = select(flat, s(0.0), stretched.y / sin_t);
    let (rx, ry) = (cos_p * sx - sin_p * sy, sin_p * sx + cos_p * sy);
    V3::new(-(mx * rx), -(my * ry), s(1.0)).unit()
}

/// The density of [`sample`]'s half vector `h` (solid angle of h): G1(wo) max(0, wo.h)
/// D(h) / cos(theta_o), with the Beckmann distribution's `d` = D(h) given.
#[inline(always)]
pub fn pdf<T: Num>(mx: T, my: T, wo: V3<T>, h: V3<T>, d: T) -> T {
    let s = T::of;
    let g1 = s(1.0) / (s(1.0) + beckmann_lambda_dir(mx, my, wo));
    let v = g1 * maximum(wo.dot(h), s(0.0)) * d / wo.z;
    select(gt(wo.z, s(0.0)) & is_finite(v), v, s(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{Vec3xN, f32xn};
    use glam::Vec3;

    fn lane0(v: f32xn) -> f32 {
        v.to_array()[0]
    }

    #[test]
    fn erf_and_erfinv_match_the_definitions() {
        for k in -400..=400 {
            let x = k as f64 * 0.01;
            let e = lane0(erf(f32xn::splat(x as f32))) as f64;
            assert!((e - libm::erf(x)).abs() < 3e-7, "erf({x}) = {e}");
        }
        for k in -999..=999 {
            let y = k as f64 * 0.001;
            let x = lane0(erfinv(f32xn::splat(y as f32))) as f64;
            let back = libm::erf(x);
            assert!(
                (back - y).abs() < 2e-6 * (1.0 + x.abs()),
                "erfinv({y}) = {x}"
            );
        }
    }

    #[test]
    fn the_marginal_is_inverted_to_its_target() {
        // CDF of the visible slopes' x marginal at slope x, in the roughness-1 frame.
        let cdf = |x: f64, tan_t: f64| {
            let (cot, sqrt_pi) = (1.0 / tan_t, std::f64::consts::PI.sqrt());
            let n = 1.0 + libm::erf(cot) + tan_t * (-cot * cot).exp() / sqrt_pi;
            (1.0 + libm::erf(x) + tan_t * (-x * x).exp() / sqrt_pi) / n
        };
        for ti in [5.0f64, 30.0, 60.0, 80.0, 88.0] {
            let cos_t = ti.to_radians().cos();
            let tan_t = ti.to_radians().tan();
            for k in 1..100 {
                let u = k as f64 / 100.0;
                let (x, _) = slope_11(
                    f32xn::splat(cos_t as f32),
                    f32xn::splat(u as f32),
                    f32xn::splat(0.5),
                );
                let got = cdf(lane0(x) as f64, tan_t);
                assert!((got - u).abs() < 2e-5, "theta {ti}, u {u}: CDF {got}");
            }
        }
    }

    #[test]
    fn lambda_is_smiths() {
        for (m, ti) in [(0.1f64, 80.0f64), (0.3, 60.0), (0.5, 85.0), (1.0, 45.0)] {
            let a = 1.0 / (m * ti.to_radians().tan());
            let want = (libm::erf(a) - 1.0) / 2.0
                + (-a * a).exp() / (2.0 * a * std::f64::consts::PI.sqrt());
            let (sin_t, cos_t) = ti.to_radians().sin_cos();
            let w = Vec3xN::splat(Vec3::new(sin_t as f32, 0.0, cos_t as f32));
            let r = f32xn::splat(m as f32);
            let got = lane0(beckmann_lambda_dir(r, r, w)) as f64;
            assert!(
                (got - want).abs() < 1e-5 + 1e-4 * want,
                "m {m}, theta {ti}: {got} vs {want}"
            );
        }
    }
}
