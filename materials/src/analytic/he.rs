//! He, Torrance, Sillion and Greenberg, "A Comprehensive Physical Model for Light
//! Reflection" (SIGGRAPH 1991): the directional-diffuse term rho_dd (eq. 71), in the form
//! Ngan et al. 2005 fitted (bbm `he.h` as aliased by `ngan.h`: Westin's formulation with a
//! real index of refraction):
//!
//!   lobe_c = F(eta, wi . h) S(wi) S(wo) G D_c / (pi cos(theta_i) cos(theta_o))
//!
//! for each colour channel c at the wavelengths lambda = 0.645, 0.526, 0.444 um (R, G, B).
//! - F: the exact dielectric Fresnel term of Cook and Torrance with real `eta`.
//! - S: Smith-style shadowing of a Gaussian surface (eqs. 24-25 with the published errata's
//!   exp(-s^2) factor): s = tau cot(theta) / (2 sigma0),
//!   Lambda = exp(-s^2) / (2 sqrt(pi) s) - erfc(s) / 2, S = (1 - erfc(s) / 2) / (1 + Lambda).
//! - G = (|wi + wo|^2 / (cos theta_i + cos theta_o))^2 = 4 (wi . h)^2 / cos^2(theta_h): the
//!   closed form of eq. 76, whose polarization factors are identically one.
//! - Effective roughness (eqs. 80-83): K(theta) = tan(theta) erfc(tau / (2 sigma0 tan theta)),
//!   z0 / sigma0 = x with x exp(x^2 / 2) = (K_i + K_o) / sqrt(8 pi) (four Newton steps, as
//!   bbm), sigma = sigma0 / sqrt(1 + x^2).
//! - g = (2 pi sigma (cos theta_i + cos theta_o) / lambda)^2 (eq. 79);
//!   D = pi^2 tau^2 / (4 lambda^2) sum_{m >= 1} g^m exp(-g) / (m! m) exp(-pi^2 tau^2 v_xy^2 / (lambda^2 m))
//!   (eq. 78 with tau -> 2 pi tau / lambda inside the exponential, Westin's reading), with
//!   v_xy^2 = |(wi + wo)_xy|^2. The series (at most 64 terms, stopped per channel once the
//!   terms are below 1e-13 of the sum past their peak) is used while the smallest
//!   g of the three channels is at most 18; above 19 Beckmann's rough-surface limit
//!   sum = exp(-E / g) / g replaces it, and between 18 and 19 the two are blended linearly
//!   (bbm's switch, so that Ngan's fitted parameters mean what they meant). The rough limit
//!   keeps evaluation cheap and finite for any roughness.
//! - The specular spike rho_s (eq. 70) is not part of the lobe (bbm drops it too); the
//!   uniform-diffuse term is the material's Lambertian.
//!
//! `sigma0` and `tau` are in micrometres. Sampling: a mixture of two Beckmann visible-normal
//! samplers (Heitz and d'Eon 2014) with alpha = lambda_G / (2 pi tau cos_o) (the diffraction
//! width of the smooth regime, which widens in angle at grazing) and alpha = 2 sigma(wo, wo) / tau (the rough regime, where the lobe
//! is Cook-Torrance with that Beckmann alpha), weighted by the diffraction term's share of
//! the series' energy at `wo` ([`He::proposals`]).

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use super::he_series;
use super::he_shadowing;
use super::microfacet::fresnel::{Fresnel::Dielectric, dielectric};
use super::microfacet::{MIN_ROUGHNESS, beckmann_visible_pdf, visible};
use crate::fastmath;
use crate::lobe::{self, Lobe, SingleLobe, above};
use crate::math::{Real, Single, V3, all, gt, half, is_finite, lt, maximum, minimum, select, sqrt};
use crate::schema::{
    Bounds, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params, PublishedFit,
};
use crate::{Flags, ParamError};
use glam::DVec3;
use std::sync::Arc;

/// Wavelengths of the R, G, B channels in micrometres (bbm's `Config::wavelength`).
pub const WAVELENGTHS_UM: [f64; 3] = [0.645, 0.526, 0.444];

/// Tested bound of the rendered lobe ([`He::value_rendered`]) against the fitted one
/// ([`He::value_tabulated`]), relative to the latter's value.
pub const RENDER_ERROR_BOUND: f64 = 5e-4;

/// Largest number of series terms.
const MAX_TERMS: usize = 64;

#[derive(Clone, Debug)]
pub struct He {
    /// RMS roughness sigma_0, micrometres.
    pub sigma0: f64,
    /// Autocorrelation length tau, micrometres.
    pub tau: f64,
    /// Real relative index of refraction.
    pub eta: f64,
}

impl He {
    /// Shadowing S(theta) of one direction.
    #[inline]
    fn shadow<T: Real>(&self, cos_t: T) -> T {
        if self.sigma0 <= f64::EPSILON {
            return T::one();
        }
        let sin_t = (T::one() - cos_t * cos_t).max(T::zero()).sqrt();
        if sin_t <= T::c(1e-7) {
            return T::one();
        }
        let s = T::c(self.tau) * (cos_t / sin_t) / (T::c(2.0 * self.sigma0));
        if s > T::c(30.0) {
            return T::one();
        }
        let e = s.erfc();
        let lambda = (-s * s).exp() / (T::c(2.0 * std::f64::consts::PI.sqrt()) * s) - T::c(0.5) * e;
        ((T::one() - T::c(0.5) * e) / (T::one() + lambda))
            .max(T::zero())
            .min(T::one())
    }

    /// K(theta) = tan(theta) erfc(tau / (2 sigma0 tan(theta))).
    #[inline]
    fn k_term<T: Real>(&self, cos_t: T) -> T {
        let sin_t = (T::one() - cos_t * cos_t).max(T::zero()).sqrt();
        let tan_t = sin_t / cos_t;
        if !(tan_t > T::c(1e-7)) {
            return T::zero();
        }
        tan_t * (T::c(self.tau) / (T::c(2.0 * self.sigma0) * tan_t)).erfc()
    }

    /// Effective roughness sigma(wi, wo) in micrometres.
    #[inline]
    pub fn sigma_eff<T: Real>(&self, ci: T, co: T) -> T {
        if self.sigma0 <= f64::EPSILON {
            return T::zero();
        }
        T::c(self.sigma0) * he_shadowing::roughness_factor_newton(self.k_term(ci) + self.k_term(co))
    }

    /// The series of eq. 78 without its prefactor, for one channel: the Poisson weights
    /// g^m exp(-g) / m! (at most 1, so f32 cannot overflow) by recurrence, one exp per term,
    /// stopped past the Poisson peak once a term is below 1e-13 of the sum (f32: its epsilon).
    #[inline]
    fn series<T: Real>(g: T, e: T) -> T {
        let tol = T::epsilon().max(T::c(1e-13));
        let mut sum = T::zero();
        let mut p = (-g).exp(); // g^m exp(-g) / m!
        for m in 1..=MAX_TERMS {
            let mf = T::c(m as f64);
            p = p * g / mf;
            let term = p * (-e / mf).exp() / mf;
            sum = sum + term;
            if mf > g && term <= tol * sum {
                break;
            }
        }
        sum
    }

    /// The factors that depend only on the two elevations: S(wi) S(wo) and sigma(wi, wo).
    #[inline]
    fn elevation_terms<T: Real>(&self, ci: T, co: T) -> (T, T) {
        (self.shadow(ci) * self.shadow(co), self.sigma_eff(ci, co))
    }

    /// The lobe per channel, its series summed term by term (the reference the table is
    /// tested against; f32 or f64).
    #[inline]
    pub fn value<T: Real>(&self, wo: V3<T>, wi: V3<T>) -> [T; 3] {
        self.value_with(wo, wi, |ci, co| self.elevation_terms(ci, co), Self::series)
    }

    /// The lobe per channel in f64 with the series from its table (fitting; within
    /// [`he_series::TABLE_ERROR_BOUND`] of the lobe's peak of the summed series).
    #[inline]
    pub fn value_tabulated(&self, wo: V3<f64>, wi: V3<f64>) -> [f64; 3] {
        self.value_with(
            wo,
            wi,
            |ci, co| self.elevation_terms(ci, co),
            Self::series_tabulated,
        )
    }

    /// The series from its table where the table covers (g, e), else summed.
    #[inline]
    fn series_tabulated(g: f64, e: f64) -> f64 {
        he_series::tabulated(g, e).unwrap_or_else(|| Self::series(g, e))
    }

    /// The render path's per-channel constants, in f32: (2 pi / lambda, with which
    /// g = (k sigma (cos_i + cos_o))^2; the prefactor pi^2 tau^2 / (4 lambda^2); and
    /// pi^2 tau^2 / lambda^2, with which e = that |(wi + wo)_xy|^2).
    #[inline(always)]
    fn channel_constants(&self) -> [(f32, f32, f32); 3] {
        let pi2tau2 = std::f64::consts::PI * std::f64::consts::PI * self.tau * self.tau;
        WAVELENGTHS_UM.map(|l| {
            let l2 = l * l;
            (
                (2.0 * std::f64::consts::PI / l) as f32,
                (pi2tau2 / (4.0 * l2)) as f32,
                (pi2tau2 / l2) as f32,
            )
        })
    }

    /// The lobe as rendered, per channel, one pair or lanes of pairs in f32:
    /// [`He::value_tabulated`]'s terms in the same order, with the elevation terms from
    /// [`he_shadowing`]'s universal tables (in lanes) and the series from its f32 table
    /// ([`he_series::tabulated_single`]); within [`RENDER_ERROR_BOUND`] of the fitted lobe
    /// (tested). The tables replace the summed series (up to 64 exponentials per channel,
    /// once the largest single cost of rendering He's fits) and four `erfc` and four `exp`
    /// of the elevation terms.
    pub fn value_rendered<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> [T; 3] {
        self.value_at_half(wo, wi, lobe::half_where(wo, wi))
    }

    /// [`He::value_rendered`] with the half vectors (and where they exist) already found.
    #[inline(always)]
    fn value_at_half<T: Single>(
        &self,
        wo: V3<T>,
        wi: V3<T>,
        (h, has_half): (V3<T>, T::Mask),
    ) -> [T; 3] {
        let s = T::of32;
        let zero = s(0.0);
        let (co, ci) = (wo.z, wi.z);
        let cd = wi.dot(h);
        let ch = h.z;
        let ok = lobe::both_above(wo, wi) & has_half & gt(cd, zero) & gt(ch, zero);
        let fresnel = Dielectric { eta: self.eta }.eval(cd);
        let (sigma0, tau) = (self.sigma0 as f32, self.tau as f32);
        let (shadow, sigma) = he_shadowing::elevation_terms(sigma0, tau, ci, co);
        let g_geo = s(4.0) * cd * cd / (ch * ch);
        let (sx, sy) = (wi.x + wo.x, wi.y + wo.y);
        let vxy2 = sx * sx + sy * sy;
        let consts = self.channel_constants();
        let gs = consts.map(|(k, _, _)| {
            let k = s(k) * sigma * (ci + co);
            k * k
        });
        let g_min = minimum(minimum(gs[0], gs[1]), gs[2]);
        let common = fresnel * shadow * g_geo / (s(std::f32::consts::PI) * ci * co);
        let (rough_only, blended) = (gt(g_min, s(19.0)), gt(g_min, s(18.0)));
        let w = g_min - s(18.0);
        // The rough limit where some value takes it, the series where some value is below
        // the rough regime (one query takes one, lanes where they disagree both).
        let (any_rough, any_series) = (!all::<T>(!blended), !all::<T>(rough_only));
        let channel = |c: usize| {
            let (_, n, e_per_vxy2) = consts[c];
            let (n, e) = (s(n), s(e_per_vxy2) * vxy2);
            let g = gs[c];
            let rough = if any_rough {
                fastmath::exp(-e / g) / g
            } else {
                zero
            };
            let series = if any_series {
                he_series::tabulated_single(g, e)
            } else {
                zero
            };
            let blend = (s(1.0) - w) * series + w * rough;
            let sum = select(rough_only, rough, select(blended, blend, series));
            let v = common * n * sum;
            select(ok & is_finite(v), maximum(v, zero), zero)
        };
        [channel(0), channel(1), channel(2)]
    }

    /// The solid-angle density of [`SingleLobe::draw`] at `wi` (one pair or lanes), the half
    /// vectors (and where they exist) already found.
    #[inline(always)]
    fn density_at_half<T: Single>(
        &self,
        wo: V3<T>,
        wi: V3<T>,
        (h, has_half): (V3<T>, T::Mask),
    ) -> T {
        let [smooth, rough, w] = self.proposals(wo.z);
        let p_h = w * beckmann_visible_pdf(smooth, wo, h)
            + (T::of32(1.0) - w) * beckmann_visible_pdf(rough, wo, h);
        let p = lobe::half_to_incident_pdf(p_h, wo.dot(h));
        let ok = lobe::both_above(wo, wi) & has_half & is_finite(p);
        select(ok, p, T::of32(0.0))
    }

    /// The proposals' roughnesses (smooth, rough) and the smooth one's share of the
    /// samples at `wo` (one or lanes, written once). The series is a Poisson mixture over m
    /// of lobes whose energy goes as the Poisson weight g^m e^-g / m!, the term m a lobe
    /// sqrt(m) times as wide as the m = 1 term, the diffraction lobe the smooth proposal
    /// follows. The rough proposal takes the width of the term one standard deviation above
    /// the Poisson mean, m = g + sqrt(g) + 1: 2 sigma / tau sqrt(1 + 1 / sqrt(g) + 1 / g),
    /// the rough limit 2 sigma / tau as g grows (the limit alone would leave the wider terms
    /// of the upper tail to heavy-tailed weights). The smooth proposal's share is the m = 1
    /// term's part of the series' energy at g(wo, wo), g e^-g / (1 - e^-g), kept within
    /// [0.05, 0.95] so that neither proposal is ever left out; it is computed only where it
    /// is under the upper bound (g above 0.1), where 1 - e^-g does not cancel in f32.
    #[inline(always)]
    fn proposals<T: Single>(&self, cos_o: T) -> [T; 3] {
        let c = T::of32;
        let clamp = |x: T, lo: T, hi: T| minimum(maximum(x, lo), hi);
        let co = clamp(cos_o, c(1e-4), c(1.0));
        // The m = 1 term is exp(-pi^2 tau^2 |(wi + wo)_xy|^2 / lambda^2): Beckmann's
        // exp(-tan^2 / m^2) with tan = |(wi + wo)_xy| / (cos_i + cos_o), so
        // m (cos_i + cos_o) = lambda / (pi tau) = a. The lobe's directions lie about half
        // its width above the mirror direction (which matters at grazing wo, where the
        // horizon cuts the lobe's lower half): cos_i ~ cos_o + m / 2, and
        // m = a / (2 cos_o + m / 2), whose positive root is
        // 2 a / (2 cos_o + sqrt(4 cos_o^2 + 2 a)).
        let a = c((WAVELENGTHS_UM[1] / (std::f64::consts::PI * self.tau)) as f32);
        let root = sqrt(c(4.0) * co * co + c(2.0) * a);
        let smooth = clamp(
            c(2.0) * a / (c(2.0) * co + root),
            c(MIN_ROUGHNESS as f32),
            c(2.0),
        );
        let sigma = he_shadowing::self_roughness(self.sigma0 as f32, self.tau as f32, co);
        let k = c((4.0 * std::f64::consts::PI / WAVELENGTHS_UM[1]) as f32) * sigma * co;
        let g = k * k;
        let live = gt(g, c(1e-12));
        let widened =
            c((2.0 / self.tau) as f32) * sigma * sqrt(c(1.0) + c(1.0) / sqrt(g) + c(1.0) / g);
        let rough = clamp(select(live, widened, smooth), smooth, c(2.0));
        // The share is over 0.95 (the clamp) up to g = 0.102; above 0.1, 1 - e^-g keeps its
        // digits in f32.
        let e = fastmath::exp(-g);
        let first = select(gt(g, c(0.1)), g * e / (c(1.0) - e), c(1.0));
        [smooth, rough, clamp(first, c(0.05), c(0.95))]
    }

    /// The lobe per channel, with the elevation factors from `terms(cos_i, cos_o)` (called
    /// at most once) and the series of eq. 78 from `series(g, e)`.
    #[inline]
    fn value_with<T: Real>(
        &self,
        wo: V3<T>,
        wi: V3<T>,
        terms: impl FnOnce(T, T) -> (T, T),
        series: impl Fn(T, T) -> T,
    ) -> [T; 3] {
        let zero = [T::zero(); 3];
        let Some((co, ci)) = above(wo, wi) else {
            return zero;
        };
        let Some(h) = half(wo, wi) else { return zero };
        let cd = wi.dot(h);
        let ch = h.z;
        if cd <= T::zero() || ch <= T::zero() {
            return zero;
        }
        let fresnel = dielectric(T::c(self.eta), cd);
        if fresnel == T::zero() {
            return zero;
        }
        let (s, sigma) = terms(ci, co);
        let g_geo = T::c(4.0) * cd * cd / (ch * ch);
        // |(wi + wo)_xy|^2 directly: 4 cd^2 (1 - ch^2) cancels catastrophically near the
        // mirror direction, where narrow lobes are evaluated.
        let (sx, sy) = (wi.x + wo.x, wi.y + wo.y);
        let vxy2 = sx * sx + sy * sy;
        let pi2tau2 = T::c(std::f64::consts::PI * std::f64::consts::PI * self.tau * self.tau);
        let mut gs = [T::zero(); 3];
        for (c, g) in gs.iter_mut().enumerate() {
            let k = T::c(2.0 * std::f64::consts::PI / WAVELENGTHS_UM[c]) * sigma * (ci + co);
            *g = k * k;
        }
        let g_min = gs[0].min(gs[1]).min(gs[2]);
        let common = fresnel * s * g_geo / (T::PI() * ci * co);
        let mut out = [T::zero(); 3];
        for c in 0..3 {
            let l2 = T::c(WAVELENGTHS_UM[c] * WAVELENGTHS_UM[c]);
            let n = pi2tau2 / (T::c(4.0) * l2);
            let e = pi2tau2 * vxy2 / l2;
            let g = gs[c];
            let rough = || (-e / g).exp() / g;
            let sum = if g_min > T::c(19.0) {
                rough()
            } else if g_min > T::c(18.0) {
                let w = g_min - T::c(18.0);
                (T::one() - w) * series(g, e) + w * rough()
            } else {
                series(g, e)
            };
            let v = common * n * sum;
            out[c] = if v.is_finite() {
                v.max(T::zero())
            } else {
                T::zero()
            };
        }
        out
    }
}

impl Lobe for He {
    fn model(&self) -> &'static str {
        "he"
    }

    fn eval_f64(&self, wo: DVec3, wi: DVec3) -> [f64; 3] {
        self.value_tabulated(wo.into(), wi.into())
    }

    fn eval_f64_many(&self, pairs: &[(DVec3, DVec3)], out: &mut [[f64; 3]]) {
        // The elevation factors of the last (cos_i, cos_o) seen, compared bit for bit so the
        // result is exactly that of `eval_f64`.
        let mut memo: Option<((u64, u64), (f64, f64))> = None;
        for (o, &(wo, wi)) in out.iter_mut().zip(pairs) {
            *o = self.value_with::<f64>(
                wo.into(),
                wi.into(),
                |ci, co| {
                    let key = (ci.to_bits(), co.to_bits());
                    match memo {
                        Some((k, t)) if k == key => t,
                        _ => {
                            let t = self.elevation_terms(ci, co);
                            memo = Some((key, t));
                            t
                        }
                    }
                },
                Self::series_tabulated,
            );
        }
    }

    crate::impl_lobe_forms!(single);

    fn flags(&self) -> Flags {
        Flags::ISOTROPIC | Flags::RECIPROCAL | Flags::GLOSSY
    }
}

/// The rendered lobe ([`He::value_rendered`]) and its sampler, in f32 and lanes.
impl SingleLobe for He {
    #[inline(always)]
    fn channels<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> [T; 3] {
        self.value_rendered(wo, wi)
    }

    /// The value and the density, sharing the half vector.
    #[inline(always)]
    fn channels_density<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> ([T; 3], T) {
        let h = lobe::half_where(wo, wi);
        (
            self.value_at_half(wo, wi, h),
            self.density_at_half(wo, wi, h),
        )
    }

    #[inline(always)]
    fn density<T: Single>(&self, wo: V3<T>, wi: V3<T>) -> T {
        self.density_at_half(wo, wi, lobe::half_where(wo, wi))
    }

    /// A direction for `wo` (one or lanes): the proposal chosen by `uc`, a Beckmann visible
    /// normal of its roughness (Heitz and d'Eon 2014) and its mirror, and where that is a
    /// sample.
    #[inline(always)]
    fn draw<T: Single>(&self, wo: V3<T>, ux: T, uy: T, uc: T) -> (V3<T>, T::Mask) {
        let [smooth, rough, w] = self.proposals(wo.z);
        let m = select(lt(uc, w), smooth, rough);
        lobe::reflect_above(wo, visible::sample(m, m, wo, ux, uy))
    }
}

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "he",
    summary: "He-Torrance-Sillion-Greenberg 1991 directional-diffuse lobe (Westin form, real eta, RGB wavelengths)",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "sigma0",
            Bounds::closed(0.0, 100.0),
            0.2,
            "RMS surface height sigma_0 in micrometres",
        )
        .fitted(FitRange::log(1e-3, 10.0, &[0.1, 1.0])),
        lobe_param(
            "tau",
            Bounds::above(0.0, 10000.0),
            3.0,
            "autocorrelation length tau in micrometres",
        )
        .fitted(FitRange::log(0.03, 200.0, &[3.0, 30.0])),
        lobe_param(
            "eta",
            Bounds::above(0.0, 100.0),
            1.5,
            "real relative index of refraction (1 makes F, hence the lobe, zero)",
        )
        .fitted(FitRange::log(1.001, 20.0, &[1.5])),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    // The tables are built when the first He material is (not during a render).
    he_series::build_table();
    he_shadowing::build_table();
    Ok(Arc::new(He {
        sigma0: p.scalar("sigma0"),
        tau: p.scalar("tau"),
        eta: p.scalar("eta"),
    }))
}

/// He et al.; Ngan's published `roughness`, `autocorrelation` and `eta` are sigma0, tau
/// and eta.
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[FitVariant::single("he", FitGroup::Isotropic)],
    published: Some(PublishedFit {
        file: "ngan_he.fit",
        class: "NganHe",
        keys: &[
            ("sigma0", "roughness"),
            ("tau", "autocorrelation"),
            ("eta", "eta"),
        ],
        settings: &[],
    }),
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::microfacet::Distribution;
    use crate::simd::{LANES, Vec3xN};
    use glam::Vec3;

    fn dir(theta: f64, phi: f64) -> V3<f64> {
        let (t, p) = (theta.to_radians(), phi.to_radians());
        V3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// S(g, e) from its definition rather than its expansion: for a Gaussian height
    /// correlation C(r) = exp(-r^2 / tau^2), He et al.'s directional-diffuse term is the
    /// Hankel transform of exp(-g) (exp(g C(r)) - 1) (their eqs. 66-68), whose expansion in
    /// powers of g C(r), transformed term by term (int exp(-m x^2) J0(b x) x dx =
    /// exp(-b^2 / 4m) / 2m), is the series of eq. 78:
    ///
    ///   S(g, e) = 2 int_0^inf exp(-g) (exp(g exp(-x^2)) - 1) J0(2 sqrt(e) x) x dx.
    ///
    /// Integrated by Simpson's rule with libm's J0, independent of the series' recurrence,
    /// truncation and tables.
    fn series_by_quadrature(g: f64, e: f64) -> f64 {
        let (n, end) = (40_000, 7.0);
        let step = end / n as f64;
        let b = 2.0 * e.sqrt();
        let f = |x: f64| 2.0 * (-g).exp() * (g * (-x * x).exp()).exp_m1() * libm::j0(b * x) * x;
        let inner: f64 = (1..n)
            .map(|k| f(k as f64 * step) * if k % 2 == 1 { 4.0 } else { 2.0 })
            .sum();
        (f(0.0) + inner + f(end)) * step / 3.0
    }

    /// The series, as summed (fitting's reference and f32 rendering) and as tabulated, is
    /// its defining integral, to 1e-6 of the lobe's peak (e = 0) from smooth (g = 0.05) to
    /// the rough end of the series' use (g = 18), near the peak and in its tail.
    #[test]
    fn series_is_the_transform_of_the_gaussian_correlation() {
        for g in [0.05, 0.5, 2.0, 8.0, 18.0] {
            let peak = series_by_quadrature(g, 0.0);
            for e in [0.0, 0.1, 1.0, 5.0, 30.0, 200.0] {
                let exact = series_by_quadrature(g, e);
                for (how, got) in [
                    ("summed", He::series::<f64>(g, e)),
                    (
                        "summed in f32",
                        He::series::<f32>(g as f32, e as f32) as f64,
                    ),
                    ("tabulated", He::series_tabulated(g, e)),
                ] {
                    let tol = if how == "summed in f32" { 1e-5 } else { 1e-6 };
                    assert!(
                        (got - exact).abs() <= tol * peak,
                        "{how} S({g}, {e}) = {got}, its integral {exact} (peak {peak})"
                    );
                    // A series 1 % off fails (the control).
                    if e < 5.0 {
                        assert!((1.01 * got - exact).abs() > tol * peak, "{g} {e}");
                    }
                }
            }
        }
    }

    /// Above g = 19 the lobe takes Beckmann's rough-surface limit exp(-e / g) / g of the
    /// series (bbm's switch, which Ngan's fits were made with): it is the integral's leading
    /// term for large g, within 1.5 / g of the peak (its first correction is 1 / g; measured:
    /// the limit is 0.946 of the integral at the peak at g = 19.5, 0.974 at g = 40).
    #[test]
    fn rough_limit_is_the_integral_for_large_g() {
        for g in [19.5, 25.0, 40.0] {
            let peak = series_by_quadrature(g, 0.0);
            for e in [0.0, 0.3 * g, g, 3.0 * g] {
                let exact = series_by_quadrature(g, e);
                let limit = (-e / g).exp() / g;
                assert!(
                    (limit - exact).abs() <= 1.5 / g * peak,
                    "S({g}, {e}): limit {limit}, integral {exact}"
                );
            }
        }
    }

    /// The render path (f32 lanes, tabulated elevation terms and series) against the f64
    /// lobe fitting uses at the same (f32) directions, on a dense grid of directions
    /// (grazing ones included) for smooth to rough, short to long correlation lengths.
    #[test]
    fn rendered_lobe_is_within_its_bound_of_the_fitted_lobe() {
        let mut worst = (0.0f64, String::new());
        for sigma0 in [0.001, 0.01, 0.1, 0.647, 3.0, 10.0] {
            for tau in [0.03, 0.3, 3.0, 28.0, 200.0] {
                let he = He {
                    sigma0,
                    tau,
                    eta: 1.8,
                };
                for ti in [0.0, 5.0, 30.0, 60.0, 80.0, 89.0, 89.9] {
                    for to in (0..=180).map(|k| k as f64 * 0.5) {
                        for po in [180.0, 150.0, 90.0, 0.0] {
                            // The directions as the renderer has them, in f32: the
                            // fitted lobe at the same directions.
                            let (wi, wo) = (dir(ti, 0.0).into_f32(), dir(to, po).into_f32());
                            let f64_of = |v: V3<f32>| V3::new(v.x as f64, v.y as f64, v.z as f64);
                            let t = he.value_tabulated(f64_of(wo), f64_of(wi));
                            let r = he.value_rendered::<f32>(wo, wi).map(|v| v as f64);
                            for c in 0..3 {
                                assert!(r[c].is_finite() && r[c] >= 0.0);
                                if t[c] < 1e-12 {
                                    assert!(r[c] <= 1e-9, "{r:?} against {t:?}");
                                    continue;
                                }
                                let e = (r[c] - t[c]).abs() / t[c];
                                if e > worst.0 {
                                    worst = (e, format!("{sigma0} {tau} {ti} {to} {po} {c}"));
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(worst.0 <= RENDER_ERROR_BOUND, "worst {worst:?}");
        eprintln!("worst relative error {worst:?}");
    }

    /// The render path's lanes equal its one-at-a-time form bit for bit, for smooth to
    /// rough lobes (the rough limit and the blend included) and directions from normal to
    /// grazing, below the horizon and opposite (no half vector).
    #[test]
    fn rendered_lanes_equal_single_evaluations() {
        let mut bits = crate::math::xorshift64(0x9e37_79b9_7f4a_7c15);
        let mut next = move || (bits() >> 40) as f32 / (1u64 << 24) as f32;
        let mut nonzero = 0;
        for (sigma0, tau) in [
            (0.0, 3.0),
            (0.01, 200.0),
            (0.2, 3.0),
            (0.647, 8.0),
            (3.0, 10.0),
            (10.0, 0.3),
        ] {
            let he = He {
                sigma0,
                tau,
                eta: 1.8,
            };
            for round in 0..200 {
                let d = |next: &mut dyn FnMut() -> f32| {
                    let z = 2.0 * next() - 1.0;
                    let phi = std::f32::consts::TAU * next();
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    Vec3::new(r * phi.cos(), r * phi.sin(), z.abs().max(1e-6))
                };
                let wo: [Vec3; LANES] = std::array::from_fn(|_| d(&mut next));
                let wi: [Vec3; LANES] = std::array::from_fn(|k| match (round + k) % 9 {
                    0 => Vec3::new(-wo[k].x, -wo[k].y, wo[k].z), // the mirror direction
                    1 => -wo[k],
                    2 => Vec3::new(wo[k].x, wo[k].y, -wo[k].z),
                    3 => Vec3::new(0.0, 0.0, 1.0),
                    _ => d(&mut next),
                });
                let lanes = he.value_rendered(Vec3xN::from_array(&wo), Vec3xN::from_array(&wi));
                for k in 0..LANES {
                    let one = he.value_rendered::<f32>(wo[k].into(), wi[k].into());
                    let lane = lanes.map(|c| c.to_array()[k]);
                    for c in 0..3 {
                        assert_eq!(
                            one[c].to_bits(),
                            lane[c].to_bits(),
                            "{he:?} {} {}",
                            wo[k],
                            wi[k]
                        );
                    }
                    nonzero += (one[0] > 0.0) as usize;
                }
            }
        }
        assert!(nonzero > 3000, "{nonzero} non-zero values");
    }

    #[test]
    fn rough_limit_is_cook_torrance_with_beckmann_alpha() {
        // With every channel in the rough regime the lobe equals
        // F S(i) S(o) D_beckmann(alpha = 2 sigma / tau) / (4 cos_i cos_o) in every channel.
        let he = He {
            sigma0: 2.0,
            tau: 20.0,
            eta: 1.6,
        };
        let (wo, wi) = (dir(35.0, 180.0), dir(40.0, 10.0));
        let v = he.value::<f64>(wo, wi);
        let h = half(wo, wi).unwrap();
        let alpha = 2.0 * he.sigma_eff::<f64>(wi.z, wo.z) / he.tau;
        let d = Distribution::Beckmann { m: alpha }.d(h.z);
        let ct = dielectric(1.6, wi.dot(h)) * he.shadow(wi.z) * he.shadow(wo.z) * d
            / (4.0 * wi.z * wo.z);
        for vc in v {
            assert!((vc - ct).abs() < 1e-9 * ct, "{vc} vs {ct}");
        }
    }

    /// The batch evaluation of the fits shares the elevation factors between consecutive
    /// pairs; its values must be those of `eval_f64`, bit for bit, whatever the order.
    #[test]
    fn batch_evaluation_equals_single_evaluation() {
        let lobes = [
            He {
                sigma0: 0.3,
                tau: 8.0,
                eta: 1.6,
            },
            He {
                sigma0: 3.0,
                tau: 10.0,
                eta: 1.8,
            },
        ];
        let mut pairs = Vec::new();
        for ti in [0.0, 10.0, 45.0, 79.5] {
            for to in [0.5, 30.0, 79.5] {
                for pd in [0.0, 1.0, 90.0, 179.0] {
                    pairs.push((dir(to, pd), dir(ti, 0.0)));
                }
            }
        }
        // Interleave repeated and changed elevations.
        let n = pairs.len();
        for k in 0..n {
            pairs.push(pairs[(k * 7) % n]);
        }
        let pairs: Vec<(DVec3, DVec3)> = pairs
            .into_iter()
            .map(|(o, i)| (DVec3::new(o.x, o.y, o.z), DVec3::new(i.x, i.y, i.z)))
            .collect();
        for lobe in &lobes {
            let mut out = vec![[f64::NAN; 3]; pairs.len()];
            lobe.eval_f64_many(&pairs, &mut out);
            assert!(out.iter().any(|v| v[0] > 0.0));
            for (v, &(wo, wi)) in out.iter().zip(&pairs) {
                let single = lobe.eval_f64(wo, wi);
                for c in 0..3 {
                    assert_eq!(v[c].to_bits(), single[c].to_bits(), "{wo} {wi}");
                }
            }
        }
    }
}
