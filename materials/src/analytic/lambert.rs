//! Lambertian reflection, f_r = rho / pi (Lambert 1760), the diffuse term of every model
//! of the study (Ngan et al. 2005, section 3.1). Sampled with a cosine-weighted
//! hemisphere, so `sample` weights are exactly `rho`.
//!
//! Parameters: `reflectance` (RGB albedo, each channel in [0, 1]).

use crate::ParamError;
use crate::bsdf::{Bsdf, BsdfSample, BsdfSamplesMut, Flags, Rgb};
use crate::columns::{Vec2Cols, Vec3Cols};
use crate::fastmath::select_branchless;
use crate::sampling::warp::{
    cosine_hemisphere, cosine_hemisphere_pdf, square_to_cosine_hemisphere,
};
use crate::schema::{Bounds, DefaultValue, ModelSchema, ParamKind, ParamRole, ParamSpec, Params};
use crate::simd;
use crate::simd::{LANES, f32xn};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// f_r = reflectance / pi.
#[derive(Clone, Debug)]
pub struct Lambert {
    pub reflectance: Rgb,
}

impl Lambert {
    pub fn new(reflectance: Rgb) -> Self {
        Self { reflectance }
    }
}

impl Bsdf for Lambert {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        // Without a branch: light samples fall below the surface half the time, at random.
        let above = wo.z > 0.0 && wi.z > 0.0;
        self.reflectance * select_branchless(above, FRAC_1_PI, 0.0)
    }

    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = square_to_cosine_hemisphere(u);
        let pdf = cosine_hemisphere_pdf(wi.z);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.reflectance,
            pdf,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        select_branchless(wo.z > 0.0 && wi.z > 0.0, cosine_hemisphere_pdf(wi.z), 0.0)
    }

    /// `LANES` pairs per SIMD warp, with `eval`'s and `pdf`'s operations.
    fn eval_pdf_many(&self, wo: Vec3Cols, wi: Vec3Cols, f: &mut [Rgb], pdf: &mut [f32]) {
        assert!(wo.len() == f.len() && wi.len() == f.len() && pdf.len() == f.len());
        let zero = f32xn::splat(0.0);
        let inv_pi = f32xn::splat(FRAC_1_PI);
        for (((oc, ic), fc), pc) in wo
            .z()
            .chunks(LANES)
            .zip(wi.z().chunks(LANES))
            .zip(f.chunks_mut(LANES))
            .zip(pdf.chunks_mut(LANES))
        {
            let n = fc.len();
            let zo = f32xn::new(simd::padded(oc));
            let zi = f32xn::new(simd::padded(ic));
            let above = zo.simd_gt(zero) & zi.simd_gt(zero);
            let s = simd::sel(above, inv_pi, zero).to_array();
            let p = simd::sel(above, zi.max(zero) * inv_pi, zero).to_array();
            for i in 0..n {
                fc[i] = self.reflectance * s[i];
                pc[i] = p[i];
            }
        }
    }

    /// `LANES` queries per SIMD warp ([`cosine_hemisphere`]).
    fn sample_many(&self, wo: Vec3Cols, u: Vec2Cols, _uc: &[f32], mut out: BsdfSamplesMut) {
        let n = out.len();
        assert!(wo.len() == n && u.len() == n);
        for first in (0..n).step_by(LANES) {
            let [ux, uy] = u.load(first);
            let [x, y, z] = cosine_hemisphere(ux, uy);
            // cosine_hemisphere_pdf, per lane.
            let pdf = (z.max(f32xn::splat(0.0)) * f32xn::splat(FRAC_1_PI)).to_array();
            let (x, y, z) = (x.to_array(), y.to_array(), z.to_array());
            for i in 0..(n - first).min(LANES) {
                let k = first + i;
                // The scalar form's tests, negated as written there (NaN goes through).
                let drawn = !(wo.z()[k] <= 0.0) && !(pdf[i] <= 0.0);
                out.set(
                    k,
                    drawn.then(|| BsdfSample {
                        wi: Vec3::new(x[i], y[i], z[i]),
                        weight: self.reflectance,
                        pdf: pdf[i],
                    }),
                );
            }
        }
    }

    fn flags(&self) -> Flags {
        Flags::ISOTROPIC | Flags::RECIPROCAL | Flags::ENERGY_BOUNDED | Flags::DIFFUSE
    }

    fn name(&self) -> &str {
        "lambert"
    }
}

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "lambert",
    summary: "Lambertian diffuse reflection, f = reflectance / pi",
    params: &[ParamSpec {
        name: "reflectance",
        kind: ParamKind::Color,
        role: ParamRole::Diffuse,
        bounds: Bounds::closed(0.0, 1.0),
        default: DefaultValue::Color([0.5, 0.5, 0.5]),
        doc: "diffuse albedo (linear RGB)",
        fit: None,
    }],
};

/// The material of a validated description.
pub fn build(p: &Params) -> Result<Arc<dyn Bsdf>, ParamError> {
    Ok(Arc::new(Lambert::new(p.color("reflectance"))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_and_one_sided() {
        let l = Lambert::new(Rgb::new(0.2, 0.5, 1.0));
        let wo = Vec3::new(0.3, 0.2, 0.93).normalize();
        let wi = Vec3::new(-0.5, 0.1, 0.86).normalize();
        assert!((l.eval(wo, wi).g - 0.5 / std::f32::consts::PI).abs() < 1e-7);
        assert_eq!(l.eval(wo, -wi), Rgb::ZERO);
        assert_eq!(l.pdf(-wo, wi), 0.0);
        assert!(l.sample(-wo, Vec2::splat(0.5), 0.5).is_none());
        let s = l.sample(wo, Vec2::new(0.3, 0.7), 0.0).unwrap();
        let f = l.eval(wo, s.wi) * s.wi.z / s.pdf;
        assert!((f - s.weight).max_component().abs() < 1e-5);
    }
}
