//! Cameras with Mitsuba 3's conventions, so one description frames the same image in
//! both renderers.
//!
//! `look_at(origin, target, up)` builds the camera-to-world frame exactly as Mitsuba's
//! `Transform4f::look_at`: forward = normalize(target - origin),
//! left = normalize(cross(up, forward)), up' = cross(forward, left); camera space is
//! (left, up', forward). Film coordinates (0, 0) are the top-left corner of the image.
//! The perspective camera's `fov` is measured along `fov_axis` (x, y, diagonal, smaller,
//! larger) and converted to the horizontal field of view as Mitsuba does; rays start on
//! the near-clip plane. The orthographic camera sees camera-space x in [-scale, scale]
//! and y in [-scale / aspect, scale / aspect].

use crate::geometry::Ray;
use glam::{Mat4, Vec2, Vec3};

/// The axis along which a perspective field of view is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    pub const NAMES: &'static [&'static str] = &["x", "y", "diagonal", "smaller", "larger"];
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            _ => return None,
        })
    }
}

/// Mitsuba's look-at camera-to-world matrix (columns left, up, forward, origin).
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Option<Mat4> {
    let dir = (target - origin).normalize_or_zero();
    let left = up.cross(dir).normalize_or_zero();
    if dir == Vec3::ZERO || left == Vec3::ZERO {
        return None;
    }
    let new_up = dir.cross(left);
    Some(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// Horizontal field of view (degrees) of a fov measured along `axis`.
pub fn fov_x_degrees(fov: f32, axis: FovAxis, width: u32, height: u32) -> f32 {
    let (w, h) = (width as f32, height as f32);
    let aspect = w / h;
    let t = (fov.to_radians() * 0.5).tan();
    let axis = match axis {
        FovAxis::Smaller => {
            if w > h {
                FovAxis::Y
            } else {
                FovAxis::X
            }
        }
        FovAxis::Larger => {
            if w > h {
                FovAxis::X
            } else {
                FovAxis::Y
            }
        }
        a => a,
    };
    let tx = match axis {
        FovAxis::X => t,
        FovAxis::Y => t * aspect,
        FovAxis::Diagonal => t * w / (w * w + h * h).sqrt(),
        _ => unreachable!(),
    };
    (2.0 * tx.atan()).to_degrees()
}

#[derive(Clone, Debug)]
pub enum Camera {
    Perspective {
        to_world: Mat4,
        /// tan(fov_x / 2).
        tan_half: f32,
        aspect: f32,
        near_clip: f32,
    },
    Orthographic {
        to_world: Mat4,
        scale: f32,
        aspect: f32,
        near_clip: f32,
    },
}

impl Camera {
    pub fn perspective(
        to_world: Mat4,
        fov_x_deg: f32,
        width: u32,
        height: u32,
        near_clip: f32,
    ) -> Self {
        Camera::Perspective {
            to_world,
            tan_half: (fov_x_deg.to_radians() * 0.5).tan(),
            aspect: width as f32 / height as f32,
            near_clip,
        }
    }

    /// Ray through film position `s` in [0, 1]^2 (x right, y down).
    #[inline]
    pub fn ray(&self, s: Vec2) -> Ray {
        match self {
            Camera::Perspective {
                to_world,
                tan_half,
                aspect,
                near_clip,
            } => {
                let x = (1.0 - 2.0 * s.x) * tan_half;
                let y = (1.0 - 2.0 * s.y) * tan_half / aspect;
                // Camera-space direction (x, y, 1): its length sets the near-plane distance.
                let len = (x * x + y * y + 1.0).sqrt();
                let d = to_world.transform_vector3(Vec3::new(x, y, 1.0)).normalize();
                let o = to_world.w_axis.truncate();
                Ray::new(o + d * (near_clip * len), d)
            }
            Camera::Orthographic {
                to_world,
                scale,
                aspect,
                near_clip,
            } => {
                let x = (1.0 - 2.0 * s.x) * scale;
                let y = (1.0 - 2.0 * s.y) * scale / aspect;
                let o = to_world.transform_point3(Vec3::new(x, y, *near_clip));
                let d = to_world.transform_vector3(Vec3::Z).normalize();
                Ray::new(o, d)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_is_not_mirrored() {
        // Looking down -z with +y up, the left of the image is -x.
        let m = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y).unwrap();
        let cam = Camera::perspective(m, 90.0, 100, 100, 0.0);
        let left = cam.ray(Vec2::new(0.0, 0.5));
        assert!(left.d.x < -0.5, "{:?}", left.d);
        let top = cam.ray(Vec2::new(0.5, 0.0));
        assert!(top.d.y > 0.5);
        let centre = cam.ray(Vec2::new(0.5, 0.5));
        assert!((centre.d - Vec3::NEG_Z).length() < 1e-6);
    }

    #[test]
    fn fov_axis_conversions() {
        assert!((fov_x_degrees(40.0, FovAxis::X, 200, 100) - 40.0).abs() < 1e-4);
        let fx = fov_x_degrees(40.0, FovAxis::Y, 200, 100);
        assert!(((fx.to_radians() / 2.0).tan() - 2.0 * (20f32.to_radians()).tan()).abs() < 1e-5);
        assert_eq!(fov_x_degrees(40.0, FovAxis::Smaller, 200, 100), fx);
    }
}
