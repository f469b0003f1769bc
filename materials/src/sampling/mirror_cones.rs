//! A mixture of Phong-like cones cos^e around a mirror direction, e = 8, 64, 512 and 4096:
//! a BRDF-independent sampling strategy that resolves highlights of any width. The sphere
//! image estimators combine it with environment-map sampling by the balance heuristic
//! (the `image` fitting metric, `fit::image`; lobe-analysis' `sphere_errors`).

use crate::frame::Frame;
use glam::DVec3;
use std::f64::consts::PI;

/// The cones' exponents: successive powers of 8.
pub const EXPONENTS: [f64; 4] = [8.0, 64.0, 512.0, 4096.0];

/// The mixture's solid-angle density at unit direction `d` (each cone e: (e + 1) / 2pi
/// cos^e around the unit `mirror`, equally weighted). Each power is the previous one
/// raised to the 8th by three squarings; once a power is below 1e-30 the higher ones are
/// dropped: each is under 2^-53 of the term before it, so the sum is the same bit for bit
/// (where cos itself is below 1e-30 the density is 0, where it was under 1e-237), and no
/// squaring passes through the subnormals (an assist of about a hundred cycles on x86,
/// where most directions of an image estimate lie far from the mirror).
pub fn pdf(mirror: DVec3, d: DVec3) -> f64 {
    let eighth = |x: f64| {
        let x2 = x * x;
        let x4 = x2 * x2;
        x4 * x4
    };
    let mut p = mirror.dot(d).max(0.0);
    let mut sum = 0.0;
    for e in EXPONENTS {
        if p < 1e-30 {
            break;
        }
        p = eighth(p);
        sum += (e + 1.0) / (2.0 * PI) * p;
    }
    sum / EXPONENTS.len() as f64
}

/// The direction of the cone of exponent `e` around the unit `mirror` for the uniform
/// point `u`.
pub fn sample(mirror: DVec3, e: f64, u: [f64; 2]) -> DVec3 {
    let cos_a = u[0].powf(1.0 / (e + 1.0));
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    let local = DVec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
    Frame::from_normal(mirror.as_vec3())
        .to_world(local.as_vec3())
        .as_dvec3()
        .normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mixture_is_a_density_over_the_sphere() {
        // Midpoint rule in (cos, phi) around the mirror: the integral is 1.
        let m = DVec3::new(0.3, -0.2, 0.9).normalize();
        let f = Frame::from_normal(m.as_vec3());
        let n = 200_000;
        let sum: f64 = (0..n)
            .map(|k| {
                let c = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
                let s = (1.0 - c * c).sqrt();
                let d = f
                    .to_world(glam::Vec3::new(s as f32, 0.0, c as f32))
                    .as_dvec3();
                pdf(m, d.normalize()) * 2.0 * PI * 2.0 / n as f64
            })
            .sum();
        assert!((sum - 1.0).abs() < 2e-3, "{sum}");
    }

    #[test]
    fn dropping_the_vanishing_powers_leaves_the_density_unchanged() {
        let every_power = |mirror: DVec3, d: DVec3| {
            let mut p = mirror.dot(d).max(0.0);
            let mut sum = 0.0;
            for e in EXPONENTS {
                let p2 = p * p;
                let p4 = p2 * p2;
                p = p4 * p4;
                sum += (e + 1.0) / (2.0 * PI) * p;
            }
            sum / EXPONENTS.len() as f64
        };
        let mirror = DVec3::new(0.3, -0.2, 0.9).normalize();
        let mut checked = 0;
        for i in 0..200_000 {
            // Directions by a Fibonacci spiral over the sphere, most far from the mirror.
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 200_000.0;
            let phi = i as f64 * 2.399_963_229_728_653;
            let r = (1.0 - z * z).sqrt();
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            if mirror.dot(d) >= 1e-30 {
                let (got, want) = (pdf(mirror, d), every_power(mirror, d));
                assert_eq!(
                    got.to_bits(),
                    want.to_bits(),
                    "{d}: {got:e} against {want:e}"
                );
                checked += 1;
            }
        }
        assert!(
            checked > 90_000,
            "{checked} directions above the mirror's horizon"
        );
    }
}
