//! Struct-of-arrays storage of 3-vectors: x, y and z in three columns, the form of lobe's
//! batched queues (pbrt-v4's `workitems.soa`, where a `Vector3f` field of a work queue is
//! three arrays). A lane vector of consecutive elements is three plain loads and one store
//! is three plain stores, so the lane kernels that read and write the queues
//! ([`crate::Bsdf::eval_pdf_many`], the renderer's shading frames) transpose nothing; a
//! chosen subset of them is three gathers.
//!
//! [`Vec3s`] owns the columns; [`Vec3Cols`] and [`Vec3ColsMut`] are views of equal-length
//! column slices (a batch's range of a queue), which the batched entry points take.

use crate::simd::{self, LANES, Vec3xN, f32xn};
use glam::Vec3;
use std::ops::Range;

/// 3-vectors as x, y and z columns of equal length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Vec3s {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Vec3s {
    /// No vectors.
    pub fn new() -> Self {
        Self::default()
    }

    /// `n` zero vectors.
    pub fn zeros(n: usize) -> Self {
        let mut v = Self::new();
        v.resize(n);
        v
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Removes every vector, keeping the columns' capacity.
    pub fn clear(&mut self) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
    }

    /// Shortens or lengthens to `n` vectors, new ones zero.
    pub fn resize(&mut self, n: usize) {
        self.x.resize(n, 0.0);
        self.y.resize(n, 0.0);
        self.z.resize(n, 0.0);
    }

    /// Room for `n` more vectors.
    pub fn reserve(&mut self, n: usize) {
        self.x.reserve(n);
        self.y.reserve(n);
        self.z.reserve(n);
    }

    #[inline]
    pub fn push(&mut self, v: Vec3) {
        self.x.push(v.x);
        self.y.push(v.y);
        self.z.push(v.z);
    }

    /// Vector `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Vec3 {
        self.cols().get(i)
    }

    /// Sets vector `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.cols_mut().set(i, v);
    }

    /// Sets vector `i` without a bounds check (as [`Vec3s::get_unchecked`]).
    ///
    /// # Safety
    /// `i < self.len()`.
    #[inline(always)]
    pub unsafe fn set_unchecked(&mut self, i: usize, v: Vec3) {
        // SAFETY: the caller's.
        unsafe {
            *self.x.get_unchecked_mut(i) = v.x;
            *self.y.get_unchecked_mut(i) = v.y;
            *self.z.get_unchecked_mut(i) = v.z;
        }
    }

    /// Vector `i` without a bounds check, for containers of several columns that check one
    /// bound for all.
    ///
    /// # Safety
    /// `i < self.len()`.
    #[inline(always)]
    pub unsafe fn get_unchecked(&self, i: usize) -> Vec3 {
        // SAFETY: the caller's.
        unsafe {
            Vec3::new(
                *self.x.get_unchecked(i),
                *self.y.get_unchecked(i),
                *self.z.get_unchecked(i),
            )
        }
    }

    /// A view of all the vectors.
    #[inline(always)]
    pub fn cols(&self) -> Vec3Cols<'_> {
        Vec3Cols {
            x: &self.x,
            y: &self.y,
            z: &self.z,
        }
    }

    /// A mutable view of all the vectors.
    #[inline(always)]
    pub fn cols_mut(&mut self) -> Vec3ColsMut<'_> {
        Vec3ColsMut {
            x: &mut self.x,
            y: &mut self.y,
            z: &mut self.z,
        }
    }

    /// Replaces the contents by `src`'s vectors `idx[0]`, `idx[1]`, ...
    ///
    /// # Panics
    /// When an index is out of range (before any column changes, so that they stay equally
    /// long).
    pub fn gather_from(&mut self, src: Vec3Cols, idx: &[u32]) {
        let max = idx.iter().copied().max().unwrap_or(0) as usize;
        assert!(
            idx.is_empty() || max < src.len(),
            "index {max} of {}",
            src.len()
        );
        for (dst, src) in [
            (&mut self.x, src.x),
            (&mut self.y, src.y),
            (&mut self.z, src.z),
        ] {
            dst.clear();
            dst.extend(idx.iter().map(|&i| src[i as usize]));
        }
    }

    /// The vectors as records (for tests and reports).
    pub fn to_vec(&self) -> Vec<Vec3> {
        self.cols().iter().collect()
    }
}

impl From<&[Vec3]> for Vec3s {
    fn from(v: &[Vec3]) -> Self {
        v.iter().copied().collect()
    }
}

impl FromIterator<Vec3> for Vec3s {
    fn from_iter<I: IntoIterator<Item = Vec3>>(iter: I) -> Self {
        let mut out = Self::new();
        out.extend(iter);
        out
    }
}

impl Extend<Vec3> for Vec3s {
    fn extend<I: IntoIterator<Item = Vec3>>(&mut self, iter: I) {
        let iter = iter.into_iter();
        self.reserve(iter.size_hint().0);
        for v in iter {
            self.push(v);
        }
    }
}

/// A view of 3-vectors stored as equal-length x, y and z column slices (the fields are
/// private so that the lengths stay equal: element access checks one bound).
#[derive(Clone, Copy, Debug)]
pub struct Vec3Cols<'a> {
    x: &'a [f32],
    y: &'a [f32],
    z: &'a [f32],
}

impl<'a> Vec3Cols<'a> {
    /// The view of three columns.
    ///
    /// # Panics
    /// When their lengths differ.
    pub fn new(x: &'a [f32], y: &'a [f32], z: &'a [f32]) -> Self {
        assert!(
            x.len() == y.len() && x.len() == z.len(),
            "columns of equal length"
        );
        Self { x, y, z }
    }

    #[inline(always)]
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// The z column (the one the batched kernels test for directions above the surface).
    #[inline(always)]
    pub fn z(&self) -> &'a [f32] {
        self.z
    }

    /// Vector `i`, with one bounds check.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Vec3 {
        let x = self.x[i];
        // SAFETY: the columns have equal lengths (checked where the view is made, and its
        // fields are private), and `i` is within x's.
        unsafe { Vec3::new(x, *self.y.get_unchecked(i), *self.z.get_unchecked(i)) }
    }

    /// The vectors of `r`.
    #[inline(always)]
    pub fn slice(&self, r: Range<usize>) -> Vec3Cols<'a> {
        Vec3Cols {
            x: &self.x[r.clone()],
            y: &self.y[r.clone()],
            z: &self.z[r],
        }
    }

    /// The vectors in order.
    pub fn iter(&self) -> impl Iterator<Item = Vec3> + 'a {
        let (x, y, z) = (self.x, self.y, self.z);
        (0..x.len()).map(move |i| Vec3::new(x[i], y[i], z[i]))
    }

    /// Vectors `first..first + LANES` in lanes, three plain loads (past the end, the last
    /// vector repeated, as [`simd::padded`]).
    #[inline(always)]
    pub fn load(&self, first: usize) -> Vec3xN {
        let n = self.len() - first;
        if n >= LANES {
            let col = |c: &[f32]| f32xn::new(c[first..first + LANES].try_into().expect("LANES"));
            return Vec3xN::new(col(self.x), col(self.y), col(self.z));
        }
        let col = |c: &[f32]| f32xn::new(simd::padded(&c[first..]));
        Vec3xN::new(col(self.x), col(self.y), col(self.z))
    }

    /// Vectors `idx[i]` in lane i for one to [`LANES`] strictly increasing indices (as
    /// [`simd::chunks_where`] gives them; past their end, the last repeated, as
    /// [`simd::lanes_of`]): three plain loads when they are `LANES` consecutive ones, else
    /// three gathers. Increasing indices are a precondition (checked in debug builds only):
    /// the test for a consecutive run looks at the first and last index alone.
    #[inline(always)]
    pub fn lanes_of(&self, idx: &[usize]) -> Vec3xN {
        debug_assert!(idx.windows(2).all(|w| w[0] < w[1]), "increasing indices");
        if idx.len() == LANES && idx[LANES - 1] - idx[0] == LANES - 1 {
            return self.load(idx[0]);
        }
        let col = |c: &[f32]| f32xn::new(simd::lanes_of(idx, |k| c[k]));
        Vec3xN::new(col(self.x), col(self.y), col(self.z))
    }
}

impl<'a> From<&'a Vec3s> for Vec3Cols<'a> {
    fn from(v: &'a Vec3s) -> Self {
        v.cols()
    }
}

/// A mutable view of 3-vectors stored as equal-length x, y and z column slices (private,
/// as [`Vec3Cols`]'s).
#[derive(Debug)]
pub struct Vec3ColsMut<'a> {
    x: &'a mut [f32],
    y: &'a mut [f32],
    z: &'a mut [f32],
}

impl<'a> Vec3ColsMut<'a> {
    /// The view of three columns.
    ///
    /// # Panics
    /// When their lengths differ.
    pub fn new(x: &'a mut [f32], y: &'a mut [f32], z: &'a mut [f32]) -> Self {
        assert!(
            x.len() == y.len() && x.len() == z.len(),
            "columns of equal length"
        );
        Self { x, y, z }
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Sets vector `i`, with one bounds check.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x[i] = v.x;
        // SAFETY: as in `Vec3Cols::get`.
        unsafe {
            *self.y.get_unchecked_mut(i) = v.y;
            *self.z.get_unchecked_mut(i) = v.z;
        }
    }

    /// The vectors of `r`.
    #[inline(always)]
    pub fn slice(&mut self, r: Range<usize>) -> Vec3ColsMut<'_> {
        Vec3ColsMut {
            x: &mut self.x[r.clone()],
            y: &mut self.y[r.clone()],
            z: &mut self.z[r],
        }
    }

    /// Writes lanes `0..min(LANES, len - first)` of `v` to vectors `first..`, three plain
    /// stores (the inverse of [`Vec3Cols::load`]).
    #[inline(always)]
    pub fn store(&mut self, first: usize, v: Vec3xN) {
        let n = (self.len() - first).min(LANES);
        for (dst, c) in [
            (&mut *self.x, v.x),
            (&mut *self.y, v.y),
            (&mut *self.z, v.z),
        ] {
            dst[first..first + n].copy_from_slice(&c.as_array()[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vectors(n: usize) -> Vec<Vec3> {
        (0..n)
            .map(|i| Vec3::new(i as f32, 0.5 - i as f32, 1e3 + i as f32))
            .collect()
    }

    #[test]
    fn load_and_store_round_trip_every_length() {
        for n in 1..3 * LANES + 2 {
            let v = vectors(n);
            let cols = Vec3s::from(&v[..]);
            assert_eq!(cols.to_vec(), v);
            let mut back = Vec3s::zeros(n);
            for first in (0..n).step_by(LANES) {
                let lanes = cols.cols().load(first);
                // Lanes past the end repeat the last vector.
                for i in 0..LANES {
                    assert_eq!(lanes.lane(i), v[(first + i).min(n - 1)], "n {n} lane {i}");
                }
                back.cols_mut().store(first, lanes);
            }
            assert_eq!(back, cols, "n {n}");
        }
    }

    #[test]
    fn lanes_of_and_gather_follow_the_indices() {
        let v = vectors(40);
        let cols = Vec3s::from(&v[..]);
        let idx = [3usize, 5, 17];
        let lanes = cols.cols().lanes_of(&idx);
        for i in 0..LANES {
            assert_eq!(lanes.lane(i), v[idx[i.min(2)]]);
        }
        // LANES consecutive indices (loaded), and LANES with a gap (gathered).
        for idx in [
            simd::lanes(|i| 7 + i),
            simd::lanes(|i| 7 + i + (i > 0) as usize),
        ] {
            let lanes = cols.cols().lanes_of(&idx);
            for i in 0..LANES {
                assert_eq!(lanes.lane(i), v[idx[i]], "{idx:?}");
            }
        }
        let mut g = Vec3s::new();
        g.gather_from(cols.cols(), &[39, 0, 7]);
        assert_eq!(g.to_vec(), vec![v[39], v[0], v[7]]);
        assert_eq!(cols.cols().slice(5..9).iter().collect::<Vec<_>>(), v[5..9]);
        let mut m = cols.clone();
        m.cols_mut().slice(2..4).set(1, Vec3::ONE);
        assert_eq!(m.get(3), Vec3::ONE);
        assert_eq!(m.get(2), v[2]);
    }

    #[test]
    #[should_panic(expected = "equal length")]
    fn unequal_columns_are_refused() {
        Vec3Cols::new(&[0.0; 3], &[0.0; 3], &[0.0; 2]);
    }
}
