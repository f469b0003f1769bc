//! Blinn-Phong (J. Blinn, "Models of Light Reflection for Computer Synthesized Pictures",
//! 1977), the normalized half-vector form of Ngan et al. 2005's fits:
//!
//!   lobe = (n + 2) / (2 pi) cos^n(theta_h)
//!
//! bbm aliases Ngan's Blinn-Phong to its mirror-direction "modified Phong", but the
//! published exponents and colours only agree with the same materials' Ward, Cook-Torrance
//! and Ashikhmin-Shirley fits under the half-vector form (lobe widths and albedos within
//! ~30 %, exponents ~4x the mirror-lobe ones, as n_h ~ 4 n_r predicts); docs/models.md
//! records the evidence.
//!
//! Sampling: the lobe is the cosine-power microfacet distribution D(h) of the same n, so its
//! half vectors are drawn as that distribution's visible normals (a Beckmann proposal of
//! m = sqrt(2 / (n + 2)), [`Distribution::sample_visible`]): the density of h follows
//! D(h) max(0, wo.h), so the weight f cos / p does not carry wo.h, which at grazing `wo`
//! would waste most samples of a D(h)-only sampler (docs/performance.md, "Sampling variance
//! per model").

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use super::microfacet::Distribution;
use crate::lobe::{self, GenericLobe, Lobe};
use crate::math::{Num, V3, le, maximum, powf, select};
use crate::schema::{
    Bounds, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params, PublishedFit,
};
use crate::{Flags, ParamError};
use std::f32::consts::PI;
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct BlinnPhong {
    pub n: f64,
}

/// Density (n + 1) / (2 pi) cos^n(theta) of a direction at angle theta from a cosine-power
/// lobe's axis (zero for `cos_t <= 0`), one formula for one value and lanes ([`Num`]).
#[inline(always)]
pub fn cos_power_pdf<T: Num>(n: f32, cos_t: T) -> T {
    let zero = T::of(0.0);
    let p = T::of(((n + 1.0) / (2.0 * PI)) as f64) * powf(cos_t, T::of(n as f64));
    select(le(cos_t, zero), zero, p)
}

impl BlinnPhong {
    /// The lobe as a microfacet distribution (cosine power of exponent n), whose visible
    /// normals sample it.
    #[inline]
    fn distribution(&self) -> Distribution {
        Distribution::CosinePower { n: self.n.max(0.0) }
    }
}

impl GenericLobe for BlinnPhong {
    /// The lobe (zero below the surface).
    #[inline(always)]
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        let (h, has_half) = lobe::half_where(wo, wi);
        let n = T::of(self.n);
        let v = (n + T::of(2.0)) / (T::of(2.0) * T::of(std::f64::consts::PI))
            * powf(maximum(h.z, zero), n);
        select(lobe::both_above(wo, wi) & has_half, v, zero)
    }

    #[inline(always)]
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        self.distribution().pdf_reflected(wo, wi)
    }

    #[inline(always)]
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, _uc: T) -> (V3<T>, T::Mask) {
        self.distribution().sample_reflected(wo, ux, uy)
    }
}

impl Lobe for BlinnPhong {
    fn model(&self) -> &'static str {
        "blinn-phong"
    }
    crate::impl_lobe_forms!();

    fn flags(&self) -> Flags {
        Flags::ISOTROPIC | Flags::RECIPROCAL | Flags::GLOSSY
    }
}

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "blinn-phong",
    summary: "Blinn-Phong, normalized: (n + 2) / (2 pi) cos^n theta_h",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "n",
            Bounds::closed(0.0, 1.0e7),
            100.0,
            "exponent of cos(theta_h)",
        )
        .fitted(FitRange::log(1.0, 1e6, &[10.0, 100.0, 1000.0])),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    Ok(Arc::new(BlinnPhong { n: p.scalar("n") }))
}

/// Blinn-Phong; Ngan's fitted `sharpness` is n (half-vector form, module docs).
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[FitVariant::single("blinn-phong", FitGroup::Isotropic)],
    published: Some(PublishedFit {
        file: "ngan_blinnphong.fit",
        class: "NganBlinnPhong",
        keys: &[("n", "sharpness")],
        settings: &[],
    }),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_value() {
        let t = 25f64.to_radians();
        let b = BlinnPhong { n: 50.0 };
        // wo at 25 degrees, wi at 55 degrees in the plane: theta_h = 15 degrees.
        let wo = V3::new(-t.sin(), 0.0, t.cos());
        let t2 = 55f64.to_radians();
        let wi = V3::new(t2.sin(), 0.0, t2.cos());
        let expected = 52.0 / (2.0 * std::f64::consts::PI) * 15f64.to_radians().cos().powf(50.0);
        assert!((b.value(wo, wi) - expected).abs() < 1e-12 * expected);
    }
}
