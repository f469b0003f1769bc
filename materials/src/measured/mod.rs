//! Tabulated measured BRDFs: MERL isotropic tables ([`merl`]), the study's binned 4D data
//! ([`binned`]), RGL tensor files ([`rgl`]), and the tabulated importance sampler they share
//! ([`sampler`]); the `merl`, `binned` and `rgl` materials load a table once, lazily, and
//! share it between every shape that uses it.
//!
//! Every reader refuses a value whose BRDF (after the format's scale factors, in f32)
//! exceeds [`MAX_VALUE`] in magnitude or is not finite, naming the file and the first bad
//! entry, so that evaluation, sampling densities and weights (at most 10 pi f, through the
//! cosine share of every sampler) stay finite in f32 with room for the renderer's products.

pub mod binned;
pub mod format;
pub mod material;
pub mod merl;
pub mod rgl;
pub mod sampler;
pub mod tabulate;
pub mod tensor;

/// Largest BRDF value (1/sr) a measured table may hold: eight orders of magnitude above the
/// brightest measured materials (MERL peaks are around 1e4 1/sr), the same bound as the
/// analytic models' specular colour; a larger value is corruption, not a measurement.
pub const MAX_VALUE: f64 = 1e12;
