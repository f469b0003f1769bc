//! The subcommands of `lobe`, one file each: its arguments (clap), its progress and what
//! it prints; the work itself is in lobe-analysis, lobe-materials and lobe-renderer.

pub mod compare;
pub mod eval;
pub mod figure;
pub mod fit;
pub mod microfacet;
pub mod models;
pub mod render;
pub mod stability;
pub mod study;
pub mod tabulate;
pub mod tradeoff;
