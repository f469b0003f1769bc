//! A batch of ray hits as columns (struct of arrays, pbrt-v4's `SOA<SurfaceInteraction>`):
//! the wavefront integrator's hit queue, whose lane stages load normals and tangents with
//! plain loads, and gather the points, normals and primitives of the hits their rays leave
//! from ([`Interactions::spawn_lanes`]).

use super::{Interaction, spawn_origin};
use glam::Vec2;
use lobe_materials::simd::{self, Vec3xN, f32xn, i32xn, u32xn};
use lobe_materials::{Vec3Cols, Vec3s};

/// The interactions of a batch of hits as columns (struct of arrays, pbrt-v4's
/// `SOA<SurfaceInteraction>`): each field of [`Interaction`] its own array, its vectors
/// x, y and z columns ([`Vec3s`]), so that the lane stages load a lane vector of normals
/// or tangents with plain loads, and a stage that reads one field streams one array. The
/// columns are private and always equally long, so [`Interactions::get`] checks one bound.
#[derive(Clone, Debug, Default)]
pub struct Interactions {
    t: Vec<f32>,
    p: Vec3s,
    ng: Vec3s,
    ns: Vec3s,
    dpdu: Vec3s,
    uv: Vec<Vec2>,
    shape: Vec<u32>,
    prim: Vec<u32>,
    exit: Vec3s,
}

impl Interactions {
    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Shortens or lengthens to `n` interactions (new ones [`Interaction::ZERO`]).
    pub fn resize(&mut self, n: usize) {
        // The widest column first: if a length cannot be had, it fails before any column
        // changed.
        self.uv.resize(n, Vec2::ZERO);
        self.t.resize(n, 0.0);
        for v in [
            &mut self.p,
            &mut self.ng,
            &mut self.ns,
            &mut self.dpdu,
            &mut self.exit,
        ] {
            v.resize(n);
        }
        self.shape.resize(n, 0);
        self.prim.resize(n, 0);
    }

    /// The hit points.
    pub fn p(&self) -> Vec3Cols<'_> {
        self.p.cols()
    }

    /// The shading normals.
    pub fn ns(&self) -> Vec3Cols<'_> {
        self.ns.cols()
    }

    /// The tangents along u.
    pub fn dpdu(&self) -> Vec3Cols<'_> {
        self.dpdu.cols()
    }

    /// The shapes hit.
    pub fn shape(&self) -> &[u32] {
        &self.shape
    }

    /// The origins and skipped primitives of the rays leaving hits `idx` (one to
    /// [`simd::LANES`] of them) along world directions `d` in lanes: [`super::spawn_ray`] of
    /// each, bit for bit, in lanes (past the end of `idx`, the last hit repeated).
    #[inline(always)]
    pub fn spawn_lanes(&self, idx: &[usize], d: Vec3xN) -> (Vec3xN, u32xn) {
        let v3 = |c: &Vec3s| c.cols().lanes_of(idx);
        let prim = i32xn::new(simd::lanes_of(idx, |k| self.prim[k] as i32));
        let (o, skip) = spawn_origin::<f32xn>(v3(&self.p), v3(&self.ng), v3(&self.exit), prim, d);
        (o, wide::bytemuck::cast(skip))
    }

    /// Interaction `h` as a record, with one bounds check (inlined, a caller's unused
    /// fields are not loaded).
    #[inline(always)]
    pub fn get(&self, h: usize) -> Interaction {
        assert!(h < self.len(), "interaction {h} of {}", self.len());
        // SAFETY: every column is `self.len()` long (`resize`, this module's, is the only
        // change of length; the fields are private to this module).
        unsafe {
            Interaction {
                t: *self.t.get_unchecked(h),
                p: self.p.get_unchecked(h),
                ng: self.ng.get_unchecked(h),
                ns: self.ns.get_unchecked(h),
                dpdu: self.dpdu.get_unchecked(h),
                uv: *self.uv.get_unchecked(h),
                shape: *self.shape.get_unchecked(h),
                prim: *self.prim.get_unchecked(h),
                exit: self.exit.get_unchecked(h),
            }
        }
    }

    /// Sets interaction `h`, with one bounds check.
    #[inline(always)]
    pub fn set(&mut self, h: usize, it: &Interaction) {
        assert!(h < self.len(), "interaction {h} of {}", self.len());
        // SAFETY: as in `get`.
        unsafe {
            *self.t.get_unchecked_mut(h) = it.t;
            self.p.set_unchecked(h, it.p);
            self.ng.set_unchecked(h, it.ng);
            self.ns.set_unchecked(h, it.ns);
            self.dpdu.set_unchecked(h, it.dpdu);
            *self.uv.get_unchecked_mut(h) = it.uv;
            *self.shape.get_unchecked_mut(h) = it.shape;
            *self.prim.get_unchecked_mut(h) = it.prim;
            self.exit.set_unchecked(h, it.exit);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Every field of an interaction set in the columns reads back the same, and resizing
    /// keeps the ones that stay.
    #[test]
    fn interactions_columns_hold_every_field() {
        let it = |k: usize| {
            let v = |a: f32| Vec3::new(a, a + 0.5, a - 2.0) * k as f32;
            Interaction {
                t: k as f32 + 0.25,
                p: v(1.0),
                ng: v(2.0),
                ns: v(3.0),
                dpdu: v(4.0),
                uv: Vec2::new(k as f32, 0.5),
                shape: k as u32,
                prim: 7 * k as u32,
                exit: v(5.0),
            }
        };
        let fields = |i: &Interaction| {
            let mut f = vec![i.t.to_bits(), i.shape, i.prim];
            for w in [i.p, i.ng, i.ns, i.dpdu, i.exit] {
                f.extend(w.to_array().map(f32::to_bits));
            }
            f.extend(i.uv.to_array().map(f32::to_bits));
            f
        };
        let mut its = Interactions::default();
        its.resize(5);
        for k in 0..5 {
            its.set(k, &it(k));
        }
        its.resize(3);
        its.resize(4);
        for k in 0..3 {
            assert_eq!(fields(&its.get(k)), fields(&it(k)));
        }
        assert_eq!(fields(&its.get(3)), fields(&Interaction::ZERO));
        assert_eq!(its.ns().get(2), it(2).ns);
        assert_eq!(its.shape(), &[0, 1, 2, 0]);
    }
}
