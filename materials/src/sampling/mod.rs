//! Importance-sampling building blocks shared by the materials and the renderer, one file
//! per concern:
//!
//! - [`warp`]: warps from the unit square to directions, triangles and bilinear patches,
//!   with their densities (Shirley and Chiu 1997, Malley's method), and Veach's power
//!   heuristic for multiple importance sampling.
//! - [`cdf`]: discrete distributions sampled by CDF inversion: one cell of a list
//!   ([`cdf::Discrete1D`], area-light triangles) or of a 2D grid ([`cdf::Cdf2D`], the
//!   tabulated samplers of measured BRDFs).
//! - [`hierarchy`]: hierarchical sample warping of a 2D grid (Clarberg et al. 2005;
//!   [`hierarchy::Hierarchy2D`], environment maps).
//! - [`marginal2d`]: a parameterized piecewise-bilinear 2D distribution (Mitsuba 3's
//!   `Marginal2D`; RGL tables and the tabulated microfacet normal distribution).
//! - [`quadrature`]: Gauss-Legendre rules for the integrals of the analytic models.
//! - [`mirror_cones`]: a mixture of cos^e cones around a mirror direction (the sphere
//!   image estimators' BRDF-independent strategy).
//! - [`random`]: counter-based random numbers (a two-word hash and its uniform double).

pub mod cdf;
pub mod hierarchy;
pub mod marginal2d;
pub mod mirror_cones;
pub mod quadrature;
pub mod random;
pub mod warp;
