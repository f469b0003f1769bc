//! RGL measured BSDFs (Dupuy and Jakob, "An Adaptive Parameterization for Efficient
//! Material Acquisition and Rendering", SIGGRAPH Asia 2018), `*_rgb.bsdf` tensor files,
//! evaluated and sampled as Mitsuba 3's `measured` plugin does:
//!
//! - angles map to the unit square by u = sqrt(theta / (pi/2)) and u = (phi + pi) / (2 pi);
//! - with `wo` the viewer direction (the table's parameter: Mitsuba's `si.wi`) and `wi` the
//!   light, m = normalize(wi + wo); the half vector's coordinates u_m (azimuth relative to
//!   phi_o for isotropic tables) are inverted through the visible-normal distribution
//!   `vndf` (a parameterized piecewise-bilinear warp, [`Marginal2D`]) to a point s of its
//!   sample space, where the `rgb` tables are interpolated; with the Jacobian flag the value
//!   is multiplied by ndf(u_m) / (4 sigma(u_o)). That value is the BRDF times cos(theta_i),
//!   so f = value / cos(theta_i). The tables can hold small negative values (down to about
//!   -0.3 x cos in vch_golden_yellow's blue channel); like Mitsuba, [`Rgl`] returns them as
//!   they are, and the `rgl` material clamps them at zero unless `"clamp": false`.
//! - Sampling warps (u2, u1) through `luminance` then `vndf` to u_m, builds m, reflects wo;
//!   pdf = p_vndf p_lum / (2 pi^2 u_m.x sin(theta_m) 4 (wo . m)).
//!
//! Anisotropic tables (more than two phi_i values) are folded by their symmetry reduction
//! as Mitsuba does; isotropic ones use no reduction.

use super::marginal2d::Marginal2D;
use super::tensor::TensorFile;
use crate::Rgb;
use crate::error::FileError;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};
use std::path::Path;

#[derive(Clone, Debug)]
pub struct Rgl {
    pub description: String,
    isotropic: bool,
    reduction: u32,
    jacobian: bool,
    ndf: Marginal2D,
    sigma: Marginal2D,
    vndf: Marginal2D,
    luminance: Marginal2D,
    rgb: [Marginal2D; 3],
}

impl Rgl {
    pub fn memory_bytes(&self) -> usize {
        self.ndf.memory_bytes()
            + self.sigma.memory_bytes()
            + self.vndf.memory_bytes()
            + self.luminance.memory_bytes()
            + self.rgb.iter().map(Marginal2D::memory_bytes).sum::<usize>()
    }
}

fn theta2u(t: f32) -> f32 {
    (t * (2.0 / PI)).max(0.0).sqrt()
}
fn phi2u(p: f32) -> f32 {
    (p + PI) * (0.5 / PI)
}
fn u2theta(u: f32) -> f32 {
    u * u * FRAC_PI_2
}
fn u2phi(u: f32) -> f32 {
    (2.0 * u - 1.0) * PI
}
/// acos(d.z) computed stably (Mitsuba's `elevation`).
fn elevation(d: Vec3) -> f32 {
    2.0 * (0.5 * (d.x * d.x + d.y * d.y + (d.z - 1.0) * (d.z - 1.0)).sqrt())
        .clamp(-1.0, 1.0)
        .asin()
}
/// -v when the sign bit of s is clear (s >= +0), v otherwise (Dr.Jit's mulsign_neg).
fn mulsign_neg(v: f32, s: f32) -> f32 {
    if s.is_sign_positive() { -v } else { v }
}

/// What a field's values may be.
#[derive(Clone, Copy)]
enum Range {
    /// Angles in radians, strictly increasing (the parameter axes).
    Angles,
    /// Densities: in [0, MAX_VALUE].
    Density,
    /// A divisor: in (0, MAX_VALUE].
    Positive,
    /// Values (BRDF x cosine): magnitude up to MAX_VALUE (small negatives occur).
    Value,
}

/// Checks every field's values, naming the first bad entry.
fn check_fields(fields: &[(&str, &[f32], Range)]) -> Result<(), String> {
    let max = super::MAX_VALUE as f32;
    for &(name, v, range) in fields {
        for (k, &x) in v.iter().enumerate() {
            let (ok, expected) = match range {
                Range::Angles => (
                    x.abs() <= 2.0 * PI && (k == 0 || x > v[k - 1]),
                    "increasing angles within [-2 pi, 2 pi] radians".to_string(),
                ),
                Range::Density => (
                    (0.0..=max).contains(&x),
                    format!("a density in [0, {max:e}]"),
                ),
                Range::Positive => (x > 0.0 && x <= max, format!("a value in (0, {max:e}]")),
                Range::Value => (
                    x.abs() <= max,
                    format!("a value of magnitude up to {max:e}"),
                ),
            };
            if !ok {
                return Err(format!(
                    "field \"{name}\": value {k} is {x}; expected {expected}"
                ));
            }
        }
    }
    Ok(())
}

impl Rgl {
    pub fn read(path: &Path) -> Result<Self, FileError> {
        let t = TensorFile::read(path)?;
        let name = path.display().to_string();
        let err = |m: String| FileError::new(&name, m);
        let (theta_i, _) = t.f32s("theta_i", 1)?;
        let (phi_i, _) = t.f32s("phi_i", 1)?;
        let (ndf, ndf_s) = t.f32s("ndf", 2)?;
        let (sigma, sigma_s) = t.f32s("sigma", 2)?;
        let (vndf, vndf_s) = t.f32s("vndf", 4)?;
        let (lum, lum_s) = t.f32s("luminance", 4)?;
        if t.fields.contains_key("wavelengths") {
            return Err(err(
                "is a spectral RGL file; expected an RGB one (*_rgb.bsdf)".into(),
            ));
        }
        let (rgb, rgb_s) = t.f32s("rgb", 5)?;
        let desc = t
            .fields
            .get("description")
            .map(|f| String::from_utf8_lossy(&f.bytes).to_string())
            .unwrap_or_default();
        let jacobian = t
            .fields
            .get("jacobian")
            .and_then(|f| f.bytes.first())
            .is_some_and(|&b| b != 0);
        check_fields(&[
            ("theta_i", &theta_i, Range::Angles),
            ("phi_i", &phi_i, Range::Angles),
            ("ndf", &ndf, Range::Density),
            ("sigma", &sigma, Range::Positive),
            ("vndf", &vndf, Range::Density),
            ("luminance", &lum, Range::Density),
            ("rgb", &rgb, Range::Value),
        ])
        .map_err(err)?;
        let (np, nt) = (phi_i.len(), theta_i.len());
        if np == 0 || nt == 0 {
            return Err(err(
                "empty theta_i or phi_i; expected the tabulated incident angles".into(),
            ));
        }
        let ok = vndf_s[0] == np
            && vndf_s[1] == nt
            && lum_s[0] == np
            && lum_s[1] == nt
            && lum_s[2] == lum_s[3]
            && rgb_s[0] == np
            && rgb_s[1] == nt
            && rgb_s[2] == 3
            && rgb_s[3] == lum_s[2]
            && rgb_s[4] == lum_s[3]
            && ndf_s.iter().all(|&s| s >= 2)
            && sigma_s.iter().all(|&s| s >= 2)
            && vndf_s[2] >= 2
            && vndf_s[3] >= 2
            && lum_s[2] >= 2;
        if !ok {
            return Err(err(format!(
                "inconsistent shapes: vndf {vndf_s:?}, luminance {lum_s:?}, rgb {rgb_s:?} for {np} phi_i and {nt} theta_i; expected [phi_i, theta_i, ...] with square luminance/rgb tables and 3 colour channels"
            )));
        }
        let isotropic = np <= 2;
        let reduction = if isotropic {
            1
        } else {
            (2.0 * PI / (phi_i[np - 1] - phi_i[0])).round().max(1.0) as u32
        };
        let params = vec![phi_i.clone(), theta_i.clone()];
        let n = lum_s[2];
        // The rgb table: one exact channel at a time, each a 2-parameter table.
        let channel = |c: usize| {
            let mut d = Vec::with_capacity(np * nt * n * n);
            for a in 0..np {
                for b in 0..nt {
                    let base = ((a * nt + b) * 3 + c) * n * n;
                    d.extend_from_slice(&rgb[base..base + n * n]);
                }
            }
            Marginal2D::new(&d, n, n, params.clone(), false)
        };
        let table = Self {
            description: desc,
            isotropic,
            reduction,
            jacobian,
            ndf: Marginal2D::new(&ndf, ndf_s[1], ndf_s[0], vec![], false),
            sigma: Marginal2D::new(&sigma, sigma_s[1], sigma_s[0], vec![], false),
            vndf: Marginal2D::new(&vndf, vndf_s[3], vndf_s[2], params.clone(), true),
            luminance: Marginal2D::new(&lum, lum_s[3], lum_s[2], params.clone(), true),
            rgb: [channel(0), channel(1), channel(2)],
        };
        table.probe().map_err(err)?;
        Ok(table)
    }

    /// Evaluates, and samples, the table on the grid of [`crate::bsdf::probe_directions`]
    /// and refuses it at the first non-finite value, density or weight: values within range
    /// can still combine badly (a vanishing `sigma` under the Jacobian, a slice of the
    /// luminance whose integral is too small to normalize in f32).
    fn probe(&self) -> Result<(), String> {
        let bad = crate::bsdf::probe_directions(|wo, wi, u, _| {
            let v = self.eval_projected_raw(wo, wi);
            let pdf = self.pdf_raw(wo, wi);
            let w = self
                .sample(wo, u)
                .map_or(Rgb::ZERO, |(wi, p)| self.eval_projected_raw(wo, wi) / p);
            (!(v.is_finite() && pdf.is_finite() && w.is_finite())).then(|| {
                format!(
                    "value {:?}, density {pdf}, sample weight {:?}",
                    v.to_array(),
                    w.to_array()
                )
            })
        });
        match bad {
            None => Ok(()),
            Some(m) => Err(format!(
                "at {m}; expected finite values (its fields combine to overflow f32)"
            )),
        }
    }

    pub fn is_isotropic(&self) -> bool {
        self.isotropic
    }

    /// Folds directions by the table's symmetry (anisotropic tables only).
    fn fold(&self, v: Vec3, by: Vec3) -> Vec3 {
        if self.reduction < 2 {
            return v;
        }
        let sy = by.y;
        let sx = if self.reduction == 4 { by.x } else { sy };
        Vec3::new(mulsign_neg(v.x, sx), mulsign_neg(v.y, sy), v.z)
    }

    /// (u_m, params, sin(theta_m)) for viewer `wo` and half vector `m`.
    fn coords(&self, wo: Vec3, m: Vec3) -> ([f32; 2], [f32; 2], f32) {
        let theta_o = elevation(wo);
        let phi_o = wo.y.atan2(wo.x);
        let theta_m = elevation(m);
        let mut phi_m = m.y.atan2(m.x);
        if self.isotropic {
            phi_m -= phi_o;
        }
        let mut uy = phi2u(phi_m);
        uy -= uy.floor();
        (
            [theta2u(theta_m), uy],
            [phi_o, theta_o],
            (m.x * m.x + m.y * m.y).max(0.0).sqrt(),
        )
    }

    /// The tabulated value (BRDF x cos(theta_i)) at sample-space point s.
    fn spectrum(&self, s: [f32; 2], params: &[f32; 2], u_m: [f32; 2], wo: Vec3) -> Rgb {
        let mut v = Rgb::new(
            self.rgb[0].eval(s, params),
            self.rgb[1].eval(s, params),
            self.rgb[2].eval(s, params),
        );
        if self.jacobian {
            let u_o = [theta2u(elevation(wo)), phi2u(wo.y.atan2(wo.x))];
            v *= self.ndf.eval(u_m, &[]) / (4.0 * self.sigma.eval(u_o, &[]));
        }
        v
    }

    /// BRDF x cos(theta_i) for viewer `wo` and light `wi` (Mitsuba's `eval`, negative values included).
    pub fn eval_projected(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let v = self.eval_projected_raw(wo, wi);
        if v.is_finite() { v } else { Rgb::ZERO }
    }

    fn eval_projected_raw(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let (wo_f, wi_f) = (self.fold(wo, wo), self.fold(wi, wo));
        let m = (wo_f + wi_f).normalize_or_zero();
        let (u_m, params, _) = self.coords(wo_f, m);
        let (s, _) = self.vndf.invert(u_m, &params);
        self.spectrum(s, &params, u_m, wo_f)
    }

    /// The BRDF (1/sr).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let v = self.eval_projected(wo, wi) / wi.z;
        if v.is_finite() { v } else { Rgb::ZERO }
    }

    /// Density of `sample`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.pdf_raw(wo, wi);
        if p.is_finite() && p > 0.0 { p } else { 0.0 }
    }

    fn pdf_raw(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let (wo_f, wi_f) = (self.fold(wo, wo), self.fold(wi, wo));
        let m = (wo_f + wi_f).normalize_or_zero();
        let (u_m, params, sin_m) = self.coords(wo_f, m);
        let (s, p_vndf) = self.vndf.invert(u_m, &params);
        let p_lum = self.luminance.eval(s, &params);
        let jac = (2.0 * PI * PI * u_m[0] * sin_m).max(1e-6) * 4.0 * wo_f.dot(m);
        p_vndf * p_lum / jac
    }

    /// Samples the light direction for viewer `wo`: (wi, pdf).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        if wo.z <= 0.0 {
            return None;
        }
        let wo_f = self.fold(wo, wo);
        let theta_o = elevation(wo_f);
        let phi_o = wo_f.y.atan2(wo_f.x);
        let params = [phi_o, theta_o];
        let (s, p_lum) = self.luminance.sample([u.y, u.x], &params);
        let (u_m, p_vndf) = self.vndf.sample(s, &params);
        let mut phi_m = u2phi(u_m[1]);
        let theta_m = u2theta(u_m[0]);
        if self.isotropic {
            phi_m += phi_o;
        }
        let (st, ct) = theta_m.sin_cos();
        let (sp, cp) = phi_m.sin_cos();
        let m = Vec3::new(cp * st, sp * st, ct);
        let jac = (2.0 * PI * PI * u_m[0] * st).max(1e-6) * 4.0 * wo_f.dot(m);
        let pdf = p_vndf * p_lum / jac;
        let wi_f = m * (2.0 * m.dot(wo_f)) - wo_f;
        let sy = wo.y;
        let sx = if self.reduction == 4 { wo.x } else { sy };
        let wi = if self.reduction >= 2 {
            Vec3::new(mulsign_neg(wi_f.x, sx), mulsign_neg(wi_f.y, sy), wi_f.z)
        } else {
            wi_f
        };
        (wi.z > 0.0 && pdf.is_finite() && pdf > 0.0).then_some((wi, pdf))
    }
}
