//! Ward-Duer: Ward's model with the normalization fix of A. Duer ("On the Ward model for
//! global illumination", 2004), the denominator 4 pi alpha_x alpha_y cos(theta_i) cos(theta_o)
//! instead of Ward's 4 pi alpha_x alpha_y sqrt(cos(theta_i) cos(theta_o)) (Ngan et al. 2005,
//! section 3.1; bbm `wardduer.h`). The lobe is [`super::ward::Ward`] with `duer = true`; it
//! is brighter toward grazing angles than Ward's.
//!
//! Near grazing the denominator is bounded: cos(theta_i) and cos(theta_o) are each floored
//! at cos(89 degrees) ([`super::ward::DUER_COS_FLOOR`]). Duer's normalization gives the lobe
//! a directional albedo that grows as 1 / cos(theta_o) without bound (measured with
//! `directional_albedo`, specular 1: 0.55, 5.2, 49 and 490 at 0, 89, 89.9 and 89.99 degrees
//! for alpha 0.68; albedo x cos(theta_o) tends to 0.086). A sample weight f cos(theta_i) /
//! pdf is an unbiased estimate of that albedo, so no sampling scheme can bound it: the
//! half-vector sampling already cancels cos(theta_i) exactly (weight (wo.h) h_z^3 /
//! cos(theta_o) per unit specular, within a factor 4 of the albedo), and a density
//! proportional to 1 / cos(theta_i) does not normalize. The 1 / cos(theta_o) growth is
//! what made single samples at a sphere's silhouette (cos(theta_o) near 1e-5) worth
//! thousands: one pixel of 519.6 where the 99.9th percentile was 9.2, and a trade-off
//! study whose Ward-Duer error was 200x the other models'. The floor is principled in that
//! the model is unchanged wherever it has meaning: the study fits data up to 80 degrees
//! only (Ngan et al. 2005, section 4: measurements near grazing are unreliable), bins are
//! one degree wide, so every bin but the last (89 to 90 degrees) sees Duer's exact values,
//! and beyond 89 degrees the exact model reflects more than it receives (albedo above 1).
//! The estimator stays unbiased for the floored lobe, which is what eval, pdf and sample
//! all compute (so multiple importance sampling stays consistent), it stays reciprocal,
//! and its sample weight is at most 1 / cos(89 degrees) = 57.3 per unit specular.

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use super::ward::Ward;
use crate::ParamError;
use crate::lobe::Lobe;
use crate::schema::{
    Bounds, FitGroup, FitRange, FitVariant, LobeModel, ModelSchema, Params, PublishedFit,
};
use std::sync::Arc;

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "ward-duer",
    summary: "Ward-Duer: exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 cos_i cos_o), each cosine floored at cos 89 degrees",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "alpha",
            Bounds::above(0.0, 10.0),
            0.1,
            "standard deviation of the surface slope; below 1e-4 it acts as 1e-4",
        )
        .fitted(FitRange::log(1e-3, 1.0, &[0.03, 0.1, 0.3])),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    let a = p.scalar("alpha");
    Ok(Arc::new(Ward::new(a, a, true)))
}

/// Ward-Duer; Ngan's fitted `roughness` is alpha.
pub const MODEL: LobeModel = LobeModel {
    schema: SCHEMA,
    lobe,
    fits: &[FitVariant::single("ward-duer", FitGroup::Isotropic)],
    published: Some(PublishedFit {
        file: "ngan_wardduer.fit",
        class: "NganWardDuer",
        keys: &[("alpha", "roughness")],
        settings: &[],
    }),
};
