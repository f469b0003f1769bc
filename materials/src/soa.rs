//! Struct-of-arrays columns of 3-vectors, the form the batched calls take their directions
//! in (pbrt-v4's `SOA<Vector3f>` work items, `src/pbrt/wavefront/workitems.soa`): many
//! vectors as an x, a y and a z column, so that a kernel loads a lane vector of them with
//! three contiguous loads and stores one back with three stores, instead of gathering
//! 12-byte records and transposing them. [`Vec3s`] owns its columns (the wavefront's
//! queues); [`Vec3Slice`] borrows them, as `&[Vec3]` borrows records.

use crate::simd::{LANES, Vec3xN, f32xn, lanes};
use glam::Vec3;
use std::ops::Range;

/// Many 3-vectors as three columns of equal length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Vec3s {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub z: Vec<f32>,
}

/// Borrowed columns of 3-vectors (all three of one length).
#[derive(Clone, Copy, Debug)]
pub struct Vec3Slice<'a> {
    pub x: &'a [f32],
    pub y: &'a [f32],
    pub z: &'a [f32],
}

impl Vec3s {
    /// The columns of `v` (a transpose: for inputs that come as records, off the hot path).
    pub fn from_vecs(v: &[Vec3]) -> Self {
        Self {
            x: v.iter().map(|v| v.x).collect(),
            y: v.iter().map(|v| v.y).collect(),
            z: v.iter().map(|v| v.z).collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    pub fn clear(&mut self) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
    }

    /// `n` vectors: the first ones kept, new ones zero.
    pub fn resize(&mut self, n: usize) {
        self.x.resize(n, 0.0);
        self.y.resize(n, 0.0);
        self.z.resize(n, 0.0);
    }

    /// `n` vectors, vector i `f(i)`.
    #[inline(always)]
    pub fn fill_with(&mut self, n: usize, f: impl Fn(usize) -> Vec3) {
        self.resize(n);
        let columns = self
            .x
            .iter_mut()
            .zip(self.y.iter_mut())
            .zip(self.z.iter_mut());
        for (i, ((x, y), z)) in columns.enumerate() {
            let v = f(i);
            (*x, *y, *z) = (v.x, v.y, v.z);
        }
    }

    #[inline(always)]
    pub fn push(&mut self, v: Vec3) {
        self.x.push(v.x);
        self.y.push(v.y);
        self.z.push(v.z);
    }

    #[inline(always)]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (v.x, v.y, v.z);
    }

    /// The columns, borrowed.
    #[inline(always)]
    pub fn as_slice(&self) -> Vec3Slice<'_> {
        Vec3Slice {
            x: &self.x,
            y: &self.y,
            z: &self.z,
        }
    }

    /// Writes lanes `0..n` of `v` to vectors `first..first + n`, where `n` is `LANES` or
    /// what is left of the columns: three stores when a whole lane vector fits.
    #[inline(always)]
    pub fn store_lanes(&mut self, first: usize, v: Vec3xN) {
        let n = (self.len() - first).min(LANES);
        for (col, lane) in [(&mut self.x, v.x), (&mut self.y, v.y), (&mut self.z, v.z)] {
            col[first..first + n].copy_from_slice(&lane.as_array()[..n]);
        }
    }

    /// `self[j] = src[idx[j]]` for every j (the columns resized to `idx.len()`).
    pub fn gather_from(&mut self, src: Vec3Slice, idx: &[u32]) {
        self.fill_with(idx.len(), |j| src.get(idx[j] as usize));
    }
}

impl<'a> Vec3Slice<'a> {
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    #[inline(always)]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// Vectors `r` of the columns.
    #[inline(always)]
    pub fn slice(&self, r: Range<usize>) -> Vec3Slice<'a> {
        Vec3Slice {
            x: &self.x[r.clone()],
            y: &self.y[r.clone()],
            z: &self.z[r],
        }
    }

    /// Vectors `first..first + LANES` in lanes, padded with the last vector where the
    /// columns end sooner (as [`crate::simd::padded`]): three loads for a whole lane vector.
    #[inline(always)]
    pub fn lanes_at(&self, first: usize) -> Vec3xN {
        let n = self.len();
        assert!(first < n, "lanes at {first} of {n} vectors");
        if first + LANES <= n {
            let load = |c: &[f32]| {
                let a: [f32; LANES] = c[first..first + LANES].try_into().unwrap();
                f32xn::new(a)
            };
            return Vec3xN::new(load(self.x), load(self.y), load(self.z));
        }
        let load = |c: &[f32]| f32xn::new(lanes(|i| c[(first + i).min(n - 1)]));
        Vec3xN::new(load(self.x), load(self.y), load(self.z))
    }

    /// The vectors `idx` (one to `LANES` indices) in lanes, the last repeated in the lanes
    /// past its end (as [`crate::simd::lanes_of`]).
    #[inline(always)]
    pub fn lanes_of(&self, idx: &[usize]) -> Vec3xN {
        let n = idx.len();
        assert!((1..=LANES).contains(&n), "a chunk of 1 to LANES indices");
        let load = |c: &[f32]| f32xn::new(lanes(|i| c[idx[i.min(n - 1)]]));
        Vec3xN::new(load(self.x), load(self.y), load(self.z))
    }

    /// The vectors as records (a transpose: for tests and tools).
    pub fn to_vecs(&self) -> Vec<Vec3> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_load_and_store_the_vectors_records_hold() {
        for n in [1, 3, LANES, LANES + 1, 3 * LANES - 2] {
            let v: Vec<Vec3> = (0..n)
                .map(|i| Vec3::new(i as f32, -(i as f32) - 0.5, 1e3 + i as f32))
                .collect();
            let cols = Vec3s::from_vecs(&v);
            assert_eq!(cols.as_slice().to_vecs(), v);
            let mut back = Vec3s::default();
            back.resize(n);
            for first in (0..n).step_by(LANES) {
                let lanes = cols.as_slice().lanes_at(first);
                for k in 0..LANES {
                    assert_eq!(
                        lanes.lane(k),
                        v[(first + k).min(n - 1)],
                        "n {n} first {first}"
                    );
                }
                back.store_lanes(first, lanes);
            }
            assert_eq!(back, cols);
            let idx: Vec<usize> = (0..n.min(LANES)).rev().collect();
            let g = cols.as_slice().lanes_of(&idx);
            for k in 0..LANES {
                assert_eq!(g.lane(k), v[idx[k.min(idx.len() - 1)]]);
            }
            let mut gathered = Vec3s::default();
            let idx32: Vec<u32> = idx.iter().map(|&i| i as u32).collect();
            gathered.gather_from(cols.as_slice(), &idx32);
            assert_eq!(
                gathered.as_slice().to_vecs(),
                idx.iter().map(|&i| v[i]).collect::<Vec<_>>()
            );
        }
    }
}
