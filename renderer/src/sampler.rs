//! A per-pixel seeded, padded 2D Sobol sampler, randomized by a random digit scramble
//! (XOR, the default) or by Burley's hash-based Owen scrambling.
//!
//! Every (pixel, sample index, dimension pair) gets its numbers from a pure function of
//! the scene seed, so an image is bit-identical whatever the number of threads or the
//! order of tiles. Each pair of dimensions uses the first two Sobol' dimensions (a (0,2)
//! sequence: stratified in 2D for every power-of-two prefix), with the sample index
//! shuffled per dimension by Kensler's hashed permutation ("Correlated Multi-Jittered
//! Sampling", 2013) so that dimensions do not correlate: the structure of pbrt-v4's
//! PaddedSobolSampler and of Mitsuba 3's `ldsampler`, written from the papers. The points
//! are randomized per pixel and dimension by [`Scramble`]: an XOR with a random value
//! (a random digit scramble: pbrt-v4's `PermuteDigits` in base 2, Mitsuba's `ldsampler`),
//! or a nested uniform (Owen) scramble with the hash of Burley, "Practical Hash-based
//! Owen Scrambling" (JCGT 2020; pbrt-v4's `FastOwen`). Both keep the (0,2) net property.
//! Measured per-pixel variance at equal spp (docs/performance.md, "Sampler
//! randomization"): XOR is 3-37 % lower at 16-128 spp on the env-map, Cornell and bunny
//! scenes; Owen's faster asymptotic convergence wins on some scenes from 256 spp.

use glam::Vec2;
use lobe_materials::columns::Vec2ColsMut;
use lobe_materials::simd::LANES;

/// 64-bit finalizer of MurmurHash3 / SplitMix64: a well-mixed hash of its input.
#[inline]
pub fn mix64(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58476d1ce4e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d049bb133111eb);
    x ^= x >> 31;
    x
}

#[inline]
fn hash3(a: u64, b: u64, c: u64) -> u64 {
    mix64(a ^ mix64(b ^ mix64(c.wrapping_add(0x9e3779b97f4a7c15))))
}

/// One dimension of samples `idx` of one pixel, whose hash for that dimension is `h`:
/// their shuffled indices, then each component `c` of their values (`value(c, h, j)`)
/// written to column `c` of `out` (a run per column, so that the writes vectorize).
#[inline(always)]
fn run_lanes<const N: usize>(
    (h, spp): (u64, u32),
    idx: &[u32],
    value: impl Fn(usize, u64, u32) -> f32,
    out: &mut [&mut [f32]; N],
) {
    let mut perm = [0u32; LANE_CHUNK];
    for (ic, first) in idx.chunks(LANE_CHUNK).zip((0..).step_by(LANE_CHUNK)) {
        let perm = &mut perm[..ic.len()];
        permute_lanes(ic, spp, h as u32, perm);
        for (c, col) in out.iter_mut().enumerate() {
            for (o, &j) in col[first..first + perm.len()].iter_mut().zip(perm.iter()) {
                *o = value(c, h, j);
            }
        }
    }
}

/// The hash of dimension `dim` of the pixel with key `key`.
#[inline(always)]
fn hash_of_dimension(key: u64, dim: u32) -> u64 {
    mix64(key.wrapping_add((dim as u64).wrapping_mul(0x9e3779b97f4a7c15)))
}

/// One round of Kensler's permutation of `i` within [0, w] (`w` = 2^k - 1 covering n - 1).
#[inline(always)]
fn permute_round(mut i: u32, w: u32, seed: u32) -> u32 {
    i ^= seed;
    i = i.wrapping_mul(0xe170893d);
    i ^= seed >> 16;
    i ^= (i & w) >> 4;
    i ^= seed >> 8;
    i = i.wrapping_mul(0x0929eb3f);
    i ^= seed >> 23;
    i ^= (i & w) >> 1;
    i = i.wrapping_mul(1 | seed >> 27);
    i = i.wrapping_mul(0x6935fa69);
    i ^= (i & w) >> 11;
    i = i.wrapping_mul(0x74dcb303);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0x9e501cc3);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0xc860a3df);
    i &= w;
    i ^= i >> 5;
    i
}

/// The smallest 2^k - 1 >= n - 1.
#[inline(always)]
fn permute_mask(n: u32) -> u32 {
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    w
}

/// Kensler's permutation of `i` within [0, n), keyed by `seed`: rounds are repeated
/// (cycle walking) until the value lands below n, which takes one round when n is a power
/// of two.
#[inline]
fn permute(mut i: u32, n: u32, seed: u32) -> u32 {
    if n <= 1 {
        return 0;
    }
    let w = permute_mask(n);
    loop {
        i = permute_round(i, w, seed);
        if i < n {
            break;
        }
    }
    (i.wrapping_add(seed)) % n
}

/// [`permute`] of many indices with one seed, the same values: a first round over all
/// lanes, then cycle walking [`LANES`] lanes at a time, each further round applied to
/// those lanes with a select (no branch per lane: a lane needs another round with probability
/// up to 1/2, which a branch predicts badly), and the final shift modulo n without a
/// division per lane. All three loops vectorize.
#[inline(never)]
fn permute_lanes(idx: &[u32], n: u32, seed: u32, out: &mut [u32]) {
    if n <= 1 {
        out.fill(0);
        return;
    }
    let w = permute_mask(n);
    for (o, &i) in out.iter_mut().zip(idx) {
        *o = permute_round(i, w, seed);
    }
    if n.is_power_of_two() {
        for o in out.iter_mut() {
            *o = o.wrapping_add(seed) & (n - 1);
        }
        return;
    }
    let (chunks, rest) = out.as_chunks_mut::<LANES>();
    for chunk in chunks {
        // Over a fixed LANES lanes both the test and the round vectorize.
        while chunk.iter().fold(false, |any, &o| any | (o >= n)) {
            for o in chunk.iter_mut() {
                let next = permute_round(*o, w, seed);
                *o = if *o >= n { next } else { *o };
            }
        }
    }
    for o in rest {
        while *o >= n {
            *o = permute_round(*o, w, seed);
        }
    }
    if n > 1 << 31 {
        for o in out.iter_mut() {
            *o = o.wrapping_add(seed) % n;
        }
        return;
    }
    // (o + seed) mod 2^32, then mod n, for o < n <= 2^31: with s = seed mod n and
    // c = 2^32 mod n, it is o + s reduced once, less c when the sum wrapped around 2^32.
    let (s, c) = (seed % n, ((1u64 << 32) % n as u64) as u32);
    for o in out.iter_mut() {
        let wrapped = *o > u32::MAX - seed;
        let mut r = *o + s;
        r = if r >= n { r - n } else { r };
        let back = r + n - c;
        r = if wrapped { back } else { r };
        *o = if r >= n { r - n } else { r };
    }
}

/// Laine-Karras style permutation of the bits of `x`, applied from the low bits up.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50b47c);
    x ^= x.wrapping_mul(0xb82f1e52);
    x ^= x.wrapping_mul(0xc7afe638);
    x ^= x.wrapping_mul(0x8d22f6e6);
    x
}

/// First Sobol' dimension (van der Corput in base 2), bit-reversed: the index itself.
/// Sobol' points are produced bit-reversed so that the Owen scramble (which works from
/// the most significant digit, i.e. the low bits of the reversed value) needs a single
/// bit reversal at the end.
#[inline]
fn sobol0_reversed(i: u32) -> u32 {
    i
}

/// Second Sobol' dimension, bit-reversed (direction numbers v_k = v_{k-1} ^ (v_{k-1} >> 1)
/// in the usual order, hence v'_k = v'_{k-1} ^ (v'_{k-1} << 1) reversed: bit j of v'_k is
/// C(k, j) mod 2, which by Lucas' theorem is 1 exactly when the bits of j are a subset
/// of those of k). Bit j of the result is then the parity of the bits k of `i` with
/// k a superset of j: a superset transform over GF(2), five masked shifts, with no
/// branch or loop (so that it vectorizes).
#[inline]
fn sobol1_reversed(i: u32) -> u32 {
    let mut x = i;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x
}

/// A Sobol' value from its bit-reversed form, Owen-scrambled (`OWEN`) or XORed with
/// `seed`.
#[inline(always)]
fn scrambled<const OWEN: bool>(reversed: u32, seed: u32) -> u32 {
    if OWEN {
        laine_karras(reversed, seed).reverse_bits()
    } else {
        reversed.reverse_bits() ^ seed
    }
}

#[inline]
fn to_unit(x: u32) -> f32 {
    // 24 significant bits: the result is strictly below 1.
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// How the Sobol' points are randomized (scene file: `sampler.scramble`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scramble {
    /// A random digit scramble: the bits XORed with a random value per pixel and dimension.
    #[default]
    Xor,
    /// A nested uniform (Owen) scramble by Burley's hash.
    Owen,
}

impl Scramble {
    pub const NAMES: [&'static str; 2] = ["xor", "owen"];

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "xor" => Some(Scramble::Xor),
            "owen" => Some(Scramble::Owen),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Scramble::Xor => "xor",
            Scramble::Owen => "owen",
        }
    }
}

/// Samples per step of the lane functions ([`Sampler::next_1d_lanes`]).
const LANE_CHUNK: usize = 64;

/// The sampler state of one pixel sample.
#[derive(Clone, Debug)]
pub struct Sampler {
    seed: u64,
    spp: u32,
    pixel_key: u64,
    /// The pixel `pixel_key` was hashed for (the samples of one pixel share it).
    pixel: Option<(u32, u32)>,
    index: u32,
    dim: u32,
    scramble: Scramble,
}

impl Sampler {
    /// A sampler with the default [`Scramble`].
    pub fn new(seed: u64, spp: u32) -> Self {
        Self::with_scramble(seed, spp, Scramble::default())
    }

    pub fn with_scramble(seed: u64, spp: u32, scramble: Scramble) -> Self {
        Self {
            seed,
            spp: spp.max(1),
            pixel_key: 0,
            pixel: None,
            index: 0,
            dim: 0,
            scramble,
        }
    }

    /// Starts sample `index` of pixel (x, y).
    #[inline]
    pub fn start(&mut self, x: u32, y: u32, index: u32) {
        if self.pixel != Some((x, y)) {
            self.pixel_key = self.key_of(x, y);
            self.pixel = Some((x, y));
        }
        self.index = index;
        self.dim = 0;
    }

    /// The key of pixel (x, y): with a sample index, what identifies a sample's numbers
    /// (the lane functions take one key per sample, so that the samples of many pixels
    /// draw a dimension together).
    #[inline]
    pub fn key_of(&self, x: u32, y: u32) -> u64 {
        hash3(self.seed, x as u64, y as u64)
    }

    /// The key of the pixel [`Sampler::start`] last started.
    #[inline]
    pub fn key(&self) -> u64 {
        self.pixel_key
    }

    /// The sample index shuffled for the current dimension (Kensler's permutation, which
    /// needs a single round when spp is a power of two).
    #[inline]
    fn shuffled_index(&self, h: u64) -> u32 {
        permute(self.index, self.spp, h as u32)
    }

    #[inline]
    fn dim_hash(&mut self) -> u64 {
        let h = hash_of_dimension(self.pixel_key, self.dim);
        self.dim += 1;
        h
    }

    /// This sampler's state for sample `index` of the pixel with key `key` (see
    /// [`Sampler::key_of`]), at the same dimension.
    pub fn with_sample(&self, key: u64, index: u32) -> Sampler {
        Sampler {
            pixel_key: key,
            pixel: None,
            index,
            ..self.clone()
        }
    }

    /// [`Sampler::next_1d`] for many samples at once, all at this sampler's dimension:
    /// `out[k]` is what the sampler of sample `idx[k]` of the pixel with key `keys[k]`
    /// would return (bit for bit). Advances the dimension by one; the sampler's own
    /// pixel and sample index are left alone. The per-dimension hash is computed once per
    /// run of samples of one pixel and the rest vectorizes.
    pub fn next_1d_lanes(&mut self, keys: &[u64], idx: &[u32], out: &mut [f32]) {
        match self.scramble {
            Scramble::Xor => self.lanes(keys, idx, component::<false>, [out]),
            Scramble::Owen => self.lanes(keys, idx, component::<true>, [out]),
        }
    }

    /// [`Sampler::next_2d`] for many samples at once (see [`Sampler::next_1d_lanes`]),
    /// into columns.
    pub fn next_2d_lanes(&mut self, keys: &[u64], idx: &[u32], mut out: Vec2ColsMut) {
        let columns = out.columns();
        match self.scramble {
            Scramble::Xor => self.lanes(keys, idx, component::<false>, columns),
            Scramble::Owen => self.lanes(keys, idx, component::<true>, columns),
        }
    }

    /// One dimension for the samples (`keys`, `idx`), its `N` components into the columns
    /// `out`: per run of equal keys (the samples of one pixel), the dimension's hash once,
    /// then [`run_lanes`].
    #[inline(always)]
    fn lanes<const N: usize>(
        &mut self,
        keys: &[u64],
        idx: &[u32],
        value: impl Fn(usize, u64, u32) -> f32 + Copy,
        mut out: [&mut [f32]; N],
    ) {
        assert!(keys.len() == idx.len() && out.iter().all(|c| c.len() == idx.len()));
        let dim = self.dim;
        self.dim += 1;
        let mut start = 0;
        while start < keys.len() {
            let key = keys[start];
            let len = keys[start..].iter().position(|&k| k != key);
            let end = len.map_or(keys.len(), |l| start + l);
            let h = hash_of_dimension(key, dim);
            let mut run = out.each_mut().map(|c| &mut c[start..end]);
            run_lanes((h, self.spp), &idx[start..end], value, &mut run);
            start = end;
        }
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let h = self.dim_hash();
        let j = self.shuffled_index(h);
        match self.scramble {
            Scramble::Xor => value_2d::<false>(h, j),
            Scramble::Owen => value_2d::<true>(h, j),
        }
    }

    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let h = self.dim_hash();
        let j = self.shuffled_index(h);
        match self.scramble {
            Scramble::Xor => value_1d::<false>(h, j),
            Scramble::Owen => value_1d::<true>(h, j),
        }
    }
}

/// Component `c` (0 or 1) of the value of shuffled sample index `j` in the dimension
/// (pair) with hash `h`: a 1D value is component 0.
#[inline(always)]
fn component<const OWEN: bool>(c: usize, h: u64, j: u32) -> f32 {
    match c {
        0 => to_unit(scrambled::<OWEN>(sobol0_reversed(j), (h >> 32) as u32)),
        _ => {
            let seed = (h as u32).rotate_left(16) ^ 0x5bd1e995;
            to_unit(scrambled::<OWEN>(sobol1_reversed(j), seed))
        }
    }
}

/// The 1D value of shuffled sample index `j` in the dimension with hash `h`.
#[inline(always)]
fn value_1d<const OWEN: bool>(h: u64, j: u32) -> f32 {
    component::<OWEN>(0, h, j)
}

/// The 2D value of shuffled sample index `j` in the dimension pair with hash `h`.
#[inline(always)]
fn value_2d<const OWEN: bool>(h: u64, j: u32) -> Vec2 {
    Vec2::new(component::<OWEN>(0, h, j), component::<OWEN>(1, h, j))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_shuffles_are_bijections() {
        for spp in [1u32, 2, 16, 64, 100] {
            let mut s = Sampler::new(3, spp);
            s.start(1, 2, 0);
            let mut seen = vec![false; spp as usize];
            for i in 0..spp {
                s.index = i;
                let p = s.shuffled_index(0x1234_5678_9abc_def0) as usize;
                assert!(!seen[p], "spp {spp}: {p} twice");
                seen[p] = true;
            }
        }
    }

    /// The lane functions give bit for bit what per-sample samplers give, for power-of-two
    /// and other sample counts, index lists in any order and longer than a chunk, and the
    /// samples of several pixels in runs of any length (a run may end inside a chunk).
    #[test]
    fn lanes_equal_single_samples() {
        for (spp, scramble) in [1u32, 3, 16, 64, 100, 256]
            .into_iter()
            .flat_map(|n| [(n, Scramble::Xor), (n, Scramble::Owen)])
        {
            let mut batch = Sampler::with_scramble(9, spp, scramble);
            let pixels = [(4, 7), (5, 7), (4, 7), (0, 0)];
            let keys_of = |b: &Sampler| pixels.map(|(x, y)| b.key_of(x, y));
            let runs: [Vec<u32>; 4] = [
                (0..spp).rev().chain((0..spp).step_by(3)).collect(),
                (0..spp).step_by(2).collect(),
                (0..spp.min(5)).collect(),
                (0..spp).collect(),
            ];
            let mut keys = Vec::new();
            let mut idx = Vec::new();
            for (key, run) in keys_of(&batch).into_iter().zip(&runs) {
                keys.extend(std::iter::repeat_n(key, run.len()));
                idx.extend_from_slice(run);
            }
            batch.start(4, 7, 0);
            let _ = batch.next_2d();
            let mut singles: Vec<Sampler> = keys
                .iter()
                .zip(&idx)
                .map(|(&k, &i)| batch.with_sample(k, i))
                .collect();
            for step in 0..6 {
                if step % 2 == 0 {
                    let mut out = vec![0.0f32; idx.len()];
                    batch.next_1d_lanes(&keys, &idx, &mut out);
                    for (s, o) in singles.iter_mut().zip(&out) {
                        assert_eq!(s.next_1d().to_bits(), o.to_bits(), "spp {spp} step {step}");
                    }
                } else {
                    let mut out = lobe_materials::Vec2s::zeros(idx.len());
                    batch.next_2d_lanes(&keys, &idx, out.cols_mut());
                    for (s, o) in singles.iter_mut().zip(out.to_vec()) {
                        assert_eq!(s.next_2d(), o, "spp {spp} step {step}");
                    }
                }
            }
        }
    }

    /// A sampler for another pixel's sample by its key draws what a sampler started at
    /// that pixel draws.
    #[test]
    fn with_sample_equals_start() {
        let mut a = Sampler::new(11, 64);
        a.start(3, 9, 0);
        let _ = a.next_2d();
        let mut b = a.with_sample(a.key_of(20, 1), 17);
        let mut c = Sampler::new(11, 64);
        c.start(20, 1, 17);
        let _ = c.next_2d();
        for _ in 0..4 {
            assert_eq!(b.next_2d(), c.next_2d());
            assert_eq!(b.next_1d().to_bits(), c.next_1d().to_bits());
        }
    }

    /// The lane form of the permutation equals the one-at-a-time form for sample counts
    /// of every kind (powers of two, counts just above one, the largest ones) and seeds
    /// whose sum with an index wraps around 2^32.
    #[test]
    fn permute_lanes_equals_permute() {
        let ns = [
            2u32,
            3,
            5,
            17,
            100,
            192,
            1000,
            65_537,
            (1 << 31) - 1,
            1 << 31,
            3_000_000_001,
        ];
        let seeds = [0u32, 1, 0xdead_beef, 0x7fff_ffff, 0xffff_fff0, u32::MAX];
        for n in ns {
            for seed in seeds {
                // The first indices, the last ones and a spread between them.
                let idx: Vec<u32> = (0..70u32.min(n))
                    .chain((n - 70u32.min(n))..n)
                    .chain((0..50u64).map(|k| (k * n as u64 / 50) as u32))
                    .collect();
                let mut out = vec![0u32; idx.len()];
                permute_lanes(&idx, n, seed, &mut out);
                for (&i, &o) in idx.iter().zip(&out) {
                    assert_eq!(o, permute(i, n, seed), "n {n} seed {seed:#x} index {i}");
                }
            }
        }
    }

    #[test]
    fn permutation_is_a_bijection() {
        for n in [1u32, 2, 3, 7, 16, 100] {
            let mut seen = vec![false; n as usize];
            for i in 0..n {
                let p = permute(i, n, 0xdead_beef) as usize;
                assert!(!seen[p]);
                seen[p] = true;
            }
        }
    }

    /// The closed form equals the product with the direction numbers, bit by bit.
    #[test]
    fn reversed_sobol_equals_the_direction_number_product() {
        let product = |mut i: u32| {
            let (mut v, mut r) = (1u32, 0u32);
            while i != 0 {
                if i & 1 != 0 {
                    r ^= v;
                }
                i >>= 1;
                v ^= v << 1;
            }
            r
        };
        for i in (0..1u32 << 20).chain([u32::MAX, 0x8000_0000, 0xdead_beef, 0x1234_5678]) {
            assert_eq!(sobol1_reversed(i), product(i), "i = {i:#x}");
        }
    }

    #[test]
    fn reversed_sobol_matches_the_direction_numbers() {
        // Unscrambled second dimension for i = 1, 2, 3: 1/2, 3/4, 1/4.
        let f = |i| sobol1_reversed(i).reverse_bits() as f64 / 2f64.powi(32);
        assert_eq!((f(1), f(2), f(3)), (0.5, 0.75, 0.25));
    }

    #[test]
    fn two_d_points_are_stratified() {
        // 16 samples of one pixel in one dimension pair: one per 4x4 cell (a (0,2)-net is
        // stratified on every elementary interval of area 1/16, including the 4x4 grid).
        for scramble in [Scramble::Xor, Scramble::Owen] {
            let mut s = Sampler::with_scramble(7, 16, scramble);
            let mut cells = [0u32; 16];
            for i in 0..16 {
                s.start(3, 5, i);
                let _ = s.next_2d();
                let u = s.next_2d();
                assert!((0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y));
                cells[(u.x * 4.0) as usize + 4 * (u.y * 4.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "{scramble:?}: {cells:?}");
        }
    }

    #[test]
    fn mean_is_unbiased() {
        for scramble in [Scramble::Xor, Scramble::Owen] {
            let mut s = Sampler::with_scramble(1, 64, scramble);
            let mut acc = 0.0f64;
            let mut n = 0;
            for px in 0..50 {
                for i in 0..64 {
                    s.start(px, 0, i);
                    acc += s.next_1d() as f64;
                    n += 1;
                }
            }
            assert!((acc / n as f64 - 0.5).abs() < 0.01, "{scramble:?}");
        }
    }

    /// Every dimension pair of a pixel's samples is a (0, m, 2)-net in base 2: for
    /// spp = 2^m, each of the m + 1 grids of 2^a x 2^(m - a) elementary intervals holds
    /// exactly one point per cell (the 4x4 test above checks one grid only).
    #[test]
    fn every_dimension_pair_is_a_net() {
        for (spp, scramble) in [16u32, 64, 256]
            .into_iter()
            .flat_map(|n| [(n, Scramble::Xor), (n, Scramble::Owen)])
        {
            let m = spp.trailing_zeros();
            for pair in 0..4 {
                for px in 0..8u32 {
                    let mut s = Sampler::with_scramble(3, spp, scramble);
                    let pts: Vec<Vec2> = (0..spp)
                        .map(|i| {
                            s.start(px, 1, i);
                            (0..pair).for_each(|_| {
                                s.next_2d();
                            });
                            s.next_2d()
                        })
                        .collect();
                    for a in 0..=m {
                        let (nx, ny) = (1u32 << a, 1u32 << (m - a));
                        let mut cells = vec![0u32; (nx * ny) as usize];
                        for p in &pts {
                            let (cx, cy) = ((p.x * nx as f32) as u32, (p.y * ny as f32) as u32);
                            cells[(cy * nx + cx) as usize] += 1;
                        }
                        assert!(
                            cells.iter().all(|&c| c == 1),
                            "{scramble:?} spp {spp}, pair {pair}, pixel {px}: not stratified on {nx}x{ny}"
                        );
                    }
                }
            }
        }
    }
}
