//! Ward's anisotropic Gaussian model (G. Ward, "Measuring and Modeling Anisotropic
//! Reflection", SIGGRAPH 1992, eq. 5), isotropic (alpha) and anisotropic (alpha_x along the
//! tangent, alpha_y along the bitangent):
//!
//!   lobe = exp(-tan^2(theta_h) (cos^2(phi_h) / alpha_x^2 + sin^2(phi_h) / alpha_y^2))
//!          / (4 pi alpha_x alpha_y sqrt(cos(theta_i) cos(theta_o)))
//!
//! `alpha` is the standard deviation of the surface slope (Ngan's fitted `roughness` is
//! alpha itself; bbm `ward.h`). The same code gives Ward-Duer ([`super::ward_duer`]) with
//! the denominator cos(theta_i) cos(theta_o) instead of its square root.
//!
//! Sampling: Ward's exp(-tan^2(theta_h)(...)) / (pi ax ay cos^4(theta_h)) is the
//! anisotropic Beckmann distribution D of roughness (ax, ay) (Walter, "Notes on the Ward
//! BRDF", 2005, samples D(h) cos(theta_h)); half vectors are drawn from its visible
//! normals ([`super::microfacet::visible`]), which at grazing `wo` waste no samples on
//! facets `wo` cannot see, and reflected.

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use super::microfacet::{MIN_ROUGHNESS, visible};
use crate::lobe::{self, GenericLobe, Lobe};
use crate::math::{Num, V3, eq, exp, gt, is_finite, le, maximum, select, sqrt};
use crate::schema::{
    Bounds, Contains, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params, PublishedFit,
};
use crate::{Flags, ParamError};
use std::f32::consts::PI;
use std::sync::Arc;

/// Ward-Duer's cosines are floored at cos(89 degrees) (module docs of
/// [`super::ward_duer`]): the lobe is Duer's exactly up to 89 degrees, and its sample weight
/// is at most 1 / cos(89 degrees) (about 57) instead of growing as 1 / cos(theta_o).
pub const DUER_COS_FLOOR: f64 = 0.017_452_406_437_283_5;

/// Ward (`duer = false`) or Ward-Duer (`duer = true`).
#[derive(Clone, Debug)]
pub struct Ward {
    pub alpha_x: f64,
    pub alpha_y: f64,
    pub duer: bool,
}

impl Ward {
    /// Ward's lobe with slope deviations `alpha_x`, `alpha_y` (> 0; each below
    /// [`MIN_ROUGHNESS`] acts as [`MIN_ROUGHNESS`], as Mitsuba clamps its microfacet
    /// roughness: narrower, 1 / alpha^2 overflows f32 near alpha 1e-19 and the lobe would
    /// vanish).
    pub fn new(alpha_x: f64, alpha_y: f64, duer: bool) -> Self {
        Self {
            alpha_x: alpha_x.max(MIN_ROUGHNESS),
            alpha_y: alpha_y.max(MIN_ROUGHNESS),
            duer,
        }
    }

    /// The exponent tan^2(theta_h) (cos^2 phi_h / ax^2 + sin^2 phi_h / ay^2) from an
    /// unnormalized half vector.
    #[inline(always)]
    fn exponent<T: Num>(&self, h: V3<T>) -> T {
        let (ax, ay) = (T::of(self.alpha_x), T::of(self.alpha_y));
        (h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay)) / (h.z * h.z)
    }

    /// The roughness (tangent, bitangent) of the visible-normal proposal.
    fn roughness<T: Num>(&self) -> (T, T) {
        (T::of(self.alpha_x), T::of(self.alpha_y))
    }
}

impl GenericLobe for Ward {
    /// The lobe: zero below the surface, where the half vector points down, where the
    /// exponential underflows or the value overflows.
    #[inline(always)]
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        let h = wo + wi;
        let e = exp(-self.exponent(h));
        let norm = T::of(4.0) * T::of(std::f64::consts::PI) * T::of(self.alpha_x * self.alpha_y);
        let cos_term = if self.duer {
            let floor = T::of(DUER_COS_FLOOR);
            maximum(wi.z, floor) * maximum(wo.z, floor)
        } else {
            sqrt(wi.z * wo.z)
        };
        let v = e / (norm * cos_term);
        let ok = lobe::both_above(wo, wi) & gt(h.z, zero) & !eq(e, zero) & is_finite(v);
        select(ok, v, zero)
    }

    /// The visible-normal density of the half vector (Ward's exp(-tan^2 ...) / (pi ax ay
    /// cos^4) is Beckmann's D) over 4 wo.h.
    #[inline(always)]
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        let norm = T::of((PI * (self.alpha_x * self.alpha_y) as f32) as f64);
        let (mx, my) = self.roughness();
        let p = lobe::reflected_pdf(wo, wi, |h| {
            let d = exp(-self.exponent(h)) / (norm * (h.z * h.z) * (h.z * h.z));
            visible::pdf(mx, my, wo, h, select(le(h.z, zero), zero, d))
        });
        select(is_finite(p), p, zero)
    }

    /// A visible normal of the anisotropic Beckmann distribution, reflected.
    #[inline(always)]
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, _uc: T) -> (V3<T>, T::Mask) {
        let (mx, my) = self.roughness();
        lobe::reflect_above(wo, visible::sample(mx, my, wo, ux, uy))
    }
}

impl Lobe for Ward {
    fn model(&self) -> &'static str {
        if self.duer { "ward-duer" } else { "ward" }
    }
    crate::impl_lobe_forms!();

    fn flags(&self) -> Flags {
        let iso = if self.alpha_x == self.alpha_y {
            Flags::ISOTROPIC
        } else {
            Flags::NONE
        };
        iso | Flags::RECIPROCAL | Flags::GLOSSY
    }
}

const ALPHA_BOUNDS: Bounds = Bounds::above(0.0, 10.0);

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "ward",
    summary: "Ward 1992, isotropic: exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 sqrt(cos_i cos_o))",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "alpha",
            ALPHA_BOUNDS,
            0.1,
            "standard deviation of the surface slope; below 1e-4 it acts as 1e-4",
        )
        .fitted(FitRange::log(1e-3, 1.0, &[0.03, 0.1, 0.3])),
    ],
};

pub const SCHEMA_ANISO: ModelSchema = ModelSchema {
    name: "ward-anisotropic",
    summary: "Ward 1992, anisotropic: alpha_x along the tangent, alpha_y along the bitangent",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "alpha_x",
            ALPHA_BOUNDS,
            0.1,
            "slope deviation along the tangent (x); below 1e-4 it acts as 1e-4",
        )
        .fitted(FitRange::log(1e-3, 1.0, &[0.03, 0.2])),
        lobe_param(
            "alpha_y",
            ALPHA_BOUNDS,
            0.1,
            "slope deviation along the bitangent (y); below 1e-4 it acts as 1e-4",
        )
        .fitted(FitRange::log(1e-3, 1.0, &[0.03, 0.2])),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    let a = p.scalar("alpha");
    Ok(Arc::new(Ward::new(a, a, false)))
}

fn lobe_aniso(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    Ok(Arc::new(Ward::new(
        p.scalar("alpha_x"),
        p.scalar("alpha_y"),
        false,
    )))
}

/// Isotropic Ward; Ngan's fitted `roughness` is alpha.
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[FitVariant::single("ward", FitGroup::Isotropic)],
    published: Some(PublishedFit {
        file: "ngan_ward.fit",
        class: "NganWard",
        keys: &[("alpha", "roughness")],
        settings: &[],
    }),
};

/// Anisotropic Ward; with alpha_x = alpha_y = alpha it is Ward, whose optimum its fit
/// starts from.
pub const MODEL_ANISO: LobeModel = LobeModel {
    schema: SCHEMA_ANISO,
    lobe: lobe_aniso,
    fits: &[
        FitVariant::single("ward-anisotropic", FitGroup::Anisotropic).containing(Contains {
            label: "ward",
            params: &[("alpha_x", "alpha"), ("alpha_y", "alpha")],
        }),
    ],
    published: None,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_values() {
        // theta_i = 20, theta_o = 40 degrees in the incidence plane (phi_o = 180).
        let (ti, to) = (20f64.to_radians(), 40f64.to_radians());
        let wi = V3::new(ti.sin(), 0.0, ti.cos());
        let wo = V3::new(-to.sin(), 0.0, to.cos());
        let th = ((to - ti) / 2.0).abs(); // half-angle from the normal in the plane
        let a = 0.2;
        let ward = Ward::new(a, a, false);
        let expected = (-(th.tan().powi(2)) / (a * a)).exp()
            / (4.0 * std::f64::consts::PI * a * a * (ti.cos() * to.cos()).sqrt());
        assert!((ward.value(wo, wi) - expected).abs() < 1e-12 * expected);
        let duer = Ward::new(a, a, true);
        assert!(
            (duer.value(wo, wi) - expected * (ti.cos() * to.cos()).sqrt() / (ti.cos() * to.cos()))
                .abs()
                < 1e-12 * expected
        );
        // Anisotropic: in the xz plane only alpha_x matters.
        let aniso = Ward::new(a, 0.05, false);
        let e2 = (-(th.tan().powi(2)) / (a * a)).exp()
            / (4.0 * std::f64::consts::PI * a * 0.05 * (ti.cos() * to.cos()).sqrt());
        assert!((aniso.value(wo, wi) - e2).abs() < 1e-12 * e2);
    }
}
