//! Ashikhmin-Shirley's anisotropic Phong specular lobe (M. Ashikhmin and P. Shirley, "An
//! Anisotropic Phong BRDF Model", JGT 2000, eq. 4 with Schlick's Fresnel, eq. 5), the form
//! Ngan et al. 2005 fitted (without the model's own diffuse term; bbm `ashikhminshirley.h`):
//!
//!   e    = (n_u h_x^2 + n_v h_y^2) / (1 - h_z^2)        (= n_u cos^2 phi_h + n_v sin^2 phi_h)
//!   lobe = sqrt((n_u + 1)(n_v + 1)) / (8 pi) cos(theta_h)^e F(wi . h)
//!          / ((wi . h) max(cos(theta_i), cos(theta_o)))
//!   F    = Rs + (1 - Rs)(1 - wi . h)^5
//!
//! Isotropic: n_u = n_v = n.
//!
//! Sampling: half vectors are the visible normals (Heitz and d'Eon 2014) of the anisotropic
//! Beckmann distribution of m = sqrt(2 / (n + 2)) per axis, whose peak matches the lobe's
//! cos(theta_h)^e. The paper's own sampler (eq. 9-10: p(h) proportional to cos(theta_h)^e)
//! ignores wo.h and wastes most samples at grazing `wo` (below the horizon): its variance
//! under an env map was 1.90x an ideal proposal's at theta_o 85 degrees, the visible
//! normals' 0.96 (docs/performance.md, "Sampling variance per model").

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use super::microfacet::fresnel::schlick;
use super::microfacet::{beckmann_d_anisotropic, cosine_power_beckmann_m, visible};
use crate::lobe::{self, GenericLobe, Lobe};
use crate::math::{Num, V3, gt, is_finite, le, maximum, powf, select, sqrt};
use crate::schema::{
    Bounds, Contains, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, ParamSpec, Params,
    PublishedFit,
};
use crate::{Flags, ParamError};
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct AshikhminShirley {
    pub nu: f64,
    pub nv: f64,
    /// Reflectance at normal incidence (Rs).
    pub rs: f64,
}

impl AshikhminShirley {
    /// The exponent nu cos^2(phi_h) + nv sin^2(phi_h), with sin^2(theta_h) from the
    /// tangential components (1 - h_z^2 cancels near the normal); at h = n, where its value
    /// does not matter (cos(theta_h)^e = 1), nu.
    #[inline(always)]
    fn exponent<T: Num>(&self, h: V3<T>) -> T {
        let s2 = h.x * h.x + h.y * h.y;
        let e = (T::of(self.nu) * h.x * h.x + T::of(self.nv) * h.y * h.y) / s2;
        select(le(s2, T::of(1e-12)), T::of(self.nu), e)
    }

    /// Roughness (tangent, bitangent) of the anisotropic Beckmann distribution whose
    /// visible normals sample the lobe: per axis, the one whose peak matches the cosine
    /// power of that axis's exponent ([`cosine_power_beckmann_m`]).
    #[inline]
    fn proposal_roughness<T: Num>(&self) -> (T, T) {
        let m = |n: f64| T::of(cosine_power_beckmann_m(n.max(0.0)) as f64);
        (m(self.nu), m(self.nv))
    }
}

impl GenericLobe for AshikhminShirley {
    /// The lobe: zero below the surface, where the half vector is behind either
    /// direction, and where the value overflows.
    #[inline(always)]
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let (zero, one) = (T::of(0.0), T::of(1.0));
        let (h, has_half) = lobe::half_where(wo, wi);
        let kh = wi.dot(h);
        let norm = sqrt((T::of(self.nu) + one) * (T::of(self.nv) + one))
            / (T::of(8.0) * T::of(std::f64::consts::PI));
        let lobe = powf(h.z, self.exponent(h));
        let v = norm * lobe * schlick(T::of(self.rs), kh) / (kh * maximum(wi.z, wo.z));
        let lit = lobe::both_above(wo, wi) & has_half & gt(kh, zero) & gt(h.z, zero);
        select(lit & is_finite(v), v, zero)
    }

    /// The visible-normal density of the half vector over 4 wo.h.
    #[inline(always)]
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let (mx, my) = self.proposal_roughness();
        lobe::reflected_pdf(wo, wi, |h| {
            visible::pdf(mx, my, wo, h, beckmann_d_anisotropic(mx, my, h))
        })
    }

    #[inline(always)]
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, _uc: T) -> (V3<T>, T::Mask) {
        let (mx, my) = self.proposal_roughness();
        lobe::reflect_above(wo, visible::sample(mx, my, wo, ux, uy))
    }
}

impl Lobe for AshikhminShirley {
    fn model(&self) -> &'static str {
        "ashikhmin-shirley"
    }
    crate::impl_lobe_forms!();

    fn flags(&self) -> Flags {
        // The specular lobe's albedo stays below its Fresnel factor (AS 2000, sec. 3).
        let iso = if self.nu == self.nv {
            Flags::ISOTROPIC
        } else {
            Flags::NONE
        };
        iso | Flags::RECIPROCAL | Flags::ENERGY_BOUNDED | Flags::GLOSSY
    }
}

const N_BOUNDS: Bounds = Bounds::closed(0.0, 1.0e7);
/// The smallest exponent fitted: below 1, as Ngan's fits of fabrics (n = 0.5).
const N_FIT_LO: f64 = 0.1;
const RS: ParamSpec = lobe_param(
    "f0",
    Bounds::closed(0.0, 1.0),
    0.05,
    "Schlick reflectance at normal incidence (Rs)",
);

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "ashikhmin-shirley",
    summary: "Ashikhmin-Shirley 2000 specular lobe, isotropic exponent n, Schlick Fresnel",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param("n", N_BOUNDS, 100.0, "Phong exponent n = n_u = n_v").fitted(FitRange::log(
            N_FIT_LO,
            1e6,
            &[10.0, 100.0, 1000.0],
        )),
        RS.fitted(FitRange::linear(0.0, 1.0, &[0.05, 0.5])),
    ],
};

pub const SCHEMA_ANISO: ModelSchema = ModelSchema {
    name: "ashikhmin-shirley-anisotropic",
    summary: "Ashikhmin-Shirley 2000 specular lobe, exponents n_u (tangent) and n_v (bitangent)",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param("nu", N_BOUNDS, 100.0, "exponent along the tangent (x)").fitted(FitRange::log(
            N_FIT_LO,
            1e6,
            &[10.0, 1000.0],
        )),
        lobe_param("nv", N_BOUNDS, 100.0, "exponent along the bitangent (y)")
            .fitted(FitRange::log(N_FIT_LO, 1e6, &[10.0, 1000.0])),
        RS.fitted(FitRange::linear(0.0, 1.0, &[0.1])),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    let n = p.scalar("n");
    Ok(Arc::new(AshikhminShirley {
        nu: n,
        nv: n,
        rs: p.scalar("f0"),
    }))
}

fn lobe_aniso(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    Ok(Arc::new(AshikhminShirley {
        nu: p.scalar("nu"),
        nv: p.scalar("nv"),
        rs: p.scalar("f0"),
    }))
}

/// Isotropic Ashikhmin-Shirley; Ngan's published `sharpness` is n and
/// `fresnelReflectance` is Rs.
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[FitVariant::single("ashikhmin-shirley", FitGroup::Isotropic)],
    published: Some(PublishedFit {
        file: "ngan_ashikhminshirley.fit",
        class: "NganAshikhminShirley",
        keys: &[("n", "sharpness"), ("f0", "fresnelReflectance")],
        settings: &[],
    }),
};

/// Anisotropic Ashikhmin-Shirley; with nu = nv = n it is the isotropic model, whose
/// optimum its fit starts from.
pub const MODEL_ANISO: LobeModel = LobeModel {
    schema: SCHEMA_ANISO,
    lobe: lobe_aniso,
    fits: &[
        FitVariant::single("ashikhmin-shirley-anisotropic", FitGroup::Anisotropic).containing(
            Contains {
                label: "ashikhmin-shirley",
                params: &[("nu", "n"), ("nv", "n"), ("f0", "f0")],
            },
        ),
    ],
    published: None,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_value() {
        let a = AshikhminShirley {
            nu: 80.0,
            nv: 80.0,
            rs: 0.1,
        };
        let (to, ti) = (30f64.to_radians(), 50f64.to_radians());
        let wo = V3::new(-to.sin(), 0.0, to.cos());
        let wi = V3::new(ti.sin(), 0.0, ti.cos());
        let th = 10f64.to_radians();
        let kh = ((ti + to) / 2.0).cos();
        let f = 0.1 + 0.9 * (1.0 - kh).powi(5);
        let expected =
            81.0 / (8.0 * std::f64::consts::PI) * th.cos().powf(80.0) * f / (kh * to.cos());
        let got = a.value(wo, wi);
        assert!(
            (got - expected).abs() < 1e-10 * expected,
            "{got} vs {expected}"
        );
    }
}
