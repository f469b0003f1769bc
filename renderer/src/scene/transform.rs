//! Transforms in scene files, with Mitsuba 3's semantics: a list of operations applied in
//! order (each later one on the left), each one of
//! `{"translate": [x, y, z]}`, `{"scale": s or [sx, sy, sz]}`,
//! `{"rotate": {"axis": [x, y, z], "angle": degrees}}`,
//! `{"matrix": [16 numbers, row-major]}`,
//! `{"look_at": {"origin": [..], "target": [..], "up": [..]}}`.
//! A single operation object may stand in for a one-element list.

use super::json::{Obj, describe, vec3_value};
use crate::camera::look_at;
use crate::error::{Error, Result};
use glam::{Mat4, Vec3};
use serde_json::Value;

pub fn parse(file: &str, path: &str, v: &Value) -> Result<Mat4> {
    let ops: Vec<(String, &Value)> = match v {
        Value::Array(a) => a
            .iter()
            .enumerate()
            .map(|(i, o)| (format!("{path}[{i}]"), o))
            .collect(),
        Value::Object(_) => vec![(path.to_string(), v)],
        _ => {
            return Err(Error::scene(
                file,
                path,
                format!(
                    "expected a transform (an operation object or a list of them), found {}",
                    describe(v)
                ),
            ));
        }
    };
    let mut m = Mat4::IDENTITY;
    for (p, op) in ops {
        m = parse_op(file, &p, op)? * m;
    }
    if !m.is_finite() || m.determinant() == 0.0 || !m.determinant().is_finite() {
        return Err(Error::scene(
            file,
            path,
            "transform is singular or not finite; expected an invertible transform",
        ));
    }
    Ok(m)
}

fn parse_op(file: &str, path: &str, v: &Value) -> Result<Mat4> {
    let o = Obj::new(
        file,
        path,
        v,
        &["translate", "scale", "rotate", "matrix", "look_at"],
    )?;
    let keys: Vec<_> = ["translate", "scale", "rotate", "matrix", "look_at"]
        .into_iter()
        .filter(|k| o.has(k))
        .collect();
    if keys.len() != 1 {
        return Err(Error::scene(
            file,
            path,
            "expected exactly one of translate, scale, rotate, matrix, look_at in a transform operation",
        ));
    }
    let key = keys[0];
    let val = o.get(key).expect("present");
    let kp = o.key_path(key);
    Ok(match key {
        "translate" => Mat4::from_translation(vec3_value(file, &kp, val)?),
        "scale" => {
            let s = if let Some(x) = val.as_f64() {
                Vec3::splat(x as f32)
            } else {
                vec3_value(file, &kp, val)?
            };
            if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 || !s.is_finite() {
                return Err(Error::scene(
                    file,
                    kp,
                    "expected non-zero finite scale factors",
                ));
            }
            Mat4::from_scale(s)
        }
        "rotate" => {
            let r = Obj::new(file, &kp, val, &["axis", "angle"])?;
            let axis = r.vec3_req("axis")?;
            if axis.length_squared() == 0.0 {
                return Err(r.err("axis", "expected a non-zero axis"));
            }
            let angle = r
                .f32_opt("angle", "an angle in degrees", |x| x.is_finite())?
                .ok_or_else(|| {
                    Error::scene(
                        file,
                        &kp,
                        "missing key \"angle\"; expected an angle in degrees",
                    )
                })?;
            Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
        }
        "matrix" => {
            let a = val.as_array().filter(|a| a.len() == 16).ok_or_else(|| {
                Error::scene(
                    file,
                    &kp,
                    format!(
                        "expected 16 numbers (row-major 4x4), found {}",
                        describe(val)
                    ),
                )
            })?;
            let mut rows = [0.0f32; 16];
            for (i, e) in a.iter().enumerate() {
                rows[i] = e.as_f64().ok_or_else(|| {
                    Error::scene(
                        file,
                        format!("{kp}[{i}]"),
                        format!("expected a number, found {}", describe(e)),
                    )
                })? as f32;
            }
            Mat4::from_cols_array(&rows).transpose()
        }
        _ => {
            let l = Obj::new(file, &kp, val, &["origin", "target", "up"])?;
            let (origin, target, up) = (
                l.vec3_req("origin")?,
                l.vec3_req("target")?,
                l.vec3_req("up")?,
            );
            look_at(origin, target, up).ok_or_else(|| {
                Error::scene(file, &kp, "degenerate look_at: target equals origin or up is parallel to the view direction")
            })?
        }
    })
}

/// Checks that a transform is a rotation (orthonormal, determinant +1) and returns it.
pub fn rotation(file: &str, path: &str, m: &Mat4) -> Result<glam::Mat3> {
    let r = glam::Mat3::from_mat4(*m);
    let should_be_identity = r * r.transpose();
    let ok = (should_be_identity - glam::Mat3::IDENTITY)
        .to_cols_array()
        .iter()
        .all(|x| x.abs() < 1e-4)
        && (r.determinant() - 1.0).abs() < 1e-4;
    if !ok {
        return Err(Error::scene(
            file,
            path,
            "expected a rotation (no scale, shear or mirror) for an environment map",
        ));
    }
    Ok(r)
}
