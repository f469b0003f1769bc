//! The microfacet-based BRDF generator of Ashikhmin, Premože and Shirley (SIGGRAPH 2000)
//! with a tabulated distribution of normals, and its estimation from measurements (Ngan et
//! al. 2005, section 5, Eq. 3 and 4).
//!
//! Forward model (APS2000, with p normalized so that <h.n> = int p(h) (h.n) dw = 1):
//!
//!   rho(k1, k2) = p(h) <h.n> F(k.h) / (4 g(k1) g(k2)),   g(k) = int (h.k)+ p(h) dw_h,
//!
//! g being APS2000's shadowing term (the projected area of the microfacets facing k). For
//! a Smith microsurface g(k) = (k.n)(1 + Lambda(k)), so with a Beckmann p the generator is
//! Cook-Torrance with Beckmann D and separable Smith shadowing G1(k1) G1(k2) exactly
//! (tested). F is Schlick's with `f0` (1: no Fresnel).
//!
//! Table: p is stored at the nodes of an N x N grid over the projected hemisphere,
//! (h_x, h_y) in [-1, 1]^2 (zero outside the unit disk), and interpolated bilinearly. The
//! projected parameterization resolves a ridge along a great circle through the normal
//! (brushed metal) as a straight line, and its node spacing 2 / (N - 1) is 0.45 degrees at
//! the pole for the default N = 257 (the narrow ridges of section 5.1 are 3 to 5 degrees
//! wide); it coarsens towards the horizon, where distributions are small and the data stop
//! at 80 degrees anyway. Because dw = dA / h_z, the bilinear table is itself the density of
//! h over the disk with respect to p(h) h_z dw: normalizing it to unit integral over the
//! disk normalizes <h.n>. g(k) is tabulated over (theta_k, phi_k) on 2 x 5 degree nodes by
//! quadrature over the same grid. The sampler draws the normals visible from wo, p(h)
//! (wo.h)+ / g(wo), with the table's fine structure exact and the smooth factor
//! (wo.h)+ / h_z piecewise constant over blocks of cells (`visible`).
//!
//! Estimation (Ngan et al. Eq. 4): p(h) = rho(k1, k2) 4 g(k1) g(k2) / (<h.n> F(k.h)),
//! averaged over all measured pairs whose half vector falls near each node (bilinear
//! splatting), starting from g = 1 and alternating the estimates of p and g; empty nodes
//! inside the disk take the mean of their filled neighbours. A constant diffuse term is
//! estimated with the colours by the fitter's non-negative least squares and subtracted in
//! a second round; `f0` is given or found by a golden-section search on the Eq. (1) error.
//!
//! Files: `table` holds the tabulated p with its shadowing table g, `visible` its
//! sampler, `lobe`
//! the generator as a lobe and its registry entry (`sampled-microfacet`), `estimate` the
//! estimation of p, g and the colours from measurements, `synthetic` the closed-form and
//! synthetic distributions and the sparse 4D data sets the tests estimate them from.

mod estimate;
mod lobe;
mod synthetic;
mod table;
mod visible;

pub use estimate::{Estimate, estimate};
pub use lobe::{SCHEMA, SampledMicrofacet, register};
pub use synthetic::{Shape, sparse_4d};
pub use table::{DEFAULT_RES, Table, correlation};
