//! Analytic BRDF models of the study (Ngan et al. 2005, section 3.1), one file each.

pub mod lambert;

use crate::registry::Registry;

/// Registers every analytic model.
pub fn register_all(r: &mut Registry) {
    lambert::register(r);
}
