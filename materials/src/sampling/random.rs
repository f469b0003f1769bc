//! Counter-based random numbers for estimators that must give the same samples whatever
//! the thread count: a well-mixed hash of two words (SplitMix64's finalizer, Steele et al.
//! 2014) and its map to a uniform double in [0, 1).

/// A well-mixed 64-bit hash of `a` and `b`.
pub fn hash(a: u64, b: u64) -> u64 {
    let mut z = a
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add(b.wrapping_mul(0xbf58_476d_1ce4_e5b9));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The top 53 bits of `h` as a uniform double in [0, 1).
pub fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}
