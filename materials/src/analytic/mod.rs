//! Analytic BRDF models of the study (Ngan et al. 2005, section 3.1), one file each, and
//! their shared microfacet parts.
//!
//! A model file holds everything about its model: the lobe (a [`crate::lobe::Lobe`]), its
//! schema with the fitter's search range and starts on each fitted parameter, and a
//! [`LobeModel`] naming the variants it is fitted as and, if Ngan et al. published fits of
//! it, their file and keywords. Adding a model is: a new file here, a `pub mod` line and an
//! entry in [`MODELS`] below (the registry, the fitter's specs and the `ngan-fit` choices
//! follow), its reference in docs/models.md regenerated with `lobe models`, and its cases
//! in tests/tests/bsdfs.rs. A model defined outside this crate is registered with
//! [`crate::registry::Registry::register_model`] and fitted with
//! [`crate::fit::model_specs`].

pub mod ashikhmin_shirley;
pub mod blinn_phong;
pub mod common;
pub mod cook_torrance;
pub mod he;
pub mod he_series;
pub mod he_shadowing;
pub mod lafortune;
pub mod lambert;
pub mod microfacet;
pub mod poulin_fournier;
pub mod ward;
pub mod ward_duer;

use crate::schema::LobeModel;

/// The analytic lobe models, each declared in its own file. The fitter lists their fit
/// variants in this order within each [`crate::schema::FitGroup`], and the `ngan-fit`
/// material offers those with published fits in this order. (Lambert, the diffuse term of
/// every model, is registered on its own.)
pub const MODELS: &[&LobeModel] = &[
    &ward::MODEL,
    &ward_duer::MODEL,
    &blinn_phong::MODEL,
    &cook_torrance::MODEL,
    &lafortune::MODEL,
    &ashikhmin_shirley::MODEL,
    &he::MODEL,
    &ward::MODEL_ANISO,
    &ashikhmin_shirley::MODEL_ANISO,
    &poulin_fournier::MODEL,
];
