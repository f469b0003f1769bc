//! Shading frames and spherical coordinates of directions.
//!
//! The orthonormal basis of a normal uses the branchless construction of Duff et al.,
//! "Building an Orthonormal Basis, Revisited" (JCGT 2017), which is continuous except on a
//! measure-zero set and exact to rounding. Spherical coordinates follow the usual physics
//! convention: theta from +z, phi from +x toward +y.

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
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// A frame whose first axis follows the projection of `dpdu` onto the plane of `n`
    /// (the tangent direction anisotropic models use); falls back to `from_normal` when
    /// the tangent is degenerate.
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        let len2 = s.length_squared();
        if !(len2 > 1e-12) || !len2.is_finite() {
            return Self::from_normal(n);
        }
        let s = s / len2.sqrt();
        Self {
            s,
            t: n.cross(s),
            n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
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

#[cfg(test)]
mod tests {
    use super::*;

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
