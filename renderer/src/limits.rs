//! Resource limits: the largest film, mesh, glTF node graph and thread count lobe accepts,
//! and fallible allocation of the buffers whose size an input file decides. Past a limit
//! lobe refuses with a one-line error naming the limit, instead of aborting on a failed
//! allocation or running for hours (docs/robustness.md lists them).

use crate::error::{Error, Result};

/// Largest film, in pixels: 2^28 = 16384 x 16384 (the largest width and height a scene
/// may give). The film holds a mean and a variance per pixel, 24 bytes, so the largest film
/// needs 6 GiB; below that it is allocated fallibly ([`try_vec`]), so a memory limit gives
/// an error, not an abort.
pub const MAX_FILM_PIXELS: u64 = 1 << 28;

/// Most render threads: more threads than cores only slow a render down (and each costs a
/// stack); 1024 leaves room for the largest machines. A render also never starts more
/// threads than it has tiles; the image never depends on the thread count.
pub const MAX_THREADS: usize = 1024;

/// Most triangles in one scene (all meshes and glTF instances): 2^26 (67 million, about
/// 5 GiB with the BVH), above the largest scanned meshes in common use.
pub const MAX_TRIANGLES: usize = 1 << 26;

/// Largest mesh vertex coordinate (after the shape's transform): ray-triangle tests form
/// products of three coordinates and the BVH sums box areas, which overflow f32 (or turn
/// the BVH build's costs to NaN) for coordinates near 1e13; 1e9 scene units leave room.
pub const MAX_COORDINATE: f32 = 1e9;

/// Most samples per pixel, in a scene file and on every command line (2^24: the sample
/// index of a pixel stays exact in f32, and a 1x1 film of it takes hours).
pub const MAX_SPP: u32 = 1 << 24;

/// Deepest glTF node hierarchy: real files nest a few levels; a deeper one is malformed.
pub const MAX_GLTF_DEPTH: usize = 64;

/// Most glTF node instances one file may expand to (a node reached through several
/// parents counts each time): bounds what a small file of shared subtrees can blow up to.
pub const MAX_GLTF_INSTANCES: usize = 1 << 16;

/// A vector of `n` copies of `value`, allocated fallibly: `what` names the buffer in the
/// error (e.g. "the 16384x16384 film").
pub fn try_vec<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        Error::Other(format!(
            "cannot allocate {} for {what}: not enough memory (or a memory limit is set)",
            human_bytes(n.saturating_mul(std::mem::size_of::<T>()))
        ))
    })?;
    v.resize(n, value);
    Ok(v)
}

/// A byte count in MiB or GiB.
pub fn human_bytes(n: usize) -> String {
    let n = n as f64;
    if n >= (1u64 << 30) as f64 {
        format!("{:.1} GiB", n / (1u64 << 30) as f64)
    } else {
        format!("{:.1} MiB", n / (1u64 << 20) as f64)
    }
}
