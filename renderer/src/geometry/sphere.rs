//! Analytic spheres with exact normals (spheres are the main subject of BRDF comparisons:
//! a tessellation would change the highlights). Intersection uses the numerically careful
//! quadratic of Haines et al., "Precision Improvements for Ray/Sphere Intersection"
//! (Ray Tracing Gems, 2019, ch. 7); the hit point is re-projected onto the sphere.

use super::Ray;
use glam::{Vec2, Vec3};
use lobe_materials::math::{Arith, V3, gt, select, sqrt};
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
    /// increasing phi around +z, Mitsuba 3's dp/du): [`Sphere::surface_of`] of one point.
    #[inline]
    pub fn surface(&self, p_approx: Vec3) -> (Vec3, Vec3, Vec3) {
        let (p, n, dpdu) = Self::surface_of(V3::from(p_approx), V3::from(self.center), self.radius);
        (p.into(), n.into(), dpdu.into())
    }

    /// The re-projected point, outward unit normal and tangent of points `p_approx` near
    /// spheres of centres `c` and radii `r`, written once for one point (f32) and for
    /// lanes of them (one sphere per lane). A point at the centre has no direction and
    /// takes the +z pole; a point on the z axis has no tangent and takes +x.
    #[inline(always)]
    pub fn surface_of<F: Arith>(p_approx: V3<F>, c: V3<F>, r: F) -> (V3<F>, V3<F>, V3<F>) {
        let (zero, one) = (F::of(0.0), F::of(1.0));
        let local = p_approx - c;
        let len = sqrt(local.dot(local));
        // local *= radius / len where len > 0, else (0, 0, radius).
        let pos = gt(len, zero);
        let scaled = local * (r / len);
        let local = V3::new(
            select(pos, scaled.x, zero),
            select(pos, scaled.y, zero),
            select(pos, scaled.z, r),
        );
        // (local / radius).normalize(): times 1 / length.
        let q = V3::new(local.x / r, local.y / r, local.z / r);
        let n = q * (one / sqrt(q.dot(q)));
        let p = c + local;
        // dpdu = (-local.y, local.x, 0), normalized where not zero, else +x.
        let u = V3::new(-local.y, local.x, zero);
        let l2 = u.dot(u);
        let some = gt(l2, zero);
        let inv = one / sqrt(l2);
        let dpdu = V3::new(
            select(some, u.x * inv, one),
            select(some, u.y * inv, zero),
            select(some, u.z * inv, zero),
        );
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
    use lobe_materials::simd::{self, LANES, Vec3xN, f32xn};

    /// The lane surface equals `surface` bit for bit, including points at the centre
    /// (no direction: the +z pole) and on the z axis (no tangent: +x).
    #[test]
    fn surface_in_lanes_is_bit_identical() {
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
            let c = Vec3xN::from_array(&simd::lanes(|k| s[k].center));
            let r = f32xn::new(simd::lanes(|k| s[k].radius));
            let (pp, n, u) = Sphere::surface_of(Vec3xN::from_array(&p), c, r);
            let (pp, n, u) = (pp.to_array(), n.to_array(), u.to_array());
            for k in 0..LANES {
                let (ep, en, eu) = s[k].surface(p[k]);
                let b = |w: Vec3| w.to_array().map(f32::to_bits);
                assert_eq!(b(pp[k]), b(ep), "point, lane {k} of round {round}");
                assert_eq!(b(n[k]), b(en), "normal, lane {k} of round {round}");
                assert_eq!(b(u[k]), b(eu), "tangent, lane {k} of round {round}");
            }
        }
    }
}
