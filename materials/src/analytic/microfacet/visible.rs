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
//!    pbrt-v3, which avoids the discontinuities of the paper's fitted inverse), from an
//!    initial guess interpolated in a table of the inverse over tan(theta / 2) and
//!    sqrt(1 - u1) (within 5e-4 in the CDF, where the fitted exponent of Mitsuba and
//!    pbrt-v3 is up to 0.03 off: one step stops 98 % of lanes or more, where from the
//!    fitted guess 76 % of lanes needed two and 19 % three);
//!    straight down (r = sqrt(-ln(1 - u1))) at normal incidence;
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
    Num, V3, abs, all, exp, gt, is_finite, le, ln, lt, maximum, select, sin_cos, sqrt,
};

/// Newton steps of the marginal's inversion at most (the inversion is tested to bring the
/// CDF within 2e-5 of its target at elevations from 5 to 88 degrees); from the tabulated
/// guess, 98 % of lanes or more stop after one, within [`TOLERANCE`] (tested).
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

/// Rows (over tan(theta / 2) in [0, 1]) and columns (over sqrt(1 - u1) in [0, 1]) of
/// [`guess_table`].
const GUESS_ROWS: usize = 32;
const GUESS_COLUMNS: usize = 128;

/// The marginal's inverse in the erf domain, b(theta, u1), at the nodes of a grid over
/// tan(theta / 2) (nearly linear in theta, where cos(theta) is flat at normal incidence)
/// and sqrt(1 - u1) (in which b is nearly linear at the upper end u1 -> 1, where the
/// inverse has a square-root singularity), row by row, padded for [`Num::gather4`]: built
/// once ([`marginal_inverse`], in f64), at the first lookup. Materials reach it when they
/// are built (`Composite::new` samples every lobe for its albedo tables), so renders do
/// not wait on it.
fn guess_table() -> &'static [f32] {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t: Vec<f32> = (0..GUESS_ROWS * GUESS_COLUMNS)
            .map(|k| {
                let v = (k / GUESS_COLUMNS) as f64 / (GUESS_ROWS - 1) as f64;
                let r = (k % GUESS_COLUMNS) as f64 / (GUESS_COLUMNS - 1) as f64;
                // cos(theta) from tan(theta / 2), kept off exactly grazing.
                let cos_t = ((1.0 - v * v) / (1.0 + v * v)).max(1e-5);
                marginal_inverse(1.0 - r * r, cos_t) as f32
            })
            .collect();
        t.extend([0.0; 4]);
        t
    })
}

/// 1 / the total of the visible slopes' x marginal seen from elevation tangent `tan_t`
/// (cotangent `cot_t`, `c` = erf(cot_t)): the marginal's normalisation, one value or
/// lanes, f32 or f64.
#[inline(always)]
fn marginal_norm<T: Num>(c: T, tan_t: T, cot_t: T) -> T {
    let s = T::of;
    s(1.0) / (s(1.0) + c + s(FRAC_1_SQRT_PI) * tan_t * exp(-cot_t * cot_t))
}

/// The visible slopes' x marginal CDF seen from elevation tangent `tan_t` (normalisation
/// `norm`, [`marginal_norm`]) at b = erf(x), `x` = erfinv(b) given, and its derivative in
/// b: what the Newton steps of [`slope_11`] and [`marginal_inverse`] invert.
#[inline(always)]
fn marginal_cdf<T: Num>(norm: T, tan_t: T, b: T, x: T) -> (T, T) {
    let s = T::of;
    (
        norm * (s(1.0) + b + s(FRAC_1_SQRT_PI) * tan_t * exp(-x * x)),
        norm * (s(1.0) - x * tan_t),
    )
}

/// The b in [-1, erf(cot theta)] where the visible slopes' x marginal seen from elevation
/// cosine `cos_t` reaches `u`, in f64: Newton steps kept inside a bisection interval, from
/// the fitted exponent of Mitsuba and pbrt-v3 (b = c - (1 + c) (1 - u)^(1 + t (-0.876 +
/// t (0.4265 - 0.0594 t))), t = theta), until the CDF is within 1e-12 of `u`.
fn marginal_inverse(u: f64, cos_t: f64) -> f64 {
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (tan_t, cot_t) = (sin_t / cos_t, cos_t / sin_t.max(1e-12));
    let (mut a, mut c) = (-1.0f64, erf(cot_t));
    let norm = marginal_norm(c, tan_t, cot_t);
    let t = cos_t.acos();
    let fit = 1.0 + t * (-0.876 + t * (0.4265 - 0.0594 * t));
    let mut b = c - (1.0 + c) * (1.0 - u).powf(fit);
    for _ in 0..60 {
        if !(a <= b && b <= c) {
            b = 0.5 * (a + c);
        }
        let (cdf, derivative) = marginal_cdf(norm, tan_t, b, erfinv(b));
        let value = cdf - u;
        if value.abs() <= 1e-12 || c - a <= 1e-15 {
            break;
        }
        match value > 0.0 {
            true => c = b,
            false => a = b,
        }
        b -= value / derivative;
    }
    b.clamp(a, c)
}

/// The Newton steps' first iterate: [`guess_table`] interpolated bilinearly at
/// tan(theta / 2) = `v` and sqrt(1 - u1) = `r` (both in [0, 1]). Within 5e-4 of the target
/// in the CDF, so that one step (two CDF evaluations in all) stops 98 % of lanes or more.
#[inline(always)]
fn initial_guess<T: Num>(v: T, r: T) -> T {
    let table = guess_table();
    let cell = |x: T, n: usize| {
        let f = x * T::of((n - 1) as f64);
        let i = T::int_min(T::int_max(f.trunc_int(), T::int(0)), T::int(n as i32 - 2));
        (i, f - T::of_int(i))
    };
    let (row, fv) = cell(v, GUESS_ROWS);
    let (column, fr) = cell(r, GUESS_COLUMNS);
    let at = row * T::int(GUESS_COLUMNS as i32) + column;
    let [t0, t1, _, _] = T::gather4(table, at);
    let [b0, b1, _, _] = T::gather4(table, at + T::int(GUESS_COLUMNS as i32));
    let one = T::of(1.0);
    let top = t0 * (one - fr) + t1 * fr;
    let bottom = b0 * (one - fr) + b1 * fr;
    top * (one - fv) + bottom * fv
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
    let mut b = initial_guess(sin_t / (s(1.0) + cos_t), sqrt(s(1.0) - u1));
    let norm = marginal_norm(c, tan_t, cot_t);
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
        let (cdf, derivative) = marginal_cdf(norm, tan_t, b, inv);
        let value = cdf - u1;
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

    /// The tabulated first iterate lies within 6e-4 of its target in the CDF (4.96e-4
    /// measured) from every elevation but the normal-incidence cone (there the slopes are
    /// drawn directly) and for every u1 of a fine grid; one Newton step from it (as [`slope_11`] takes, in f32)
    /// reaches [`TOLERANCE`] at 98 % of the grid's points or more; and lanes of different
    /// points give each point's one-value result.
    #[test]
    fn the_tabulated_guess_is_close_to_the_inverse() {
        let (mut worst, mut points, mut one_step) = (0.0f64, 0usize, 0usize);
        let mut inputs = Vec::new();
        for ti in 0..180 {
            let theta = (ti as f64 * 0.5 + 0.25).to_radians();
            let (sin_t, cos_t) = theta.sin_cos();
            if cos_t > 0.9999 {
                continue;
            }
            let (tan_t, cot_t) = (sin_t / cos_t, cos_t / sin_t);
            let norm = marginal_norm(erf(cot_t), tan_t, cot_t);
            for k in 0..400 {
                let u = (k as f64 + 0.5) / 400.0;
                let (v, r) = ((sin_t / (1.0 + cos_t)) as f32, ((1.0 - u) as f32).sqrt());
                inputs.push((v, r));
                let b = initial_guess(v, r);
                // The CDF the Newton steps invert, in f64 (with the same erf and erfinv).
                let (cdf, _) = marginal_cdf(norm, tan_t, b as f64, erfinv(b as f64));
                worst = worst.max((cdf - u).abs());
                // slope_11's first step and the CDF where it lands, in f32.
                let (n32, t32, u32_) = (norm as f32, tan_t as f32, u as f32);
                let value = |b: f32| {
                    let (cdf, derivative) = marginal_cdf(n32, t32, b, erfinv(b));
                    (cdf - u32_, derivative)
                };
                let (mut lo, mut hi) = (-1.0f32, erf(cot_t as f32));
                let b = if lo <= b && b <= hi {
                    b
                } else {
                    0.5 * (lo + hi)
                };
                let (v0, d0) = value(b);
                match v0 > 0.0 {
                    true => hi = b,
                    false => lo = b,
                }
                let b1 = b - v0 / d0;
                // Outside the bracket, slope_11 bisects.
                let b1 = if lo <= b1 && b1 <= hi {
                    b1
                } else {
                    0.5 * (lo + hi)
                };
                points += 1;
                one_step += usize::from(
                    v0.abs() as f64 <= TOLERANCE || value(b1).0.abs() as f64 <= TOLERANCE,
                );
            }
        }
        assert!(worst < 6e-4, "tabulated guess off by {worst} in the CDF");
        let share = one_step as f64 / points as f64;
        assert!(
            share >= 0.98,
            "one Newton step suffices at {share} of the points"
        );
        // Lanes of points of different elevations and u1 (a stride through the grid).
        let n = inputs.len();
        for first in (0..n).step_by(crate::simd::LANES) {
            let point = |i: usize| inputs[((first + i) * 7919) % n];
            let lanes = initial_guess(
                f32xn::new(std::array::from_fn(|i| point(i).0)),
                f32xn::new(std::array::from_fn(|i| point(i).1)),
            );
            for (i, got) in lanes.to_array().into_iter().enumerate() {
                let (v, r) = point(i);
                assert_eq!(got.to_bits(), initial_guess(v, r).to_bits());
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
