//! The film: per-pixel means (box filter) and variances of the mean, the sRGB tonemap of
//! the PNG output, and atomic writes of output files (the JSON statistics sidecar here, the
//! images in [`crate::image_io`]): the data goes to a temporary file in the destination
//! folder, is flushed to disk, then renamed over the destination, so a failed or
//! interrupted write never leaves a truncated file nor clobbers an existing good one.

use crate::Rgb;
use crate::error::{Error, Result};
use crate::limits::{MAX_FILM_PIXELS, try_vec};
use std::io::{BufWriter, Write};
use std::path::Path;

/// A rendered image: mean radiance per pixel and the variance of that mean.
#[derive(Clone, Debug)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Rgb>,
    /// Sample variance of each pixel's mean (per channel), for noise-aware comparisons.
    pub variance: Vec<Rgb>,
    /// Degrees of freedom of those variance estimates (samples - 1 for a render,
    /// runs - 1 for a mean of independent runs; infinity when exact or unknown).
    pub variance_dof: f64,
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            pixels: vec![Rgb::ZERO; n],
            variance: vec![Rgb::ZERO; n],
            variance_dof: f64::INFINITY,
        }
    }

    /// A black film, allocated fallibly: a film above [`MAX_FILM_PIXELS`] or one that does
    /// not fit in memory is an error naming its size, not an abort.
    pub fn try_new(width: u32, height: u32) -> Result<Self> {
        let n = width as u64 * height as u64;
        if n > MAX_FILM_PIXELS {
            return Err(Error::Other(format!(
                "a {width}x{height} film has {n} pixels; expected at most {MAX_FILM_PIXELS}"
            )));
        }
        let what = format!("the {width}x{height} film");
        Ok(Self {
            width,
            height,
            pixels: try_vec(n as usize, Rgb::ZERO, &what)?,
            variance: try_vec(n as usize, Rgb::ZERO, &what)?,
            variance_dof: f64::INFINITY,
        })
    }

    pub fn get(&self, x: u32, y: u32) -> Rgb {
        self.pixels[(y * self.width + x) as usize]
    }

    pub fn mean(&self) -> Rgb {
        let mut acc = [0.0f64; 3];
        for p in &self.pixels {
            acc[0] += p.r as f64;
            acc[1] += p.g as f64;
            acc[2] += p.b as f64;
        }
        let n = self.pixels.len().max(1) as f64;
        Rgb::new(
            (acc[0] / n) as f32,
            (acc[1] / n) as f32,
            (acc[2] / n) as f32,
        )
    }
}

/// Writes a file atomically (see [`lobe_materials::io::atomic_write`]).
pub fn atomic_write(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    lobe_materials::io::atomic_write(path, fill).map_err(Error::from)
}

/// sRGB opto-electronic transfer function.
#[inline]
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.0031308 {
        12.92 * v.max(0.0)
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Tonemaps linear RGB (scaled by 2^exposure, clamped, sRGB-encoded) to 8-bit pixels.
pub fn tonemap(pixels: &[Rgb], exposure: f32) -> Vec<u8> {
    let k = exposure.exp2();
    pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(|c| {
            let v = if c.is_finite() { c * k } else { 0.0 };
            (srgb_encode(v).clamp(0.0, 1.0) * 255.0 + 0.5) as u8
        })
        .collect()
}

/// Writes a JSON value, pretty-printed.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    atomic_write(path, |out| encode_json(out, value))
}

/// Encodes a JSON value, pretty-printed and ending in a newline, into `out`.
pub fn encode_json<W: Write>(mut out: W, value: &serde_json::Value) -> std::io::Result<()> {
    serde_json::to_writer_pretty(&mut out, value).map_err(std::io::Error::other)?;
    out.write_all(b"\n")
}
