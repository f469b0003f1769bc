//! Geometry: rays, analytic spheres with exact normals, triangle meshes, rectangles, and
//! one BVH over all of them ([`bvh::Geometry`]).
//!
//! Spawned rays start at a point offset along the geometric normal by the integer-ULP
//! method of Wächter and Binder ("A Fast and Robust Method for Avoiding Self-Intersection",
//! Ray Tracing Gems, 2019, ch. 6), after the hit point has been recomputed from the
//! surface itself (re-projection onto the sphere, barycentric interpolation on triangles)
//! so its error is a few ULPs, as pbrt-v4 does with its error bounds. The offset and the
//! spawned ray's origin and skipped primitive are written once over [`Single`]
//! ([`offset_origin`], [`spawn_origin`]) for one ray and for lanes of them
//! ([`Interactions::spawn_lanes`]).

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
use lobe_materials::math::{Single, V3, abs, ge, lt, select};

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
}

/// Origin of a ray leaving `p` on the side of `n` (Wächter and Binder 2019).
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_origin::<f32>(p.into(), n.into()).into()
}

/// [`offset_ray_origin`] written once over [`Single`] (one point, or lanes of them),
/// component by component: p's bits stepped by `(256 n) as i32` units in the last place
/// away from the surface (the offset's sign from p's), or, near the origin where a step
/// of p's bits is too small, p plus n / 65536.
#[inline(always)]
pub fn offset_origin<T: Single>(p: V3<T>, n: V3<T>) -> V3<T> {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let axis = |p: T, n: T| {
        // `trunc_int` maps NaN to 0, as `as i32` does; a unit normal's step is at most 256
        // (the clamp only keeps the integer arithmetic from overflowing on other input).
        let of = (T::of32(INT_SCALE) * n).trunc_int();
        let of = T::int_min(T::int_max(of, T::int(-256)), T::int(256));
        // NaN counts as near: its bits, like those of values near the origin, may sit at
        // the ends of i32's range, where the step would overflow.
        let near = !ge(abs(p), T::of32(ORIGIN));
        // Near the origin the step is not taken (nor computed).
        let off = T::int_select(lt(p, T::of32(0.0)), T::int(0) - of, of);
        let stepped = T::from_bits(p.to_bits() + T::int_select(near, T::int(0), off));
        select(near, p + T::of32(FLOAT_SCALE) * n, stepped)
    };
    V3::new(axis(p.x, n.x), axis(p.y, n.y), axis(p.z, n.z))
}

/// A ray leaving the surface point `it` in direction `d` (world space, any length).
#[inline(always)]
pub fn spawn_ray(it: &Interaction, d: Vec3) -> Ray {
    let (o, skip) = spawn_origin_of(it, d);
    Ray {
        skip,
        ..Ray::new(o, d)
    }
}

/// [`spawn_origin`] of one ray leaving `it` along `d`: its origin and skipped primitive.
#[inline(always)]
fn spawn_origin_of(it: &Interaction, d: Vec3) -> (Vec3, u32) {
    let (o, skip) = spawn_origin::<f32>(
        it.p.into(),
        it.ng.into(),
        it.exit.into(),
        it.prim as i32,
        d.into(),
    );
    (o.into(), skip as u32)
}

/// The origin and skipped primitive of [`spawn_ray`] (one ray, or lanes of rays), written
/// once over [`Single`]: the origin offset from `p` to the side of the geometric normal
/// `ng` that `d` leaves by, and the primitive `prim` skipped (see [`Ray::skip`]) when `d`
/// leaves along the exit direction `exit`, else [`Ray::NO_SKIP`] (as an i32).
#[inline(always)]
pub fn spawn_origin<T: Single>(
    p: V3<T>,
    ng: V3<T>,
    exit: V3<T>,
    prim: T::Int,
    d: V3<T>,
) -> (V3<T>, T::Int) {
    let zero = T::of32(0.0);
    let out = ge(d.dot(ng), zero);
    let n = V3::new(
        select(out, ng.x, -ng.x),
        select(out, ng.y, -ng.y),
        select(out, ng.z, -ng.z),
    );
    let skip = T::int_select(ge(d.dot(exit), zero), prim, T::int(Ray::NO_SKIP as i32));
    (offset_origin(p, n), skip)
}

/// A shadow ray from surface point `it` to the point `target`; `target_n`, when given,
/// is the geometric normal there, used to pull the end point off that surface too.
#[inline(always)]
pub fn spawn_ray_to(it: &Interaction, target: Vec3, target_n: Option<Vec3>) -> Ray {
    let d0 = target - it.p;
    let (o, skip) = spawn_origin_of(it, d0);
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
        skip,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lobe_materials::simd::{LANES, Vec3xN};

    /// Wächter and Binder's offset written per component (the paper's form).
    fn offset_reference(p: Vec3, n: Vec3) -> Vec3 {
        let (pa, na) = (p.to_array(), n.to_array());
        Vec3::from_array(std::array::from_fn(|k| {
            let of = (256.0 * na[k]) as i32;
            let off = if pa[k] < 0.0 { of.wrapping_neg() } else { of };
            let p_i = f32::from_bits((pa[k].to_bits() as i32).wrapping_add(off) as u32);
            // NaN counts as near (see `offset_origin`).
            if !(pa[k].abs() >= 1.0 / 32.0) {
                pa[k] + na[k] / 65536.0
            } else {
                p_i
            }
        }))
    }

    /// [`offset_ray_origin`] (the one-ray form of [`offset_origin`]) equals the
    /// per-component form bit for bit: points near and far from the origin, of both signs,
    /// and normals along and across the axes.
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

    /// Rays spawned in lanes ([`Interactions::spawn_lanes`]) and one at a time
    /// ([`spawn_ray`]) equal the per-component reference bit for bit: points near the
    /// origin (among them -0 and the smallest negative values, whose bits sit at the ends
    /// of i32's range), far from it and NaN; normals along the axes (the largest integer
    /// step) and a NaN one; directions on either side of the geometric normal and of the
    /// exit direction, a zero exit direction (planar primitives); chunks of consecutive
    /// hits (one plain load per column), of scattered ones, and partial ones.
    #[test]
    fn spawned_rays_match_the_per_component_reference() {
        let n = 5 * LANES + 3;
        let its: Vec<Interaction> = (0..n)
            .map(|i| {
                let t = i as f32;
                let scale = [1e-4f32, 0.02, 1.0, 37.0, 1e5][i % 5];
                let p = match i % 9 {
                    0 => Vec3::new(-0.0, f32::from_bits(0x8000_0001), 0.0),
                    4 => Vec3::new(f32::from_bits(0x7fff_ffff), 2.0, -f32::NAN),
                    _ => Vec3::new((t * 0.7).sin(), (t * 1.3).cos(), (t * 0.37).sin()) * scale,
                };
                let ng = match i % 11 {
                    3 => Vec3::new(f32::NAN, 0.0, 1.0),
                    5 => Vec3::X,
                    6 => -Vec3::Y,
                    _ => Vec3::new((t * 0.11).cos(), (t * 0.23).sin(), 0.5).normalize(),
                };
                let exit = match i % 4 {
                    0 => Vec3::ZERO,
                    _ => Vec3::new((t * 0.5).sin(), 0.3, (t * 0.9).cos()),
                };
                Interaction {
                    p,
                    ng,
                    prim: i as u32,
                    exit,
                    ..Interaction::ZERO
                }
            })
            .collect();
        let mut cols = Interactions::default();
        cols.resize(n);
        its.iter().enumerate().for_each(|(h, it)| cols.set(h, it));
        let dir = |h: usize| {
            let t = h as f32;
            Vec3::new((t * 2.1).cos(), (t * 0.4).sin() - 0.2, (t * 1.7).sin())
        };
        let (mut skipped, mut kept) = (0, 0);
        let chunks = (0..n).step_by(3).flat_map(|first| {
            let run = first..n.min(first + LANES);
            [run.clone().collect::<Vec<usize>>(), run.rev().collect()]
        });
        for idx in chunks {
            let d = Vec3xN::from_array(&lobe_materials::simd::lanes_of(&idx, dir));
            let (o, skip) = cols.spawn_lanes(&idx, d);
            let (o, skip) = (o.to_array(), skip.to_array());
            for (k, &h) in idx.iter().enumerate() {
                let (it, d) = (&its[h], dir(h));
                let ray = spawn_ray(it, d);
                // The reference: the offset toward the side `d` leaves by, the primitive
                // skipped when `d` leaves along the exit direction.
                let side = if d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
                let want = Ray {
                    skip: if d.dot(it.exit) >= 0.0 {
                        it.prim
                    } else {
                        Ray::NO_SKIP
                    },
                    ..Ray::new(offset_reference(it.p, side), d)
                };
                let bits = |r: &Ray| (r.o.to_array().map(f32::to_bits), r.skip);
                assert_eq!(bits(&ray), bits(&want), "hit {h}");
                assert_eq!(
                    bits(&Ray {
                        o: o[k],
                        skip: skip[k],
                        ..want
                    }),
                    bits(&want),
                    "hit {h}"
                );
                match want.skip == Ray::NO_SKIP {
                    true => kept += 1,
                    false => skipped += 1,
                }
            }
        }
        assert!(skipped > 0 && kept > 0, "{skipped} skipping, {kept} not");
    }
}
