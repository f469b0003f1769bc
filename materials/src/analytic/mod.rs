//! Analytic BRDF models of the study (Ngan et al. 2005, section 3.1), one file each, and
//! their shared microfacet parts.

pub mod ashikhmin_shirley;
pub mod blinn_phong;
pub mod common;
pub mod cook_torrance;
pub mod he;
pub mod lafortune;
pub mod lambert;
pub mod microfacet;
pub mod poulin_fournier;
pub mod ward;
pub mod ward_duer;

use crate::registry::Registry;

/// Registers every analytic model.
pub fn register_all(r: &mut Registry) {
    lambert::register(r);
    cook_torrance::register(r);
    ward::register(r);
    ward_duer::register(r);
    blinn_phong::register(r);
    lafortune::register(r);
    ashikhmin_shirley::register(r);
    he::register(r);
    poulin_fournier::register(r);
}
