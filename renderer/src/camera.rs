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

use crate::geometry::{Ray, Rays};
use glam::{Mat4, Vec2, Vec3};
use lobe_materials::Vec2Cols;
use lobe_materials::math::{Arith, V3, sqrt};
use lobe_materials::simd;
use lobe_materials::simd::{LANES, Vec3xN, f32xn, u32xn};

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
                let (o, d) = perspective_ray(to_world, *tan_half, *aspect, *near_clip, s.x, s.y);
                Ray::new(o.into(), d.into())
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

impl Camera {
    /// The film position in [0, 1]^2 (x right, y down) whose ray passes through the world
    /// point `p` (the inverse of [`Camera::ray`]); None behind a perspective camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let (to_world, half_x, aspect) = match self {
            Camera::Perspective {
                to_world,
                tan_half,
                aspect,
                ..
            } => (to_world, *tan_half, *aspect),
            Camera::Orthographic {
                to_world,
                scale,
                aspect,
                ..
            } => (to_world, *scale, *aspect),
        };
        let c = to_world.inverse().transform_point3(p);
        let (x, y) = match self {
            Camera::Perspective { .. } if c.z <= 0.0 => return None,
            Camera::Perspective { .. } => (c.x / c.z, c.y / c.z),
            Camera::Orthographic { .. } => (c.x, c.y),
        };
        Some(Vec2::new(
            0.5 * (1.0 - x / half_x),
            0.5 * (1.0 - y * aspect / half_x),
        ))
    }

    /// [`Camera::ray`] of the film positions `(pixel + j) * inv` for each `j` in
    /// `jitter`, appended to `out`, bit for bit the same: a lane vector at a time
    /// ([`Camera::ray_lanes`]).
    pub fn rays_many(&self, pixel: Vec2, jitter: Vec2Cols, inv: Vec2, out: &mut Rays) {
        let start = out.len();
        out.resize(start + jitter.len());
        for first in (0..jitter.len()).step_by(LANES) {
            let [jx, jy] = jitter.load(first);
            let film = |p: f32, j: f32xn, inv: f32| (f32xn::splat(p) + j) * f32xn::splat(inv);
            let sx = film(pixel.x, jx, inv.x);
            let sy = film(pixel.y, jy, inv.y);
            let (o, d) = self.ray_lanes(sx, sy);
            out.store_lanes(start + first, o, d, u32xn::splat(Ray::NO_SKIP));
        }
    }

    /// The origins and unit directions of [`Camera::ray`] at the film positions (`sx`,
    /// `sy`) of `LANES` lanes, lane k bit for bit `ray((sx[k], sy[k]))`'s: perspective rays
    /// with the scalar form's operations in SIMD lanes, others lane by lane.
    #[inline]
    pub fn ray_lanes(&self, sx: f32xn, sy: f32xn) -> (Vec3xN, Vec3xN) {
        if let Camera::Perspective {
            to_world,
            tan_half,
            aspect,
            near_clip,
        } = self
        {
            return perspective_ray(to_world, *tan_half, *aspect, *near_clip, sx, sy);
        }
        let (x, y) = (sx.to_array(), sy.to_array());
        let rays = simd::lanes(|k| self.ray(Vec2::new(x[k], y[k])));
        (
            Vec3xN::from_array(&rays.map(|r| r.o)),
            Vec3xN::from_array(&rays.map(|r| r.d)),
        )
    }
}

/// The origin and unit direction of a perspective camera's ray through film position
/// (`sx`, `sy`), written once for one ray and lanes of them: the camera-space direction
/// (x, y, 1), whose length sets the near-plane distance, turned to world space as glam's
/// `Mat4::transform_vector3` does (the y term, then x, then z) and normalized.
#[inline(always)]
fn perspective_ray<T: Arith>(
    to_world: &Mat4,
    tan_half: f32,
    aspect: f32,
    near_clip: f32,
    sx: T,
    sy: T,
) -> (V3<T>, V3<T>) {
    let of = |v: f32| T::of(v as f64);
    let axis = |a: glam::Vec4| V3::new(of(a.x), of(a.y), of(a.z));
    let (one, two) = (T::of(1.0), T::of(2.0));
    let x = (one - two * sx) * of(tan_half);
    let y = (one - two * sy) * of(tan_half) / of(aspect);
    let len = sqrt(x * x + y * y + one);
    let d = axis(to_world.y_axis) * y + axis(to_world.x_axis) * x + axis(to_world.z_axis);
    let d = d.unit();
    (axis(to_world.w_axis) + d * (of(near_clip) * len), d)
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
    #[test]
    fn project_inverts_ray() {
        let m = look_at(Vec3::new(0.3, 1.0, 5.0), Vec3::new(0.1, -0.2, 0.0), Vec3::Y).unwrap();
        let cams = [
            Camera::perspective(m, 50.0, 320, 200, 0.01),
            Camera::Orthographic {
                to_world: m,
                scale: 2.0,
                aspect: 1.6,
                near_clip: 0.1,
            },
        ];
        for cam in &cams {
            for s in [
                Vec2::new(0.5, 0.5),
                Vec2::new(0.1, 0.8),
                Vec2::new(0.9, 0.25),
            ] {
                let r = cam.ray(s);
                let p = cam.project(r.o + r.d * 3.0).unwrap();
                assert!((p - s).length() < 1e-4, "{s} -> {p}");
            }
        }
        assert_eq!(cams[0].project(Vec3::new(0.3, 1.0, 9.0)), None);
    }

    /// The perspective ray in glam's operations, as the formula reads: the generic form
    /// must give it bit for bit.
    fn glam_ray(cam: &Camera, s: Vec2) -> Ray {
        let Camera::Perspective {
            to_world,
            tan_half,
            aspect,
            near_clip,
        } = cam
        else {
            return cam.ray(s);
        };
        let x = (1.0 - 2.0 * s.x) * tan_half;
        let y = (1.0 - 2.0 * s.y) * tan_half / aspect;
        let len = (x * x + y * y + 1.0).sqrt();
        let d = to_world.transform_vector3(Vec3::new(x, y, 1.0)).normalize();
        Ray::new(to_world.w_axis.truncate() + d * (near_clip * len), d)
    }

    /// The batched rays (`LANES` perspective rays per SIMD op) equal `ray` bit for bit, and
    /// both equal the formula in glam's operations.
    #[test]
    fn batched_rays_equal_single_rays() {
        let m = look_at(Vec3::new(0.3, 1.0, 5.0), Vec3::new(0.1, -0.2, 0.0), Vec3::Y).unwrap();
        let cams = [
            Camera::perspective(m, 30.0, 256, 256, 0.0),
            Camera::perspective(m, 75.0, 384, 160, 0.25),
            Camera::Orthographic {
                to_world: m,
                scale: 2.0,
                aspect: 2.0,
                near_clip: 0.1,
            },
        ];
        let bits =
            |r: &Ray| [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax].map(f32::to_bits);
        for cam in &cams {
            for n in [1usize, 8, 13, 64] {
                let jitter: Vec<Vec2> = (0..n)
                    .map(|k| {
                        let t = k as f32;
                        Vec2::new((t * 0.618_034).fract(), (t * 0.754_878).fract())
                    })
                    .collect();
                let inv = Vec2::new(1.0 / 384.0, 1.0 / 160.0);
                for pixel in [Vec2::ZERO, Vec2::new(17.0, 93.0), Vec2::new(383.0, 159.0)] {
                    let mut out = Rays::new();
                    let columns = lobe_materials::Vec2s::from(&jitter[..]);
                    cam.rays_many(pixel, columns.cols(), inv, &mut out);
                    assert_eq!(out.len(), n);
                    for (k, &j) in jitter.iter().enumerate() {
                        let one = cam.ray((pixel + j) * inv);
                        let r = out.get(k);
                        assert_eq!(bits(&r), bits(&one), "{cam:?} {pixel} {j}");
                        assert_eq!(r.skip, one.skip);
                        assert_eq!(bits(&one), bits(&glam_ray(cam, (pixel + j) * inv)));
                    }
                }
            }
        }
    }
}
