//! The images scene files can name as `"file": "builtin:<name>"` (see
//! [`super::LoadOptions::with_builtins`]): `studio`, an HDR "studio" environment built in
//! code (a soft key light, a fill, a rim strip over a graded backdrop) that lights the
//! built-in showcase and benchmark scenes with no data on disk, and `sunset`, the outdoor
//! map of scenes/envmaps embedded in the program.

use crate::Rgb;
use crate::image_io::RgbImage;
use std::f32::consts::{PI, TAU};

/// The sunset map of scenes/envmaps (512 x 256, CC0, Greg Zaal / HDRI Haven), embedded so
/// that scenes, fits and the built-in study have an outdoor lighting without any file.
pub const SUNSET_EXR: &[u8] = include_bytes!("../../../scenes/envmaps/sunset-512.exr");

/// The pixels of [`SUNSET_EXR`].
pub fn sunset_environment() -> RgbImage {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| crate::image_io::exr_canvas(res),
            crate::image_io::exr_set_pixel,
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(SUNSET_EXR))
        // The file is part of the program and decoded by a test (`sunset_is_embedded`).
        .expect("the embedded sunset map decodes");
    image.layer_data.channel_data.pixels
}

/// A smooth box window: 1 inside [lo, hi], falling to 0 over `soft` on each side.
fn window(x: f32, lo: f32, hi: f32, soft: f32) -> f32 {
    let s = |t: f32| {
        let t = t.clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    s((x - lo + soft) / soft) * s((hi + soft - x) / soft)
}

/// Angular difference in degrees, wrapped to [-180, 180).
fn dphi(a: f32, b: f32) -> f32 {
    (a - b + 540.0).rem_euclid(360.0) - 180.0
}

/// The studio environment as a lat-long image in Mitsuba's convention (row j at
/// theta = j pi / (H - 1) from +y, column i at phi = (i + 1/2) 2 pi / W; phi = 180 degrees
/// is +z, behind a camera that looks down -z).
pub fn studio_environment(width: usize, height: usize) -> RgbImage {
    let mut pixels = Vec::with_capacity(width * height);
    for j in 0..height {
        let theta = (j as f32 * PI / (height - 1) as f32).to_degrees();
        for i in 0..width {
            let phi = ((i as f32 + 0.5) * TAU / width as f32).to_degrees();
            // Backdrop: cool grey above the horizon, warm dark floor below.
            let h = (90.0 - theta) / 90.0;
            let mut c = if h >= 0.0 {
                Rgb::new(0.30, 0.33, 0.38) * (0.6 + 0.4 * h)
            } else {
                Rgb::new(0.10, 0.09, 0.08) * (1.0 + h * 0.5)
            };
            // Key: a large softbox up and to the right, in front of the subject.
            let key = window(theta, 30.0, 60.0, 6.0) * window(dphi(phi, 140.0), -20.0, 20.0, 6.0);
            c += Rgb::new(7.0, 6.8, 6.3) * key;
            // Fill: dimmer, to the left.
            let fill =
                window(theta, 45.0, 80.0, 10.0) * window(dphi(phi, 235.0), -25.0, 25.0, 10.0);
            c += Rgb::new(2.2, 2.4, 2.8) * fill;
            // Rim: a narrow vertical strip behind the subject.
            let rim = window(theta, 15.0, 80.0, 4.0) * window(dphi(phi, 0.0), -3.0, 3.0, 1.5);
            c += Rgb::new(9.0, 9.0, 9.0) * rim;
            pixels.push(c);
        }
    }
    RgbImage {
        width,
        height,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn sunset_is_embedded() {
        let img = super::sunset_environment();
        assert_eq!((img.width, img.height), (512, 256));
        let lum = |p: &crate::Rgb| p.r + p.g + p.b;
        assert!(
            img.pixels
                .iter()
                .all(|p| lum(p).is_finite() && lum(p) >= 0.0)
        );
        // A sun: the brightest pixel is far above the mean.
        let mean = img.pixels.iter().map(lum).sum::<f32>() / img.pixels.len() as f32;
        let max = img.pixels.iter().map(lum).fold(0.0, f32::max);
        assert!(max > 50.0 * mean, "{max} {mean}");
    }
}
