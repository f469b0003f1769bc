//! Pieces shared by the analytic models' schemas: the diffuse and specular colour
//! parameters of the study's `M = diffuse_rgb * Lambert + specular_rgb * lobe(p)`, and
//! helpers for lobe-shape parameters and discrete settings.

use crate::schema::{Bounds, DefaultValue, ParamKind, ParamRole, ParamSpec};

/// `diffuse`: the Lambertian colour (albedo), linear RGB.
pub const DIFFUSE: ParamSpec = ParamSpec {
    name: "diffuse",
    kind: ParamKind::Color,
    role: ParamRole::Diffuse,
    bounds: Bounds::closed(0.0, 1.0),
    default: DefaultValue::Color([0.0, 0.0, 0.0]),
    doc: "diffuse albedo (linear RGB); the Lambertian term is diffuse / pi",
    fit: None,
};

/// `specular`: the colour multiplying the lobe, linear RGB (not bounded above: several
/// models' lobes are not normalized to unit albedo, e.g. He's).
pub const SPECULAR: ParamSpec = ParamSpec {
    name: "specular",
    kind: ParamKind::Color,
    role: ParamRole::Specular,
    bounds: Bounds::closed(0.0, 1.0e12),
    default: DefaultValue::Color([0.04, 0.04, 0.04]),
    doc: "specular colour (linear RGB) multiplying the lobe",
    fit: None,
};

/// A lobe-shape scalar parameter.
pub const fn lobe_param(
    name: &'static str,
    bounds: Bounds,
    default: f64,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec {
        name,
        kind: ParamKind::Scalar,
        role: ParamRole::Lobe,
        bounds,
        default: DefaultValue::Scalar(default),
        doc,
        fit: None,
    }
}

/// A discrete setting.
pub const fn setting(
    name: &'static str,
    options: &'static [&'static str],
    default: &'static str,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec {
        name,
        kind: ParamKind::Choice(options),
        role: ParamRole::Setting,
        bounds: Bounds::closed(0.0, 0.0),
        default: DefaultValue::Choice(default),
        doc,
        fit: None,
    }
}
