//! The elevation terms of He, Torrance, Sillion and Greenberg 1991 for rendering: the
//! shadowing of a Gaussian surface (eqs. 24-25 with the errata's exp(-s^2) factor) and the
//! effective roughness (eqs. 80-83), from one universal table instead of libm's `erfc` and
//! four Newton steps with `exp` per call.
//!
//! Both terms depend on the elevation of a direction only through
//! s = tau cot(theta) / (2 sigma0):
//! - S(s) = (1 - erfc(s) / 2) / (1 + Lambda(s)), Lambda = exp(-s^2) / (2 sqrt(pi) s) - erfc(s) / 2;
//! - K(theta) = tan(theta) erfc(tau / (2 sigma0 tan(theta))) = tan(theta) erfc(s).
//!
//! So one table of S(s) and erfc(s), shared by every material, serves all of them. It is
//! indexed by v = s / (1 + s) in [0, 1] (s in [0, inf)), [`NODES`] nodes with linear
//! interpolation; both functions are smooth in v (S ~ sqrt(pi) s near 0, erfc(s) and
//! 1 - S vanish faster than any power as v -> 1). The tested bound of the interpolation is
//! [`TABLE_ERROR_BOUND`] (absolute; both functions lie in [0, 1]).
//!
//! The effective roughness sigma = sigma0 / sqrt(1 + x^2), where x exp(x^2 / 2) =
//! (K_i + K_o) / sqrt(8 pi) (bbm's four Newton steps), is a function of K_i + K_o alone:
//! a second universal table holds it per 256th of an octave of K_i + K_o (a serial chain of
//! four `exp` per call before). Fitting keeps the f64 forms of `he.rs`; the render's lobe
//! is within [`super::he::RENDER_ERROR_BOUND`] of them (tested).

use crate::math::{Real, Single, all, ge, le, lt, maximum, select, sqrt};
use std::sync::LazyLock;

/// Nodes of the table over v = s / (1 + s) in [0, 1].
pub const NODES: usize = 4097;
/// Tested bound of the table's absolute error for S(s) and erfc(s).
pub const TABLE_ERROR_BOUND: f32 = 2e-6;

/// S(s) of one direction (the f64 reference; 1 for s = inf).
pub fn shadowing(s: f64) -> f64 {
    if s.is_nan() {
        return 1.0;
    }
    if s > 30.0 {
        return 1.0;
    }
    if s <= 0.0 {
        return 0.0;
    }
    let e = libm::erfc(s);
    let lambda = (-s * s).exp() / (2.0 * std::f64::consts::PI.sqrt() * s) - 0.5 * e;
    ((1.0 - 0.5 * e) / (1.0 + lambda)).clamp(0.0, 1.0)
}

/// (S, erfc) at every node, interleaved: node k's S at 2k, its erfc at 2k + 1.
static TABLE: LazyLock<Vec<f32>> = LazyLock::new(|| {
    (0..NODES)
        .flat_map(|k| {
            let v = k as f64 / (NODES - 1) as f64;
            if k == NODES - 1 {
                return [1.0, 0.0];
            }
            let s = v / (1.0 - v);
            [shadowing(s) as f32, libm::erfc(s) as f32]
        })
        .collect()
});

/// Builds the tables now (they are otherwise built at the first lookup).
pub fn build_table() {
    LazyLock::force(&TABLE);
    LazyLock::force(&ROUGHNESS);
}

/// (S(s), erfc(s)) from the table, for s >= 0 (+inf allowed; NaN reads as s = inf); one
/// value or lanes.
#[inline(always)]
pub fn lookup<T: Single>(s: T) -> (T, T) {
    let c = T::of32;
    let v = select(
        lt(s, c(f32::INFINITY)),
        maximum(s / (c(1.0) + s), c(0.0)),
        c(1.0),
    );
    let x = v * c((NODES - 1) as f32);
    let k = T::int_min(x.trunc_int(), T::int(NODES as i32 - 2));
    let t = x - T::of_int(k);
    let [a0, a1, b0, b1] = T::gather4(&TABLE, k << 1);
    (a0 + t * (b0 - a0), a1 + t * (b1 - a1))
}

/// The elevation terms of the render path for one material: (S(theta_i) S(theta_o),
/// sigma(theta_i, theta_o)) at cos theta_i = `ci`, cos theta_o = `co` (both in (0, 1]); one
/// pair or lanes.
#[inline(always)]
pub fn elevation_terms<T: Single>(sigma0: f32, tau: f32, ci: T, co: T) -> (T, T) {
    if sigma0 <= f32::EPSILON {
        return (T::of32(1.0), T::of32(0.0));
    }
    let (s_i, k_i) = direction_terms(sigma0, tau, ci);
    let (s_o, k_o) = direction_terms(sigma0, tau, co);
    (s_i * s_o, T::of32(sigma0) * roughness_factor(k_i + k_o))
}

/// sigma(theta, theta), the effective roughness with both directions at cos theta = `c`
/// (one or lanes; [`elevation_terms`]' second term, one direction's terms found once): the
/// width of He's rough sampling proposal.
#[inline(always)]
pub fn self_roughness<T: Single>(sigma0: f32, tau: f32, c: T) -> T {
    if sigma0 <= f32::EPSILON {
        return T::of32(0.0);
    }
    let (_, k) = direction_terms(sigma0, tau, c);
    T::of32(sigma0) * roughness_factor(k + k)
}

/// (S, K) of one direction at cos theta = `c` (one or lanes): s = tau cot(theta) / (2 sigma0),
/// K = tan(theta) erfc(s) (0 at normal incidence, where he.rs's forms cut off at
/// tan(theta) <= 1e-7 too). `sigma0` must be above `f32::EPSILON`.
#[inline(always)]
pub fn direction_terms<T: Single>(sigma0: f32, tau: f32, c: T) -> (T, T) {
    let (zero, one) = (T::of32(0.0), T::of32(1.0));
    let sin = sqrt(maximum(one - c * c, zero));
    let tan = sin / c;
    let (shadow, erfc) = lookup(T::of32(tau / (2.0 * sigma0)) / tan);
    let normal = le(sin, T::of32(1e-7));
    (
        select(normal, one, shadow),
        select(normal, zero, tan * erfc),
    )
}

/// 1 / sqrt(1 + x^2) where x exp(x^2 / 2) = f0 = k / sqrt(8 pi), by bbm's four Newton
/// steps from x = f0 (f0 <= 1) or sqrt(2 ln f0), in f64 (or f32): the form `He::sigma_eff`
/// uses, from which [`roughness_factor`]'s table is made.
pub fn roughness_factor_newton<T: Real>(k: T) -> T {
    let f0 = k / T::c((8.0 * std::f64::consts::PI).sqrt());
    let mut x = if f0 <= T::one() {
        f0
    } else {
        (T::c(2.0) * f0.ln()).sqrt()
    };
    for _ in 0..4 {
        let e = (x * x * T::c(0.5)).exp();
        x = x - (x * e - f0) / ((T::one() + x * x) * e);
    }
    T::one() / (T::one() + x * x).sqrt()
}

/// Octaves of k below 1 and above it that [`roughness_factor`]'s table covers, and its
/// nodes per octave (256, as a power of two: the top mantissa bits of k index the node).
const K_OCTAVE_MIN: i32 = -24;
const K_OCTAVE_MAX: i32 = 100;
const K_NODE_BITS: u32 = 8;

/// [`roughness_factor_newton`] at k = 2^e (1 + j / 256) for every octave e of the table and j.
static ROUGHNESS: LazyLock<Vec<f32>> = LazyLock::new(|| {
    let per = 1usize << K_NODE_BITS;
    let n = (K_OCTAVE_MAX - K_OCTAVE_MIN) as usize * per + 1;
    (0..n)
        .map(|i| {
            let e = K_OCTAVE_MIN + (i / per) as i32;
            let k = 2f64.powi(e) * (1.0 + (i % per) as f64 / per as f64);
            roughness_factor_newton(k) as f32
        })
        .collect()
});

/// [`roughness_factor_newton`] in f32 from its table (one value or lanes): the float's
/// exponent and top mantissa bits pick the node (nodes linear in k within each 256th of an
/// octave, so the bits' rest is the interpolation weight). Below the table the factor is 1
/// (within 1e-15), above it (k > 1e30, a hair from grazing) the f64 steps; 0 for an infinite
/// k (at grazing).
#[inline(always)]
pub fn roughness_factor<T: Single>(k: T) -> T {
    let c = T::of32;
    let shift = (23 - K_NODE_BITS) as i32;
    let table = &*ROUGHNESS;
    let last = table.len() as i32 - 1;
    let bits = k.to_bits();
    let node = (bits >> shift) - T::int((127 + K_OCTAVE_MIN) << K_NODE_BITS);
    let below = !ge(k, c(2f32.powi(K_OCTAVE_MIN)));
    let inside = T::int_lt(node, T::int(last));
    let at = T::int_min(T::int_max(node, T::int(0)), T::int(last - 1));
    let t = T::of_int(bits & T::int((1 << shift) - 1)) / c((1u32 << shift) as f32);
    let (a, b) = (T::gather(table, at), T::gather(table, at + T::int(1)));
    let factor = a + t * (b - a);
    let factor = match all::<T>(inside | below) {
        true => factor,
        // Only within a hair of grazing (or infinite at it).
        false => {
            let [beyond] = T::per_lane([k], |[k]| match k.is_finite() {
                true => [roughness_factor_newton(k as f64) as f32],
                false => [0.0],
            });
            select(inside, factor, beyond)
        }
    };
    select(below, c(1.0), factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_within_its_bound_of_shadowing_and_erfc() {
        let mut worst = (0.0f64, 0.0f64);
        // Dense in v (between and at the nodes) and far out in s.
        let points = (0..200_000)
            .map(|k| k as f64 / 200_000.0)
            .map(|v| v / (1.0 - v))
            .chain([1e-9, 1e-4, 0.5, 3.0, 29.0, 31.0, 1e4, 1e30]);
        for s in points {
            let (shadow, erfc) = lookup(s as f32);
            let de = (shadow as f64 - shadowing(s)).abs();
            let dr = (erfc as f64 - libm::erfc(s)).abs();
            worst.0 = worst.0.max(de);
            worst.1 = worst.1.max(dr);
        }
        assert!(
            worst.0 <= TABLE_ERROR_BOUND as f64 && worst.1 <= TABLE_ERROR_BOUND as f64,
            "worst errors: shadowing {:e}, erfc {:e}",
            worst.0,
            worst.1
        );
        // Limits: fully shadowed at s = 0, unshadowed for s = inf (and NaN).
        assert_eq!(lookup(0.0f32), (0.0, 1.0));
        assert_eq!(lookup(f32::INFINITY), (1.0, 0.0));
        assert_eq!(lookup(f32::NAN), (1.0, 0.0));
    }

    #[test]
    fn the_roughness_factor_table_follows_the_newton_steps() {
        let mut worst = 0.0f64;
        // Every 1/1000 of an octave from 2^-30 to 2^110 (nodes, between them, both ends).
        for i in 0..140_000 {
            let k = 2f64.powf(-30.0 + i as f64 / 1000.0) as f32;
            let got = roughness_factor(k) as f64;
            let want = roughness_factor_newton(k as f64);
            worst = worst.max((got - want).abs() / want);
        }
        assert!(worst <= 2e-5, "worst relative error {worst:e}");
        assert_eq!(roughness_factor(0.0f32), 1.0);
        assert_eq!(roughness_factor(f32::INFINITY), 0.0);
        assert_eq!(roughness_factor(f32::NAN), 1.0);
    }

    #[test]
    fn lanes_equal_the_scalar_terms_bit_for_bit() {
        use crate::simd::{LANES, f32xn};
        let ks = [
            0.0,
            -1.0,
            1e-30,
            1e-7,
            0.3,
            1.0,
            7.5,
            1e10,
            3e30,
            1e38,
            f32::INFINITY,
            f32::NAN,
        ];
        let cs = [
            1.0,
            1.0 - 1e-7,
            0.999,
            0.5,
            0.1,
            1e-4,
            1e-7,
            0.0,
            0.7,
            0.2,
            0.05,
            0.9,
        ];
        for first in (0..ks.len()).step_by(LANES) {
            let lane = |v: &[f32]| f32xn::new(crate::simd::lanes(|j| v[(first + j) % v.len()]));
            let r = roughness_factor(lane(&ks)).to_array();
            let (sh, kk) = direction_terms(0.3, 2.0, lane(&cs));
            let (e_s, e_k) = elevation_terms(0.3, 2.0, lane(&cs), lane(&cs[1..]));
            for j in 0..LANES {
                let (k, c, c2) = (
                    ks[(first + j) % ks.len()],
                    cs[(first + j) % cs.len()],
                    cs[1..][(first + j) % (cs.len() - 1)],
                );
                assert_eq!(r[j].to_bits(), roughness_factor(k).to_bits(), "k {k}");
                let (s1, k1) = direction_terms(0.3, 2.0, c);
                assert_eq!(
                    (sh.to_array()[j].to_bits(), kk.to_array()[j].to_bits()),
                    (s1.to_bits(), k1.to_bits()),
                    "c {c}"
                );
                let (s2, k2) = elevation_terms(0.3, 2.0, c, c2);
                assert_eq!(
                    (e_s.to_array()[j].to_bits(), e_k.to_array()[j].to_bits()),
                    (s2.to_bits(), k2.to_bits())
                );
            }
        }
    }
}
