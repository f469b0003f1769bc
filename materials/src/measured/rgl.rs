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
use crate::math::{
    Num, V3, asin, atan2, clamp, copysign, floor, gt, is_finite, le, maximum, select, sin_cos, sqrt,
};
use crate::sampling::marginal2d::{Marginal2D, Slices};
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
/// The elevation of the VNDF table's first coordinate `u` (inverse of [`theta2u`]).
#[inline(always)]
fn u2theta<T: Num>(u: T) -> T {
    u * u * T::of(FRAC_PI_2 as f64)
}
/// The azimuth of the table's coordinate `u` (inverse of [`phi2u`]).
#[inline(always)]
fn u2phi<T: Num>(u: T) -> T {
    (T::of(2.0) * u - T::of(1.0)) * T::of(PI as f64)
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
#[inline(always)]
fn mulsign_neg<T: Num>(v: T, s: T) -> T {
    select(gt(copysign(T::of(1.0), s), T::of(0.0)), -v, v)
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
/// One viewer (f32) or one per lane.
struct View<T: Num> {
    wo: V3<T>,
    phi_o: T,
    slices: Slices<T>,
    /// 4 sigma(u_o) (tables with the Jacobian flag; 1 otherwise).
    sigma4: T,
}

/// A half vector's table coordinates and its inversion through the VNDF.
struct Half<T: Num> {
    m: V3<T>,
    u_m: [T; 2],
    /// The sample-space point of `u_m` and the VNDF density there.
    s: [T; 2],
    p_vndf: T,
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
            let (v, pdf) = self.raw_query(wo, wi);
            let w = self
                .sample(wo, u)
                .map_or(Rgb::ZERO, |(wi, p)| self.raw_query(wo, wi).0 / p);
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
    #[inline(always)]
    fn fold<T: Num>(&self, v: V3<T>, by: V3<T>) -> V3<T> {
        if self.reduction < 2 {
            return v;
        }
        let sy = by.y;
        let sx = if self.reduction == 4 { by.x } else { sy };
        V3::new(mulsign_neg(v.x, sx), mulsign_neg(v.y, sy), v.z)
    }

    /// The viewer-dependent part of a query (`wo` unfolded).
    #[inline(always)]
    fn view<T: Num>(&self, wo: V3<T>) -> View<T> {
        let wo = self.fold(wo, wo);
        let theta_o = elevation(wo);
        let phi_o = atan2(wo.y, wo.x);
        let sigma4 = if self.jacobian {
            let u_o = [theta2u(theta_o), phi2u(phi_o)];
            T::of(4.0) * self.sigma.eval_in(u_o, &Slices::none())
        } else {
            T::of(1.0)
        };
        View {
            wo,
            phi_o,
            slices: self.vndf.slices(&[phi_o, theta_o]),
            sigma4,
        }
    }

    /// The half vector of the (folded) viewer and light `wi`, inverted through the VNDF.
    #[inline(always)]
    fn half<T: Num>(&self, v: &View<T>, wi: V3<T>, wo: V3<T>) -> Half<T> {
        let zero = T::of(0.0);
        let m = (v.wo + self.fold(wi, wo)).unit_or(V3::new(zero, zero, zero));
        let mut phi_m = atan2(m.y, m.x);
        if self.isotropic {
            phi_m = phi_m - v.phi_o;
        }
        let uy = phi2u(phi_m);
        let u_m = [theta2u(elevation(m)), uy - floor(uy)];
        let (s, p_vndf) = self.vndf.invert_in(u_m, &v.slices);
        Half { m, u_m, s, p_vndf }
    }

    /// The tabulated value (BRDF x cos(theta_i)) at sample-space point s, and the
    /// luminance density there.
    #[inline(always)]
    fn lookup<T: Num>(&self, v: &View<T>, s: [T; 2], u_m: [T; 2]) -> ([T; 3], T) {
        let [r, g, b, p_lum] = self.colour.eval_channels::<T, 4>(s, &v.slices);
        if self.jacobian {
            let k = self.ndf.eval_in(u_m, &Slices::none()) / v.sigma4;
            ([r * k, g * k, b * k], p_lum)
        } else {
            ([r, g, b], p_lum)
        }
    }

    /// The table's density of the light direction with half vector `m` (sin(theta_m)
    /// `sin_m`, first table coordinate `u_m0`, VNDF density `p_vndf`) from the luminance
    /// density at its sample-space point, as computed (non-finite or not).
    #[inline(always)]
    fn density<T: Num>(&self, v: &View<T>, m: V3<T>, sin_m: T, u_m0: T, p_vndf: T, p_lum: T) -> T {
        let two_pi2 = T::of((2.0 * PI * PI) as f64);
        let jac = maximum(two_pi2 * u_m0 * sin_m, T::of(1e-6)) * T::of(4.0) * v.wo.dot(m);
        p_vndf * p_lum / jac
    }

    /// BRDF x cos(theta_i) and the density of `wi` as computed, non-finite or not (for
    /// [`Rgl::probe`]), for a pair above the surface.
    #[inline(always)]
    fn query<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> ([T; 3], T) {
        let v = self.view(wo);
        let h = self.half(&v, wi, wo);
        let (c, p_lum) = self.lookup(&v, h.s, h.u_m);
        let sin_m = sqrt(maximum(h.m.x * h.m.x + h.m.y * h.m.y, T::of(0.0)));
        (c, self.density(&v, h.m, sin_m, h.u_m[0], h.p_vndf, p_lum))
    }

    /// [`Rgl::query`] of one pair, zero below the surface.
    fn raw_query(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let (c, p) = self.query::<f32>(wo.into(), wi.into());
        (Rgb::from(c), p)
    }

    /// BRDF x cos(theta_i) for viewer `wo` and light `wi` (Mitsuba's `eval`, negative
    /// values included) and the density of [`Rgl::sample_value`]'s `wi`: zero below the
    /// surface, the value zero where not finite, the density where not finite and
    /// positive. One pair (f32) or lanes of pairs.
    pub fn eval_projected_pdf<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> ([T; 3], T) {
        let zero = T::of(0.0);
        let below = le(wo.z, zero) | le(wi.z, zero);
        let (c, p) = self.query(wo, wi);
        let finite = is_finite(c[0]) & is_finite(c[1]) & is_finite(c[2]);
        let c = c.map(|x| select(finite & !below, x, zero));
        let p_ok = is_finite(p) & gt(p, zero) & !below;
        (c, select(p_ok, p, zero))
    }

    /// [`Rgl::eval_projected_pdf`]'s value of one pair (zero below the surface).
    pub fn eval_projected(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_projected_pdf_one(wo, wi).0
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
        self.eval_projected_pdf_one(wo, wi).1
    }

    /// [`Rgl::eval_projected_pdf`] of one pair, zero below the surface.
    fn eval_projected_pdf_one(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let (c, p) = self.eval_projected_pdf::<f32>(wo.into(), wi.into());
        (Rgb::from(c), p)
    }

    /// Samples the light direction for viewer `wo`: (wi, pdf).
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        if wo.z <= 0.0 {
            return None;
        }
        let (wi, pdf, _, ok) = self.sample_value::<f32>(wo.into(), [u.x, u.y]);
        ok.then(|| (wi.into(), pdf))
    }

    /// Samples the light direction for viewer `wo` as Mitsuba's `measured` does: (wi, pdf,
    /// BRDF x cos(theta_i) at the sampled point, zero when not finite, and where the
    /// sample exists: `wo` and `wi` above the surface, the pdf finite and positive). One
    /// viewer (f32) or lanes of viewers.
    pub fn sample_value<T: Num>(&self, wo: V3<T>, u: [T; 2]) -> (V3<T>, T, [T; 3], T::Mask) {
        let zero = T::of(0.0);
        let v = self.view(wo);
        let (s, p_lum) = self.luminance.sample_in([u[1], u[0]], &v.slices);
        let (u_m, p_vndf) = self.vndf.sample_in(s, &v.slices);
        let mut phi_m = u2phi(u_m[1]);
        let theta_m = u2theta(u_m[0]);
        if self.isotropic {
            phi_m = phi_m + v.phi_o;
        }
        let (st, ct) = sin_cos(theta_m);
        let (sp, cp) = sin_cos(phi_m);
        let m = V3::new(cp * st, sp * st, ct);
        let pdf = self.density(&v, m, st, u_m[0], p_vndf, p_lum);
        let wi = self.fold(m * (T::of(2.0) * m.dot(v.wo)) - v.wo, wo);
        let ok = gt(wo.z, zero) & gt(wi.z, zero) & is_finite(pdf) & gt(pdf, zero);
        let (c, _) = self.lookup(&v, s, u_m);
        let finite = is_finite(c[0]) & is_finite(c[1]) & is_finite(c[2]);
        (wi, pdf, c.map(|x| select(finite, x, zero)), ok)
    }
}
