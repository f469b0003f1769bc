//! Struct-of-arrays storage of small vectors: a 3-vector's x, y and z (a 2D sample
//! point's x and y) in columns, the form of lobe's batched queues (pbrt-v4's
//! `workitems.soa`, where a `Vector3f` field of a work queue is three arrays). A lane
//! vector of consecutive elements is one plain load per column and a store one plain store
//! per column, so the lane kernels that read and write the queues
//! ([`crate::Bsdf::eval_pdf_many`], [`crate::Bsdf::sample_many`], the renderer's shading
//! frames and samplers) transpose nothing; a chosen subset of them is one gather per column.
//!
//! [`Columns`] owns the columns ([`Vec3s`], [`Vec2s`]); [`Cols`] and [`ColsMut`] are views
//! of equal-length column slices (a batch's range of a queue), which the batched entry
//! points take ([`Vec3Cols`], [`Vec2Cols`]). One generic code serves every width: a
//! [`Record`] says how an element and a lane vector of them split into components.

use crate::simd::{self, LANES, Vec3xN, f32xn};
use glam::{Vec2, Vec3};
use std::marker::PhantomData;
use std::ops::Range;

/// An element of [`Columns`]: `N` f32 components, and its lane vector (`LANES` elements,
/// one register per component).
pub trait Record<const N: usize>: Copy {
    /// `LANES` elements as `N` registers.
    type Lanes: Copy;
    fn components(self) -> [f32; N];
    fn from_components(c: [f32; N]) -> Self;
    fn from_lanes(c: [f32xn; N]) -> Self::Lanes;
    fn to_lanes(v: Self::Lanes) -> [f32xn; N];
}

impl Record<3> for Vec3 {
    type Lanes = Vec3xN;
    #[inline(always)]
    fn components(self) -> [f32; 3] {
        self.to_array()
    }
    #[inline(always)]
    fn from_components(c: [f32; 3]) -> Self {
        Vec3::from_array(c)
    }
    #[inline(always)]
    fn from_lanes([x, y, z]: [f32xn; 3]) -> Vec3xN {
        Vec3xN::new(x, y, z)
    }
    #[inline(always)]
    fn to_lanes(v: Vec3xN) -> [f32xn; 3] {
        [v.x, v.y, v.z]
    }
}

impl Record<2> for Vec2 {
    type Lanes = [f32xn; 2];
    #[inline(always)]
    fn components(self) -> [f32; 2] {
        self.to_array()
    }
    #[inline(always)]
    fn from_components(c: [f32; 2]) -> Self {
        Vec2::from_array(c)
    }
    #[inline(always)]
    fn from_lanes(c: [f32xn; 2]) -> [f32xn; 2] {
        c
    }
    #[inline(always)]
    fn to_lanes(v: [f32xn; 2]) -> [f32xn; 2] {
        v
    }
}

/// Elements `T` as `N` f32 columns of equal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Columns<T, const N: usize> {
    c: [Vec<f32>; N],
    _t: PhantomData<T>,
}

/// 3-vectors as x, y and z columns.
pub type Vec3s = Columns<Vec3, 3>;
/// 2D points (sample points) as x and y columns.
pub type Vec2s = Columns<Vec2, 2>;
/// A view of [`Vec3s`] columns.
pub type Vec3Cols<'a> = Cols<'a, Vec3, 3>;
/// A mutable view of [`Vec3s`] columns.
pub type Vec3ColsMut<'a> = ColsMut<'a, Vec3, 3>;
/// A view of [`Vec2s`] columns.
pub type Vec2Cols<'a> = Cols<'a, Vec2, 2>;
/// A mutable view of [`Vec2s`] columns.
pub type Vec2ColsMut<'a> = ColsMut<'a, Vec2, 2>;

impl<T: Record<N>, const N: usize> Default for Columns<T, N> {
    fn default() -> Self {
        Self {
            c: std::array::from_fn(|_| Vec::new()),
            _t: PhantomData,
        }
    }
}

impl<T: Record<N>, const N: usize> Columns<T, N> {
    /// No elements.
    pub fn new() -> Self {
        Self::default()
    }

    /// `n` zero elements.
    pub fn zeros(n: usize) -> Self {
        let mut v = Self::new();
        v.resize(n);
        v
    }

    pub fn len(&self) -> usize {
        self.c[0].len()
    }

    pub fn is_empty(&self) -> bool {
        self.c[0].is_empty()
    }

    /// Removes every element, keeping the columns' capacity.
    pub fn clear(&mut self) {
        self.c.iter_mut().for_each(Vec::clear);
    }

    /// Shortens or lengthens to `n` elements, new ones zero.
    pub fn resize(&mut self, n: usize) {
        self.c.iter_mut().for_each(|c| c.resize(n, 0.0));
    }

    /// Room for `n` more elements.
    pub fn reserve(&mut self, n: usize) {
        self.c.iter_mut().for_each(|c| c.reserve(n));
    }

    #[inline]
    pub fn push(&mut self, v: T) {
        for (c, x) in self.c.iter_mut().zip(v.components()) {
            c.push(x);
        }
    }

    /// Element `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> T {
        self.cols().get(i)
    }

    /// Sets element `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: T) {
        self.cols_mut().set(i, v);
    }

    /// Sets element `i` without a bounds check (as [`Columns::get_unchecked`]).
    ///
    /// # Safety
    /// `i < self.len()`.
    #[inline(always)]
    pub unsafe fn set_unchecked(&mut self, i: usize, v: T) {
        for (c, x) in self.c.iter_mut().zip(v.components()) {
            // SAFETY: the caller's.
            unsafe { *c.get_unchecked_mut(i) = x };
        }
    }

    /// Element `i` without a bounds check, for containers of several columns that check
    /// one bound for all.
    ///
    /// # Safety
    /// `i < self.len()`.
    #[inline(always)]
    pub unsafe fn get_unchecked(&self, i: usize) -> T {
        // SAFETY: the caller's.
        T::from_components(std::array::from_fn(|k| unsafe {
            *self.c[k].get_unchecked(i)
        }))
    }

    /// A view of all the elements.
    #[inline(always)]
    pub fn cols(&self) -> Cols<'_, T, N> {
        Cols {
            c: std::array::from_fn(|k| &self.c[k][..]),
            _t: PhantomData,
        }
    }

    /// A mutable view of all the elements.
    #[inline(always)]
    pub fn cols_mut(&mut self) -> ColsMut<'_, T, N> {
        ColsMut {
            c: self.c.each_mut().map(|c| &mut c[..]),
            _t: PhantomData,
        }
    }

    /// Replaces the contents by `src`'s elements `idx[0]`, `idx[1]`, ...
    ///
    /// # Panics
    /// When an index is out of range (before any column changes, so that they stay equally
    /// long).
    #[inline]
    pub fn gather_from(&mut self, src: Cols<T, N>, idx: &[u32]) {
        let max = idx.iter().copied().max().unwrap_or(0) as usize;
        assert!(
            idx.is_empty() || max < src.len(),
            "index {max} of {}",
            src.len()
        );
        for (dst, src) in self.c.iter_mut().zip(src.c) {
            dst.clear();
            // SAFETY: every index is under the source's length (checked above).
            dst.extend(
                idx.iter()
                    .map(|&i| unsafe { *src.get_unchecked(i as usize) }),
            );
        }
    }

    /// Appends `src`'s elements, one slice copy per column.
    pub fn extend_from_cols(&mut self, src: Cols<T, N>) {
        for (dst, src) in self.c.iter_mut().zip(src.c) {
            dst.extend_from_slice(src);
        }
    }

    /// The elements as records (for tests and reports).
    pub fn to_vec(&self) -> Vec<T> {
        self.cols().iter().collect()
    }
}

impl<T: Record<N>, const N: usize> From<&[T]> for Columns<T, N> {
    fn from(v: &[T]) -> Self {
        v.iter().copied().collect()
    }
}

impl<T: Record<N>, const N: usize> FromIterator<T> for Columns<T, N> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let mut out = Self::new();
        out.extend(iter);
        out
    }
}

impl<T: Record<N>, const N: usize> Extend<T> for Columns<T, N> {
    fn extend<I: IntoIterator<Item = T>>(&mut self, iter: I) {
        let iter = iter.into_iter();
        self.reserve(iter.size_hint().0);
        for v in iter {
            self.push(v);
        }
    }
}

/// A view of elements stored as `N` equal-length column slices (the fields are private so
/// that the lengths stay equal: element access checks one bound).
#[derive(Debug)]
pub struct Cols<'a, T, const N: usize> {
    c: [&'a [f32]; N],
    _t: PhantomData<T>,
}

impl<T, const N: usize> Clone for Cols<'_, T, N> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T, const N: usize> Copy for Cols<'_, T, N> {}

impl<'a> Cols<'a, Vec3, 3> {
    /// The view of three columns.
    ///
    /// # Panics
    /// When their lengths differ.
    pub fn new(x: &'a [f32], y: &'a [f32], z: &'a [f32]) -> Self {
        Self::of([x, y, z])
    }

    /// The x column.
    #[inline(always)]
    pub fn x(&self) -> &'a [f32] {
        self.c[0]
    }

    /// The y column.
    #[inline(always)]
    pub fn y(&self) -> &'a [f32] {
        self.c[1]
    }

    /// The z column (the one the batched kernels test for directions above the surface).
    #[inline(always)]
    pub fn z(&self) -> &'a [f32] {
        self.c[2]
    }
}

impl<'a, T: Record<N>, const N: usize> Cols<'a, T, N> {
    /// The view of `N` columns.
    ///
    /// # Panics
    /// When their lengths differ.
    pub fn of(c: [&'a [f32]; N]) -> Self {
        assert!(
            c.iter().all(|x| x.len() == c[0].len()),
            "columns of equal length"
        );
        Self { c, _t: PhantomData }
    }

    #[inline(always)]
    pub fn len(&self) -> usize {
        self.c[0].len()
    }

    pub fn is_empty(&self) -> bool {
        self.c[0].is_empty()
    }

    /// Element `i`, with one bounds check.
    #[inline(always)]
    pub fn get(&self, i: usize) -> T {
        assert!(i < self.len(), "index {i} of {}", self.len());
        // SAFETY: the columns have equal lengths (checked where the view is made, and its
        // fields are private), and `i` is within them.
        T::from_components(std::array::from_fn(|k| unsafe {
            *self.c[k].get_unchecked(i)
        }))
    }

    /// The elements of `r`.
    #[inline(always)]
    pub fn slice(&self, r: Range<usize>) -> Cols<'a, T, N> {
        Cols {
            c: self.c.map(|c| &c[r.clone()]),
            _t: PhantomData,
        }
    }

    /// The elements in order.
    pub fn iter(&self) -> impl Iterator<Item = T> + 'a {
        let c = self.c;
        (0..c[0].len()).map(move |i| T::from_components(std::array::from_fn(|k| c[k][i])))
    }

    /// Elements `first..first + LANES` in lanes, one plain load per column (past the end,
    /// the last element repeated, as [`simd::padded`]).
    #[inline(always)]
    pub fn load(&self, first: usize) -> T::Lanes {
        let n = self.len() - first;
        if n >= LANES {
            let col = |c: &[f32]| f32xn::new(c[first..first + LANES].try_into().expect("LANES"));
            return T::from_lanes(self.c.map(col));
        }
        T::from_lanes(self.c.map(|c| f32xn::new(simd::padded(&c[first..]))))
    }

    /// Elements `idx[i]` in lane i for one to [`LANES`] indices in any order (past their
    /// end, the last repeated, as [`simd::lanes_of`]): one plain load per column when they
    /// are `LANES` consecutive ones (the ends tested first, then every index in one
    /// branch-free pass), else one gather per column.
    ///
    /// # Panics
    /// When an index is out of range.
    #[inline(always)]
    pub fn lanes_of(&self, idx: &[usize]) -> T::Lanes {
        let consecutive = |run: bool, (i, &k): (usize, &usize)| run & (k.wrapping_sub(i) == idx[0]);
        // A run past the end goes to the gather, which refuses it (the load would pad).
        if idx.len() == LANES
            && idx[0] < self.len()
            && idx[LANES - 1] < self.len()
            && idx[LANES - 1].wrapping_sub(idx[0]) == LANES - 1
            && idx.iter().enumerate().fold(true, consecutive)
        {
            return self.load(idx[0]);
        }
        let (n, len) = (idx.len(), self.len());
        assert!((1..=LANES).contains(&n), "a chunk of 1 to LANES indices");
        assert!(
            idx.iter().all(|&k| k < len),
            "an index beyond {len} elements"
        );
        let lane: [usize; LANES] = simd::lanes(|i| idx[i.min(n - 1)]);
        T::from_lanes(std::array::from_fn(|c| {
            let col = self.c[c];
            // SAFETY: every index is below the columns' common length (checked above).
            f32xn::new(simd::lanes(|i| unsafe { *col.get_unchecked(lane[i]) }))
        }))
    }
}

impl<'a, T: Record<N>, const N: usize> From<&'a Columns<T, N>> for Cols<'a, T, N> {
    fn from(v: &'a Columns<T, N>) -> Self {
        v.cols()
    }
}

/// A mutable view of elements stored as `N` equal-length column slices (private, as
/// [`Cols`]'s).
#[derive(Debug)]
pub struct ColsMut<'a, T, const N: usize> {
    c: [&'a mut [f32]; N],
    _t: PhantomData<T>,
}

impl<'a> ColsMut<'a, Vec3, 3> {
    /// The view of three columns.
    ///
    /// # Panics
    /// When their lengths differ.
    pub fn new(x: &'a mut [f32], y: &'a mut [f32], z: &'a mut [f32]) -> Self {
        Self::of([x, y, z])
    }
}

impl<'a, T: Record<N>, const N: usize> ColsMut<'a, T, N> {
    /// The view of `N` columns.
    ///
    /// # Panics
    /// When their lengths differ.
    pub fn of(c: [&'a mut [f32]; N]) -> Self {
        let n = c[0].len();
        assert!(c.iter().all(|x| x.len() == n), "columns of equal length");
        Self { c, _t: PhantomData }
    }

    pub fn len(&self) -> usize {
        self.c[0].len()
    }

    pub fn is_empty(&self) -> bool {
        self.c[0].is_empty()
    }

    /// Sets element `i`, with one bounds check.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: T) {
        assert!(i < self.len(), "index {i} of {}", self.len());
        for (c, x) in self.c.iter_mut().zip(v.components()) {
            // SAFETY: as in `Cols::get`.
            unsafe { *c.get_unchecked_mut(i) = x };
        }
    }

    /// The columns, to be written element by element (their lengths cannot change).
    #[inline(always)]
    pub fn columns(&mut self) -> [&mut [f32]; N] {
        self.c.each_mut().map(|c| &mut **c)
    }

    /// The elements of `r`.
    #[inline(always)]
    pub fn slice(&mut self, r: Range<usize>) -> ColsMut<'_, T, N> {
        ColsMut {
            c: self.c.each_mut().map(|c| &mut c[r.clone()]),
            _t: PhantomData,
        }
    }

    /// Writes lanes `0..min(LANES, len - first)` of `v` to elements `first..`, one plain
    /// store per column (the inverse of [`Cols::load`]).
    #[inline(always)]
    pub fn store(&mut self, first: usize, v: T::Lanes) {
        let n = (self.len() - first).min(LANES);
        for (dst, c) in self.c.iter_mut().zip(T::to_lanes(v)) {
            // A whole lane vector is one fixed-size copy (a vector store, not a call).
            match n == LANES {
                true => dst[first..first + LANES].copy_from_slice(c.as_array()),
                false => dst[first..first + n].copy_from_slice(&c.as_array()[..n]),
            }
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
        // LANES consecutive indices (loaded); LANES with a gap, and LANES that span a run's
        // first and last index but with a pair swapped (gathered).
        let mut swapped = simd::lanes(|i| 7 + i);
        swapped.swap(1, 2);
        for idx in [
            simd::lanes(|i| 7 + i),
            simd::lanes(|i| 7 + i + (i > 0) as usize),
            swapped,
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

    /// A run of consecutive indices past the end is refused, not padded.
    #[test]
    #[should_panic]
    fn a_run_past_the_end_is_refused() {
        let cols = Vec3s::from(&vectors(40)[..]);
        cols.cols().lanes_of(&simd::lanes(|i| 40 - LANES / 2 + i));
    }

    /// Sample points as two columns: the same load, gather and store.
    #[test]
    fn points_load_gather_and_store_as_two_columns() {
        let v: Vec<Vec2> = (0..2 * LANES + 3)
            .map(|i| Vec2::new(i as f32 / 64.0, 1.0 - i as f32 / 128.0))
            .collect();
        let n = v.len();
        let cols = Vec2s::from(&v[..]);
        let mut back = Vec2s::zeros(n);
        for first in (0..n).step_by(LANES) {
            let [x, y] = cols.cols().load(first);
            for i in 0..LANES {
                let want = v[(first + i).min(n - 1)];
                assert_eq!((x.as_array()[i], y.as_array()[i]), (want.x, want.y));
            }
            back.cols_mut().store(first, [x, y]);
        }
        assert_eq!(back, cols);
        let [x, _] = cols.cols().lanes_of(&[1, 4]);
        assert_eq!(x.as_array()[..3], [v[1].x, v[4].x, v[4].x]);
        let mut g = Vec2s::new();
        g.gather_from(cols.cols(), &[5, 0]);
        assert_eq!(g.to_vec(), vec![v[5], v[0]]);
    }

    #[test]
    #[should_panic(expected = "equal length")]
    fn unequal_columns_are_refused() {
        Vec3Cols::new(&[0.0; 3], &[0.0; 3], &[0.0; 2]);
    }
}
