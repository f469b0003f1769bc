//! What every figure shares: the embedded DejaVu Sans (plotters' bitmap backend, so no
//! system font library is needed), the chart size and palette, the RGB canvas a figure is
//! drawn on ([`Figure`]), and text labels drawn over a rendered image.

use lobe_renderer::Error;
use plotters::prelude::*;
use std::path::Path;

/// DejaVu Sans (licence in assets/DejaVuSans-LICENSE.txt).
pub const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// Width of a chart in pixels.
pub const W: u32 = 1000;
/// Height of a chart in pixels.
pub const H: u32 = 600;
/// Line colours, in order of the series.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// An 8-bit RGB image: a drawn figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    pub width: u32,
    pub height: u32,
    /// Row-major RGB bytes, top row first.
    pub rgb: Vec<u8>,
}

impl Figure {
    /// A white canvas.
    pub fn white(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            rgb: vec![255u8; (width * height * 3) as usize],
        }
    }

    /// A white chart-sized canvas ([`W`] x [`H`]).
    pub fn chart() -> Self {
        Self::white(W, H)
    }

    /// Writes the figure as a PNG (atomically).
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        lobe_renderer::image_io::write_png_rgb8(path, self.width, self.height, &self.rgb)
    }
}

/// A drawing error as lobe's error.
pub fn plot_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Other(format!("cannot draw the figure: {e:?}"))
}

/// Registers the embedded font as "sans-serif" (again is harmless).
pub fn register_font() {
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
}

/// Writes each label centred at its pixel position (its top edge there) onto an 8-bit RGB
/// image: white text on a translucent dark box, so it reads on any background, at a size
/// that keeps neighbouring labels apart.
pub fn draw_labels(
    rgb: &mut [u8],
    (w, h): (u32, u32),
    labels: &[(String, glam::Vec2)],
) -> Result<(), Error> {
    if labels.is_empty() {
        return Ok(());
    }
    register_font();
    let font = |size: f64| TextStyle::from(("sans-serif", size).into_font());
    let root = BitMapBackend::with_buffer(rgb, (w, h)).into_drawing_area();
    // The widest label fits in 90 % of the gap between neighbouring centres.
    let mut xs: Vec<f32> = labels.iter().map(|l| l.1.x).collect();
    xs.sort_by(f32::total_cmp);
    let gap = xs.windows(2).map(|p| p[1] - p[0]).fold(w as f32, f32::min) as f64;
    let mut size = (h as f64 / 22.0).max(10.0);
    for (text, _) in labels {
        let (tw, _) = root
            .estimate_text_size(text, &font(size))
            .map_err(plot_err)?;
        if tw as f64 > 0.9 * gap {
            size *= 0.9 * gap / tw as f64;
        }
    }
    let size = size.max(8.0);
    for (text, at) in labels {
        let (tw, th) = root
            .estimate_text_size(text, &font(size))
            .map_err(plot_err)?;
        let (x, y) = (at.x.round() as i32 - tw as i32 / 2, at.y.round() as i32 + 4);
        root.draw(&Rectangle::new(
            [(x - 4, y - 2), (x + tw as i32 + 4, y + th as i32 + 3)],
            BLACK.mix(0.5).filled(),
        ))
        .map_err(plot_err)?;
        root.draw(&Text::new(text.clone(), (x, y), font(size).color(&WHITE)))
            .map_err(plot_err)?;
    }
    root.present().map_err(plot_err)
}
