//! Rectangles as in Mitsuba 3's `rectangle` shape: the square [-1, 1]^2 of the local xy
//! plane, normal +z, mapped by an affine `to_world` transform (so any parallelogram).

use super::Ray;
use glam::{Mat4, Vec2, Vec3};
use lobe_materials::math::{Arith, V3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    /// World position of local (-1, -1, 0).
    pub corner: Vec3,
    /// World images of local (2, 0, 0) and (0, 2, 0): the two edges.
    pub eu: Vec3,
    pub ev: Vec3,
    /// Unit normal (the image of +z under the inverse transpose).
    pub n: Vec3,
    /// Dual vectors: (p - corner) . du = u in [0, 1], same for v.
    du: Vec3,
    dv: Vec3,
    /// `eu` normalized (the surface tangent along u) and the area |eu x ev|, computed once:
    /// every hit and every light sample needs them.
    tangent: Vec3,
    area: f32,
}

impl Rectangle {
    pub fn from_transform(m: &Mat4) -> Option<Self> {
        let corner = m.transform_point3(Vec3::new(-1.0, -1.0, 0.0));
        let eu = m.transform_vector3(Vec3::new(2.0, 0.0, 0.0));
        let ev = m.transform_vector3(Vec3::new(0.0, 2.0, 0.0));
        let cross = eu.cross(ev);
        let area2 = cross.length_squared();
        if !(area2 > 0.0) || !area2.is_finite() {
            return None;
        }
        // Orientation follows the transform's image of +z (Mitsuba uses the inverse
        // transpose), which for a mirror transform is -cross.
        let nz = m.inverse().transpose().transform_vector3(Vec3::Z);
        let n = if nz.dot(cross) >= 0.0 {
            cross.normalize()
        } else {
            -cross.normalize()
        };
        let du = ev.cross(cross) / area2;
        let dv = cross.cross(eu) / area2;
        Some(Self {
            corner,
            eu,
            ev,
            n,
            du,
            dv,
            tangent: eu.normalize(),
            area: cross.length(),
        })
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> f32 {
        let denom = ray.d.dot(self.n);
        if denom == 0.0 {
            return f32::INFINITY;
        }
        let t = (self.corner - ray.o).dot(self.n) / denom;
        if !(t > ray.tmin && t < ray.tmax) {
            return f32::INFINITY;
        }
        let rel = ray.at(t) - self.corner;
        let u = rel.dot(self.du);
        let v = rel.dot(self.dv);
        if (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v) {
            t
        } else {
            f32::INFINITY
        }
    }

    /// Dual vector of `eu`: (p - corner) . du is the local u of a point p on the plane.
    pub fn du(&self) -> Vec3 {
        self.du
    }

    /// Dual vector of `ev`.
    pub fn dv(&self) -> Vec3 {
        self.dv
    }

    /// Local (u, v) in [0, 1]^2 of a point on the plane.
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let rel = p - self.corner;
        Vec2::new(rel.dot(self.du), rel.dot(self.dv)).clamp(Vec2::ZERO, Vec2::ONE)
    }

    pub fn point(&self, uv: Vec2) -> Vec3 {
        self.point_of(uv.x, uv.y).into()
    }

    /// The point at (u, v) of [0, 1]^2, `corner + eu u + ev v`, for one point and lanes of
    /// them.
    #[inline(always)]
    pub fn point_of<T: Arith>(&self, u: T, v: T) -> V3<T> {
        let of = |w: Vec3| V3::new(T::of(w.x as f64), T::of(w.y as f64), T::of(w.z as f64));
        of(self.corner) + of(self.eu) * u + of(self.ev) * v
    }

    pub fn area(&self) -> f32 {
        self.area
    }

    /// The unit tangent along u (`eu` normalized).
    pub fn tangent(&self) -> Vec3 {
        self.tangent
    }
}
