//! Shading frames and spherical coordinates of directions.
//!
//! The orthonormal basis of a normal uses the branchless construction of Duff et al.,
//! "Building an Orthonormal Basis, Revisited" (JCGT 2017), which is continuous except on a
//! measure-zero set and exact to rounding. Spherical coordinates follow the usual physics
//! convention: theta from +z, phi from +x toward +y.

use crate::math::{Arith, Num, V3, copysign, gt, is_finite, sqrt};
use glam::Vec3;

/// An orthonormal frame (s, t, n): `n` is the shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// The frame of a unit normal (Duff et al. 2017, Listing 3).
    pub fn from_normal(n: Vec3) -> Self {
        let (s, t) = tangents_of_normal(V3::from(n));
        Self {
            s: s.into(),
            t: t.into(),
            n,
        }
    }

    /// A frame whose first axis follows the projection of `dpdu` onto the plane of `n`
    /// (the tangent direction anisotropic models use); falls back to `from_normal` when
    /// the tangent is degenerate.
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Self {
        let (s, t, usable) = tangent_axes(V3::from(n), V3::from(dpdu));
        if !usable {
            return Self::from_normal(n);
        }
        Self {
            s: s.into(),
            t: t.into(),
            n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        to_local(
            V3::from(self.s),
            V3::from(self.t),
            V3::from(self.n),
            V3::from(v),
        )
        .into()
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        to_world(
            V3::from(self.s),
            V3::from(self.t),
            V3::from(self.n),
            V3::from(v),
        )
        .into()
    }
}

/// The axes s and t of [`Frame::from_normal_tangent`], written once for one frame and for
/// lanes of them: s is `dpdu` projected onto the plane of the unit normal `n` and divided
/// by its length, t = n x s. The mask says where the projection is long enough to use
/// (its squared length above 1e-12 and finite); elsewhere the frame is
/// [`Frame::from_normal`]'s.
#[inline(always)]
pub fn tangent_axes<T: Arith>(n: V3<T>, dpdu: V3<T>) -> (V3<T>, V3<T>, T::Mask) {
    let s = dpdu - n * n.dot(dpdu);
    let len2 = s.length_squared();
    let usable = gt(len2, T::of(1e-12f32 as f64)) & is_finite(len2);
    let s = s / sqrt(len2);
    (s, n.cross(s), usable)
}

/// The axes s and t of [`Frame::from_normal_tangent`] for normals `n` and tangents `dpdu`,
/// the unit outgoing direction `-d` of rays of direction `d` in that frame (normalized as
/// glam does), and the mask of [`tangent_axes`] (elsewhere the frame is
/// [`Frame::from_normal`]'s, which the caller takes): a hit's shading frame and `wo`,
/// written once for one hit and lanes of them.
#[inline(always)]
pub fn shading_axes<T: Arith>(n: V3<T>, dpdu: V3<T>, d: V3<T>) -> (V3<T>, V3<T>, V3<T>, T::Mask) {
    let (s, t, usable) = tangent_axes(n, dpdu);
    (s, t, to_local(s, t, n, -d).unit(), usable)
}

/// `v` in the frame (s, t, n): its components along the three axes (glam's dot products),
/// for one vector or lanes of them ([`Frame::to_local`]).
#[inline(always)]
pub fn to_local<T: Arith>(s: V3<T>, t: V3<T>, n: V3<T>, v: V3<T>) -> V3<T> {
    V3::new(v.dot(s), v.dot(t), v.dot(n))
}

/// [`Frame::to_world`] of local `v` in the frame (`s`, `t`, `n`), written once over
/// [`Arith`] (one frame, or lanes of frames): s v.x + t v.y + n v.z.
#[inline(always)]
pub fn to_world<T: Arith>(s: V3<T>, t: V3<T>, n: V3<T>, v: V3<T>) -> V3<T> {
    s * v.x + t * v.y + n * v.z
}

/// The tangent and bitangent of [`Frame::from_normal`] for a unit normal `n`, written once
/// over [`Num`] (Duff et al. 2017, Listing 3).
#[inline(always)]
pub fn tangents_of_normal<T: Num>(n: V3<T>) -> (V3<T>, V3<T>) {
    let one = T::of(1.0);
    let sign = copysign(one, n.z);
    let a = -one / (sign + n.z);
    let b = n.x * n.y * a;
    let s = V3::new(one + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let t = V3::new(b, sign + n.y * n.y * a, -n.y);
    (s, t)
}

/// `Frame::from_normal(n).to_world(v)`, written once over [`Num`].
#[inline(always)]
pub fn to_world_of_normal<T: Num>(n: V3<T>, v: V3<T>) -> V3<T> {
    let (s, t) = tangents_of_normal(n);
    s * v.x + t * v.y + n * v.z
}

/// Unit direction from spherical angles (radians).
#[inline]
pub fn spherical_direction(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

/// (theta, phi) of a unit direction, phi in [0, 2 pi).
#[inline]
pub fn spherical_angles(w: Vec3) -> (f32, f32) {
    let theta = w.z.clamp(-1.0, 1.0).acos();
    let mut phi = w.y.atan2(w.x);
    if phi < 0.0 {
        phi += std::f32::consts::TAU;
    }
    (theta, phi)
}

/// Rusinkiewicz's half/difference angles ("A New Change of Variables for Efficient BRDF
/// Representation", 1998) of a direction pair: (theta_h, phi_h, theta_d, phi_d), with
/// h = normalize(wi + wo) and d the direction `wi` expressed in the frame of `h` (rotated
/// by -phi_h about the normal, then by -theta_h about the bitangent), as MERL's tables use.
pub fn half_diff(wi: Vec3, wo: Vec3) -> (f64, f64, f64, f64) {
    let (wi, wo) = (wi.as_dvec3().normalize(), wo.as_dvec3().normalize());
    let h = (wi + wo).normalize_or(glam::DVec3::Z);
    let theta_h = h.z.clamp(-1.0, 1.0).acos();
    let phi_h = h.y.atan2(h.x);
    // Rotate wi by -phi_h about z, then by -theta_h about y.
    let (sp, cp) = (-phi_h).sin_cos();
    let t = glam::DVec3::new(wi.x * cp - wi.y * sp, wi.x * sp + wi.y * cp, wi.z);
    let (st, ct) = (-theta_h).sin_cos();
    let d = glam::DVec3::new(t.x * ct + t.z * st, t.y, -t.x * st + t.z * ct);
    let theta_d = d.z.clamp(-1.0, 1.0).acos();
    let phi_d = d.y.atan2(d.x);
    (theta_h, phi_h, theta_d, phi_d)
}

/// The direction pair (wi, wo) of half/difference angles (the inverse of [`half_diff`]).
pub fn from_half_diff(theta_h: f64, phi_h: f64, theta_d: f64, phi_d: f64) -> (Vec3, Vec3) {
    let d = glam::DVec3::new(
        theta_d.sin() * phi_d.cos(),
        theta_d.sin() * phi_d.sin(),
        theta_d.cos(),
    );
    // Rotate d by theta_h about y, then by phi_h about z.
    let (st, ct) = theta_h.sin_cos();
    let t = glam::DVec3::new(d.x * ct + d.z * st, d.y, -d.x * st + d.z * ct);
    let (sp, cp) = phi_h.sin_cos();
    let wi = glam::DVec3::new(t.x * cp - t.y * sp, t.x * sp + t.y * cp, t.z);
    let h = glam::DVec3::new(
        theta_h.sin() * phi_h.cos(),
        theta_h.sin() * phi_h.sin(),
        theta_h.cos(),
    );
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wi.as_vec3(), wo.as_vec3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_diff_round_trip() {
        for &(th, ph, td, pd) in &[
            (0.3, 0.5, 0.7, 1.2),
            (0.05, -2.0, 1.2, -0.4),
            (1.0, 3.0, 0.2, 2.9),
        ] {
            let (wi, wo) = from_half_diff(th, ph, td, pd);
            let (a, b, c, d) = half_diff(wi, wo);
            assert!(
                (a - th).abs() < 1e-5
                    && (b - ph).abs() < 1e-5
                    && (c - td).abs() < 1e-5
                    && (d - pd).abs() < 1e-5,
                "{:?}",
                (a, b, c, d)
            );
        }
        // Normal incidence mirror: theta_h = 0, theta_d = the angle of wi.
        let wi = Vec3::new(0.5, 0.0, 0.75f32.sqrt());
        let wo = Vec3::new(-0.5, 0.0, 0.75f32.sqrt());
        let (th, _, td, _) = half_diff(wi, wo);
        assert!(th.abs() < 1e-6 && (td - 30f64.to_radians()).abs() < 1e-6);
    }

    #[test]
    fn frames_are_orthonormal_and_invert() {
        let dirs = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            Vec3::new(-1e-7, 1e-7, -1.0).normalize(),
        ];
        for n in dirs {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5);
            assert!((f.s.cross(f.t) - n).length() < 1e-5, "right-handed for {n}");
            let v = Vec3::new(0.2, 0.5, -0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
            assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
        }
    }

    #[test]
    fn spherical_round_trip() {
        for &(t, p) in &[(0.3f32, 0.1f32), (1.2, 3.0), (2.9, 6.0)] {
            let (t2, p2) = spherical_angles(spherical_direction(t, p));
            assert!((t - t2).abs() < 1e-5 && (p - p2).abs() < 1e-4);
        }
    }
}
