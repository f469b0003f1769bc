//! Tabulated measured BRDFs: MERL isotropic tables ([`merl`]), the study's binned 4D data
//! ([`binned`]), RGL tensor files ([`rgl`]), and the tabulated importance sampler they share
//! ([`sampler`]); the `merl`, `binned` and `rgl` materials load a table once, lazily, and
//! share it between every shape that uses it.

pub mod binned;
pub mod format;
pub mod marginal2d;
pub mod material;
pub mod merl;
pub mod rgl;
pub mod sampler;
pub mod tabulate;
pub mod tensor;
