//! Image files: reading OpenEXR (exr crate, first layer, RGB) and Radiance HDR (image
//! crate) into linear RGB (environment maps, the images `lobe compare` compares), and
//! writing linear 32-bit float OpenEXR and 8-bit sRGB PNG (the render outputs). Every
//! write is atomic ([`crate::film::atomic_write`]: temporary file in the destination
//! folder, flushed, renamed over the destination). Reads of third-party formats run under
//! [`lobe_materials::guard::third_party`], so a decoder panic is an error naming the file.

use crate::Rgb;
use crate::error::{Error, Result};
use crate::film::{Image, atomic_write};
use std::path::Path;

/// An RGB float image, row-major, top row first.
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Rgb>,
}

/// Reads an HDR image: OpenEXR (`.exr`, first layer, RGB) or Radiance (`.hdr`, `.pic`).
pub fn read_rgb_image(path: &Path) -> Result<RgbImage> {
    let shown = path.display();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    if path.is_dir() {
        return Err(Error::file(
            shown,
            "is a directory; expected an .exr or .hdr image",
        ));
    }
    let img = match ext.as_str() {
        "exr" => {
            use exr::prelude::*;
            lobe_materials::io::check_exr_size(path).map_err(|m| crate::Error::file(&shown, m))?;
            let image = lobe_materials::guard::third_party("OpenEXR", || {
                read_first_rgba_layer_from_file(
                    path,
                    |res, _| RgbImage {
                        width: res.width(),
                        height: res.height(),
                        pixels: vec![Rgb::ZERO; res.width() * res.height()],
                    },
                    |img: &mut RgbImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                        img.pixels[pos.y() * img.width + pos.x()] = Rgb::new(r, g, b);
                    },
                )
            })
            .map_err(|m| crate::Error::file(&shown, m))?
            .map_err(|e| crate::Error::file(&shown, format!("cannot read OpenEXR image: {e}")))?;
            image.layer_data.channel_data.pixels
        }
        "hdr" | "pic" => {
            let rgb = lobe_materials::guard::third_party("Radiance HDR", || {
                image::open(path).map(|i| i.into_rgb32f())
            })
            .map_err(|m| Error::file(&shown, m))?
            .map_err(|e| Error::file(&shown, format!("cannot read Radiance HDR image: {e}")))?;
            RgbImage {
                width: rgb.width() as usize,
                height: rgb.height() as usize,
                pixels: rgb.pixels().map(|p| Rgb::new(p[0], p[1], p[2])).collect(),
            }
        }
        _ => {
            return Err(Error::file(
                shown,
                format!("unsupported image extension \"{ext}\"; expected .exr or .hdr"),
            ));
        }
    };
    Ok(img)
}

/// Reads a linear RGB image (OpenEXR first layer, or Radiance HDR) as a film image.
pub fn read_exr(path: &Path) -> Result<Image> {
    let img = read_rgb_image(path)?;
    let mut out = Image::new(img.width as u32, img.height as u32);
    out.pixels = img.pixels;
    Ok(out)
}

/// Writes linear RGB as a 32-bit float OpenEXR file.
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[Rgb]) -> Result<()> {
    use exr::prelude::*;
    let w = width as usize;
    let channels = SpecificChannels::rgb(|pos: exr::math::Vec2<usize>| {
        let p = pixels[pos.y() * w + pos.x()];
        (p.r, p.g, p.b)
    });
    // Tiles in increasing order: the compression runs in parallel, and with the default
    // (unspecified) order the tiles would be written as they finish, so the same pixels
    // would make files that differ from run to run.
    let encoding = Encoding {
        line_order: LineOrder::Increasing,
        ..Encoding::FAST_LOSSLESS
    };
    let image = exr::image::Image::from_encoded_channels(
        (width as usize, height as usize),
        encoding,
        channels,
    );
    // Straight into the (seekable) temporary file, block by block: no copy of the whole
    // image in memory.
    atomic_write(path, |out| {
        image
            .write()
            .to_buffered(out)
            .map_err(std::io::Error::other)
    })
}

/// Writes an 8-bit RGB PNG.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb8: &[u8]) -> Result<()> {
    use image::ImageEncoder;
    atomic_write(path, |out| {
        image::codecs::png::PngEncoder::new(out)
            .write_image(rgb8, width, height, image::ExtendedColorType::Rgb8)
            .map_err(std::io::Error::other)
    })
}
