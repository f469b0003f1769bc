//! The `camera` of a scene file (docs/scene-format.md, "Camera"; Mitsuba 3's
//! `perspective` and `orthographic` sensors, same parameters and meanings), placed by
//! `to_world` or by origin/target/up; a scene without one uses the first camera of its
//! glTF shapes.

use super::json::{Obj, describe};
use super::mesh_io::GltfCamera;
use super::{non_negative, positive, transform};
use crate::camera::{Camera, FovAxis, fov_x_degrees, look_at};
use crate::error::{Error, Result};
use crate::limits::MAX_COORDINATE;
use glam::{Mat4, Vec3};
use serde_json::Value;

/// The scene's camera: its `camera` object (`v`), or else the first glTF camera.
pub(super) fn scene_camera(
    file: &str,
    v: Option<&Value>,
    gltf_camera: Option<GltfCamera>,
    width: u32,
    height: u32,
) -> Result<Camera> {
    match v {
        Some(cv) => parse_camera(file, cv, width, height),
        None => match gltf_camera {
            Some(c) => Ok(c.build(width, height)),
            None => Err(Error::scene(
                file,
                "camera",
                "missing; expected a camera object (or a glTF shape whose file has a camera)",
            )),
        },
    }
}

fn camera_frame(o: &Obj, file: &str) -> Result<Mat4> {
    if let Some(t) = o.get("to_world") {
        if o.has("origin") || o.has("target") || o.has("up") {
            return Err(o.err(
                "to_world",
                "give either to_world or origin/target/up, not both",
            ));
        }
        return transform::parse(file, &o.key_path("to_world"), t);
    }
    let origin = o.vec3_opt("origin")?.unwrap_or(Vec3::ZERO);
    let target = o.vec3_opt("target")?.unwrap_or(Vec3::Z);
    let up = o.vec3_opt("up")?.unwrap_or(Vec3::Y);
    for (key, p) in [("origin", origin), ("target", target)] {
        if !(p.abs().max_element() <= MAX_COORDINATE) {
            return Err(o.err(
                key,
                format!(
                    "is {p}; expected finite coordinates within {MAX_COORDINATE:e} (as mesh vertices)"
                ),
            ));
        }
    }
    look_at(origin, target, up).ok_or_else(|| {
        Error::scene(
            file,
            &o.path,
            "degenerate look-at: target equals origin or up is parallel to the view direction",
        )
    })
}

fn parse_camera(file: &str, v: &Value, width: u32, height: u32) -> Result<Camera> {
    let kind = v.get("type").and_then(Value::as_str).unwrap_or("");
    match kind {
        "perspective" => {
            let o = Obj::new(
                file,
                "camera",
                v,
                &[
                    "type",
                    "fov",
                    "fov_axis",
                    "origin",
                    "target",
                    "up",
                    "to_world",
                    "near_clip",
                ],
            )?;
            let fov = o.f32_or(
                "fov",
                39.3077,
                "a field of view in degrees in (0, 180)",
                |x| x > 0.0 && x < 180.0,
            )?;
            let axis = o
                .name_opt("fov_axis", FovAxis::NAMES, FovAxis::parse)?
                .unwrap_or(FovAxis::X);
            let near = o.f32_or("near_clip", 0.01, "a non-negative distance", non_negative)?;
            let m = camera_frame(&o, file)?;
            Ok(Camera::perspective(
                m,
                fov_x_degrees(fov, axis, width, height),
                width,
                height,
                near,
            ))
        }
        "orthographic" => {
            let o = Obj::new(
                file,
                "camera",
                v,
                &[
                    "type",
                    "scale",
                    "origin",
                    "target",
                    "up",
                    "to_world",
                    "near_clip",
                ],
            )?;
            let scale = o.f32_or("scale", 1.0, "a positive half-width", positive)?;
            let near = o.f32_or("near_clip", 0.01, "a non-negative distance", non_negative)?;
            Ok(Camera::Orthographic {
                to_world: camera_frame(&o, file)?,
                scale,
                aspect: width as f32 / height as f32,
                near_clip: near,
            })
        }
        _ => Err(Error::scene(
            file,
            "camera.type",
            format!(
                "expected \"perspective\" or \"orthographic\", found {}",
                v.get("type")
                    .map(describe)
                    .unwrap_or_else(|| "nothing".into())
            ),
        )),
    }
}
