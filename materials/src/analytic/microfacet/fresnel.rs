//! Fresnel reflectance: Schlick's approximation F = F0 + (1 - F0)(1 - cos)^5 (Schlick 1994,
//! eq. 15) and the exact unpolarized reflectance of a dielectric interface with a real
//! relative index of refraction eta (Cook and Torrance 1981, eq. 5; Born and Wolf).

use crate::math::Real;
use crate::simd::{f32xn, sel};

/// Which Fresnel term a model uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// F = 1.
    None,
    /// Schlick with reflectance at normal incidence F0 in [0, 1].
    Schlick { f0: f64 },
    /// Exact dielectric with relative index eta > 0 (eta < 1 allows total internal reflection).
    Dielectric { eta: f64 },
}

pub const FRESNELS: &[&str] = &["none", "schlick", "dielectric"];

impl Fresnel {
    /// F for the cosine `c` of the angle between the incident direction and the microfacet
    /// normal.
    #[inline]
    pub fn eval<T: Real>(&self, c: T) -> T {
        match *self {
            Fresnel::None => T::one(),
            Fresnel::Schlick { f0 } => schlick(T::c(f0), c),
            Fresnel::Dielectric { eta } => dielectric(T::c(eta), c),
        }
    }
}

/// [`Fresnel::eval`] per lane.
impl Fresnel {
    #[inline(always)]
    pub fn eval_xn(&self, c: f32xn) -> f32xn {
        let s = f32xn::splat;
        match *self {
            Fresnel::None => s(1.0),
            Fresnel::Schlick { f0 } => {
                let f0 = f0 as f32;
                let m = (s(1.0) - c).max(s(0.0)).min(s(1.0));
                let m2 = m * m;
                s(f0) + s(1.0 - f0) * m2 * m2 * m
            }
            Fresnel::Dielectric { eta } => {
                let eta = eta as f32;
                let c = c.max(s(0.0)).min(s(1.0));
                let g2 = s(eta * eta) + c * c - s(1.0);
                let g = g2.sqrt();
                let a = (g - c) / (g + c);
                let b = (c * (g + c) - s(1.0)) / (c * (g - c) + s(1.0));
                let f = (s(0.5) * a * a * (s(1.0) + b * b)).max(s(0.0)).min(s(1.0));
                sel(g2.simd_le(s(0.0)), s(1.0), f)
            }
        }
    }
}

#[inline]
pub fn schlick<T: Real>(f0: T, c: T) -> T {
    let m = (T::one() - c).max(T::zero()).min(T::one());
    let m2 = m * m;
    f0 + (T::one() - f0) * m2 * m2 * m
}

/// Cook and Torrance's form: with g^2 = eta^2 + c^2 - 1,
/// F = (g - c)^2 / (2 (g + c)^2) * (1 + ((c (g + c) - 1) / (c (g - c) + 1))^2);
/// total internal reflection (g^2 < 0) gives 1.
#[inline]
pub fn dielectric<T: Real>(eta: T, c: T) -> T {
    let c = c.max(T::zero()).min(T::one());
    let g2 = eta * eta + c * c - T::one();
    if g2 <= T::zero() {
        return T::one();
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - T::one()) / (c * (g - c) + T::one());
    let f = T::c(0.5) * a * a * (T::one() + b * b);
    f.max(T::zero()).min(T::one())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_values() {
        // Normal incidence: ((eta - 1) / (eta + 1))^2 = 0.04 for eta = 1.5.
        assert!((dielectric(1.5f64, 1.0) - 0.04).abs() < 1e-12);
        // Grazing: 1.
        assert!((dielectric(1.5f64, 0.0) - 1.0).abs() < 1e-12);
        // 45 degrees, eta 1.5: Rs = 0.0920, Rp = 0.00847 -> 0.05023 (textbook value).
        let f = dielectric(1.5f64, std::f64::consts::FRAC_1_SQRT_2);
        assert!((f - 0.050_23).abs() < 1e-4, "{f}");
        assert_eq!(schlick(0.04f64, 1.0), 0.04);
        assert!((schlick(0.04f64, 0.0) - 1.0).abs() < 1e-12);
        assert!((schlick(0.04f64, 0.5) - (0.04 + 0.96 / 32.0)).abs() < 1e-12);
    }
}
