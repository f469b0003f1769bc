//! Analytic BRDF models of the study (Ngan et al. 2005, section 3.1), one file each, and
//! their shared microfacet parts.

pub mod common;
pub mod cook_torrance;
pub mod lambert;
pub mod microfacet;

use crate::registry::Registry;

/// Registers every analytic model.
pub fn register_all(r: &mut Registry) {
    lambert::register(r);
    cook_torrance::register(r);
}
