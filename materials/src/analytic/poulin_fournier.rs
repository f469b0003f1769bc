//! Poulin and Fournier, "A Model for Anisotropic Reflection" (SIGGRAPH 1990): a surface of
//! parallel cylinders (axis along the tangent, x) of radius 1 whose axes lie at height `h`
//! above a flat base and are separated by gaps `d` (both in cylinder radii; the period is
//! P = 2 + d), each point reflecting with a normalized Phong lobe (exponent `n`); the BRDF is
//! the average over one period of the light reflected by the points that are both visible
//! and lit, self-shadowing and masking by the neighbouring cylinders included.
//!
//! Only the abstract of the paper was available; the construction below (a reconstruction
//! checked against brute-force ray casting, see the tests) follows it: for a direction w,
//! alpha = atan2(w_y, w_z) is its angle in the cross-section and |w'| = sqrt(w_y^2 + w_z^2).
//! Points of the arc at angle phi (normal N = (0, sin phi, cos phi)) are visible for phi in
//! one interval bounded by front-facing (|phi - alpha| < pi/2), the base (|phi| <= acos(-h))
//! and the neighbouring cylinder on the side w leans to (|phi - alpha| < asin(P cos alpha - 1)
//! there); the flat strip between cylinders is visible on one interval bounded by the
//! neighbours' overhang shadows. With the local lobe
//! f_loc(N) = (n + 2) / (2 pi) max(R . wo, 0)^n, R the mirror of wi about N, which on the arc
//! is R . wo = |wi'||wo'| cos(2 phi - alpha_i - alpha_o) - wi_x wo_x,
//!
//!   lobe = [ int_{vis and lit} f_loc(N(phi)) cos(phi - alpha_i) cos(phi - alpha_o) dphi
//!            + f_loc(z) l cos(alpha_i) cos(alpha_o) ] / (P cos(alpha_i) cos(alpha_o))
//!
//! (l the width of the strip both visible and lit). The arc integral is evaluated with
//! 32-point Gauss-Legendre quadrature over the part of the interval where the lobe is
//! non-zero, narrowed to +-12 standard deviations of its peak for large n (Ngan et al.
//! 2005 fit brushed aluminium with n = 3000, d = 0.18, h = 0.5, Fig. 9).
//!
//! Sampling: a facet is chosen with probability proportional to its visible projected
//! area as seen from wo (the strip, or an arc angle with density cos(phi - alpha_o)), wo is
//! mirrored about its normal and the Phong lobe (n) sampled around the mirror direction;
//! the density marginalizes over the facet with the same quadrature.

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use crate::frame::Frame;
use crate::lobe::{Lobe, above};
use crate::math::{Real, V3};
use crate::sampling::quadrature::gl32;
use crate::schema::{Bounds, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params};
use crate::{Flags, ParamError};
use glam::{Vec2, Vec3};
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct PoulinFournier {
    pub n: f64,
    pub d: f64,
    pub h: f64,
}

/// A direction's cross-section angle alpha and projected length |w'|.
#[inline]
fn project<T: Real>(w: V3<T>) -> (T, T) {
    (w.y.atan2(w.z), (w.y * w.y + w.z * w.z).sqrt())
}

impl PoulinFournier {
    fn period(&self) -> f64 {
        2.0 + self.d
    }

    /// Arc angles visible from a direction at cross-section angle `alpha`: [lo, hi].
    #[inline]
    pub fn arc_interval<T: Real>(&self, alpha: T) -> (T, T) {
        let half_pi = T::FRAC_PI_2();
        let phi_b = T::c((-self.h).acos());
        let s = T::c(self.period()) * alpha.cos() - T::one();
        let beta = s.min(T::one()).max(-T::one()).asin();
        if alpha >= T::zero() {
            (
                (alpha - half_pi).max(-phi_b),
                (alpha + half_pi).min(phi_b).min(alpha + beta),
            )
        } else {
            (
                (alpha - half_pi).max(-phi_b).max(alpha - beta),
                (alpha + half_pi).min(phi_b),
            )
        }
    }

    /// Part of the flat strip [u_f, P - u_f] visible from `alpha`: [left, right].
    #[inline]
    pub fn flat_interval<T: Real>(&self, alpha: T) -> (T, T) {
        let c = T::c(self.h);
        let p = T::c(self.period());
        let uf = T::c((1.0 - self.h * self.h).max(0.0).sqrt());
        let (sa, ca) = (alpha.sin(), alpha.cos());
        let left = if c - sa > T::zero() {
            (T::one() - c * sa) / ca
        } else {
            uf
        };
        let right = if c + sa > T::zero() {
            p - (T::one() + c * sa) / ca
        } else {
            p - uf
        };
        (left.max(uf), right.min(p - uf))
    }

    /// int_lo^hi max(a cos(2 phi - beta) - b, 0)^n weight(phi) dphi.
    #[inline]
    fn peak_integral<T: Real>(
        &self,
        a: T,
        b: T,
        beta: T,
        lo: T,
        hi: T,
        weight: impl Fn(T) -> T,
    ) -> T {
        if hi <= lo || a <= T::zero() || b >= a {
            return T::zero();
        }
        let n = T::c(self.n);
        let hw = T::c(0.5) * (b / a).max(-T::one()).acos();
        let s = ((a - b) / (T::c(4.0) * n.max(T::c(1e-12)) * a)).sqrt();
        let reach = if T::c(12.0) * s < hw {
            T::c(12.0) * s
        } else {
            hw
        };
        let rule = gl32();
        let mut total = T::zero();
        for k in [-1.0, 0.0, 1.0] {
            let centre = T::c(0.5) * beta + T::c(k) * T::PI();
            let (w_lo, w_hi) = ((centre - reach).max(lo), (centre + reach).min(hi));
            if w_hi <= w_lo {
                continue;
            }
            let (mid, half) = (T::c(0.5) * (w_lo + w_hi), T::c(0.5) * (w_hi - w_lo));
            let mut acc = T::zero();
            for &(x, w) in rule {
                let phi = mid + half * T::c(x);
                let r = a * (T::c(2.0) * phi - beta).cos() - b;
                if r > T::zero() {
                    acc = acc + T::c(w) * r.powf(n) * weight(phi);
                }
            }
            total = total + acc * half;
        }
        total
    }

    #[inline]
    pub fn value<T: Real>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let Some((co, ci)) = above(wo, wi) else {
            return T::zero();
        };
        let (ao, no) = project(wo);
        let (ai, ni) = project(wi);
        let (cao, cai) = (ao.cos(), ai.cos());
        let denom = T::c(self.period()) * cao * cai;
        if !(denom > T::zero()) {
            return T::zero();
        }
        let norm = (T::c(self.n) + T::c(2.0)) / (T::c(2.0) * T::PI());
        let (lo_o, hi_o) = self.arc_interval(ao);
        let (lo_i, hi_i) = self.arc_interval(ai);
        let arc = self.peak_integral(
            no * ni,
            wo.x * wi.x,
            ao + ai,
            lo_o.max(lo_i),
            hi_o.min(hi_i),
            |phi| (phi - ai).cos().max(T::zero()) * (phi - ao).cos().max(T::zero()),
        );
        let (l_o, r_o) = self.flat_interval(ao);
        let (l_i, r_i) = self.flat_interval(ai);
        let strip = (r_o.min(r_i) - l_o.max(l_i)).max(T::zero());
        let rz = T::c(2.0) * ci * co - wi.dot(wo);
        let flat = if rz > T::zero() {
            rz.powf(T::c(self.n))
        } else {
            T::zero()
        };
        let v = norm * (arc + flat * strip * cao * cai) / denom;
        if v.is_finite() {
            v.max(T::zero())
        } else {
            T::zero()
        }
    }

    fn phong_around(&self, axis: Vec3, u: Vec2) -> Vec3 {
        let n = self.n as f32;
        let cos_t = u.y.powf(1.0 / (n + 1.0));
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (s, c) = (2.0 * std::f32::consts::PI * u.x).sin_cos();
        Frame::from_normal(axis).to_world(Vec3::new(sin_t * c, sin_t * s, cos_t))
    }
}

impl Lobe for PoulinFournier {
    fn model(&self) -> &'static str {
        "poulin-fournier"
    }
    crate::impl_lobe_eval!();

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<Vec3> {
        if wo.z <= 0.0 {
            return None;
        }
        let (ao, _) = project::<f32>(wo.into());
        let p = self.period() as f32;
        let (l, r) = self.flat_interval(ao);
        let p_flat = ((r - l).max(0.0) / p).clamp(0.0, 1.0);
        let normal = if uc < p_flat {
            Vec3::Z
        } else {
            // phi with density proportional to cos(phi - alpha_o) on the visible arc.
            let (lo, hi) = self.arc_interval(ao);
            if hi <= lo {
                return None;
            }
            let t = (uc - p_flat) / (1.0 - p_flat).max(f32::MIN_POSITIVE);
            let (s_lo, s_hi) = ((lo - ao).sin(), (hi - ao).sin());
            let phi = ao
                + (s_lo + t.clamp(0.0, 1.0) * (s_hi - s_lo))
                    .clamp(-1.0, 1.0)
                    .asin();
            Vec3::new(0.0, phi.sin(), phi.cos())
        };
        let mirror = 2.0 * wo.dot(normal) * normal - wo;
        let wi = self.phong_around(mirror.normalize_or(Vec3::Z), u);
        (wi.z > 0.0).then_some(wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let (ao, no) = project::<f32>(wo.into());
        let (ai, ni) = project::<f32>(wi.into());
        let p = self.period() as f32;
        let cao = ao.cos();
        if !(cao > 0.0) {
            return 0.0;
        }
        let n = self.n as f32;
        let phong = (n + 1.0) / (2.0 * std::f32::consts::PI);
        let (l, r) = self.flat_interval(ao);
        let p_flat = ((r - l).max(0.0) / p).clamp(0.0, 1.0);
        let rz = 2.0 * wi.z * wo.z - wi.dot(wo);
        let flat = if rz > 0.0 {
            p_flat * phong * rz.powf(n)
        } else {
            0.0
        };
        let (lo, hi) = self.arc_interval(ao);
        let arc = self.peak_integral(no * ni, wo.x * wi.x, ao + ai, lo, hi, |phi| {
            (phi - ao).cos().max(0.0)
        });
        let v = flat + phong * arc / (p * cao);
        if v.is_finite() { v } else { 0.0 }
    }

    fn flags(&self) -> Flags {
        Flags::RECIPROCAL | Flags::GLOSSY
    }
}

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "poulin-fournier",
    summary: "Poulin-Fournier 1990 anisotropic cylinders (axis along the tangent): Phong exponent n, gap d, height h",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "n",
            Bounds::closed(0.0, 1.0e7),
            100.0,
            "Phong exponent of the cylinders' reflection",
        )
        .fitted(FitRange::log(1.0, 1e5, &[30.0, 1000.0])),
        lobe_param(
            "d",
            Bounds::closed(0.0, 1.0e3),
            0.5,
            "gap between adjacent cylinders, in cylinder radii",
        )
        .fitted(FitRange::linear(0.0, 5.0, &[0.2, 1.0])),
        lobe_param(
            "h",
            Bounds::closed(0.0, 1.0),
            0.5,
            "height of the cylinder axes above the base, in radii (0: half cylinders, 1: resting on the base)",
        )
        .fitted(FitRange::linear(0.0, 1.0, &[0.5])),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    Ok(Arc::new(PoulinFournier {
        n: p.scalar("n"),
        d: p.scalar("d"),
        h: p.scalar("h"),
    }))
}

/// Poulin-Fournier, fitted to anisotropic (4D) data (section 5).
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[FitVariant::single("poulin-fournier", FitGroup::Anisotropic)],
    published: None,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Is the point at arc angle `phi` (or flat position `u`) of the cylinder at the origin
    /// visible from cross-section direction `alpha`? Brute-force 2D ray casting against the
    /// neighbouring cylinders.
    fn visible(pf: &PoulinFournier, point: (f64, f64), normal: (f64, f64), alpha: f64) -> bool {
        let dir = (alpha.sin(), alpha.cos());
        if normal.0 * dir.0 + normal.1 * dir.1 <= 0.0 {
            return false;
        }
        let p = pf.period();
        for k in -3i32..=3 {
            let c = (k as f64 * p, pf.h);
            // Ray-circle intersection (radius 1) for t > 1e-9, with the hit above z = 0.
            let f = (point.0 - c.0, point.1 - c.1);
            let b = f.0 * dir.0 + f.1 * dir.1;
            let cc = f.0 * f.0 + f.1 * f.1 - 1.0;
            let disc = b * b - cc;
            if disc < 0.0 {
                continue;
            }
            for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
                if t > 1e-9 && point.1 + t * dir.1 >= 0.0 {
                    return false;
                }
            }
        }
        true
    }

    #[test]
    fn visibility_intervals_match_ray_casting() {
        let mut mismatches = 0;
        let mut checked = 0;
        for &(d, h) in &[(0.18, 0.5), (0.0, 0.0), (1.0, 1.0), (0.5, 0.9), (3.0, 0.2)] {
            let pf = PoulinFournier { n: 10.0, d, h };
            for k in 0..41 {
                let alpha = -1.5 + 3.0 * k as f64 / 40.0;
                let (lo, hi) = pf.arc_interval(alpha);
                let phi_b = (-h).acos();
                for j in 0..400 {
                    let phi = -phi_b + 2.0 * phi_b * (j as f64 + 0.5) / 400.0;
                    let inside = phi > lo && phi < hi;
                    let truth = visible(
                        &pf,
                        (phi.sin(), h + phi.cos()),
                        (phi.sin(), phi.cos()),
                        alpha,
                    );
                    // Points within 1e-6 of an interval end are ambiguous.
                    if (phi - lo).abs() > 1e-6 && (phi - hi).abs() > 1e-6 {
                        checked += 1;
                        mismatches += (inside != truth) as u32;
                    }
                }
                let (l, r) = pf.flat_interval(alpha);
                let uf = (1.0 - h * h).sqrt();
                for j in 0..200 {
                    let u = uf + (pf.period() - 2.0 * uf) * (j as f64 + 0.5) / 200.0;
                    let inside = u > l && u < r;
                    let truth = visible(&pf, (u, 0.0), (0.0, 1.0), alpha);
                    if (u - l).abs() > 1e-6 && (u - r).abs() > 1e-6 {
                        checked += 1;
                        mismatches += (inside != truth) as u32;
                    }
                }
            }
        }
        assert_eq!(
            mismatches, 0,
            "{mismatches} of {checked} points disagree with ray casting"
        );
    }

    #[test]
    fn lobe_matches_brute_force_integration() {
        // Average f_loc (N.wi)(N.wo) over visible-and-lit points of one period, by ray
        // casting on a fine grid, divided by P cos(theta_i) cos(theta_o).
        let pf = PoulinFournier {
            n: 20.0,
            d: 0.4,
            h: 0.6,
        };
        let dir = |t: f64, p: f64| {
            let (t, p) = (t.to_radians(), p.to_radians());
            V3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
        };
        for (wo, wi) in [
            (dir(30.0, 80.0), dir(40.0, 250.0)),
            (dir(60.0, 100.0), dir(20.0, 290.0)),
            (dir(45.0, 30.0), dir(45.0, 200.0)),
        ] {
            let (ao, ai) = (wo.y.atan2(wo.z), wi.y.atan2(wi.z));
            let f_loc = |nrm: V3<f64>| {
                let r = nrm * (2.0 * nrm.dot(wi)) - wi;
                (pf.n + 2.0) / (2.0 * std::f64::consts::PI) * r.dot(wo).max(0.0).powf(pf.n)
            };
            let mut acc = 0.0;
            let steps = 200_000;
            let phi_b = (-pf.h).acos();
            let dphi = 2.0 * phi_b / steps as f64;
            for j in 0..steps {
                let phi = -phi_b + (j as f64 + 0.5) * dphi;
                let pt = (phi.sin(), pf.h + phi.cos());
                let nrm2 = (phi.sin(), phi.cos());
                if visible(&pf, pt, nrm2, ao) && visible(&pf, pt, nrm2, ai) {
                    let nrm = V3::new(0.0, phi.sin(), phi.cos());
                    acc += f_loc(nrm) * nrm.dot(wi).max(0.0) * nrm.dot(wo).max(0.0) * dphi;
                }
            }
            let uf = (1.0 - pf.h * pf.h).sqrt();
            let du = (pf.period() - 2.0 * uf) / steps as f64;
            for j in 0..steps {
                let u = uf + (j as f64 + 0.5) * du;
                if visible(&pf, (u, 0.0), (0.0, 1.0), ao) && visible(&pf, (u, 0.0), (0.0, 1.0), ai)
                {
                    acc += f_loc(V3::new(0.0, 0.0, 1.0)) * wi.z * wo.z * du;
                }
            }
            let expected = acc / (pf.period() * wi.z * wo.z);
            let got = pf.value(wo, wi);
            assert!(
                (got - expected).abs() <= 1e-3 * expected + 1e-9,
                "{got} vs brute force {expected}"
            );
        }
    }
}
