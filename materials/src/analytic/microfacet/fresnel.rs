//! Fresnel reflectance: Schlick's approximation F = F0 + (1 - F0)(1 - cos)^5 (Schlick 1994,
//! eq. 15) and the exact unpolarized reflectance of a dielectric interface with a real
//! relative index of refraction eta (Cook and Torrance 1981, eq. 5; Born and Wolf).

use crate::math::{Num, le, maximum, minimum, select, sqrt};

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
    /// normal; one formula for f64, f32 and lanes ([`Num`]).
    #[inline(always)]
    pub fn eval<T: Num>(&self, c: T) -> T {
        match *self {
            Fresnel::None => T::of(1.0),
            Fresnel::Schlick { f0 } => schlick(T::of(f0), c),
            Fresnel::Dielectric { eta } => dielectric(T::of(eta), c),
        }
    }
}

#[inline(always)]
pub fn schlick<T: Num>(f0: T, c: T) -> T {
    let one = T::of(1.0);
    let m = minimum(maximum(one - c, T::of(0.0)), one);
    let m2 = m * m;
    f0 + (one - f0) * m2 * m2 * m
}

/// Cook and Torrance's form: with g^2 = eta^2 + c^2 - 1,
/// F = (g - c)^2 / (2 (g + c)^2) * (1 + ((c (g + c) - 1) / (c (g - c) + 1))^2);
/// total internal reflection (g^2 <= 0) gives 1.
#[inline(always)]
pub fn dielectric<T: Num>(eta: T, c: T) -> T {
    let (zero, one) = (T::of(0.0), T::of(1.0));
    let c = minimum(maximum(c, zero), one);
    let g2 = eta * eta + c * c - one;
    let g = sqrt(g2);
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - one) / (c * (g - c) + one);
    let f = minimum(maximum(T::of(0.5) * a * a * (one + b * b), zero), one);
    select(le(g2, zero), one, f)
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
