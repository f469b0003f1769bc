//! Geometry: rays, analytic spheres with exact normals, triangle meshes, rectangles, and
//! one BVH over all of them ([`bvh::Geometry`]).
//!
//! Spawned rays start at a point offset along the geometric normal by the integer-ULP
//! method of Wächter and Binder ("A Fast and Robust Method for Avoiding Self-Intersection",
//! Ray Tracing Gems, 2019, ch. 6), after the hit point has been recomputed from the
//! surface itself (re-projection onto the sphere, barycentric interpolation on triangles)
//! so its error is a few ULPs, as pbrt-v4 does with its error bounds.

pub mod bvh;
pub mod bvh8;
mod bvh8_build;
mod bvh8_packet;
mod interactions;
pub mod kernels;
pub mod mesh;
mod ploc;
pub mod primitive;
pub mod prims;
mod rays;
pub mod rectangle;
pub mod sphere;

use glam::{Vec2, Vec3};

pub use bvh::Geometry;
pub use interactions::Interactions;
pub use mesh::{Mesh, Triangle};
pub use rays::Rays;
pub use rectangle::Rectangle;
pub use sphere::Sphere;

/// A ray with a parametric range (tmin, tmax); queues of them are [`Rays`] (columns).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
    /// A primitive (index into [`Geometry::prims`]) the ray cannot hit and that queries
    /// skip: the one a spawned ray leaves when the geometry rules a second hit out (a
    /// planar primitive, or a sphere left on its outside). [`Ray::NO_SKIP`] otherwise.
    pub skip: u32,
}

impl Ray {
    /// No primitive is skipped.
    pub const NO_SKIP: u32 = u32::MAX;

    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self {
            o,
            d,
            tmin: 0.0,
            tmax: f32::INFINITY,
            skip: Self::NO_SKIP,
        }
    }
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Local geometry at a ray hit.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    pub t: f32,
    /// Hit point, recomputed from the surface.
    pub p: Vec3,
    /// Geometric normal, oriented by the shape (outward unless flipped), unit.
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normal or `ng`), same hemisphere as `ng`.
    pub ns: Vec3,
    /// Surface tangent along u (for anisotropic materials).
    pub dpdu: Vec3,
    /// Surface coordinates: mesh texture coordinates (or barycentrics), rectangle (u, v);
    /// zero on spheres (see [`Sphere::uv`]), whose materials need none.
    pub uv: Vec2,
    /// Index of the scene shape that was hit.
    pub shape: u32,
    /// Index of the primitive that was hit (into [`Geometry::prims`]).
    pub prim: u32,
    /// Rays leaving the hit point along `d` with `d . exit >= 0` cannot hit this primitive
    /// again: zero for planar primitives (never), the outward normal for spheres (convex).
    pub exit: Vec3,
}

impl Interaction {
    /// All zero: the record [`Geometry::interaction`] fills, and what new rows of
    /// [`Interactions`] read as.
    pub const ZERO: Self = Self {
        t: 0.0,
        p: Vec3::ZERO,
        ng: Vec3::ZERO,
        ns: Vec3::ZERO,
        dpdu: Vec3::ZERO,
        uv: Vec2::ZERO,
        shape: 0,
        prim: 0,
        exit: Vec3::ZERO,
    };

    /// The primitive a ray leaving along `d` may skip (see [`Ray::skip`]).
    #[inline]
    pub fn skip_for(&self, d: Vec3) -> u32 {
        if d.dot(self.exit) >= 0.0 {
            self.prim
        } else {
            Ray::NO_SKIP
        }
    }
}

/// Origin of a ray leaving `p` on the side of `n` (Wächter and Binder 2019).
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    use wide::bytemuck::cast;
    use wide::{f32x4, i32x4};
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    // The three components side by side in one SIMD register (the fourth lane is unused),
    // with the operations of the per-component form: `(INT_SCALE * n) as i32` (`trunc_int`
    // saturates and maps NaN to 0 as `as` does), the offset's sign from p's, the integer
    // step of p's bits, and the float step near the origin.
    let pv = f32x4::new([p.x, p.y, p.z, 0.0]);
    let nv = f32x4::new([n.x, n.y, n.z, 0.0]);
    let of = (f32x4::splat(INT_SCALE) * nv).trunc_int();
    let neg: i32x4 = cast(pv.simd_lt(f32x4::splat(0.0)));
    let off = neg.select(-of, of);
    let pi: f32x4 = cast(cast::<f32x4, i32x4>(pv) + off);
    let near = pv.abs().simd_lt(f32x4::splat(ORIGIN));
    let out = near
        .select(pv + f32x4::splat(FLOAT_SCALE) * nv, pi)
        .to_array();
    Vec3::new(out[0], out[1], out[2])
}

/// A ray leaving the surface point `it` in direction `d` (world space, any length).
#[inline(always)]
pub fn spawn_ray(it: &Interaction, d: Vec3) -> Ray {
    let n = if d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
    Ray {
        skip: it.skip_for(d),
        ..Ray::new(offset_ray_origin(it.p, n), d)
    }
}

/// A shadow ray from surface point `it` to the point `target`; `target_n`, when given,
/// is the geometric normal there, used to pull the end point off that surface too.
#[inline(always)]
pub fn spawn_ray_to(it: &Interaction, target: Vec3, target_n: Option<Vec3>) -> Ray {
    let d0 = target - it.p;
    let n = if d0.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
    let o = offset_ray_origin(it.p, n);
    let end = match target_n {
        Some(tn) => {
            let tn = if (o - target).dot(tn) >= 0.0 { tn } else { -tn };
            offset_ray_origin(target, tn)
        }
        None => target,
    };
    let d = end - o;
    Ray {
        o,
        d,
        tmin: 0.0,
        tmax: 1.0 - 1e-4,
        skip: it.skip_for(d0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Wächter and Binder's offset written per component (the paper's form).
    fn offset_reference(p: Vec3, n: Vec3) -> Vec3 {
        let (pa, na) = (p.to_array(), n.to_array());
        Vec3::from_array(std::array::from_fn(|k| {
            let of = (256.0 * na[k]) as i32;
            let off = if pa[k] < 0.0 { of.wrapping_neg() } else { of };
            let p_i = f32::from_bits((pa[k].to_bits() as i32).wrapping_add(off) as u32);
            if pa[k].abs() < 1.0 / 32.0 {
                pa[k] + na[k] / 65536.0
            } else {
                p_i
            }
        }))
    }

    /// The SIMD offset equals the per-component form bit for bit: points near and far
    /// from the origin, of both signs, and normals along and across the axes.
    #[test]
    fn offset_ray_origin_matches_the_per_component_form() {
        let mut cases = 0;
        for i in 0..400 {
            let t = i as f32;
            let scale = [1e-4f32, 0.02, 1.0, 37.0, 1e5][i % 5];
            let p = Vec3::new((t * 0.7).sin(), (t * 1.3).cos(), (t * 0.37).sin() - 0.3) * scale;
            for n in [
                Vec3::new((t * 0.11).cos(), (t * 0.23).sin(), 0.5).normalize(),
                Vec3::X,
                -Vec3::Z,
                Vec3::new(0.0, -0.0, 1.0),
            ] {
                let (a, b) = (offset_ray_origin(p, n), offset_reference(p, n));
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits),
                    "p {p}, n {n}"
                );
                assert!(a != p || n == Vec3::ZERO);
                cases += 1;
            }
        }
        assert_eq!(cases, 1600);
    }
}
