//! Triangle meshes in world space (positions, optional vertex normals, indices) and their
//! triangles as BVH primitives. Intersection is Möller and Trumbore's ("Fast, Minimum
//! Storage Ray/Triangle Intersection", 1997); the hit point is recomputed from the
//! barycentric coordinates, which bounds its error to a few ULPs of the vertices.
//!
//! When a mesh has no normals, smooth vertex normals are computed by weighting each face
//! normal by its corner angle (Thürmer and Wüthrich 1998), which is what Mitsuba 3 does
//! for meshes without normals, unless `face_normals` is requested.

use super::Ray;
use super::kernels::{moller_trumbore, triangle_hit};
use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex unit normals, or empty for flat shading.
    pub normals: Vec<Vec3>,
    pub texcoords: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// Applies an affine transform (normals by the inverse transpose).
    pub fn transform(&mut self, m: &Mat4) {
        let nm = m.inverse().transpose();
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        for n in &mut self.normals {
            *n = nm.transform_vector3(*n).normalize_or_zero();
        }
        if m.determinant() < 0.0 {
            // A mirror transform reverses the winding; keep faces and normals consistent.
            for t in &mut self.indices {
                t.swap(1, 2);
            }
        }
    }

    /// Replaces the normals by angle-weighted smooth vertex normals. The corners' weighted
    /// normals are computed on all cores, a block of triangles at a time, and added up in
    /// triangle order, so the normals are the sequential ones bit for bit whatever the
    /// thread count.
    pub fn compute_vertex_normals(&mut self) {
        use rayon::prelude::*;
        const BLOCK: usize = 1 << 18;
        let corners = |t: &[u32; 3]| -> Option<[Vec3; 3]> {
            let p = t.map(|i| self.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if !(n.length_squared() > 0.0) {
                return None;
            }
            let n = n.normalize();
            Some(std::array::from_fn(|k| {
                let a = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let b = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                n * a.dot(b).clamp(-1.0, 1.0).acos()
            }))
        };
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        let mut weighted = Vec::with_capacity(BLOCK.min(self.indices.len()));
        for tris in self.indices.chunks(BLOCK) {
            tris.par_iter().map(corners).collect_into_vec(&mut weighted);
            for (t, w) in tris.iter().zip(&weighted) {
                if let Some(w) = w {
                    for k in 0..3 {
                        acc[t[k] as usize] += w[k];
                    }
                }
            }
        }
        self.normals = acc.into_par_iter().map(|n| n.normalize_or_zero()).collect();
    }
}

/// A triangle as a BVH primitive: its vertices, precomputed edges, and where it lives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    pub mesh: u32,
    pub index: u32,
}

impl Triangle {
    pub fn new(mesh_id: u32, mesh: &Mesh, index: u32) -> Self {
        let [a, b, c] = mesh.indices[index as usize].map(|k| mesh.positions[k as usize]);
        Self {
            p0: a,
            e1: b - a,
            e2: c - a,
            mesh: mesh_id,
            index,
        }
    }

    /// Möller-Trumbore: parametric distance in (tmin, tmax), or infinity.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> f32 {
        match self.intersect_bary(ray) {
            Some((t, _)) => t,
            None => f32::INFINITY,
        }
    }

    /// Distance and barycentrics (b1, b2) of the hit.
    #[inline]
    pub fn intersect_bary(&self, ray: &Ray) -> Option<(f32, Vec2)> {
        let q = moller_trumbore(
            ray.o.into(),
            ray.d.into(),
            self.p0.into(),
            self.e1.into(),
            self.e2.into(),
        );
        triangle_hit(q, ray.tmin, ray.tmax).then(|| (q.t, Vec2::new(q.u, q.v)))
    }

    /// Unit geometric normal, following the winding (e1 x e2).
    pub fn normal(&self) -> Vec3 {
        self.e1.cross(self.e2).normalize_or_zero()
    }

    pub fn point(&self, b: Vec2) -> Vec3 {
        // p0 + b1 e1 + b2 e2, i.e. (1 - b1 - b2) p0 + b1 p1 + b2 p2.
        self.p0 + self.e1 * b.x + self.e2 * b.y
    }

    pub fn area(&self) -> f32 {
        0.5 * self.e1.cross(self.e2).length()
    }
}
