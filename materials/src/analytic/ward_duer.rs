//! Ward-Duer: Ward's model with the normalization fix of A. Duer ("On the Ward model for
//! global illumination", 2004), the denominator 4 pi alpha_x alpha_y cos(theta_i) cos(theta_o)
//! instead of Ward's 4 pi alpha_x alpha_y sqrt(cos(theta_i) cos(theta_o)) (Ngan et al. 2005,
//! section 3.1; bbm `wardduer.h`). The lobe is [`super::ward::Ward`] with `duer = true`; it
//! is brighter toward grazing angles than Ward's.

use super::common::{DIFFUSE, SPECULAR, lobe_param};
use super::ward::Ward;
use crate::ParamError;
use crate::lobe::Lobe;
use crate::registry::{Bounds, ModelSchema, Params, Registry};
use std::sync::Arc;

pub const SCHEMA: ModelSchema = ModelSchema {
    name: "ward-duer",
    summary: "Ward-Duer: exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 cos_i cos_o)",
    params: &[
        DIFFUSE,
        SPECULAR,
        lobe_param(
            "alpha",
            Bounds::above(0.0, 10.0),
            0.1,
            "standard deviation of the surface slope",
        ),
    ],
};

fn lobe(p: &Params) -> Result<Arc<dyn Lobe>, ParamError> {
    let a = p.scalar("alpha");
    Ok(Arc::new(Ward::new(a, a, true)))
}

pub fn register(r: &mut Registry) {
    r.register_lobe(SCHEMA, lobe);
}
