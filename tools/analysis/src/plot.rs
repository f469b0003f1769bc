//! What every figure shares: the embedded DejaVu Sans (plotters' bitmap backend, so no
//! system font library is needed), the chart size, the one style (colour and marker) of
//! each model in every figure ([`style`]), the canvas a figure is drawn on ([`Figure`]:
//! RGB pixels, and for charts the same drawing as SVG, see [`vector_figure!`]), legends
//! beside the data ([`draw_legend`]), equal axis scales ([`equal_scale`]), material names
//! on an axis ([`axis_name`]), and text labels drawn over a rendered image.

use lobe_renderer::Error;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The colour type of styles (plotters').
pub use plotters::style::RGBColor;

/// DejaVu Sans (licence in assets/DejaVuSans-LICENSE.txt).
pub const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// Width of a chart in pixels.
pub const W: u32 = 1000;
/// Height of a chart in pixels.
pub const H: u32 = 600;
/// Series colours: 18 well-separated hues, readable on white (after Trubetskoy's list of
/// distinct colours, the lightest ones darkened). A model's colour is fixed by [`style`].
pub const PALETTE: [RGBColor; 18] = [
    RGBColor(230, 25, 75),
    RGBColor(60, 180, 75),
    RGBColor(67, 99, 216),
    RGBColor(245, 130, 49),
    RGBColor(145, 30, 180),
    RGBColor(30, 190, 220),
    RGBColor(240, 50, 230),
    RGBColor(154, 99, 36),
    RGBColor(128, 0, 0),
    RGBColor(70, 153, 144),
    RGBColor(128, 128, 0),
    RGBColor(0, 0, 117),
    RGBColor(150, 150, 150),
    RGBColor(210, 170, 0),
    RGBColor(120, 190, 30),
    RGBColor(250, 120, 160),
    RGBColor(160, 120, 240),
    RGBColor(0, 100, 60),
];

/// The marker shapes, drawn at every point of a model's series.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    Cross,
}

const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::Cross,
];

/// How a series is drawn: its colour, marker, and a dashed line for a model's two-lobe
/// form (solid for everything else).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Style {
    pub color: RGBColor,
    pub marker: Marker,
    pub dashed: bool,
}

/// The labels of the measured data itself (drawn black, thicker).
pub const MEASURED: [&str; 2] = ["measured", "data"];

/// The label of the estimated microfacet distribution (section 5), a family of its own.
pub const SAMPLED_MICROFACET: &str = "sampled-microfacet";

/// One hue per model family, in the order families first appear in
/// [`lobe_materials::fit::builtin_specs`] (then the sampled microfacet distribution):
/// Ward, Blinn-Phong, Cook-Torrance, Lafortune, Ashikhmin-Shirley, He, Poulin-Fournier,
/// sampled microfacet. A family's variants are shades of its hue ([`shade`]).
pub const FAMILY_HUES: [RGBColor; 8] = [
    RGBColor(31, 100, 200),
    RGBColor(130, 50, 180),
    RGBColor(215, 25, 28),
    RGBColor(240, 130, 0),
    RGBColor(30, 150, 60),
    RGBColor(140, 86, 30),
    RGBColor(0, 150, 150),
    RGBColor(220, 40, 200),
];

/// The `k`-th shade of a family's hue: the hue itself, then darker and lighter in turn,
/// all dark enough to read on white.
pub fn shade(hue: RGBColor, k: usize) -> RGBColor {
    // (factor towards black, fraction of white mixed in)
    const SHADES: [(f64, f64); 6] = [
        (1.0, 0.0),
        (0.6, 0.0),
        (1.0, 0.4),
        (0.38, 0.0),
        (0.8, 0.25),
        (1.0, 0.55),
    ];
    let (f, w) = SHADES[k % SHADES.len()];
    let c = |v: u8| ((v as f64 * f) * (1.0 - w) + 255.0 * w).round() as u8;
    RGBColor(c(hue.0), c(hue.1), c(hue.2))
}

/// The family of a fit variant: its model, with the anisotropic forms and Duer's
/// normalization folded into the model they vary (`ward-anisotropic` and `ward-duer` are
/// Wards).
fn family_of(model: &str) -> &str {
    ["-anisotropic", "-duer"]
        .iter()
        .find_map(|s| model.strip_suffix(s))
        .unwrap_or(model)
}

/// The reserved styles: every fit variant of [`lobe_materials::fit::builtin_specs`] and
/// the sampled microfacet distribution, by label. A family shares a hue; its one-lobe
/// variants take shades and markers in turn; a two-lobe form takes the colour of the
/// one-lobe model it contains, dashed.
fn reserved_styles() -> &'static [(String, Style)] {
    static STYLES: std::sync::LazyLock<Vec<(String, Style)>> = std::sync::LazyLock::new(|| {
        let specs = lobe_materials::fit::builtin_specs();
        let entries = specs
            .iter()
            .map(|s| {
                let two_lobe_of = s.contains.filter(|_| s.lobes > 1).map(|c| c.label);
                (s.label, family_of(s.model), two_lobe_of)
            })
            .chain(std::iter::once((
                SAMPLED_MICROFACET,
                SAMPLED_MICROFACET,
                None,
            )));
        // Per family: its index, how many variants and how many shades it has used.
        let mut families: Vec<(&str, usize, usize)> = Vec::new();
        let mut out: Vec<(String, Style)> = Vec::new();
        for (label, family, two_lobe_of) in entries {
            let f = match families.iter().position(|x| x.0 == family) {
                Some(f) => f,
                None => {
                    families.push((family, 0, 0));
                    families.len() - 1
                }
            };
            let marker = MARKERS[families[f].1 % MARKERS.len()];
            families[f].1 += 1;
            let contained =
                two_lobe_of.and_then(|c| out.iter().find(|(l, _)| l == c).map(|(_, st)| st.color));
            let (color, dashed) = match contained {
                Some(color) => (color, true),
                None => {
                    families[f].2 += 1;
                    let hue = FAMILY_HUES[f % FAMILY_HUES.len()];
                    (shade(hue, families[f].2 - 1), false)
                }
            };
            out.push((
                label.to_string(),
                Style {
                    color,
                    marker,
                    dashed,
                },
            ));
        }
        out
    });
    &STYLES
}

/// Every label with a reserved style ([`style`]): the fitter's models in the order of
/// [`lobe_materials::fit::builtin_specs`], and the estimated microfacet distribution.
pub fn known_labels() -> &'static [String] {
    static LABELS: std::sync::LazyLock<Vec<String>> =
        std::sync::LazyLock::new(|| reserved_styles().iter().map(|(l, _)| l.clone()).collect());
    &LABELS
}

/// The style of a series label, the same in every figure: black circles for the measured
/// data, the reserved style of every known model (one hue per family, see
/// [`reserved_styles`]), and for any other label an entry chosen from a hash of its name
/// (stable from run to run).
pub fn style(label: &str) -> Style {
    if MEASURED.contains(&label) {
        return Style {
            color: BLACK,
            marker: Marker::Circle,
            dashed: false,
        };
    }
    if let Some((_, st)) = reserved_styles().iter().find(|(l, _)| l == label) {
        return *st;
    }
    // FNV-1a: a fixed hash, so an unknown label keeps its style between runs.
    let h = label.bytes().fold(0xcbf29ce484222325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    });
    let k = (h % (PALETTE.len() * MARKERS.len()) as u64) as usize;
    Style {
        color: PALETTE[k % PALETTE.len()],
        marker: MARKERS[(k + k / PALETTE.len()) % MARKERS.len()],
        dashed: false,
    }
}

/// Draws a marker of `style` centred at pixel `at` (radius `r`).
pub fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    r: i32,
    style: Style,
) -> Result<(), Error> {
    let c = style.color.filled();
    let (x, y) = at;
    match style.marker {
        Marker::Circle => area.draw(&Circle::new(at, r, c)),
        Marker::Square => area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], c)),
        Marker::Triangle => area.draw(&Polygon::new(
            vec![(x, y - r - 1), (x - r - 1, y + r), (x + r + 1, y + r)],
            c,
        )),
        Marker::Diamond => area.draw(&Polygon::new(
            vec![
                (x, y - r - 1),
                (x + r + 1, y),
                (x, y + r + 1),
                (x - r - 1, y),
            ],
            c,
        )),
        Marker::Cross => {
            let s = style.color.stroke_width(2);
            area.draw(&PathElement::new(vec![(x - r, y - r), (x + r, y + r)], s))
                .and_then(|_| area.draw(&PathElement::new(vec![(x - r, y + r), (x + r, y - r)], s)))
        }
    }
    .map_err(plot_err)
}

/// The cartesian chart of f64 ranges every line figure draws on.
pub type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draws the line through `pts` in `style`'s colour, `width` pixels wide: solid, or
/// dashed (8 on, 5 off) for a two-lobe form.
pub fn draw_line<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    pts: Vec<(f64, f64)>,
    style: Style,
    width: u32,
) -> Result<(), Error> {
    let shape = style.color.stroke_width(width);
    if style.dashed {
        chart
            .draw_series(DashedLineSeries::new(pts, 8, 5, shape))
            .map(|_| ())
    } else {
        chart.draw_series(LineSeries::new(pts, shape)).map(|_| ())
    }
    .map_err(plot_err)
}

/// Draws a legend in its own area (beside the plot, so it hides no data): one row per
/// entry with a line and the marker of its style, then the label; `title` above.
pub fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    entries: &[(String, Style)],
) -> Result<(), Error> {
    let font = ("sans-serif", 15).into_font();
    let mut y = 48;
    area.draw(&Text::new(title.to_string(), (8, y - 24), font.clone()))
        .map_err(plot_err)?;
    for (label, st) in entries {
        let width = if MEASURED.contains(&label.as_str()) {
            3
        } else {
            2
        };
        let line = st.color.stroke_width(width);
        match st.dashed {
            true => area.draw(&plotters::element::DashedPathElement::new(
                vec![(8, y), (38, y)],
                6,
                4,
                line,
            )),
            false => area.draw(&PathElement::new(vec![(8, y), (38, y)], line)),
        }
        .map_err(plot_err)?;
        draw_marker(area, (23, y), 4, *st)?;
        area.draw(&Text::new(
            label.clone(),
            (46, y),
            TextStyle::from(font.clone()).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(plot_err)?;
        y += 22;
    }
    Ok(())
}

/// The ranges widened so that one unit spans as many pixels along x as along y in a plot
/// area of `dims` pixels (a circle stays a circle): the tighter axis grows, centred, or
/// for y upwards from its start when `y_floor` (a polar plot's horizon stays at the bottom).
pub fn equal_scale(
    dims: (u32, u32),
    x: Range<f64>,
    y: Range<f64>,
    y_floor: bool,
) -> (Range<f64>, Range<f64>) {
    let (w, h) = (dims.0.max(1) as f64, dims.1.max(1) as f64);
    let u = ((x.end - x.start) / w).max((y.end - y.start) / h);
    let xc = 0.5 * (x.start + x.end);
    let x = xc - 0.5 * u * w..xc + 0.5 * u * w;
    let y = if y_floor {
        y.start..y.start + u * h
    } else {
        let yc = 0.5 * (y.start + y.end);
        yc - 0.5 * u * h..yc + 0.5 * u * h
    };
    (x, y)
}

/// A material's name as an axis label: whole up to 24 characters, longer ones shortened in
/// the middle with an ellipsis (the start and the end usually tell materials apart).
pub fn axis_name(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    if chars.len() <= 24 {
        return name.to_string();
    }
    let head: String = chars[..14].iter().collect();
    let tail: String = chars[chars.len() - 9..].iter().collect();
    format!("{head}\u{2026}{tail}")
}

/// Draws `names` vertically (reading downwards) under an axis, each centred on its pixel
/// column `xs[i]`, starting at pixel row `y`, at a size that keeps neighbours apart.
pub fn draw_axis_names<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    names: &[String],
    xs: &[i32],
    y: i32,
) -> Result<(), Error> {
    let gap = xs
        .windows(2)
        .map(|p| (p[1] - p[0]).abs())
        .min()
        .unwrap_or(40);
    let size = (gap as f64 * 0.9).clamp(7.0, 14.0);
    let font = TextStyle::from(
        ("sans-serif", size)
            .into_font()
            .transform(FontTransform::Rotate90),
    )
    .pos(Pos::new(HPos::Left, VPos::Center));
    for (name, &x) in names.iter().zip(xs) {
        area.draw(&Text::new(axis_name(name), (x, y), font.clone()))
            .map_err(plot_err)?;
    }
    Ok(())
}

/// An 8-bit RGB image: a drawn figure, and for a chart the same drawing as SVG.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    pub width: u32,
    pub height: u32,
    /// Row-major RGB bytes, top row first.
    pub rgb: Vec<u8>,
    /// The SVG document of a chart (None for a raster figure: renders, tables of p).
    pub svg: Option<String>,
}

/// Draws a chart twice, on the RGB canvas and as SVG, with one body: `vector_figure!((w,
/// h), |root| body)` where `body` uses `root` (a `DrawingArea` of either backend, so it
/// calls functions generic over `DrawingBackend`) and may return early with `?`.
#[macro_export]
macro_rules! vector_figure {
    (($w:expr, $h:expr), |$root:ident| $body:expr) => {{
        let (w, h): (u32, u32) = ($w, $h);
        $crate::plot::register_font();
        let mut fig = $crate::plot::Figure::white(w, h);
        {
            let $root = plotters::prelude::BitMapBackend::with_buffer(&mut fig.rgb, (w, h))
                .into_drawing_area();
            $root
                .fill(&plotters::prelude::WHITE)
                .map_err($crate::plot::plot_err)?;
            $body;
            $root.present().map_err($crate::plot::plot_err)?;
        }
        let mut svg = String::new();
        {
            let $root =
                plotters::prelude::SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
            $root
                .fill(&plotters::prelude::WHITE)
                .map_err($crate::plot::plot_err)?;
            $body;
            $root.present().map_err($crate::plot::plot_err)?;
        }
        fig.svg = Some(svg);
        fig
    }};
}

impl Figure {
    /// A white canvas.
    pub fn white(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            rgb: vec![255u8; (width * height * 3) as usize],
            svg: None,
        }
    }

    /// A white chart-sized canvas ([`W`] x [`H`]).
    pub fn chart() -> Self {
        Self::white(W, H)
    }

    /// The SVG file written next to the PNG `path` (same stem, .svg).
    pub fn svg_path(path: &Path) -> PathBuf {
        path.with_extension("svg")
    }

    /// Writes the figure as a PNG, and a chart also as SVG next to it
    /// ([`Figure::svg_path`]), each atomically.
    pub fn save(&self, path: &Path) -> Result<(), Error> {
        lobe_renderer::image_io::write_png_rgb8(path, self.width, self.height, &self.rgb)?;
        if let Some(svg) = &self.svg {
            lobe_renderer::film::atomic_write(&Self::svg_path(path), |w| {
                std::io::Write::write_all(w, svg.as_bytes())
            })?;
        }
        Ok(())
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

/// Width in pixels of the legend column beside a chart.
pub const LEGEND_W: u32 = 250;

/// A cartesian chart on `area` (margin 15, label areas `labels` = (x, y) pixels) whose
/// ranges are `x` and `y` widened by [`equal_scale`] to the plot area's pixels, so that
/// a unit is as long along x as along y.
pub fn equal_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    labels: (u32, u32),
    (x, y): (Range<f64>, Range<f64>),
    y_floor: bool,
) -> Result<Chart<'a, DB>, Error> {
    let mut b = ChartBuilder::on(area);
    b.margin(15)
        .x_label_area_size(labels.0)
        .y_label_area_size(labels.1);
    // Building draws nothing without a caption: the first build only measures how many
    // pixels the ranges span.
    let probe = b
        .build_cartesian_2d(x.clone(), y.clone())
        .map_err(plot_err)?;
    let (a, c) = (
        probe.backend_coord(&(x.start, y.start)),
        probe.backend_coord(&(x.end, y.end)),
    );
    let span = ((c.0 - a.0).unsigned_abs(), (c.1 - a.1).unsigned_abs());
    let (x, y) = equal_scale(span, x, y, y_floor);
    b.build_cartesian_2d(x, y).map_err(plot_err)
}

/// A pixel box (left, top, right, bottom), right and bottom exclusive.
pub type PixelBox = (i32, i32, i32, i32);

fn overlaps(a: PixelBox, b: PixelBox) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Places text labels of `sizes` (width, height in pixels) beside their `points` inside
/// `bounds` so that no label overlaps another label, any point's marker (a square of
/// half-size `marker`) or any of `obstacles` (lines drawn on the plot): each label, in order, takes the first free spot of a ring of
/// candidates around its point (right, left, above, below, the diagonals), at growing
/// distances. Returns each label's box; a label with no free spot within reach takes its
/// least-covered spot (the caller draws a leader line to any label away from its point).
pub fn place_labels(
    points: &[(i32, i32)],
    sizes: &[(u32, u32)],
    marker: i32,
    bounds: PixelBox,
    obstacles: &[PixelBox],
) -> Vec<PixelBox> {
    let markers: Vec<PixelBox> = points
        .iter()
        .map(|&(x, y)| (x - marker, y - marker, x + marker + 1, y + marker + 1))
        .chain(obstacles.iter().copied())
        .collect();
    let mut placed: Vec<PixelBox> = Vec::with_capacity(points.len());
    for (&(x, y), &(w, h)) in points.iter().zip(sizes) {
        let (w, h) = (w as i32, h as i32);
        let gap = marker + 3;
        let mut best: Option<(usize, PixelBox)> = None;
        'search: for step in 0..12 {
            let d = gap + step * (h / 2 + 2);
            let candidates = [
                (x + d, y - h / 2),
                (x - d - w, y - h / 2),
                (x - w / 2, y - d - h),
                (x - w / 2, y + d),
                (x + d, y - d - h + h / 2),
                (x - d - w, y - d - h + h / 2),
                (x + d, y + d - h / 2),
                (x - d - w, y + d - h / 2),
            ];
            for (l, t) in candidates {
                let b = (l, t, l + w, t + h);
                if b.0 < bounds.0 || b.1 < bounds.1 || b.2 > bounds.2 || b.3 > bounds.3 {
                    continue;
                }
                let hits = placed
                    .iter()
                    .chain(&markers)
                    .filter(|o| overlaps(b, **o))
                    .count();
                if hits == 0 {
                    best = Some((0, b));
                    break 'search;
                }
                if best.is_none_or(|(n, _)| hits < n) {
                    best = Some((hits, b));
                }
            }
        }
        let b = best.map_or((x + gap, y - h / 2, x + gap + w, y - h / 2 + h), |(_, b)| b);
        placed.push(b);
    }
    placed
}

#[cfg(test)]
mod label_tests {
    use super::*;

    #[test]
    fn crowded_labels_do_not_overlap() {
        // Twelve points in a tight cluster, as close models land on a trade-off plot.
        let points: Vec<(i32, i32)> = (0..12)
            .map(|k| (400 + 6 * (k % 4), 300 + 5 * (k / 4)))
            .collect();
        let sizes = vec![(110, 14); 12];
        let line = (380, 310, 440, 313);
        let boxes = place_labels(&points, &sizes, 6, (0, 0, 1000, 600), &[line]);
        for (i, a) in boxes.iter().enumerate() {
            for b in boxes.iter().skip(i + 1) {
                assert!(!overlaps(*a, *b), "{a:?} and {b:?} overlap");
            }
            for &(x, y) in &points {
                assert!(
                    !overlaps(*a, (x - 6, y - 6, x + 7, y + 7)),
                    "{a:?} covers a marker"
                );
            }
        }
    }
}
