//! The `lights` of a scene file (docs/scene-format.md, "Lights"; Mitsuba 3's `envmap`,
//! `constant`, `point` and `directional` emitters, same parameters and meanings). Area
//! lights are the `emitter` of a shape (see [`super::shapes`]).

use super::json::{Obj, describe};
use super::{Loader, non_negative, transform};
use crate::error::{Error, Result};
use crate::lights::Light;
use crate::lights::envmap::EnvMap;
use crate::settings::Integrator;
use glam::Mat3;
use serde_json::Value;

/// Reads the `lights` array of a scene (absent: none), appending to `lights`.
pub(super) fn parse_lights(
    ld: &Loader,
    v: Option<&Value>,
    integrator: &Integrator,
    lights: &mut Vec<Light>,
) -> Result<()> {
    if let Some(lv) = v {
        let list = lv.as_array().ok_or_else(|| {
            Error::scene(
                ld.file,
                "lights",
                format!("expected an array of lights, found {}", describe(lv)),
            )
        })?;
        for (i, l) in list.iter().enumerate() {
            lights.push(parse_light(ld, &format!("lights[{i}]"), l, integrator)?);
        }
    }
    Ok(())
}

fn parse_light(ld: &Loader, path: &str, v: &Value, integrator: &Integrator) -> Result<Light> {
    let file = ld.file;
    let kind = v.get("type").and_then(Value::as_str).unwrap_or("");
    match kind {
        "envmap" => {
            let o = Obj::new(
                file,
                path,
                v,
                &["type", "file", "scale", "to_world", "mis_compensation"],
            )?;
            let scale = o.f32_or("scale", 1.0, "a non-negative scale", non_negative)?;
            let compensate = o.bool_or("mis_compensation", false)?;
            let bsdf_sampling = match integrator {
                Integrator::Path { .. } => true,
                Integrator::Direct { bsdf_samples, .. } => *bsdf_samples > 0,
            };
            if compensate && !bsdf_sampling {
                // Without BSDF samples, directions darker than the map's mean would never
                // be sampled: the image would be too dark.
                return Err(o.err(
                    "mis_compensation",
                    "expected false with this integrator: compensation needs BSDF sampling (the path integrator, or direct with bsdf_samples >= 1)",
                ));
            }
            let rot = match o.get("to_world") {
                Some(t) => {
                    let m = transform::parse(file, &o.key_path("to_world"), t)?;
                    transform::rotation(file, &o.key_path("to_world"), &m)?
                }
                None => Mat3::IDENTITY,
            };
            let img = ld.image(&o, "file")?;
            Ok(Light::Env(Box::new(EnvMap::with_mis_compensation(
                &img, scale, rot, compensate,
            ))))
        }
        "constant" => {
            let o = Obj::new(file, path, v, &["type", "radiance"])?;
            Ok(Light::Constant {
                radiance: o.rgb_opt("radiance")?.unwrap_or(lobe_materials::Rgb::ONE),
            })
        }
        "point" => {
            let o = Obj::new(file, path, v, &["type", "position", "intensity"])?;
            Ok(Light::Point {
                position: o.vec3_req("position")?,
                intensity: o.rgb_req("intensity")?,
            })
        }
        "directional" => {
            let o = Obj::new(file, path, v, &["type", "direction", "irradiance"])?;
            let d = o.vec3_req("direction")?;
            if d.length_squared() == 0.0 {
                return Err(o.err("direction", "expected a non-zero direction of propagation"));
            }
            Ok(Light::Directional {
                direction: d.normalize(),
                irradiance: o.rgb_req("irradiance")?,
            })
        }
        _ => Err(Error::scene(
            file,
            format!("{path}.type"),
            format!(
                "expected one of \"envmap\", \"constant\", \"point\", \"directional\" (area lights are an \"emitter\" of a shape), found {}",
                v.get("type")
                    .map(describe)
                    .unwrap_or_else(|| "nothing".into())
            ),
        )),
    }
}
