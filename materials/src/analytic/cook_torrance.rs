//! Cook-Torrance (Cook and Torrance, "A Reflectance Model for Computer Graphics", 1981) in
//! the form Ngan et al. 2005 fitted (sections 3.1, 4.3, 4.4):
//!
//!   lobe = D(h) G(wo, wi) F(wi . h) / (pi cos(theta_i) cos(theta_o))
//!
//! with D one of the distributions of [`super::microfacet`] (Beckmann, Gaussian, cosine
//! power; roughness `m`), G the V-groove shadowing-masking, and F none, Schlick's with
//! reflectance `f0` at normal incidence, or the exact dielectric Fresnel with index `eta`.
//! The division by pi (rather than 4) is the convention of Ngan's published fits
//! (bbm `ngan.h`, `microfacet_n::Cook`); docs/models.md states it.
//!
//! Sampling: half vectors visible from `wo` (Beckmann's distribution of visible normals,
//! Heitz and d'Eon 2014, [`super::microfacet::visible`]; a Beckmann proposal of the same
//! m for the Gaussian), or from D(h) cos(theta_h) for cosine power, reflected about h
//! (Walter et al. 2007, eq. 14).

use super::common::{DIFFUSE, SPECULAR, lobe_param, setting};
use super::microfacet::fresnel::{FRESNELS, Fresnel};
use super::microfacet::{DISTRIBUTIONS, Distribution, vgroove_g};
use crate::lobe::{self, GenericLobe, Lobe};
use crate::math::{Num, V3, eq, is_finite, maximum, select};
use crate::schema::{
    Bounds, Contains, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params, PublishedFit,
};
use crate::{Flags, ParamError};
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct CookTorrance {
    pub distribution: Distribution,
    pub fresnel: Fresnel,
}

impl CookTorrance {
    pub fn new(distribution: Distribution, fresnel: Fresnel) -> Self {
        Self {
            distribution,
            fresnel,
        }
    }
}

impl GenericLobe for CookTorrance {
    /// D G F / (pi cos_i cos_o): zero below the surface, where D vanishes, and where the
    /// value overflows.
    #[inline(always)]
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        let (h, has_half) = lobe::half_where(wo, wi);
        let (co, ci, ch, oh) = (wo.z, wi.z, h.z, wo.dot(h));
        let d = self.distribution.d(ch);
        let g = vgroove_g(ch, co, ci, oh);
        let f = self.fresnel.eval(wi.dot(h));
        let v = d * g * f / (T::of(std::f64::consts::PI) * ci * co);
        let ok = lobe::both_above(wo, wi) & has_half & !eq(d, zero) & is_finite(v);
        select(ok, maximum(v, zero), zero)
    }

    #[inline(always)]
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        self.distribution.pdf_reflected(wo, wi)
    }

    #[inline(always)]
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, _uc: T) -> (V3<T>, T::Mask) {
        self.distribution.sample_reflected(wo, ux, uy)
    }
}

impl Lobe for CookTorrance {
    fn model(&self) -> &'static str {
        "cook-torrance"
    }
    crate::impl_lobe_forms!();

    fn flags(&self) -> Flags {
        // Reciprocal (symmetric in wo, wi); not energy-bounded: the 1/pi normalization is
        // 4/pi times the physically normalized microfacet BRDF.
        Flags::ISOTROPIC | Flags::RECIPROCAL | Flags::GLOSSY
    }
}

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "cook-torrance",
    summary: "Cook-Torrance: D G F / (pi cos_i cos_o), Beckmann/Gaussian/cosine-power D, V-groove G",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "m",
            Bounds::above(0.0, 10.0),
            0.2,
            "microfacet roughness m (rms slope for Beckmann); below 1e-4 it acts as 1e-4, as in Mitsuba",
        )
        .fitted(FitRange::log(1e-3, 1.0, &[0.03, 0.1, 0.3])),
        setting(
            "distribution",
            DISTRIBUTIONS,
            "beckmann",
            "microfacet distribution",
        ),
        setting("fresnel", FRESNELS, "schlick", "Fresnel term"),
        lobe_param(
            "f0",
            Bounds::closed(0.0, 1.0),
            0.04,
            "Schlick reflectance at normal incidence (fresnel = schlick)",
        )
        .fitted(FitRange::linear(0.0, 1.0, &[0.05, 0.5]).when("fresnel", "schlick")),
        lobe_param(
            "eta",
            Bounds::above(0.0, 100.0),
            1.5,
            "relative index of refraction (fresnel = dielectric)",
        )
        .fitted(FitRange::log(1.001, 20.0, &[1.5, 4.0]).when("fresnel", "dielectric")),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    let d = Distribution::new(p.text("distribution"), p.scalar("m")).expect("validated choice");
    let f = match p.text("fresnel") {
        "none" => Fresnel::None,
        "schlick" => Fresnel::Schlick { f0: p.scalar("f0") },
        _ => Fresnel::Dielectric {
            eta: p.scalar("eta"),
        },
    };
    Ok(Arc::new(CookTorrance::new(d, f)))
}

/// A fit variant of Cook-Torrance with the given settings.
const fn variant(
    label: &'static str,
    settings: &'static [(&'static str, &'static str)],
    lobes: usize,
    group: FitGroup,
) -> FitVariant {
    FitVariant {
        label,
        settings,
        lobes,
        group,
        contains: None,
    }
}

/// The two-lobe variant contains the one-lobe one: its fit starts from (and keeps, unless
/// something beats it) the one-lobe optimum in both lobes, whose colours the linear solve
/// can give to one lobe alone, so it is never worse than one lobe.
const CONTAINS_ONE_LOBE: Contains = Contains {
    label: "cook-torrance",
    params: &[("m", "m"), ("f0", "f0")],
};

const BECKMANN_SCHLICK: &[(&str, &str)] = &[("distribution", "beckmann"), ("fresnel", "schlick")];

/// Cook-Torrance as the study fits it: Beckmann with Schlick's Fresnel (section 4), the
/// other distributions and Fresnel terms (sections 4.3, 4.4) and two lobes (section 4.2).
/// Ngan's published `roughness` is m and `eta` is Schlick's F0 (bbm `ngan.h`).
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[
        variant("cook-torrance", BECKMANN_SCHLICK, 1, FitGroup::Isotropic),
        variant(
            "cook-torrance-gaussian",
            &[("distribution", "gaussian"), ("fresnel", "schlick")],
            1,
            FitGroup::Variant,
        ),
        variant(
            "cook-torrance-cosine-power",
            &[("distribution", "cosine-power"), ("fresnel", "schlick")],
            1,
            FitGroup::Variant,
        ),
        variant(
            "cook-torrance-no-fresnel",
            &[("distribution", "beckmann"), ("fresnel", "none")],
            1,
            FitGroup::Variant,
        ),
        variant(
            "cook-torrance-dielectric",
            &[("distribution", "beckmann"), ("fresnel", "dielectric")],
            1,
            FitGroup::Variant,
        ),
        variant("cook-torrance-2", BECKMANN_SCHLICK, 2, FitGroup::TwoLobes)
            .containing(CONTAINS_ONE_LOBE),
    ],
    published: Some(PublishedFit {
        file: "ngan_cooktorrance.fit",
        class: "NganCookTorrance",
        keys: &[("m", "roughness"), ("f0", "eta")],
        settings: BECKMANN_SCHLICK,
    }),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_value_from_the_formula() {
        // wo = wi at 30 degrees from the normal in the same azimuth: h = n, D = 1/(pi m^2),
        // G = min(1, 2 cos30 * 1 / cos30) = 1, F = schlick(f0, cos 30).
        let m = 0.3f64;
        let ct = CookTorrance::new(
            Distribution::new("beckmann", m).unwrap(),
            Fresnel::Schlick { f0: 0.05 },
        );
        let t = 30f64.to_radians();
        let wo = V3::new(t.sin(), 0.0, t.cos());
        let wi = V3::new(-t.sin(), 0.0, t.cos());
        let d = 1.0 / (std::f64::consts::PI * m * m);
        let f = 0.05 + 0.95 * (1.0 - t.cos()).powi(5);
        let expected = d * 1.0 * f / (std::f64::consts::PI * t.cos() * t.cos());
        let got = ct.value::<f64>(wo, wi);
        assert!(
            (got - expected).abs() < 1e-12 * expected,
            "{got} vs {expected}"
        );
        assert!(
            (ct.value::<f32>(
                V3::new(t.sin() as f32, 0.0, t.cos() as f32),
                V3::new(-t.sin() as f32, 0.0, t.cos() as f32)
            ) as f64
                - expected)
                .abs()
                < 1e-5 * expected
        );
    }
}
