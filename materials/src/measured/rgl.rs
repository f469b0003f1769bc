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
//!   pdf = p_vndf p_lum / (2 pi^2 u_m.x sin(theta_m) 4 (wo . m)); the sample's value is
//!   the colour table at the warped point (Mitsuba's `sample`), not a second inversion.
//!
//! As in Mitsuba's plugin, what depends on the viewer only (its angles, the parameter
//! slices they select, sigma(u_o)) is found once per query and shared by the VNDF
//! inversion, the colour table and the luminance density (r, g, b and the density of a
//! node side by side: one lookup for all four); the angles use `fastmath`'s
//! approximations (errors under 4e-7 rad).
//!
//! Anisotropic tables (more than two phi_i values) are folded by their symmetry reduction
//! as Mitsuba does; isotropic ones use no reduction.

use super::tensor::TensorFile;
use crate::Rgb;
use crate::error::FileError;
use crate::fastmath;
use crate::fastmath::xn;
use crate::math::{Num, V3, asin, clamp, maximum, sqrt};
use crate::sampling::marginal2d::{Marginal2D, Slices, SlicesxN};
use crate::simd::{MaskN, RgbxN, Vec3xN, f32xn, max_lane, sel};
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
    /// The colour table and the luminance density, r, g, b and the density of a node side
    /// by side: one lookup serves the value and the density at a sample-space point.
    colour: Marginal2D,
}

impl Rgl {
    pub fn memory_bytes(&self) -> usize {
        self.ndf.memory_bytes()
            + self.sigma.memory_bytes()
            + self.vndf.memory_bytes()
            + self.luminance.memory_bytes()
            + self.colour.memory_bytes()
    }
}

/// The VNDF table's first coordinate of elevation `t`: sqrt(t / (pi / 2)) (one value or
/// lanes).
#[inline(always)]
fn theta2u<T: Num>(t: T) -> T {
    let pi = T::of(std::f64::consts::PI);
    sqrt(maximum(t * (T::of(2.0) / pi), T::of(0.0)))
}
/// The table's azimuth coordinate of `p` in [-pi, pi]: (p + pi) / (2 pi).
#[inline(always)]
fn phi2u<T: Num>(p: T) -> T {
    let pi = T::of(std::f64::consts::PI);
    (p + pi) * (T::of(0.5) / pi)
}
fn u2theta(u: f32) -> f32 {
    u * u * FRAC_PI_2
}
fn u2phi(u: f32) -> f32 {
    (2.0 * u - 1.0) * PI
}
/// acos(d.z) computed stably (Mitsuba's `elevation`), one direction or lanes.
#[inline(always)]
fn elevation<T: Num>(d: V3<T>) -> T {
    let one = T::of(1.0);
    let zm = d.z - one;
    let dist = sqrt(d.x * d.x + d.y * d.y + zm * zm);
    T::of(2.0) * asin(clamp(T::of(0.5) * dist, -one, one))
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

/// Everything that depends on the viewer direction only, shared by evaluation, density
/// and sampling: the folded direction, its angles (the tables' parameters), the slices
/// they select, and the Jacobian's sigma(u_o).
struct View {
    wo: Vec3,
    phi_o: f32,
    slices: Slices,
    /// 4 sigma(u_o) (tables with the Jacobian flag; 1 otherwise).
    sigma4: f32,
}

/// A half vector's table coordinates and its inversion through the VNDF.
struct Half {
    m: Vec3,
    u_m: [f32; 2],
    /// The sample-space point of `u_m` and the VNDF density there.
    s: [f32; 2],
    p_vndf: f32,
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
        for (field, v) in [("theta_i", &theta_i), ("phi_i", &phi_i)] {
            if v.windows(2).any(|p| !(p[0] < p[1])) {
                return Err(err(format!(
                    "field \"{field}\" is not increasing ({v:?}); expected increasing angles"
                )));
            }
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
        let luminance = Marginal2D::new(&lum, lum_s[3], lum_s[2], params.clone(), true);
        // r, g, b and the (normalized) luminance density of each node side by side.
        let mut colour = Vec::with_capacity(rgb.len() / 3 * 4);
        for slice in 0..np * nt {
            for k in 0..n * n {
                for c in 0..3 {
                    colour.push(rgb[(slice * 3 + c) * n * n + k]);
                }
                colour.push(luminance.values()[slice * n * n + k]);
            }
        }
        let table = Self {
            description: desc,
            isotropic,
            reduction,
            jacobian,
            ndf: Marginal2D::new(&ndf, ndf_s[1], ndf_s[0], vec![], false),
            sigma: Marginal2D::new(&sigma, sigma_s[1], sigma_s[0], vec![], false),
            vndf: Marginal2D::new(&vndf, vndf_s[3], vndf_s[2], params.clone(), true),
            luminance,
            colour: Marginal2D::with_channels(&colour, n, n, 4, params),
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

    /// Folds directions by the table's symmetry (anisotropic tables only); folding twice
    /// by the same `by` is the identity.
    #[inline]
    fn fold(&self, v: Vec3, by: Vec3) -> Vec3 {
        if self.reduction < 2 {
            return v;
        }
        let sy = by.y;
        let sx = if self.reduction == 4 { by.x } else { sy };
        Vec3::new(mulsign_neg(v.x, sx), mulsign_neg(v.y, sy), v.z)
    }

    /// The viewer-dependent part of a query (`wo` unfolded).
    #[inline]
    fn view(&self, wo: Vec3) -> View {
        let wo = self.fold(wo, wo);
        let theta_o = elevation(V3::from(wo));
        let phi_o = fastmath::atan2(wo.y, wo.x);
        let sigma4 = if self.jacobian {
            let u_o = [theta2u(theta_o), phi2u(phi_o)];
            4.0 * self.sigma.eval_in(u_o, &Slices::NONE)
        } else {
            1.0
        };
        View {
            wo,
            phi_o,
            slices: self.vndf.slices(&[phi_o, theta_o]),
            sigma4,
        }
    }

    /// The half vector of the (folded) viewer and light `wi`, inverted through the VNDF.
    #[inline]
    fn half(&self, v: &View, wi: Vec3, wo: Vec3) -> Half {
        let m = (v.wo + self.fold(wi, wo)).normalize_or_zero();
        let mut phi_m = fastmath::atan2(m.y, m.x);
        if self.isotropic {
            phi_m -= v.phi_o;
        }
        let mut uy = phi2u(phi_m);
        uy -= uy.floor();
        let u_m = [theta2u(elevation(V3::from(m))), uy];
        let (s, p_vndf) = self.vndf.invert_in(u_m, &v.slices);
        Half { m, u_m, s, p_vndf }
    }

    /// The tabulated value (BRDF x cos(theta_i)) at sample-space point s, and the
    /// luminance density there.
    #[inline]
    fn lookup(&self, v: &View, s: [f32; 2], u_m: [f32; 2]) -> (Rgb, f32) {
        let [r, g, b, p_lum] = self.colour.eval_channels::<4>(s, &v.slices);
        let mut c = Rgb::new(r, g, b);
        if self.jacobian {
            c *= self.ndf.eval_in(u_m, &Slices::NONE) / v.sigma4;
        }
        (c, p_lum)
    }

    /// The table's density of `wi` at a half vector from the luminance density at its
    /// sample-space point (0 when not finite and positive).
    #[inline]
    fn density(&self, v: &View, h: &Half, p_lum: f32) -> f32 {
        let p = self.density_raw(v, h, p_lum);
        if p.is_finite() && p > 0.0 { p } else { 0.0 }
    }

    /// [`Rgl::density`] as computed, non-finite or not (for [`Rgl::probe`]).
    #[inline]
    fn density_raw(&self, v: &View, h: &Half, p_lum: f32) -> f32 {
        let sin_m = max_lane(h.m.x * h.m.x + h.m.y * h.m.y, 0.0).sqrt();
        let jac = max_lane(2.0 * PI * PI * h.u_m[0] * sin_m, 1e-6) * 4.0 * v.wo.dot(h.m);
        h.p_vndf * p_lum / jac
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
        let v = self.view(wo);
        let h = self.half(&v, wi, wo);
        let (c, _) = self.lookup(&v, h.s, h.u_m);
        c
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
        let v = self.view(wo);
        let h = self.half(&v, wi, wo);
        let (_, p_lum) = self.lookup(&v, h.s, h.u_m);
        self.density_raw(&v, &h, p_lum)
    }

    /// [`Rgl::eval_projected`] and [`Rgl::pdf`] of one pair with the work they share done
    /// once (bit for bit the two calls).
    pub fn eval_projected_pdf(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let v = self.view(wo);
        let h = self.half(&v, wi, wo);
        let (c, p_lum) = self.lookup(&v, h.s, h.u_m);
        let c = if c.is_finite() { c } else { Rgb::ZERO };
        (c, self.density(&v, &h, p_lum))
    }

    /// Samples the light direction for viewer `wo`: (wi, pdf).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        self.sample_value(wo, u).map(|(wi, pdf, _)| (wi, pdf))
    }

    /// Samples the light direction for viewer `wo` as Mitsuba's `measured` does: (wi,
    /// pdf, BRDF x cos(theta_i) at the sampled point, zero when not finite).
    pub fn sample_value(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, f32, Rgb)> {
        if wo.z <= 0.0 {
            return None;
        }
        let v = self.view(wo);
        let (s, p_lum) = self.luminance.sample_in([u.y, u.x], &v.slices);
        let (u_m, p_vndf) = self.vndf.sample_in(s, &v.slices);
        let mut phi_m = u2phi(u_m[1]);
        let theta_m = u2theta(u_m[0]);
        if self.isotropic {
            phi_m += v.phi_o;
        }
        let (st, ct) = fastmath::sin_cos_moderate(theta_m);
        let (sp, cp) = fastmath::sin_cos_moderate(phi_m);
        let m = Vec3::new(cp * st, sp * st, ct);
        let jac = max_lane(2.0 * PI * PI * u_m[0] * st, 1e-6) * 4.0 * v.wo.dot(m);
        let pdf = p_vndf * p_lum / jac;
        let wi = self.fold(m * (2.0 * m.dot(v.wo)) - v.wo, wo);
        if !(wi.z > 0.0 && pdf.is_finite() && pdf > 0.0) {
            return None;
        }
        let (c, _) = self.lookup(&v, s, u_m);
        Some((wi, pdf, if c.is_finite() { c } else { Rgb::ZERO }))
    }
}

/// [`View`] of `LANES` viewers.
struct ViewxN {
    wo: Vec3xN,
    phi_o: f32xn,
    slices: SlicesxN,
    sigma4: f32xn,
}

/// [`Half`] of `LANES` pairs.
struct HalfxN {
    m: Vec3xN,
    u_m: [f32xn; 2],
    s: [f32xn; 2],
    p_vndf: f32xn,
}

/// [`mulsign_neg`] per lane: the sign bit of v flipped where s's is clear.
#[inline(always)]
fn mulsign_neg_xn(v: f32xn, s: f32xn) -> f32xn {
    let sign = crate::simd::u32xn::splat(0x8000_0000);
    f32xn::from_bits(v.to_bits() ^ (!s.to_bits() & sign))
}

/// The lane forms of evaluation, density and sampling: every lane equals the
/// scalar form bit for bit (the same operations in the same order, tested), so that the
/// renderer's batched calls agree exactly with its one-at-a-time ones.
impl Rgl {
    #[inline(always)]
    fn fold_xn(&self, v: Vec3xN, by: Vec3xN) -> Vec3xN {
        if self.reduction < 2 {
            return v;
        }
        let sx = if self.reduction == 4 { by.x } else { by.y };
        Vec3xN::new(mulsign_neg_xn(v.x, sx), mulsign_neg_xn(v.y, by.y), v.z)
    }

    #[inline(always)]
    fn view_xn(&self, wo: Vec3xN) -> ViewxN {
        let wo = self.fold_xn(wo, wo);
        let theta_o = elevation(wo);
        let phi_o = xn::atan2(wo.y, wo.x);
        let sigma4 = if self.jacobian {
            let u_o = [theta2u(theta_o), phi2u(phi_o)];
            f32xn::splat(4.0) * self.sigma.eval_xn(u_o, &SlicesxN::none())
        } else {
            f32xn::splat(1.0)
        };
        ViewxN {
            wo,
            phi_o,
            slices: self.vndf.slices_xn(&[phi_o, theta_o]),
            sigma4,
        }
    }

    #[inline(always)]
    fn half_xn(&self, v: &ViewxN, wi: Vec3xN, wo: Vec3xN) -> HalfxN {
        let m = (v.wo + self.fold_xn(wi, wo)).normalize_or_zero();
        let mut phi_m = xn::atan2(m.y, m.x);
        if self.isotropic {
            phi_m -= v.phi_o;
        }
        let uy = phi2u(phi_m);
        let uy = uy - uy.floor();
        let u_m = [theta2u(elevation(m)), uy];
        let (s, p_vndf) = self.vndf.invert_xn(u_m, &v.slices);
        HalfxN { m, u_m, s, p_vndf }
    }

    #[inline(always)]
    fn lookup_xn(&self, v: &ViewxN, s: [f32xn; 2], u_m: [f32xn; 2]) -> (RgbxN, f32xn) {
        let [r, g, b, p_lum] = self.colour.eval_channels_xn::<4>(s, &v.slices);
        let c = RgbxN::new(r, g, b);
        if self.jacobian {
            let k = self.ndf.eval_xn(u_m, &SlicesxN::none()) / v.sigma4;
            (c * k, p_lum)
        } else {
            (c, p_lum)
        }
    }

    #[inline(always)]
    fn density_xn(&self, v: &ViewxN, h: &HalfxN, p_lum: f32xn) -> f32xn {
        let zero = f32xn::splat(0.0);
        let sin_m = (h.m.x * h.m.x + h.m.y * h.m.y).max(zero).sqrt();
        let jac = (f32xn::splat(2.0 * PI * PI) * h.u_m[0] * sin_m).max(f32xn::splat(1e-6))
            * f32xn::splat(4.0)
            * v.wo.dot(h.m);
        let p = h.p_vndf * p_lum / jac;
        sel(p.is_finite() & p.simd_gt(zero), p, zero)
    }

    /// [`Rgl::eval_projected_pdf`] of `LANES` pairs.
    pub fn eval_projected_pdf_xn(&self, wo: Vec3xN, wi: Vec3xN) -> (RgbxN, f32xn) {
        let zero = f32xn::splat(0.0);
        let below = wo.z.simd_le(zero) | wi.z.simd_le(zero);
        let v = self.view_xn(wo);
        let h = self.half_xn(&v, wi, wo);
        let (c, p_lum) = self.lookup_xn(&v, h.s, h.u_m);
        let black = RgbxN::splat(Rgb::ZERO);
        let c = RgbxN::select(c.is_finite() & !below, c, black);
        (c, sel(below, zero, self.density_xn(&v, &h, p_lum)))
    }

    /// [`Rgl::sample_value`] of `LANES` viewers: (wi, pdf, value, where a sample exists).
    pub fn sample_value_xn(&self, wo: Vec3xN, u: [f32xn; 2]) -> (Vec3xN, f32xn, RgbxN, MaskN) {
        let zero = f32xn::splat(0.0);
        let v = self.view_xn(wo);
        let (s, p_lum) = self.luminance.sample_xn([u[1], u[0]], &v.slices);
        let (u_m, p_vndf) = self.vndf.sample_xn(s, &v.slices);
        let mut phi_m = (f32xn::splat(2.0) * u_m[1] - f32xn::splat(1.0)) * f32xn::splat(PI);
        let theta_m = u_m[0] * u_m[0] * f32xn::splat(FRAC_PI_2);
        if self.isotropic {
            phi_m += v.phi_o;
        }
        let (st, ct) = xn::sin_cos_moderate(theta_m);
        let (sp, cp) = xn::sin_cos_moderate(phi_m);
        let m = Vec3xN::new(cp * st, sp * st, ct);
        let jac = (f32xn::splat(2.0 * PI * PI) * u_m[0] * st).max(f32xn::splat(1e-6))
            * f32xn::splat(4.0)
            * v.wo.dot(m);
        let pdf = p_vndf * p_lum / jac;
        let wi = self.fold_xn(m * (f32xn::splat(2.0) * m.dot(v.wo)) - v.wo, wo);
        let ok = wo.z.simd_gt(zero) & wi.z.simd_gt(zero) & pdf.is_finite() & pdf.simd_gt(zero);
        let (c, _) = self.lookup_xn(&v, s, u_m);
        let c = RgbxN::select(c.is_finite(), c, RgbxN::splat(Rgb::ZERO));
        (wi, pdf, c, ok)
    }
}
