//! lobe-analysis: the analyses of Ngan, Durand and Matusik 2005 ("Experimental Analysis of
//! BRDF Models") as library functions with typed inputs and outputs, for the `lobe` CLI
//! (tools/cli) and for tests. No command-line parsing, printing or progress bars here:
//! long work reports progress through a callback.
//!
//! One module per concern:
//! - [`models`]: which fitted models a command uses (the study's defaults, a list by name);
//! - [`convergence`]: speed/accuracy curves of path-traced renders, equal-time errors;
//! - [`cost`]: eval and sample time per call of a material;
//! - [`selection`]: the cheapest fitted model within a tolerance of the best error;
//! - [`sphere_errors`]: image errors of every representation on a sphere under a map,
//!   with 95 % intervals and the noise floor (common random numbers, batches);
//! - [`fitting`]: fitting one material into a report, and the data files of a folder;
//! - [`fit_images`]: the environment maps and reference renders of the `image` metric;
//! - [`reports`]: reading fit reports, merging them into tables, building their models;
//! - [`plot`]: what every figure shares (font, palette, the RGB canvas, labels);
//! - [`figures`]: the study's figures (error charts, polar plots, sphere grids, lobes);
//! - [`metric_study`]: which fitting metric's fits render closest to the data under
//!   held-out environment maps;
//! - [`microfacet`]: section 5.1, the distribution recovered from a synthetic structure;
//! - [`tradeoff`]: the speed/accuracy/memory trade-off between representations;
//! - [`stability`]: the numerical sweep of every model at the extremes;
//! - [`study`]: the whole experiment on a set of materials, resumable, and its report as a
//!   static site.

pub mod convergence;
pub mod cost;
pub mod figures;
pub mod fit_images;
pub mod fitting;
pub mod metric_study;
pub mod microfacet;
pub mod models;
pub mod plot;
pub mod reports;
pub mod sampling_variance;
pub mod selection;
pub mod sphere_errors;
pub mod stability;
pub mod study;
pub mod tradeoff;

/// A labelled material (a figure's or a trade-off's representation).
pub type NamedMaterial = (String, std::sync::Arc<dyn lobe_materials::Bsdf>);
