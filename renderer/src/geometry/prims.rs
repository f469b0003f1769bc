//! The scene's primitive list, stored as runs: a mesh's consecutive triangles are one run
//! (its mesh, first triangle and shape), each sphere or rectangle a run of its own. A
//! primitive index names the same primitive as in a flat list, but a mesh costs a few
//! bytes instead of 24 per triangle (at 16 million triangles, 384 MB).

use super::primitive::{PrimKind, Primitive};

/// A run of primitives from index `start`: `first.kind` is a sphere or a rectangle (a run
/// of one), or a mesh triangle followed by that mesh's next triangles.
#[derive(Clone, Copy, Debug)]
struct Run {
    start: u32,
    first: Primitive,
}

/// The primitives of a scene ([`Prims::get`] gives primitive `i`).
#[derive(Clone, Debug, Default)]
pub struct Prims {
    runs: Vec<Run>,
    len: u32,
}

impl Prims {
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of primitives.
    #[inline]
    pub fn len(&self) -> usize {
        self.len as usize
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a primitive (index `len()`): a triangle that follows the last one of the
    /// same mesh and shape extends its run.
    pub fn push(&mut self, p: Primitive) {
        if let (Some(last), PrimKind::Triangle { mesh, index }) = (self.runs.last(), p.kind)
            && let PrimKind::Triangle {
                mesh: run_mesh,
                index: run_first,
            } = last.first.kind
            && run_mesh == mesh
            && last.first.shape == p.shape
            && index.wrapping_sub(run_first) == self.len - last.start
        {
            self.len += 1;
            return;
        }
        self.runs.push(Run {
            start: self.len,
            first: p,
        });
        self.len += 1;
    }

    /// Primitive `i` (< `len()`).
    #[inline(always)]
    pub fn get(&self, i: u32) -> Primitive {
        debug_assert!(i < self.len);
        let r = match self.runs.len() {
            1 => &self.runs[0],
            _ => &self.runs[self.runs.partition_point(|r| r.start <= i) - 1],
        };
        match r.first.kind {
            PrimKind::Triangle { mesh, index } => Primitive {
                kind: PrimKind::Triangle {
                    mesh,
                    index: index + (i - r.start),
                },
                shape: r.first.shape,
            },
            _ => r.first,
        }
    }

    /// The primitives in order.
    pub fn iter(&self) -> impl Iterator<Item = Primitive> + '_ {
        (0..self.len).map(|i| self.get(i))
    }

    /// The primitives that are not mesh triangles (spheres and rectangles), in order.
    pub fn singles(&self) -> impl Iterator<Item = Primitive> + '_ {
        self.runs
            .iter()
            .filter(|r| !matches!(r.first.kind, PrimKind::Triangle { .. }))
            .map(|r| r.first)
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.runs.len() * size_of::<Run>()
    }
}

impl FromIterator<Primitive> for Prims {
    fn from_iter<I: IntoIterator<Item = Primitive>>(iter: I) -> Self {
        let mut p = Prims::new();
        for x in iter {
            p.push(x);
        }
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sphere;
    use glam::Vec3;

    #[test]
    fn runs_give_back_every_primitive_in_order() {
        let tri = |mesh, index, shape| Primitive {
            kind: PrimKind::Triangle { mesh, index },
            shape,
        };
        let sphere = Primitive {
            kind: PrimKind::Sphere(Sphere {
                center: Vec3::ONE,
                radius: 0.5,
            }),
            shape: 3,
        };
        // Mesh 0 with triangle 3 left out (degenerate), a sphere, mesh 1 as two shapes,
        // a rectangle, mesh 0 again.
        let flat: Vec<Primitive> = (0..3)
            .map(|t| tri(0, t, 0))
            .chain((4..9).map(|t| tri(0, t, 0)))
            .chain([sphere])
            .chain((0..4).map(|t| tri(1, t, 1)))
            .chain((4..6).map(|t| tri(1, t, 2)))
            .chain([Primitive {
                kind: PrimKind::Rectangle(0),
                shape: 4,
            }])
            .chain((9..11).map(|t| tri(0, t, 0)))
            .collect();
        let prims: Prims = flat.iter().copied().collect();
        assert_eq!(prims.len(), flat.len());
        assert_eq!(prims.runs.len(), 7);
        let singles: Vec<Primitive> = prims.singles().collect();
        assert_eq!(singles, [flat[8], flat[15]]);
        for (i, p) in flat.iter().enumerate() {
            assert_eq!(prims.get(i as u32), *p, "primitive {i}");
        }
        assert!(prims.iter().eq(flat.iter().copied()));
    }
}
