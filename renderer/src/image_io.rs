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

/// A rectangle of pixel coordinates: an OpenEXR data or display window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelWindow {
    pub x: i64,
    pub y: i64,
    pub width: usize,
    pub height: usize,
}

impl PixelWindow {
    /// The window of an image without windows of its own: (0, 0) and its size.
    pub fn whole(width: usize, height: usize) -> Self {
        Self {
            x: 0,
            y: 0,
            width,
            height,
        }
    }
}

impl std::fmt::Display for PixelWindow {
    /// As OpenEXR writes a window: the first and the last pixel, inclusive.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "({},{})-({},{})",
            self.x,
            self.y,
            self.x + self.width as i64 - 1,
            self.y + self.height as i64 - 1
        )
    }
}

/// Where an image's pixels lie: the data window (the pixels stored, the image's size) and
/// the display window (the frame they belong to). Radiance HDR images have both at (0, 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageWindows {
    pub data: PixelWindow,
    pub display: PixelWindow,
}

impl ImageWindows {
    /// Refuses an image whose data window is not its display window: a crop or an
    /// overscan, which a reader of whole images (an environment map) cannot place.
    pub fn require_whole(&self, name: &str) -> Result<()> {
        if self.data != self.display {
            return Err(Error::file(
                name,
                format!(
                    "data window {} differs from display window {}; expected a whole image (data window = display window)",
                    self.data, self.display
                ),
            ));
        }
        Ok(())
    }
}

/// An empty image of `res` pixels for the `exr` crate's RGBA reader to fill.
pub(crate) fn exr_canvas(res: exr::math::Vec2<usize>) -> RgbImage {
    RgbImage {
        width: res.width(),
        height: res.height(),
        pixels: vec![Rgb::ZERO; res.width() * res.height()],
    }
}

/// Stores one pixel the `exr` crate's RGBA reader decoded (alpha dropped).
pub(crate) fn exr_set_pixel(
    img: &mut RgbImage,
    pos: exr::math::Vec2<usize>,
    (r, g, b, _a): (f32, f32, f32, f32),
) {
    img.pixels[pos.y() * img.width + pos.x()] = Rgb::new(r, g, b);
}

/// Reads an HDR image: OpenEXR (`.exr`, first layer, RGB) or Radiance (`.hdr`, `.pic`).
/// The pixels are those of the data window, whatever its origin: see
/// [`read_rgb_image_windows`] for where they lie.
pub fn read_rgb_image(path: &Path) -> Result<RgbImage> {
    read_rgb_image_windows(path).map(|(img, _)| img)
}

/// [`read_rgb_image`] and the image's data and display windows.
pub fn read_rgb_image_windows(path: &Path) -> Result<(RgbImage, ImageWindows)> {
    let shown = path.display();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    lobe_materials::io::open_regular(
        path,
        lobe_materials::io::MAX_DATA_BYTES,
        "an .exr or .hdr image",
    )?;
    let img = match ext.as_str() {
        "exr" => {
            use exr::prelude::*;
            lobe_materials::io::check_exr_size(path).map_err(|m| crate::Error::file(&shown, m))?;
            let image = lobe_materials::guard::third_party("OpenEXR", || {
                read_first_rgba_layer_from_file(path, |res, _| exr_canvas(res), exr_set_pixel)
            })
            .map_err(|m| crate::Error::file(&shown, m))?
            .map_err(|e| crate::Error::file(&shown, format!("cannot read OpenEXR image: {e}")))?;
            let window = |b: exr::math::Vec2<i32>, (width, height): (usize, usize)| PixelWindow {
                x: b.x() as i64,
                y: b.y() as i64,
                width,
                height,
            };
            let pixels = &image.layer_data.channel_data.pixels;
            let display = image.attributes.display_window;
            let windows = ImageWindows {
                data: window(
                    image.layer_data.attributes.layer_position,
                    (pixels.width, pixels.height),
                ),
                display: window(display.position, (display.size.x(), display.size.y())),
            };
            (image.layer_data.channel_data.pixels, windows)
        }
        "hdr" | "pic" => {
            let rgb = lobe_materials::guard::third_party("Radiance HDR", || {
                image::open(path).map(|i| i.into_rgb32f())
            })
            .map_err(|m| Error::file(&shown, m))?
            .map_err(|e| Error::file(&shown, format!("cannot read Radiance HDR image: {e}")))?;
            let (width, height) = (rgb.width() as usize, rgb.height() as usize);
            let whole = PixelWindow::whole(width, height);
            let img = RgbImage {
                width,
                height,
                pixels: rgb.pixels().map(|p| Rgb::new(p[0], p[1], p[2])).collect(),
            };
            let windows = ImageWindows {
                data: whole,
                display: whole,
            };
            (img, windows)
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
    read_exr_windows(path).map(|(img, _)| img)
}

/// [`read_exr`] and the image's data and display windows.
pub fn read_exr_windows(path: &Path) -> Result<(Image, ImageWindows)> {
    let (img, windows) = read_rgb_image_windows(path)?;
    let mut out = Image::new(img.width as u32, img.height as u32);
    out.pixels = img.pixels;
    Ok((out, windows))
}

/// Writes linear RGB as a 32-bit float OpenEXR file.
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[Rgb]) -> Result<()> {
    atomic_write(path, |out| encode_exr(out, width, height, pixels))
}

/// Encodes linear RGB as a 32-bit float OpenEXR file into `out` (seekable: block by
/// block, with no copy of the whole image in memory).
pub fn encode_exr<W: std::io::Write + std::io::Seek>(
    out: W,
    width: u32,
    height: u32,
    pixels: &[Rgb],
) -> std::io::Result<()> {
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
    image
        .write()
        .to_buffered(out)
        .map_err(std::io::Error::other)
}

/// Writes an 8-bit RGB PNG.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb8: &[u8]) -> Result<()> {
    atomic_write(path, |out| encode_png_rgb8(out, width, height, rgb8))
}

/// Encodes an 8-bit RGB PNG into `out`.
pub fn encode_png_rgb8<W: std::io::Write>(
    out: W,
    width: u32,
    height: u32,
    rgb8: &[u8],
) -> std::io::Result<()> {
    use image::ImageEncoder;
    image::codecs::png::PngEncoder::new(out)
        .write_image(rgb8, width, height, image::ExtendedColorType::Rgb8)
        .map_err(std::io::Error::other)
}
