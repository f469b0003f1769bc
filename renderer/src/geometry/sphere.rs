//! Analytic spheres with exact normals (spheres are the main subject of BRDF comparisons:
//! a tessellation would change the highlights). Intersection uses the numerically careful
//! quadratic of Haines et al., "Precision Improvements for Ray/Sphere Intersection"
//! (Ray Tracing Gems, 2019, ch. 7); the hit point is re-projected onto the sphere.

use super::Ray;
use glam::{Vec2, Vec3};
use lobe_materials::fastmath::x8;
use std::f32::consts::{PI, TAU};
use wide::f32x8;

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

    /// [`Sphere::intersect`] of eight rays (origins `o`, directions `d`, ranges
    /// (`tmin`, `tmax`), one per lane), with the same operations: bit for bit the same.
    #[inline(always)]
    pub fn intersect_x8(&self, o: [f32x8; 3], d: [f32x8; 3], tmin: f32x8, tmax: f32x8) -> f32x8 {
        let dot = x8::dot3;
        let c = self.center;
        let r2 = f32x8::splat(self.radius * self.radius);
        let zero = f32x8::splat(0.0);
        let inf = f32x8::splat(f32::INFINITY);
        let d_len2 = dot(d, d);
        let inv_len2 = f32x8::splat(1.0) / d_len2;
        let f = [
            o[0] - f32x8::splat(c.x),
            o[1] - f32x8::splat(c.y),
            o[2] - f32x8::splat(c.z),
        ];
        let b = -dot(f, d);
        let s = b * inv_len2;
        let l = [f[0] + d[0] * s, f[1] + d[1] * s, f[2] + d[2] * s];
        let disc = (r2 - dot(l, l)) * d_len2;
        let cc = dot(f, f) - r2;
        let sq = disc.sqrt();
        let q = x8::sel(b.simd_ge(zero), b + sq, b - sq);
        let (a0, a1) = (cc / q, q * inv_len2);
        let swap = a0.simd_gt(a1);
        let (t0, t1) = (x8::sel(swap, a1, a0), x8::sel(swap, a0, a1));
        let t = x8::sel(
            t0.simd_gt(tmin) & t0.simd_lt(tmax),
            t0,
            x8::sel(t1.simd_gt(tmin) & t1.simd_lt(tmax), t1, inf),
        );
        x8::sel(disc.simd_lt(zero), inf, t)
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
