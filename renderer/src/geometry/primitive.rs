//! The primitives a BVH holds: a sphere, a mesh triangle or a rectangle
//! ([`PrimKind`], with its shape in [`Primitive`]), the same with its geometric data for
//! intersection ([`PrimShape`], with the ray-intersection kernels' lane form), and the
//! data a primitive index points into ([`PrimSource`]).

use super::kernels::{self, RayLanes};
use super::prims::Prims;
use super::{Mesh, Ray, Rectangle, Sphere, Triangle};
use glam::{Vec3, Vec3A};
use lobe_materials::simd::f32xn;
use obvhs::aabb::Aabb;

/// One primitive: a sphere by value, a mesh triangle by its mesh and index (its vertices
/// live in the mesh), a rectangle by its index into [`Geometry::rects`]. [`Prims`] stores
/// a mesh's triangles as one run; [`PrimShape`] is the primitive with its data, for
/// intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimKind {
    Sphere(Sphere),
    Triangle { mesh: u32, index: u32 },
    Rectangle(u32),
}

/// A BVH primitive and the scene shape it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primitive {
    pub kind: PrimKind,
    pub shape: u32,
}

/// A primitive with its geometric data ([`Geometry::shape_of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimShape {
    Sphere(Sphere),
    Triangle(Triangle),
    Rectangle(Rectangle),
}

impl PrimShape {
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> f32 {
        match self {
            PrimShape::Sphere(s) => s.intersect(ray),
            PrimShape::Triangle(t) => t.intersect(ray),
            PrimShape::Rectangle(r) => r.intersect(ray),
        }
    }

    /// [`PrimShape::intersect`] of rays in SIMD lanes, bit for bit the same.
    #[inline(always)]
    pub fn intersect_lanes(&self, r: &RayLanes<f32xn>) -> f32xn {
        use kernels::splat3;
        match self {
            PrimShape::Sphere(s) => kernels::sphere(r, splat3(s.center), f32xn::splat(s.radius)),
            PrimShape::Triangle(t) => {
                kernels::triangle(r, splat3(t.p0), splat3(t.e1), splat3(t.e2))
            }
            PrimShape::Rectangle(q) => kernels::rectangle(
                r,
                splat3(q.corner),
                splat3(q.n),
                splat3(q.du()),
                splat3(q.dv()),
            ),
        }
    }

    /// The primitive's bounding box, padded a little so that axis-aligned rectangles and
    /// triangles have volume.
    #[inline(always)]
    pub fn aabb(&self) -> Aabb {
        let (lo, hi) = match self {
            PrimShape::Sphere(s) => (
                s.center - Vec3::splat(s.radius),
                s.center + Vec3::splat(s.radius),
            ),
            PrimShape::Triangle(t) => {
                let (a, b, c) = (t.p0, t.p0 + t.e1, t.p0 + t.e2);
                (a.min(b).min(c), a.max(b).max(c))
            }
            PrimShape::Rectangle(r) => {
                let pts = [
                    r.corner,
                    r.corner + r.eu,
                    r.corner + r.ev,
                    r.corner + r.eu + r.ev,
                ];
                let lo = pts.iter().fold(Vec3::INFINITY, |a, p| a.min(*p));
                let hi = pts.iter().fold(Vec3::NEG_INFINITY, |a, p| a.max(*p));
                (lo, hi)
            }
        };
        let pad = (hi - lo).max_element().max(1e-3) * 1e-5;
        Aabb::new(
            Vec3A::from(lo - Vec3::splat(pad)),
            Vec3A::from(hi + Vec3::splat(pad)),
        )
    }
}

/// The data a primitive index stands for: the primitives and what their indices point into.
#[derive(Clone, Copy)]
pub struct PrimSource<'a> {
    pub prims: &'a Prims,
    pub meshes: &'a [Mesh],
    pub rects: &'a [Rectangle],
}

impl PrimSource<'_> {
    /// Primitive `i` with its data (a triangle's vertex and edges computed from its mesh,
    /// bit for bit those of [`Triangle::new`]).
    #[inline(always)]
    pub fn shape_of(&self, i: u32) -> PrimShape {
        self.shape_of_primitive(self.prims.get(i))
    }

    /// [`PrimSource::shape_of`] of a primitive already looked up.
    #[inline(always)]
    pub fn shape_of_primitive(&self, p: Primitive) -> PrimShape {
        match p.kind {
            PrimKind::Sphere(s) => PrimShape::Sphere(s),
            PrimKind::Triangle { mesh, index } => {
                PrimShape::Triangle(Triangle::new(mesh, &self.meshes[mesh as usize], index))
            }
            PrimKind::Rectangle(r) => PrimShape::Rectangle(self.rects[r as usize]),
        }
    }
}
