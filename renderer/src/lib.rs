//! lobe-renderer: light transport for comparing reflectance models.
//!
//! A scene file (JSON, see docs/scene-format.md) is loaded by [`scene::load`] into a
//! [`scene::Scene`]: analytic spheres, rectangles and triangle meshes (OBJ, PLY, glTF) under
//! one BVH (a binary tree by lobe's PLOC and obvhs's reinsertion, per Morton chunk for big
//! meshes, collapsed into lobe's own 8-wide BVH and traversed by lobe's SIMD kernels), a
//! Mitsuba-3-compatible camera,
//! lights (importance-sampled lat-long environment maps with Mitsuba 3's direction
//! convention, constant environments, point, directional and diffuse area lights) and
//! materials from the lobe-materials registry. [`render::render`] runs a path tracer with
//! next-event estimation and multiple importance sampling (Veach 1997, power heuristic)
//! or a one-bounce direct integrator over parallel tiles, with a per-pixel seeded
//! low-discrepancy sampler so that images are bit-identical whatever the thread count.
//! [`image_io`] reads HDR images and writes linear EXR and tonemapped PNG, [`film`] the
//! statistics sidecar, all atomically.

pub mod camera;
pub mod compare;
pub mod error;
pub mod error_stats;
pub mod film;
pub mod geometry;
pub mod image_io;
pub mod integrators;
pub mod lights;
pub mod limits;
pub mod memory;
pub mod outputs;
pub mod partial;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod settings;
pub mod showcase;

pub use error::Error;
pub use lobe_materials::Rgb;
