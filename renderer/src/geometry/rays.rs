//! Rays as struct-of-arrays columns, the form of the wavefront's ray queues (pbrt-v4's
//! `RayWorkItem` queues in `src/pbrt/wavefront/workitems.soa`): origins and directions as
//! x/y/z columns ([`Vec3s`]), ranges and skipped primitives as columns of their own. The
//! wavefront keeps the live paths' rays in order, compacted each bounce, so the geometry's
//! batched queries load a lane vector of consecutive rays with one plain load per column
//! ([`Rays::lanes`]); a chosen subset (the hits on spheres) is one gather per column
//! ([`Rays::lanes_at`]), and the camera and the bounces write their rays a lane vector at
//! a time ([`Rays::store_lanes`]), so no stage transposes ray records. The BVH reads one ray's
//! nine values where it traverses one ray at a time ([`Rays::get`]), and eight rays' in
//! lanes where it traverses a packet of coherent ones ([`Rays::packet`]).

use super::Ray;
use super::kernels::{RayLanes, V3};
use glam::Vec3;
use lobe_materials::simd::{self, LANES, Vec3xN, f32xn, u32xn};
use lobe_materials::{Vec3Cols, Vec3s};
use wide::{f32x8, u32x8};

/// Rays in columns, all equally long (private fields; every change keeps them so, and
/// changes `skip` last, so that `skip` is never longer than another column: the bound that
/// [`Rays::get`], [`Rays::set`] and [`Rays::lanes_at`] check).
#[derive(Clone, Debug, Default)]
pub struct Rays {
    o: Vec3s,
    d: Vec3s,
    tmin: Vec<f32>,
    tmax: Vec<f32>,
    skip: Vec<u32>,
}

impl Rays {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn len(&self) -> usize {
        self.skip.len()
    }

    pub fn is_empty(&self) -> bool {
        self.skip.is_empty()
    }

    /// Removes every ray, keeping the columns' capacity.
    pub fn clear(&mut self) {
        self.o.clear();
        self.d.clear();
        self.tmin.clear();
        self.tmax.clear();
        self.skip.clear();
    }

    #[inline]
    pub fn push(&mut self, r: Ray) {
        self.o.push(r.o);
        self.d.push(r.d);
        self.tmin.push(r.tmin);
        self.tmax.push(r.tmax);
        self.skip.push(r.skip);
    }

    /// Ray `i`, with one bounds check.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Ray {
        assert!(i < self.len(), "ray {i} of {}", self.len());
        // SAFETY: every column is as long as `skip` (checked above).
        unsafe {
            Ray {
                o: self.o.get_unchecked(i),
                d: self.d.get_unchecked(i),
                tmin: *self.tmin.get_unchecked(i),
                tmax: *self.tmax.get_unchecked(i),
                skip: *self.skip.get_unchecked(i),
            }
        }
    }

    /// Replaces ray `i`, with one bounds check.
    #[inline(always)]
    pub fn set(&mut self, i: usize, r: Ray) {
        assert!(i < self.len(), "ray {i} of {}", self.len());
        // SAFETY: every column is as long as `skip` (checked above).
        unsafe {
            self.o.set_unchecked(i, r.o);
            self.d.set_unchecked(i, r.d);
            *self.tmin.get_unchecked_mut(i) = r.tmin;
            *self.tmax.get_unchecked_mut(i) = r.tmax;
            *self.skip.get_unchecked_mut(i) = r.skip;
        }
    }

    /// Shortens or lengthens to `n` rays, new ones [`Ray::new`] at the origin along zero.
    pub fn resize(&mut self, n: usize) {
        let open = Ray::new(Vec3::ZERO, Vec3::ZERO);
        self.o.resize(n);
        self.d.resize(n);
        self.tmin.resize(n, open.tmin);
        self.tmax.resize(n, open.tmax);
        self.skip.resize(n, open.skip);
    }

    /// Replaces the contents by `src`'s rays, one slice copy per column.
    pub fn copy_from(&mut self, src: &Rays) {
        self.clear();
        self.o.extend_from_cols(src.o.cols());
        self.d.extend_from_cols(src.d.cols());
        self.tmin.extend_from_slice(&src.tmin);
        self.tmax.extend_from_slice(&src.tmax);
        self.skip.extend_from_slice(&src.skip);
    }

    /// The directions.
    pub fn dirs(&self) -> Vec3Cols<'_> {
        self.d.cols()
    }

    /// Sets the origins, directions and skipped primitives of rays `first..` (a lane
    /// vector's worth, or up to the end) to those of `o`, `d` and `skip` in lanes, keeping
    /// their ranges: one plain store per column.
    ///
    /// # Panics
    /// When `first` is beyond the last ray.
    #[inline(always)]
    pub fn store_lanes(&mut self, first: usize, o: Vec3xN, d: Vec3xN, skip: u32xn) {
        assert!(first < self.len(), "ray {first} of {}", self.len());
        let n = (self.len() - first).min(LANES);
        self.o.cols_mut().store(first, o);
        self.d.cols_mut().store(first, d);
        self.skip[first..first + n].copy_from_slice(&skip.as_array()[..n]);
    }

    /// Rays `first..first + LANES` in lanes and their skipped primitives, one plain load
    /// per column (past the end, the last ray repeated).
    #[inline(always)]
    pub fn lanes(&self, first: usize) -> (RayLanes<f32xn>, u32xn) {
        let (o, d) = (self.o.cols().load(first), self.d.cols().load(first));
        let lanes = RayLanes {
            o,
            d,
            tmin: f32xn::new(load(&self.tmin, first)),
            tmax: f32xn::new(load(&self.tmax, first)),
        };
        (lanes, u32xn::new(load(&self.skip, first)))
    }

    /// Rays `first..first + 8` in the eight lanes of a BVH8 packet
    /// ([`super::bvh8::Bvh8`]'s width, whatever [`LANES`] is) and their skipped primitives;
    /// panics unless there are eight rays from `first` on.
    pub fn packet(&self, first: usize) -> (RayLanes<f32x8>, u32x8) {
        let eight = |c: &[f32]| f32x8::new(*c[first..].first_chunk().expect("eight rays"));
        let (o, d) = (self.o.cols(), self.d.cols());
        let v3 = |c: Vec3Cols| V3::new(eight(c.x()), eight(c.y()), eight(c.z()));
        let lanes = RayLanes {
            o: v3(o),
            d: v3(d),
            tmin: eight(&self.tmin),
            tmax: eight(&self.tmax),
        };
        let skip = *self.skip[first..].first_chunk().expect("eight rays");
        (lanes, u32x8::new(skip))
    }

    /// Rays `ray(0)`, ..., `ray(LANES - 1)` in lanes and their skipped primitives, one
    /// gather per column.
    #[inline(always)]
    pub fn lanes_at(&self, ray: impl Fn(usize) -> usize) -> (RayLanes<f32xn>, u32xn) {
        let idx = simd::lanes(&ray);
        assert!(
            idx.iter().all(|&i| i < self.len()),
            "ray index out of range"
        );
        let (o, d) = (self.o.cols(), self.d.cols());
        // SAFETY: every index is under the columns' common length (checked above).
        let col = |c: &[f32]| f32xn::new(idx.map(|i| unsafe { *c.get_unchecked(i) }));
        let v3 = |c: Vec3Cols| V3::new(col(c.x()), col(c.y()), col(c.z()));
        let lanes = RayLanes {
            o: v3(o),
            d: v3(d),
            tmin: col(&self.tmin),
            tmax: col(&self.tmax),
        };
        // SAFETY: as above.
        let skip = idx.map(|i| unsafe { *self.skip.get_unchecked(i) });
        (lanes, u32xn::new(skip))
    }
}

/// Elements `first..first + LANES` of `c`, one plain load (past the end, the last element
/// repeated, as [`simd::padded`]).
#[inline(always)]
fn load<T: Copy>(c: &[T], first: usize) -> [T; LANES] {
    match c.get(first..first + LANES) {
        Some(run) => run.try_into().expect("LANES"),
        None => simd::padded(&c[first..]),
    }
}

impl FromIterator<Ray> for Rays {
    fn from_iter<I: IntoIterator<Item = Ray>>(iter: I) -> Self {
        let mut rays = Rays::new();
        iter.into_iter().for_each(|r| rays.push(r));
        rays
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(i: usize) -> Ray {
        let t = i as f32;
        Ray {
            o: Vec3::new(t, -t, 0.5 * t),
            d: Vec3::new(0.1 * t - 1.0, 0.5 - 0.03 * t, 1.0),
            tmin: 1e-3 * t,
            tmax: 10.0 + t,
            skip: i as u32 * 7,
        }
    }

    /// Lane `k` of a lane vector, as a ray.
    fn lane(l: &(RayLanes<f32xn>, u32xn), k: usize) -> Ray {
        let (r, skip) = l;
        let a = |v: f32xn| v.to_array()[k];
        Ray {
            o: Vec3::new(a(r.o.x), a(r.o.y), a(r.o.z)),
            d: Vec3::new(a(r.d.x), a(r.d.y), a(r.d.z)),
            tmin: a(r.tmin),
            tmax: a(r.tmax),
            skip: skip.to_array()[k],
        }
    }

    fn bits(r: &Ray) -> ([u32; 8], u32) {
        let v = [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax];
        (v.map(f32::to_bits), r.skip)
    }

    /// Every way of reading rays from the columns gives each ray bit for bit: one ray,
    /// consecutive lane vectors (with a padded tail), chosen subsets, copies, replaced and
    /// appended rays, and rays stored a lane vector at a time.
    #[test]
    fn columns_hold_each_ray() {
        let n = 3 * LANES + 5;
        let rays: Rays = (0..n).map(ray).collect();
        assert_eq!(rays.len(), n);
        for i in 0..n {
            assert_eq!(bits(&rays.get(i)), bits(&ray(i)));
        }
        for first in (0..n).step_by(LANES) {
            let l = rays.lanes(first);
            for k in 0..LANES {
                assert_eq!(bits(&lane(&l, k)), bits(&ray((first + k).min(n - 1))));
            }
        }
        let (short, gathered) = ([1, 4, 7, 10, 13], simd::lanes(|k| 2 * k + 1));
        for idx in [&short[..], &gathered[..]] {
            let l = rays.lanes_at(|k| idx[k.min(idx.len() - 1)]);
            for k in 0..LANES {
                let i = idx[k.min(idx.len() - 1)];
                assert_eq!(bits(&lane(&l, k)), bits(&ray(i)), "lane {k} of {idx:?}");
            }
        }
        let mut copy = Rays::new();
        copy.push(ray(99));
        copy.copy_from(&rays);
        copy.set(2, ray(42));
        assert_eq!(copy.len(), n);
        assert_eq!(bits(&copy.get(2)), bits(&ray(42)));
        assert_eq!(bits(&copy.get(n - 1)), bits(&ray(n - 1)));
        copy.resize(n - 1);
        copy.push(ray(77));
        assert_eq!(copy.len(), n);
        assert_eq!(bits(&copy.get(n - 1)), bits(&ray(77)));
        // Lane stores (the camera's and the bounces'): at offsets that are not multiples of
        // LANES, a partial vector at the end; skips stored, ranges kept.
        let mut stored: Rays = (0..2).map(ray).collect();
        let lanes_from = |at: usize| {
            let v = |f: fn(&Ray) -> Vec3| Vec3xN::from_array(&simd::lanes(|k| f(&ray(at + k))));
            let skip = u32xn::new(simd::lanes(|k| 7 * (at + k) as u32 + 1));
            (v(|r| r.o), v(|r| r.d), skip)
        };
        for n in [3, 5, LANES] {
            let at = stored.len();
            stored.resize(at + n);
            let (o, d, skip) = lanes_from(at);
            stored.store_lanes(at, o, d, skip);
            assert_eq!(stored.len(), at + n);
            for i in at..at + n {
                let want = Ray {
                    skip: 7 * i as u32 + 1,
                    ..Ray::new(ray(i).o, ray(i).d)
                };
                assert_eq!(bits(&stored.get(i)), bits(&want), "ray {i}");
            }
        }
        let (o, d, skip) = lanes_from(0);
        stored.store_lanes(0, o, d, skip);
        for i in 0..2 {
            let want = Ray {
                skip: 7 * i as u32 + 1,
                ..ray(i)
            };
            assert_eq!(bits(&stored.get(i)), bits(&want), "ray {i} keeps its range");
        }
    }
}
