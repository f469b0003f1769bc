//! Analytic spheres with exact normals (spheres are the main subject of BRDF comparisons:
//! a tessellation would change the highlights). Intersection uses the numerically careful
//! quadratic of Haines et al., "Precision Improvements for Ray/Sphere Intersection"
//! (Ray Tracing Gems, 2019, ch. 7); the hit point is re-projected onto the sphere.

use super::Ray;
use glam::{Vec2, Vec3};
use lobe_materials::simd;
use lobe_materials::simd::FloatLanes;
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

    /// [`Sphere::surface`] of points on spheres in SIMD lanes (centres `c`, radii `r`, one
    /// per lane), with the same operations: bit for bit the same.
    #[inline(always)]
    pub fn surface_lanes<F: FloatLanes>(
        p_approx: [F; 3],
        c: [F; 3],
        r: F,
    ) -> ([F; 3], [F; 3], [F; 3]) {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let local = [p_approx[0] - c[0], p_approx[1] - c[1], p_approx[2] - c[2]];
        let len = simd::dot3(local, local).sqrt();
        // local *= radius / len where len > 0, else (0, 0, radius).
        let pos = len.simd_gt(zero);
        let k = r / len;
        let local = [
            simd::sel(pos, local[0] * k, zero),
            simd::sel(pos, local[1] * k, zero),
            simd::sel(pos, local[2] * k, r),
        ];
        // (local / radius).normalize(): times 1 / length.
        let q = [local[0] / r, local[1] / r, local[2] / r];
        let inv = one / simd::dot3(q, q).sqrt();
        let n = [q[0] * inv, q[1] * inv, q[2] * inv];
        let p = [c[0] + local[0], c[1] + local[1], c[2] + local[2]];
        // dpdu = (-local.y, local.x, 0), normalized where not zero, else +x.
        let u = [-local[1], local[0], zero];
        let l2 = simd::dot3(u, u);
        let some = l2.simd_gt(zero);
        let inv = one / l2.sqrt();
        let dpdu = [
            simd::sel(some, u[0] * inv, one),
            simd::sel(some, u[1] * inv, zero),
            simd::sel(some, u[2] * inv, zero),
        ];
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

#[cfg(test)]
mod tests {
    use super::*;
    use lobe_materials::simd::{LANES, f32xn};

    /// The lane surface equals `surface` bit for bit, including points at the centre
    /// (no direction: the +z pole) and on the z axis (no tangent: +x).
    #[test]
    fn surface_lanes_is_bit_identical() {
        let spheres = [
            Sphere {
                center: Vec3::new(0.3, -1.2, 2.0),
                radius: 0.7,
            },
            Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            },
            Sphere {
                center: Vec3::new(-5.0, 0.1, 0.0),
                radius: 130.0,
            },
        ];
        for round in 0..768 / LANES {
            let s = simd::lanes(|k| spheres[(round + k) % 3]);
            let p = simd::lanes(|k| {
                let t = (round * LANES + k) as f32;
                let c = s[k].center;
                match (round + k) % 9 {
                    0 => c,
                    1 => c + Vec3::new(0.0, 0.0, -0.5 * s[k].radius),
                    _ => {
                        c + Vec3::new((t * 0.7).sin(), (t * 1.3).cos(), (t * 0.37).sin())
                            * s[k].radius
                            * (1.0 + 1e-3 * (t * 0.11).sin())
                    }
                }
            });
            let c = simd::vec3s(&simd::lanes(|k| s[k].center));
            let r = f32xn::new(simd::lanes(|k| s[k].radius));
            let (pp, n, u) = Sphere::surface_lanes(simd::vec3s(&p), c, r);
            let (pp, n, u) = (
                pp.map(|v| v.to_array()),
                n.map(|v| v.to_array()),
                u.map(|v| v.to_array()),
            );
            for k in 0..LANES {
                let (ep, en, eu) = s[k].surface(p[k]);
                let v = |a: &[[f32; LANES]; 3]| [a[0][k], a[1][k], a[2][k]].map(f32::to_bits);
                let b = |w: Vec3| w.to_array().map(f32::to_bits);
                assert_eq!(v(&pp), b(ep), "point, lane {k} of round {round}");
                assert_eq!(v(&n), b(en), "normal, lane {k} of round {round}");
                assert_eq!(v(&u), b(eu), "tangent, lane {k} of round {round}");
            }
        }
    }
}
