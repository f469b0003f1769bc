//! Lafortune's generalized cosine lobes (Lafortune, Foo, Torrance and Greenberg,
//! "Non-Linear Approximation of Reflectance Functions", SIGGRAPH 1997, eq. 4; Ngan et al.
//! 2005, eq. 2), with the extra normalization of Ngan's fits (bbm `ngan.h`):
//!
//!   s    = Cx wi_x wo_x + Cy wi_y wo_y + Cz wi_z wo_z
//!   lobe = (n + 2) / (2 pi) (max(s, 0) / max(|Cx|, |Cy|, |Cz|))^n     (normalization "ngan")
//!   lobe = max(s, 0)^n                                               (normalization "none")
//!
//! The ratio is raised to the power as one number, so large n neither underflows nor gives
//! 0/0 (bbm's separate powers of s and of max|C| do for n > ~1350). Several lobes form a
//! `composite` material (section 4.2 of the study).
//!
//! Sampling: a cosine-power lobe (n) around the generalized mirror direction
//! u' = normalize(Cx wo_x, Cy wo_y, Cz wo_z): the lobe is |C o wo|^n (u' . wi)^n.

use super::blinn_phong::cos_power_pdf;
use super::common::{DIFFUSE, SPECULAR, lobe_param, setting};
use crate::frame;
use crate::lobe::{self, GenericLobe, Lobe};
use crate::math::{Num, V3, gt, is_finite, le, minimum, powf, select, sqrt};
use crate::schema::{
    Bounds, Contains, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params, PublishedFit,
};
use crate::{Flags, ParamError};
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct Lafortune {
    pub cx: f64,
    pub cy: f64,
    pub cz: f64,
    pub n: f64,
    /// Ngan's (n + 2) / (2 pi max|C|^n) normalization.
    pub ngan: bool,
}

impl Lafortune {
    fn cmax(&self) -> f64 {
        self.cx.abs().max(self.cy.abs()).max(self.cz.abs())
    }

    /// The generalized mirror direction of `wo`, normalized as glam's `try_normalize`
    /// (times the reciprocal length), and where it exists.
    #[inline(always)]
    fn axis<T: Num>(&self, wo: V3<T>) -> (V3<T>, T::Mask) {
        let a = V3::new(
            T::of(self.cx) * wo.x,
            T::of(self.cy) * wo.y,
            T::of(self.cz) * wo.z,
        );
        let rcp = T::of(1.0) / sqrt(a.length_squared());
        (a * rcp, is_finite(rcp) & gt(rcp, T::of(0.0)))
    }
}

impl GenericLobe for Lafortune {
    /// The lobe: zero below the surface, where the generalized cosine is not positive,
    /// and where the power overflows.
    #[inline(always)]
    fn value<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let zero = T::of(0.0);
        let s = T::of(self.cx) * wi.x * wo.x
            + T::of(self.cy) * wi.y * wo.y
            + T::of(self.cz) * wi.z * wo.z;
        let n = T::of(self.n);
        let v = if self.ngan {
            let cmax = T::of(self.cmax());
            let norm = (n + T::of(2.0)) / (T::of(2.0) * T::of(std::f64::consts::PI));
            let v = norm * powf(minimum(s / cmax, T::of(1.0)), n);
            select(le(cmax, zero), zero, v)
        } else {
            powf(s, n)
        };
        select(
            lobe::both_above(wo, wi) & gt(s, zero) & is_finite(v),
            v,
            zero,
        )
    }

    /// The cosine-power density about the axis.
    #[inline(always)]
    fn density<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        let (axis, has_axis) = self.axis(wo);
        let p = cos_power_pdf(self.n as f32, axis.dot(wi));
        select(lobe::both_above(wo, wi) & has_axis, p, T::of(0.0))
    }

    /// A cosine-power direction about the axis, kept above the surface.
    #[inline(always)]
    fn draw<T: Num>(&self, wo: V3<T>, ux: T, uy: T, _uc: T) -> (V3<T>, T::Mask) {
        let zero = T::of(0.0);
        let (axis, has_axis) = self.axis(wo);
        let n = self.n as f32;
        let local = lobe::half_from(powf(uy, T::of((1.0 / (n + 1.0)) as f64)), ux);
        let wi = frame::to_world_of_normal(axis, local);
        (wi, gt(wo.z, zero) & has_axis & gt(wi.z, zero))
    }
}

impl Lobe for Lafortune {
    fn model(&self) -> &'static str {
        "lafortune"
    }
    crate::impl_lobe_forms!();

    fn flags(&self) -> Flags {
        let iso = if self.cx == self.cy {
            Flags::ISOTROPIC
        } else {
            Flags::NONE
        };
        iso | Flags::RECIPROCAL | Flags::GLOSSY
    }
}

const C_BOUNDS: Bounds = Bounds::closed(-1.0e3, 1.0e3);

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "lafortune",
    summary: "Lafortune generalized cosine lobe (Cx wi_x wo_x + Cy wi_y wo_y + Cz wi_z wo_z)^n, Ngan-normalized",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "cx",
            C_BOUNDS,
            -0.577,
            "C_x (tangent); -Cz gives a lobe about the mirror direction",
        )
        .fitted(FitRange::linear(-1.0, 1.0, &[-0.6]).tied(&["cy"])),
        lobe_param(
            "cy",
            C_BOUNDS,
            -0.577,
            "C_y (bitangent); equal to cx for isotropic lobes",
        ),
        // In log space down to 1e-12: Ngan's fits of fabrics have Cz = 1.2e-10 against
        // Cxy = -0.707 (a lobe about the horizontal mirror direction only).
        lobe_param("cz", C_BOUNDS, 0.577, "C_z (normal)").fitted(FitRange::log(1e-12, 1.0, &[0.6])),
        lobe_param(
            "n",
            Bounds::closed(0.0, 1.0e7),
            100.0,
            "exponent; above 1e6 it acts as 1e6",
        )
        .fitted(FitRange::log(1.0, 1e5, &[10.0, 100.0, 1000.0])),
        setting(
            "normalization",
            &["ngan", "none"],
            "ngan",
            "Ngan's (n+2)/(2 pi max|C|^n) factor, or the raw lobe",
        ),
    ],
};

/// The largest exponent the lobe uses: a larger n acts as this one. The lobe's width is
/// about 1 / sqrt(n) radians, and near the lobe's axis f32 resolves a cosine only to
/// 6e-8 (1 - 1e-6 ~ cos(1.4 mrad)); at n = 1e7 a step of one ulp changes the lobe by a
/// factor exp(-0.6), and the sampled and evaluated cosines, rounded apart, lost 9 % of
/// the energy. At 1e6 the lobe (1.4 mrad wide) is a mirror for every practical purpose.
pub const MAX_EXPONENT: f64 = 1e6;

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    let l = Lafortune {
        cx: p.scalar("cx"),
        cy: p.scalar("cy"),
        cz: p.scalar("cz"),
        n: p.scalar("n").min(MAX_EXPONENT),
        ngan: p.text("normalization") == "ngan",
    };
    if l.cmax() == 0.0 {
        return Err(ParamError::new(
            format!("{}.cz", p.path),
            "expected at least one of cx, cy, cz non-zero",
        ));
    }
    // Unnormalized, the lobe peaks at up to max|C|^n: beyond f32 it would be dropped as
    // non-finite where it is largest (a lobe with a hole at its peak).
    let peak = l.cmax().powf(l.n);
    if !l.ngan && !(peak <= f32::MAX as f64) {
        return Err(ParamError::new(
            format!("{}.n", p.path),
            format!(
                "max(|cx|, |cy|, |cz|)^n = {:.3}^{} = {peak:.3e} overflows single precision; expected at most {:.3e} (a smaller n or C, or \"normalization\": \"ngan\")",
                l.cmax(),
                l.n,
                f32::MAX
            ),
        ));
    }
    Ok(Arc::new(l))
}

const NGAN: &[(&str, &str)] = &[("normalization", "ngan")];

/// Lafortune, fitted to isotropic data with cy = cx (one lobe, and two: section 4.2);
/// Ngan's published `Cxy`, `Cz` and `sharpness` are cx = cy, cz and n.
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[
        FitVariant {
            label: "lafortune",
            settings: NGAN,
            lobes: 1,
            group: FitGroup::Isotropic,
            contains: None,
        },
        FitVariant {
            label: "lafortune-2",
            settings: NGAN,
            lobes: 2,
            group: FitGroup::TwoLobes,
            // Starts from (and keeps, unless something beats it) the one-lobe optimum in
            // both lobes: never worse than one lobe.
            contains: Some(Contains {
                label: "lafortune",
                params: &[("cx", "cx"), ("cz", "cz"), ("n", "n")],
            }),
        },
    ],
    published: Some(PublishedFit {
        file: "ngan_lafortune.fit",
        class: "NganLafortune",
        keys: &[
            ("cx", "Cxy"),
            ("cy", "Cxy"),
            ("cz", "Cz"),
            ("n", "sharpness"),
        ],
        settings: NGAN,
    }),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_value_and_no_underflow() {
        let l = Lafortune {
            cx: -0.6,
            cy: -0.6,
            cz: 0.5,
            n: 20.0,
            ngan: true,
        };
        let wo = V3::new(0.3f64, 0.1, (1.0f64 - 0.1).sqrt());
        let wi = V3::new(-0.2f64, -0.3, (1.0f64 - 0.13).sqrt());
        let s = -0.6 * 0.3 * -0.2 + -0.6 * 0.1 * -0.3 + 0.5 * wo.z * wi.z;
        let expected = 22.0 / (2.0 * std::f64::consts::PI) * (s / 0.6f64).powf(20.0);
        assert!((l.value(wo, wi) - expected).abs() < 1e-12 * expected);
        // Ngan's chrome-like fit: n = 6630 with |C| = 0.577 stays finite at the mirror peak.
        let chrome = Lafortune {
            cx: -0.577,
            cy: -0.577,
            cz: 0.577,
            n: 6630.0,
            ngan: true,
        };
        let w = V3::new(0.5f32, 0.0, 0.75f32.sqrt());
        let m = V3::new(-0.5f32, 0.0, 0.75f32.sqrt());
        let v = chrome.value(w, m);
        assert!(
            v.is_finite() && (v - 6632.0 / (2.0 * std::f32::consts::PI)).abs() < 1e-2 * v,
            "{v}"
        );
    }
}
