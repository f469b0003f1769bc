//! lobe-materials: the BRDF plugin suite of lobe.
//!
//! This crate holds everything that is BRDF math and nothing about rays, cameras or
//! images: the plugin interface ([`Bsdf`]), the linear-RGB spectrum type ([`Rgb`]), the
//! shading frame and direction parameterizations ([`frame`]), the sample warps,
//! distributions and quadrature shared with the renderer ([`sampling`]), and the registry
//! that turns a JSON description into a material while validating its parameters against
//! a per-model schema ([`registry`]).
//!
//! The models are those of Ngan, Durand and Matusik, "Experimental Analysis of BRDF
//! Models" (EGSR 2005), section 3.1: every material is
//! `M = diffuse_rgb * Lambert + sum_k specular_rgb_k * lobe_k(p)`.
//!
//! ```
//! use lobe_materials::{registry::Registry, Bsdf};
//! use glam::Vec3;
//! let reg = Registry::builtin();
//! let m = reg.create(&serde_json::json!({"type": "lambert", "reflectance": 0.5}), "material").unwrap();
//! let f = m.eval(Vec3::Z, Vec3::Z);
//! assert!((f.r - 0.5 / std::f32::consts::PI).abs() < 1e-6);
//! ```

pub mod analytic;
pub mod bsdf;
pub mod builtin;
pub mod columns;
pub mod composite;
pub mod error;
pub mod fastmath;
pub mod fit;
pub mod frame;
pub mod grouping;
pub mod guard;
pub mod io;
pub mod json;
pub mod key;
pub mod lobe;
pub mod math;
pub mod measured;
pub mod microfacet_gen;
pub mod ngan_fit;
pub mod registry;
pub mod sampling;
pub mod schema;
pub mod simd;

pub use bsdf::{Bsdf, BsdfSample, BsdfSamples, BsdfSamplesMut, Flags, Rgb};
pub use columns::{Vec2Cols, Vec2s, Vec3Cols, Vec3s};
pub use error::{FileError, ParamError};
/// The vector types of the public interface (re-exported for the exported macros).
pub use glam;
