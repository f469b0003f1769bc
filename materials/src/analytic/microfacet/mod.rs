//! Shared microfacet parts: normal distributions (Beckmann, Gaussian, cosine power), the
//! V-groove shadowing-masking of Torrance and Sparrow / Cook and Torrance, and Fresnel
//! terms (Schlick's approximation and the exact unpolarized dielectric Fresnel equations).
//!
//! Every distribution D is normalized so that the projected microfacet area is one:
//! int D(h) cos(theta_h) dh = 1 over the hemisphere (Walter et al. 2007, eq. 4), and is
//! parameterized by the one roughness `m` of Cook and Torrance 1981:
//! - Beckmann: D = exp(-tan^2(theta_h) / m^2) / (pi m^2 cos^4(theta_h)) (CT81 eq. 3);
//! - Gaussian: D = c exp(-(theta_h / m)^2) (CT81 eq. 2), c computed numerically;
//! - cosine power: D = (n + 2) / (2 pi) cos^n(theta_h) with n = 2 / m^2 - 2, the exponent
//!   whose lobe matches Beckmann's near the peak (Walter et al. 2007, sec. 5.2).

pub mod fresnel;
pub mod visible;

use crate::lobe;
use crate::math::{Num, V3, acos, eq, exp, le, maximum, minimum, powf, select};

/// A microfacet normal distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Distribution {
    Beckmann {
        m: f64,
    },
    /// `c` normalizes exp(-(theta / m)^2) to unit projected area.
    Gaussian {
        m: f64,
        c: f64,
    },
    CosinePower {
        n: f64,
    },
}

pub const DISTRIBUTIONS: &[&str] = &["beckmann", "gaussian", "cosine-power"];

/// The smallest roughness a distribution uses: a smaller m acts as this one (Mitsuba 3
/// clamps its alpha at the same 1e-4). Below it the lobe is narrower than f32 directions
/// can resolve: a half vector recomputed from a sampled direction is a few ulps off the
/// normal, exp(-tan^2 / m^2) underflows to 0 there (at m = 5e-5 after 2 ulps), and every
/// sample of the peak would be lost, leaving a near-mirror without its reflection.
pub const MIN_ROUGHNESS: f64 = 1e-4;

impl Distribution {
    /// The named distribution with roughness m (> 0; below [`MIN_ROUGHNESS`] it is
    /// [`MIN_ROUGHNESS`]).
    pub fn new(name: &str, m: f64) -> Option<Self> {
        let m = m.max(MIN_ROUGHNESS);
        Some(match name {
            "beckmann" => Distribution::Beckmann { m },
            "gaussian" => Distribution::Gaussian {
                m,
                c: gaussian_normalization(m),
            },
            "cosine-power" => Distribution::CosinePower {
                n: (2.0 / (m * m) - 2.0).max(0.0),
            },
            _ => return None,
        })
    }

    /// D(h) for cos(theta_h) = `cos_h` (isotropic distributions), zero for `cos_h <= 0`;
    /// one formula for f64, f32 and lanes ([`Num`]).
    #[inline(always)]
    pub fn d<T: Num>(&self, cos_h: T) -> T {
        let zero = T::of(0.0);
        let d = match *self {
            Distribution::Beckmann { m } => beckmann_d(T::of(m * m), cos_h),
            Distribution::Gaussian { m, c } => {
                let theta = acos(minimum(cos_h, T::of(1.0)));
                let r = theta / T::of(m);
                T::of(c) * exp(-r * r)
            }
            Distribution::CosinePower { n } => {
                T::of((n + 2.0) / (2.0 * std::f64::consts::PI)) * powf(cos_h, T::of(n))
            }
        };
        select(le(cos_h, zero), zero, d)
    }

    /// The roughness of the Beckmann distribution whose visible normals
    /// ([`visible`]) sample this one: its own for Beckmann; for the Gaussian and cosine
    /// power (proposals), the `m` they were made from (cosine power's exponent is
    /// n = 2 / m^2 - 2, the one whose peak matches Beckmann's of that m).
    fn visible_m(&self) -> f32 {
        match *self {
            Distribution::Beckmann { m } | Distribution::Gaussian { m, .. } => m as f32,
            Distribution::CosinePower { n } => cosine_power_beckmann_m(n),
        }
    }

    /// Samples a half vector seen from `wo` (local frame, wo.z > 0) from uniforms
    /// (`ux`, `uy`): Beckmann's visible normals ([`visible`]) of
    /// [`Distribution::visible_m`].
    #[inline(always)]
    pub fn sample_visible<T: Num>(&self, wo: V3<T>, ux: T, uy: T) -> V3<T> {
        let m = T::of(self.visible_m() as f64);
        visible::sample(m, m, wo, ux, uy)
    }

    /// Density of [`Distribution::sample_visible`] (solid angle of h).
    #[inline(always)]
    pub fn pdf_visible<T: Num>(&self, wo: V3<T>, h: V3<T>) -> T {
        beckmann_visible_pdf(T::of(self.visible_m() as f64), wo, h)
    }

    /// `wo` reflected about a visible normal ([`Distribution::sample_visible`]), and where
    /// that is a sample ([`lobe::reflect_above`]).
    #[inline(always)]
    pub fn sample_reflected<T: Num>(&self, wo: V3<T>, ux: T, uy: T) -> (V3<T>, T::Mask) {
        lobe::reflect_above(wo, self.sample_visible(wo, ux, uy))
    }

    /// Density (solid angle of `wi`) of [`Distribution::sample_reflected`]: the visible
    /// normal's density over 4 wo.h (Walter et al. 2007, eq. 14), zero below the surface.
    #[inline(always)]
    pub fn pdf_reflected<T: Num>(&self, wo: V3<T>, wi: V3<T>) -> T {
        lobe::reflected_pdf(wo, wi, |h| self.pdf_visible(wo, h))
    }
}

/// The density (solid angle of h) of Beckmann visible normals seen from `wo`, of isotropic
/// roughness `m` (each lane its own): [`visible::pdf`] with D(h) of the squared roughness
/// `m * m` (in f32 the rounding of [`Distribution::d`]'s `(m * m) as f32`: the product
/// of two f32 is exact in f64), zero for `h.z <= 0`.
#[inline(always)]
pub fn beckmann_visible_pdf<T: Num>(m: T, wo: V3<T>, h: V3<T>) -> T {
    let zero = T::of(0.0);
    let d = select(le(h.z, zero), zero, beckmann_d(m * m, h.z));
    visible::pdf(m, m, wo, h, d)
}

/// Beckmann's D for positive `cos_h`, of squared roughness `m2` (`(m * m) as f32` in f32, as
/// [`Distribution::d`] rounds it): exp(-tan^2(theta_h) / m2) / (pi m2 cos^4(theta_h)), zero
/// where the exponential underflows.
#[inline(always)]
pub fn beckmann_d<T: Num>(m2: T, cos_h: T) -> T {
    let zero = T::of(0.0);
    let c2 = cos_h * cos_h;
    let tan2 = maximum(T::of(1.0) - c2, zero) / c2;
    let e = exp(-tan2 / m2);
    let d = e / (T::of(std::f64::consts::PI) * m2 * c2 * c2);
    select(eq(e, zero), zero, d)
}

/// The roughness m = sqrt(2 / (n + 2)) of the Beckmann distribution whose peak matches
/// that of a cosine power of exponent `n`: the visible-normal proposal of cosine-power
/// lobes.
#[inline]
pub fn cosine_power_beckmann_m(n: f64) -> f32 {
    (2.0 / (n + 2.0)).sqrt() as f32
}

/// The anisotropic Beckmann D (one value or lanes), roughness `mx` along the tangent and `my` along the
/// bitangent: exp(-tan^2(theta_h) (cos^2(phi_h) / mx^2 + sin^2(phi_h) / my^2)) /
/// (pi mx my cos^4(theta_h)), zero for h_z <= 0 and where the exponential underflows.
/// tan^2 comes from cos(theta_h) as in [`beckmann_d`], so that a lobe evaluated from
/// cos(theta_h) rounds as this density does where a narrow lobe meets f32's resolution of
/// cos(theta_h) near 1, and weights f / p stay near their exact value.
#[inline(always)]
pub fn beckmann_d_anisotropic<T: Num>(mx: T, my: T, h: V3<T>) -> T {
    let (zero, one) = (T::of(0.0), T::of(1.0));
    let c2 = h.z * h.z;
    let tan2 = maximum(one - c2, zero) / c2;
    let s2 = h.x * h.x + h.y * h.y;
    let cos2_phi = select(le(s2, T::of(1e-30)), one, h.x * h.x / s2);
    let e = exp(-tan2 * (cos2_phi / (mx * mx) + (one - cos2_phi) / (my * my)));
    let d = e / (T::of(std::f64::consts::PI) * mx * my * c2 * c2);
    select(le(h.z, zero) | eq(e, zero), zero, d)
}

/// c such that 2 pi c int_0^{pi/2} exp(-(theta/m)^2) cos(theta) sin(theta) dtheta = 1
/// (composite Simpson's rule on 4096 intervals, exact to ~1e-12 for m >= 1e-3; for smaller
/// m the small-angle closed form c = 1 / (pi m^2) is used).
pub fn gaussian_normalization(m: f64) -> f64 {
    if m < 1e-3 {
        return 1.0 / (std::f64::consts::PI * m * m);
    }
    let upper = std::f64::consts::FRAC_PI_2.min(12.0 * m);
    let n = 4096;
    let h = upper / n as f64;
    let f = |t: f64| (-(t / m) * (t / m)).exp() * t.cos() * t.sin();
    let mut s = f(0.0) + f(upper);
    for k in 1..n {
        s += f(k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    1.0 / (2.0 * std::f64::consts::PI * s * h / 3.0)
}

/// V-groove shadowing-masking (Torrance and Sparrow 1967; Cook and Torrance 1981, eq. 4):
/// G = min(1, 2 (n.h)(n.wo) / (wo.h), 2 (n.h)(n.wi) / (wi.h)), zero for wo.h <= 0.
#[inline(always)]
pub fn vgroove_g<T: Num>(cos_h: T, cos_o: T, cos_i: T, wo_dot_h: T) -> T {
    // wo.h = wi.h for the half vector of wo and wi.
    let (zero, two) = (T::of(0.0), T::of(2.0));
    let a = two * cos_h * cos_o / wo_dot_h;
    let b = two * cos_h * cos_i / wo_dot_h;
    let g = maximum(minimum(minimum(T::of(1.0), a), b), zero);
    select(le(wo_dot_h, zero), zero, g)
}
