//! SIMD building blocks of lobe: the lane vectors and helpers over `wide`'s vectors, shared
//! by the materials' batched kernels (`Bsdf::eval_pdf_many`, `Bsdf::sample_many`) and the
//! renderer's wavefront stages (camera rays, sphere tests, shading frames, env-map lookups
//! and sampling).
//!
//! The lane count is chosen here, once, for the CPU the build targets: [`LANES`] is 16
//! (`wide::f32x16`, one AVX-512 register) when the build enables AVX-512F, else 8
//! (`wide::f32x8`, one AVX register). Every kernel is written over [`f32xn`], [`i32xn`],
//! [`u32xn`] and `[T; LANES]`, so no kernel names a width of its own. (This is how Dr.Jit
//! serves Mitsuba: its kernels are compiled for the host, 16 lanes wide on AVX-512 CPUs.)
//!
//! Every batched kernel of lobe must give, in each lane, bit for bit what its one-at-a-time
//! scalar form gives (the wavefront integrator is tested against the scalar one), so the
//! operations here are the scalar ones in the same order per lane: [`Vec3xN::dot`] is
//! glam's `(x x' + y y') + z z'`, [`Vec3xN::normalize`] multiplies by `1 / length` as glam
//! does, [`fmadd`] is fused in every build as `f32::mul_add` is, and [`RgbxN::luminance`]
//! is [`Rgb::luminance`]. Results therefore do not depend on the lane count either. The
//! transcendental approximations (`sin_cos`, `atan2`, `acos`, `asin`, `exp`, `ln`, `powf`) are
//! written once for both in [`crate::fastmath`].
//!
//! Contents: [`lanes`], [`padded`] and [`lanes_of`] (arrays of [`LANES`], written out so
//! they inline), [`chunks_where`] (the queries a batched kernel works on, a lane vector at
//! a time), transposes of records into lane vectors and back ([`transpose4xn`], [`rows4`],
//! [`vec3s`], [`arrays3`]; the batched queues hold their vectors and sample points as columns,
//! [`crate::columns`], which lane vectors load and store directly), per-lane select and
//! clamp ([`sel`], [`clamp`]), masks ([`MaskN`], [`mask_from_bools`], [`mask_bits`],
//! [`ALL_LANES`]), [`gather`], [`float_of`], [`fmadd`], the small types [`Vec3xN`] and
//! [`RgbxN`]. The arithmetic of lanes of either width is [`crate::math::Arith`]'s.

use crate::Rgb;
use crate::math::V3;
use glam::Vec3;
use std::ops::Mul;

#[cfg(target_feature = "avx512f")]
mod width {
    pub use wide::{f32x16 as f32xn, i32x16 as i32xn, u32x16 as u32xn};
    /// Lanes per vector: one AVX-512 register of f32.
    pub const LANES: usize = 16;
}
#[cfg(not(target_feature = "avx512f"))]
mod width {
    pub use wide::{f32x8 as f32xn, i32x8 as i32xn, u32x8 as u32xn};
    /// Lanes per vector: one AVX register of f32.
    pub const LANES: usize = 8;
}
pub use width::{LANES, f32xn, i32xn, u32xn};

/// [`mask_bits`] of a mask with every lane set.
pub const ALL_LANES: u32 = ((1u64 << LANES) - 1) as u32;

/// A per-lane condition: all bits set (true) or clear (false) in each lane, as `wide`'s
/// comparisons (`simd_lt`, `simd_eq`, ...) return it; `&`, `|` and `!` combine masks.
pub type MaskN = f32xn;

/// The mask with every lane set (true).
#[inline(always)]
pub fn all_set() -> MaskN {
    !f32xn::splat(0.0)
}

/// `[f(0), .., f(LANES - 1)]`, written out so that it always inlines (`array::map` and
/// `array::from_fn` do not reliably, which costs a call per lane).
#[inline(always)]
pub fn lanes<T>(f: impl Fn(usize) -> T) -> [T; LANES] {
    #[cfg(not(target_feature = "avx512f"))]
    {
        [f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7)]
    }
    #[cfg(target_feature = "avx512f")]
    {
        [
            f(0),
            f(1),
            f(2),
            f(3),
            f(4),
            f(5),
            f(6),
            f(7),
            f(8),
            f(9),
            f(10),
            f(11),
            f(12),
            f(13),
            f(14),
            f(15),
        ]
    }
}

/// The first [`LANES`] elements of a chunk of one to [`LANES`], the last repeated into the
/// lanes past its end (so that those lanes compute something valid, to be ignored).
#[inline(always)]
pub fn padded<T: Copy>(chunk: &[T]) -> [T; LANES] {
    let n = chunk.len();
    assert!((1..=LANES).contains(&n), "a chunk of 1 to LANES elements");
    lanes(|i| chunk[i.min(n - 1)])
}

/// [`LANES`] 4-float records as four lane vectors, `[r[0][k], .., r[LANES - 1][k]]` for
/// k = 0..4: with AVX, one 16-byte load per record and a 4x8 transpose by shuffles per
/// eight records instead of four scalar loads and inserts per record.
#[inline(always)]
pub fn transpose4xn(r: &[[f32; 4]; LANES]) -> [f32xn; 4] {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    {
        let (lo, hi) = r.split_at(8);
        let lo = transpose4x8(lo.try_into().expect("8 records"));
        let hi = transpose4x8(hi.try_into().expect("8 records"));
        // Lanes 0..8 from the first eight records, 8..16 from the others.
        let join = |k: usize| wide::bytemuck::cast::<_, f32xn>([lo[k], hi[k]]);
        [join(0), join(1), join(2), join(3)]
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
    {
        transpose4x8(r)
    }
}

/// [`transpose4xn`] of the rows `row(0)`, .., `row(LANES - 1)`: fields that lie four
/// floats in a row in memory are read as one 16-byte load per lane.
#[inline(always)]
pub fn rows4(row: impl Fn(usize) -> [f32; 4]) -> [f32xn; 4] {
    transpose4xn(&lanes(row))
}

/// Eight 4-float records as four eight-lane vectors, `[r[0][k], .., r[7][k]]` for
/// k = 0..4: the 4x8 transpose [`transpose4xn`] is made of.
#[inline(always)]
fn transpose4x8(r: &[[f32; 4]; 8]) -> [wide::f32x8; 4] {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    {
        // SAFETY: only needs AVX, which this build enables (the cfg above).
        unsafe { transpose4x8_avx(r) }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
    {
        let c = |k: usize| wide::f32x8::new(std::array::from_fn(|i| r[i][k]));
        [c(0), c(1), c(2), c(3)]
    }
}

/// [`transpose4x8`] with AVX: eight 16-byte loads and eight shuffles.
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
#[target_feature(enable = "avx")]
#[inline]
fn transpose4x8_avx(r: &[[f32; 4]; 8]) -> [wide::f32x8; 4] {
    use core::arch::x86_64::{
        __m128, _mm256_castpd_ps, _mm256_castps_pd, _mm256_set_m128, _mm256_unpackhi_pd,
        _mm256_unpackhi_ps, _mm256_unpacklo_pd, _mm256_unpacklo_ps,
    };
    use wide::f32x8;
    let q = |k: usize| __m128::from(wide::f32x4::new(r[k]));
    // Records k and k + 4 side by side: [r0 | r4], [r1 | r5], [r2 | r6], [r3 | r7].
    let a = _mm256_set_m128(q(4), q(0));
    let b = _mm256_set_m128(q(5), q(1));
    let c = _mm256_set_m128(q(6), q(2));
    let d = _mm256_set_m128(q(7), q(3));
    // Interleave pairs of records, then pairs of pairs (within each 128-bit half).
    let ab_lo = _mm256_castps_pd(_mm256_unpacklo_ps(a, b));
    let ab_hi = _mm256_castps_pd(_mm256_unpackhi_ps(a, b));
    let cd_lo = _mm256_castps_pd(_mm256_unpacklo_ps(c, d));
    let cd_hi = _mm256_castps_pd(_mm256_unpackhi_ps(c, d));
    [
        f32x8::from(_mm256_castpd_ps(_mm256_unpacklo_pd(ab_lo, cd_lo))),
        f32x8::from(_mm256_castpd_ps(_mm256_unpackhi_pd(ab_lo, cd_lo))),
        f32x8::from(_mm256_castpd_ps(_mm256_unpacklo_pd(ab_hi, cd_hi))),
        f32x8::from(_mm256_castpd_ps(_mm256_unpackhi_pd(ab_hi, cd_hi))),
    ]
}

/// The integers of `i` as floats, per lane (`f32xn::from_i32x8` or `from_i32x16`).
#[inline(always)]
pub fn float_of(i: i32xn) -> f32xn {
    #[cfg(target_feature = "avx512f")]
    {
        f32xn::from_i32x16(i)
    }
    #[cfg(not(target_feature = "avx512f"))]
    {
        f32xn::from_i32x8(i)
    }
}

/// `f(idx[i])` in lane i for a chunk of one to [`LANES`] indices, the last repeated into the
/// lanes past its end (as [`padded`]).
#[inline(always)]
pub fn lanes_of<T>(idx: &[usize], f: impl Fn(usize) -> T) -> [T; LANES] {
    let n = idx.len();
    assert!((1..=LANES).contains(&n), "a chunk of 1 to LANES indices");
    lanes(|i| f(idx[i.min(n - 1)]))
}

/// Calls `f` with the indices `k` of `0..n` where `keep(k)`, in increasing order, `LANES` at
/// a time (the last chunk shorter), without allocating: batched kernels give their SIMD
/// lanes only to the queries that need them (not to light samples below the surface, say).
#[inline]
pub fn chunks_where(n: usize, keep: impl Fn(usize) -> bool, mut f: impl FnMut(&[usize])) {
    let mut buf = [0usize; LANES];
    let mut len = 0;
    for k in 0..n {
        // Written without a branch on `keep`, which is often unpredictable.
        buf[len] = k;
        len += keep(k) as usize;
        if len == LANES {
            f(&buf);
            len = 0;
        }
    }
    if len > 0 {
        f(&buf[..len]);
    }
}

/// `LANES` vectors as their x, y and z components in three SIMD registers.
#[inline(always)]
pub fn vec3s(v: &[Vec3; LANES]) -> [f32xn; 3] {
    [
        f32xn::new(lanes(|i| v[i].x)),
        f32xn::new(lanes(|i| v[i].y)),
        f32xn::new(lanes(|i| v[i].z)),
    ]
}

/// The components of [`vec3s`] back as arrays (`[x, y, z]`, `LANES` lanes each).
#[inline(always)]
pub fn arrays3(v: [f32xn; 3]) -> [[f32; LANES]; 3] {
    [v[0].to_array(), v[1].to_array(), v[2].to_array()]
}

/// `if m { a } else { b }` per lane (`m` from a comparison), for vectors of any width.
#[inline(always)]
pub fn sel<T: wide::Select<T>>(m: T, a: T, b: T) -> T {
    m.select(a, b)
}

/// `f32::clamp` per lane (NaN stays NaN).
#[inline(always)]
pub fn clamp(x: f32xn, lo: f32, hi: f32) -> f32xn {
    let (lo, hi) = (f32xn::splat(lo), f32xn::splat(hi));
    let x = sel(x.simd_lt(lo), lo, x);
    sel(x.simd_gt(hi), hi, x)
}

/// A mask with lane i set where `b[i]`.
#[inline(always)]
pub fn mask_from_bools(b: [bool; LANES]) -> MaskN {
    f32xn::from_bits(u32xn::new(lanes(|i| 0u32.wrapping_sub(b[i] as u32))))
}

/// Bit i set where lane i of the mask is set.
#[inline(always)]
pub fn mask_bits(m: MaskN) -> u32 {
    m.to_bitmask()
}

/// `table[idx[i]]` in lane i. Indices must be non-negative and in bounds (checked: an
/// index out of bounds panics as slice indexing does). With AVX-512 one gather
/// instruction after one vector bounds test (the `LANES` scalar loads otherwise spill and
/// extract lane by lane); with AVX2 `LANES` scalar loads, since AVX2's gather instruction
/// measured slower than them (docs/performance.md).
#[inline(always)]
pub fn gather(table: &[f32], idx: i32xn) -> f32xn {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    {
        use std::arch::x86_64::{__m512, __m512i, _mm512_cmplt_epu32_mask, _mm512_i32gather_ps};
        let len = table.len().min(u32::MAX as usize) as u32;
        // SAFETY: `i32xn` is `wide::i32x16`, 64 bytes of 16 i32 as `__m512i` (and the
        // result 16 f32 as `__m512`); the gather reads table[idx[i]] only once every
        // index, taken as unsigned, is below the table's length.
        unsafe {
            let v = std::mem::transmute::<i32xn, __m512i>(idx);
            let len_v = std::mem::transmute::<u32xn, __m512i>(u32xn::splat(len));
            if _mm512_cmplt_epu32_mask(v, len_v) == u16::MAX {
                let g = _mm512_i32gather_ps::<4>(v, table.as_ptr());
                return std::mem::transmute::<__m512, f32xn>(g);
            }
        }
    }
    let idx = idx.to_array();
    f32xn::new(lanes(|i| table[idx[i] as usize]))
}

/// `a * b + c` per lane with a single rounding, as `f32::mul_add` gives it, in every build
/// (`wide`'s `mul_add` rounds twice when the target has no FMA unit).
#[inline(always)]
pub fn fmadd(a: f32xn, b: f32xn, c: f32xn) -> f32xn {
    #[cfg(all(target_arch = "x86_64", target_feature = "fma"))]
    {
        a.mul_add(b, c)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "fma")))]
    {
        let (a, b, c) = (a.to_array(), b.to_array(), c.to_array());
        f32xn::new(lanes(|i| a[i].mul_add(b[i], c[i])))
    }
}

/// `LANES` 3-vectors, one component per register: [`V3`] over lanes, so that a formula
/// over [`V3`] serves one vector and lanes of them.
pub type Vec3xN = V3<f32xn>;

impl Vec3xN {
    /// The same vector in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        Self::new(f32xn::splat(v.x), f32xn::splat(v.y), f32xn::splat(v.z))
    }

    /// `LANES` vectors, vector i in lane i.
    #[inline(always)]
    pub fn from_array(v: &[Vec3; LANES]) -> Self {
        Self::from(vec3s(v))
    }

    /// Lane i as a glam vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(
            self.x.as_array()[i],
            self.y.as_array()[i],
            self.z.as_array()[i],
        )
    }

    /// The `LANES` vectors.
    #[inline(always)]
    pub fn to_array(self) -> [Vec3; LANES] {
        let [x, y, z] = arrays3(self.into());
        lanes(|i| Vec3::new(x[i], y[i], z[i]))
    }

    /// `self * a + b` per component, fused ([`fmadd`]).
    #[inline(always)]
    pub fn mul_add(self, a: f32xn, b: Self) -> Self {
        Self::new(
            fmadd(self.x, a, b.x),
            fmadd(self.y, a, b.y),
            fmadd(self.z, a, b.z),
        )
    }

    /// `if m { a } else { b }` per lane.
    #[inline(always)]
    pub fn select(m: MaskN, a: Self, b: Self) -> Self {
        Self::new(sel(m, a.x, b.x), sel(m, a.y, b.y), sel(m, a.z, b.z))
    }
}

impl From<[f32xn; 3]> for Vec3xN {
    #[inline(always)]
    fn from(v: [f32xn; 3]) -> Self {
        Self::new(v[0], v[1], v[2])
    }
}

impl From<Vec3xN> for [f32xn; 3] {
    #[inline(always)]
    fn from(v: Vec3xN) -> Self {
        [v.x, v.y, v.z]
    }
}

impl Mul for Vec3xN {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

/// `LANES` RGB triples, one channel per register, with [`Rgb`]'s operations per lane.
#[derive(Clone, Copy, Debug)]
pub struct RgbxN {
    pub r: f32xn,
    pub g: f32xn,
    pub b: f32xn,
}

impl RgbxN {
    #[inline(always)]
    pub fn new(r: f32xn, g: f32xn, b: f32xn) -> Self {
        Self { r, g, b }
    }

    /// `LANES` colours, colour i in lane i.
    #[inline(always)]
    pub fn from_array(c: &[Rgb; LANES]) -> Self {
        Self::new(
            f32xn::new(lanes(|i| c[i].r)),
            f32xn::new(lanes(|i| c[i].g)),
            f32xn::new(lanes(|i| c[i].b)),
        )
    }

    /// Lane i.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Rgb {
        Rgb::new(
            self.r.as_array()[i],
            self.g.as_array()[i],
            self.b.as_array()[i],
        )
    }

    /// The `LANES` colours.
    #[inline(always)]
    pub fn to_array(self) -> [Rgb; LANES] {
        let (r, g, b) = (self.r.to_array(), self.g.to_array(), self.b.to_array());
        lanes(|i| Rgb::new(r[i], g[i], b[i]))
    }

    /// [`Rgb::luminance`] per lane.
    #[inline(always)]
    pub fn luminance(self) -> f32xn {
        f32xn::splat(0.212671) * self.r
            + f32xn::splat(0.715160) * self.g
            + f32xn::splat(0.072169) * self.b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Awkward values: zeros of both signs, tiny and huge magnitudes, NaN and infinities.
    fn values() -> Vec<f32> {
        let mut v: Vec<f32> = (0..200)
            .map(|k| ((k as f32 * 0.618_034).fract() - 0.5) * 4.0)
            .collect();
        v.extend([
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-30,
            -1e-30,
            3e38,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
        ]);
        v
    }

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn vecs() -> Vec<Vec3> {
        let v = values();
        (0..v.len())
            .map(|k| Vec3::new(v[k], v[(k * 7 + 3) % v.len()], v[(k * 13 + 5) % v.len()]))
            .collect()
    }

    #[test]
    fn transpose4xn_puts_component_k_of_record_i_in_lane_i() {
        let r: [[f32; 4]; LANES] = lanes(|i| [0, 1, 2, 3].map(|k| (10 * i + k) as f32));
        let t = transpose4xn(&r);
        for (k, v) in t.iter().enumerate() {
            assert_eq!(v.to_array(), lanes(|i| r[i][k]), "component {k}");
        }
        let t = rows4(|i| r[LANES - 1 - i]);
        assert_eq!(t[2].to_array(), lanes(|i| r[LANES - 1 - i][2]));
        let t8 = transpose4x8(&std::array::from_fn(|i| r[(i + 1) % LANES]));
        let expected: [f32; 8] = std::array::from_fn(|i| r[(i + 1) % LANES][3]);
        assert_eq!(t8[3].to_array(), expected);
    }

    #[test]
    fn padded_repeats_the_last_element() {
        assert_eq!(padded(&[1, 2, 3]), lanes(|i| [1, 2, 3][i.min(2)]));
        let full: Vec<usize> = (1..=LANES).collect();
        assert_eq!(padded(&full), lanes(|i| i + 1));
        assert_eq!(lanes_of(&[4, 9], |k| 10 * k), lanes(|i| [40, 90][i.min(1)]));
    }

    #[test]
    fn chunks_where_visits_the_kept_indices_in_order_a_lane_vector_at_a_time() {
        for n in [0usize, 1, 7, 8, 9, 16, 17, 100] {
            let keep = |k: usize| k % 3 != 1;
            let mut seen = Vec::new();
            let mut sizes = Vec::new();
            chunks_where(n, keep, |idx| {
                seen.extend_from_slice(idx);
                sizes.push(idx.len());
            });
            assert_eq!(seen, (0..n).filter(|&k| keep(k)).collect::<Vec<_>>());
            assert!(sizes.iter().rev().skip(1).all(|&s| s == LANES));
            assert!(sizes.last().is_none_or(|&s| (1..=LANES).contains(&s)));
        }
    }

    #[test]
    fn vec3xn_operations_equal_glams_per_lane() {
        let v = vecs();
        for (a, b) in v
            .chunks(LANES)
            .zip(v.chunks(LANES).skip(1).chain(v.chunks(LANES)))
        {
            let (a, b) = (padded(a), padded(b));
            let (va, vb) = (Vec3xN::from_array(&a), Vec3xN::from_array(&b));
            let s = f32xn::new(lanes(|i| b[i].y));
            let dot = va.dot(vb).to_array();
            let cross = va.cross(vb).to_array();
            let norm = va.unit().to_array();
            let nz = va.unit_or(Vec3xN::splat(Vec3::ZERO)).to_array();
            let ma = va.mul_add(s, vb).to_array();
            let sum = (va + vb).to_array();
            let diff = (va - vb).to_array();
            let prod = (va * vb).to_array();
            let scaled = (va * s).to_array();
            let neg = (-va).to_array();
            let sv = |x: Vec3, y: Vec3| same(x.x, y.x) && same(x.y, y.y) && same(x.z, y.z);
            for i in 0..LANES {
                let (x, y) = (a[i], b[i]);
                assert!(same(dot[i], x.dot(y)), "dot {x} {y}");
                assert!(sv(cross[i], x.cross(y)), "cross {x} {y}");
                assert!(sv(norm[i], x * (1.0 / x.length())), "normalize {x}");
                assert!(sv(nz[i], x.normalize_or_zero()), "normalize_or_zero {x}");
                let fused = Vec3::new(
                    x.x.mul_add(y.y, y.x),
                    x.y.mul_add(y.y, y.y),
                    x.z.mul_add(y.y, y.z),
                );
                assert!(sv(ma[i], fused), "mul_add {x} {y}");
                assert!(sv(sum[i], x + y) && sv(diff[i], x - y) && sv(prod[i], x * y));
                assert!(sv(scaled[i], x * y.y) && sv(neg[i], -x));
                assert!(sv(va.lane(i), x));
            }
        }
    }

    #[test]
    fn rgbxn_lanes_hold_the_rgbs_and_their_luminance() {
        let v = vecs();
        let rgb: Vec<Rgb> = v.iter().map(|v| Rgb::new(v.x, v.y, v.z)).collect();
        for a in rgb.chunks(LANES) {
            let a = padded(a);
            let ca = RgbxN::from_array(&a);
            let sr = |x: Rgb, y: Rgb| same(x.r, y.r) && same(x.g, y.g) && same(x.b, y.b);
            let (lum, back) = (ca.luminance().to_array(), ca.to_array());
            for i in 0..LANES {
                assert!(same(lum[i], a[i].luminance()), "luminance {:?}", a[i]);
                assert!(sr(ca.lane(i), a[i]) && sr(back[i], a[i]), "{:?}", a[i]);
            }
        }
    }

    #[test]
    fn fmadd_is_fused_as_f32_mul_add() {
        let v = values();
        for c in v.chunks(LANES) {
            let a = padded(c);
            let b = lanes(|i| a[(i + 3) % LANES] * 1.000_001);
            let d = lanes(|i| -a[(i + 5) % LANES]);
            let r = fmadd(f32xn::new(a), f32xn::new(b), f32xn::new(d)).to_array();
            for i in 0..LANES {
                assert!(
                    same(r[i], a[i].mul_add(b[i], d[i])),
                    "{} {} {}",
                    a[i],
                    b[i],
                    d[i]
                );
            }
        }
        // A case where one rounding and two differ: (1 + e)(1 - e) - 1 = -e^2 exactly.
        let e = f32::EPSILON;
        let r = fmadd(
            f32xn::splat(1.0 + e),
            f32xn::splat(1.0 - e),
            f32xn::splat(-1.0),
        );
        assert_eq!(r.to_array()[0], -e * e);
    }

    #[test]
    fn gather_masks_and_clamp() {
        let table: Vec<f32> = (0..100).map(|k| k as f32 * 0.5).collect();
        let idx = lanes(|i| [3, 99, 0, 7, 7, 50, 1, 2][i % 8]);
        let g = gather(&table, i32xn::new(idx)).to_array();
        assert_eq!(g, idx.map(|k| k as f32 * 0.5));
        let b = lanes(|i| [true, false, false, true, true, false, true, false][i % 8]);
        let m = mask_from_bools(b);
        assert_eq!(mask_bits(m), ALL_LANES / 0xff * 0b0101_1001);
        assert_eq!(mask_bits(all_set()), ALL_LANES);
        let x = lanes(|i| [-2.0, 0.5, 3.0, f32::NAN, 1.0, 0.0, -0.0, 9.0][i % 8]);
        let x = f32xn::new(x);
        let c = clamp(x, 0.0, 1.0).to_array();
        for (c, x) in c.into_iter().zip(x.to_array()) {
            assert!(same(c, x.clamp(0.0, 1.0)), "clamp {x}");
        }
        let s = sel(m, f32xn::splat(1.0), f32xn::splat(2.0)).to_array();
        assert_eq!(s, b.map(|t| if t { 1.0 } else { 2.0 }));
    }

    /// An index past the end or negative in any one lane panics, as slice indexing does
    /// (the AVX-512 gather is taken only when every lane is in bounds).
    #[test]
    fn gather_checks_bounds_in_every_lane() {
        let table: Vec<f32> = (0..40).map(|k| k as f32).collect();
        for bad in [40, 41, -1, i32::MIN] {
            for lane in [0, LANES / 2, LANES - 1] {
                let idx = lanes(|i| if i == lane { bad } else { i as i32 });
                let r = std::panic::catch_unwind(|| gather(&table, i32xn::new(idx)));
                assert!(r.is_err(), "index {bad} in lane {lane} was read");
            }
        }
        let last = gather(&table, i32xn::splat(39)).to_array();
        assert_eq!(last, [39.0; LANES]);
    }
}
