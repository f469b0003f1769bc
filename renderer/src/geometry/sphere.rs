//! Analytic spheres with exact normals (spheres are the main subject of BRDF comparisons:
//! a tessellation would change the highlights). Intersection uses the numerically careful
//! quadratic of Haines et al., "Precision Improvements for Ray/Sphere Intersection"
//! (Ray Tracing Gems, 2019, ch. 7); the hit point is re-projected onto the sphere.

use super::Ray;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    /// Nearest parametric hit in (tmin, tmax), or infinity.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> f32 {
        let d_len2 = ray.d.length_squared();
        let inv_len2 = 1.0 / d_len2;
        let f = ray.o - self.center;
        let b = -f.dot(ray.d);
        // Distance of the center to the line, squared, computed without cancellation.
        let l = f + ray.d * (b * inv_len2);
        let disc = (self.radius * self.radius - l.length_squared()) * d_len2;
        if disc < 0.0 {
            return f32::INFINITY;
        }
        let c = f.length_squared() - self.radius * self.radius;
        let sq = disc.sqrt();
        let q = if b >= 0.0 { b + sq } else { b - sq };
        let mut t0 = c / q;
        let mut t1 = q * inv_len2;
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if t0 > ray.tmin && t0 < ray.tmax {
            t0
        } else if t1 > ray.tmin && t1 < ray.tmax {
            t1
        } else {
            f32::INFINITY
        }
    }

    /// Hit point re-projected onto the surface, outward unit normal and tangent (along
    /// increasing phi around +z, Mitsuba 3's dp/du).
    #[inline]
    pub fn surface(&self, p_approx: Vec3) -> (Vec3, Vec3, Vec3) {
        let mut local = p_approx - self.center;
        let len = local.length();
        if len > 0.0 {
            local *= self.radius / len;
        } else {
            local = Vec3::new(0.0, 0.0, self.radius);
        }
        let n = (local / self.radius).normalize();
        let p = self.center + local;
        let dpdu = Vec3::new(-local.y, local.x, 0.0);
        let dpdu = if dpdu.length_squared() > 0.0 {
            dpdu.normalize()
        } else {
            Vec3::X
        };
        (p, n, dpdu)
    }

    /// Mitsuba 3's (u, v) of a point on the sphere: u = phi / 2 pi around +z, v = theta / pi.
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let local = (p - self.center) / self.radius;
        let mut phi = local.y.atan2(local.x);
        if phi < 0.0 {
            phi += TAU;
        }
        Vec2::new(phi / TAU, local.z.clamp(-1.0, 1.0).acos() / PI)
    }

    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }
}
