//! The study's figures (Ngan et al. 2005), each drawn as a [`Figure`] (plotters; the charts
//! also as SVG), every model in its one [`crate::plot::style`], legends beside the data,
//! polar and lobe plots on equal axis scales:
//! - [`errors`]: Figure 14, the normalized fitting error (log scale) of every model for
//!   every material, materials sorted by the Lafortune error;
//! - [`multilobe`]: Figure 5, one against two lobes for Cook-Torrance and Lafortune on the
//!   30 materials whose error the second lobe improves most;
//! - [`polar`]: Figure 4, the incidence-plane BRDF of the data and of fitted models, cube
//!   root;
//! - [`spheres`]: Figures 3 and 6, the measured material and each model's fit as labelled
//!   spheres under an environment map;
//! - [`lobes`]: Figures 7 and 8, iso-contours of a half-vector (H.N) and of a mirror (V.R)
//!   lobe of the same exponent over the outgoing hemisphere at a chosen incidence;
//! - [`lobe_contours`]: the same contours of measured data and of its fits;
//! - [`distribution`]: Figures 11 to 13, an estimated microfacet distribution, log scale.

use crate::NamedMaterial;
use crate::plot::{
    Figure, H, LEGEND_W, MEASURED, Style, W, axis_name, draw_axis_names, draw_legend, draw_line,
    draw_marker, equal_chart, plot_err, register_font, style,
};
use crate::reports::model_labels;
use crate::vector_figure;
use lobe_materials::Bsdf;
use lobe_materials::fit::report::FitReport;
use lobe_materials::microfacet_gen::Table;
use lobe_renderer::Error;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// The normalized error of `model` in a report, if it has a positive finite one.
pub fn err_of(r: &FitReport, model: &str) -> Option<f64> {
    r.models
        .get(model)
        .map(|m| m.error_normalized)
        .filter(|x| x.is_finite() && *x > 0.0)
}

/// Figure 14: the normalized error (log10) of every model of the reports for every
/// material, materials sorted by the Lafortune error (by the first model's when no report
/// has Lafortune).
pub fn errors(reports: &[FitReport]) -> Result<Figure, Error> {
    errors_with(reports, &[])
}

/// A normalized error of a material that its fit report does not hold: (material, label,
/// error), e.g. the estimated microfacet distribution's.
pub type ExtraError = (String, String, f64);

/// [`errors`] with further series: every label of `extra` is drawn as one more model.
pub fn errors_with(reports: &[FitReport], extra: &[ExtraError]) -> Result<Figure, Error> {
    let mut order: Vec<&FitReport> = reports.iter().collect();
    let mut labels = model_labels(&order);
    for (_, label, _) in extra {
        if !labels.contains(label) {
            labels.push(label.clone());
        }
    }
    let models: Vec<&str> = labels.iter().map(String::as_str).collect();
    let lookup = |r: &FitReport, m: &str| {
        err_of(r, m).or_else(|| {
            extra
                .iter()
                .find(|e| e.0 == r.material && e.1 == m)
                .map(|e| e.2)
                .filter(|x| x.is_finite() && *x > 0.0)
        })
    };
    let key = if models.contains(&"lafortune") {
        "lafortune"
    } else {
        models.first().copied().unwrap_or("lafortune")
    };
    order.sort_by(|a, b| {
        lookup(a, key)
            .unwrap_or(0.0)
            .total_cmp(&lookup(b, key).unwrap_or(0.0))
    });
    let title = format!(
        "Normalized fitting error of {} models on {} materials, sorted by the {key} error",
        models.len(),
        order.len()
    );
    error_chart(&title, &order, &models, &lookup)
}

/// Figure 5: one lobe against two (Cook-Torrance, Lafortune) on the (at most) 30
/// materials whose error the second lobe improves most.
pub fn multilobe(reports: &[FitReport]) -> Result<Figure, Error> {
    let pairs = [
        ("cook-torrance", "cook-torrance-2"),
        ("lafortune", "lafortune-2"),
    ];
    let mut rows: Vec<(&FitReport, f64)> = reports
        .iter()
        .filter_map(|r| {
            let gains: Vec<f64> = pairs
                .iter()
                .filter_map(|(a, b)| Some(err_of(r, a)? / err_of(r, b)?))
                .collect();
            (!gains.is_empty()).then(|| (r, gains.iter().cloned().fold(0.0, f64::max)))
        })
        .collect();
    if rows.is_empty() {
        return Err(Error::Other("no report has both one- and two-lobe fits (cook-torrance and cook-torrance-2, or lafortune and lafortune-2)".into()));
    }
    let with_both = rows.len();
    rows.sort_by(|a, b| b.1.total_cmp(&a.1));
    rows.truncate(30);
    let order: Vec<&FitReport> = rows.into_iter().map(|(r, _)| r).collect();
    let title = if order.len() == with_both {
        format!(
            "One lobe against two: all {with_both} materials with both fits, most improved first"
        )
    } else {
        format!(
            "One lobe against two: the {} most improved of {with_both} materials",
            order.len()
        )
    };
    error_chart(
        &title,
        &order,
        &[
            "cook-torrance",
            "cook-torrance-2",
            "lafortune",
            "lafortune-2",
        ],
        &err_of,
    )
}

/// Whether a report's data is a built-in analytic material tabulated in memory.
fn is_synthetic(r: &FitReport) -> bool {
    r.source.starts_with("built-in:")
}

/// A line and markers per model (its [`style`]) of log10 normalized error over the
/// materials in `order`, named under the x axis; y range from the data in whole decades;
/// the legend beside the plot.
fn error_chart(
    title: &str,
    order: &[&FitReport],
    models: &[&str],
    error: &dyn Fn(&FitReport, &str) -> Option<f64>,
) -> Result<Figure, Error> {
    // The axis spans the measured materials' errors when there are any: a synthetic
    // material fitted by its own generating model (errors of 1e-6 to 1e-8) would squeeze
    // them into the top decade. Its smaller errors are drawn on the bottom edge with their
    // value.
    let real: Vec<&&FitReport> = order.iter().filter(|r| !is_synthetic(r)).collect();
    let ranged: Vec<&&FitReport> = match real.is_empty() {
        true => order.iter().collect(),
        false => real,
    };
    let (lo, hi) = ranged
        .iter()
        .flat_map(|r| models.iter().filter_map(move |m| error(r, m)))
        .fold((f64::MAX, f64::MIN), |(a, b), x| {
            (a.min(x.log10()), b.max(x.log10()))
        });
    let (lo, hi) = if lo <= hi {
        (lo.floor(), hi.ceil().max(lo.floor() + 1.0))
    } else {
        (-4.0, 0.0)
    };
    let names: Vec<String> = order
        .iter()
        .map(|r| match is_synthetic(r) {
            true => format!("{}*", r.material),
            false => r.material.clone(),
        })
        .collect();
    // The rotated names' height: their widths at the largest size they are drawn at.
    crate::plot::register_font();
    let font = ("sans-serif", 14.0).into_font();
    let longest = names
        .iter()
        .map(|n| {
            let name = axis_name(n);
            font.box_size(&name)
                .map_or(8 * name.chars().count() as u32, |b| b.0)
        })
        .max()
        .unwrap_or(8);
    let names_h = 12 + longest;
    let plot_w = (100 + 18 * order.len() as u32).max(W - LEGEND_W);
    let legend: Vec<(String, Style)> = models.iter().map(|m| (m.to_string(), style(m))).collect();
    let chart = ErrorChart {
        title,
        order,
        models,
        error,
        range: lo..hi,
        names: &names,
        names_h,
    };
    Ok(vector_figure!(
        (plot_w + LEGEND_W, H - 60 + names_h),
        |root| {
            let (plot, side) = root.split_horizontally(plot_w);
            chart.draw(&plot)?;
            draw_legend(&side, "model", &legend)?
        }
    ))
}

/// What an error chart draws (see [`error_chart`]).
struct ErrorChart<'a> {
    title: &'a str,
    order: &'a [&'a FitReport],
    models: &'a [&'a str],
    error: &'a dyn Fn(&FitReport, &str) -> Option<f64>,
    range: std::ops::Range<f64>,
    names: &'a [String],
    names_h: u32,
}

impl ErrorChart<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), Error> {
        let area = area
            .titled(self.title, ("sans-serif", 19))
            .map_err(plot_err)?;
        let n = self.order.len();
        let mut chart = ChartBuilder::on(&area)
            .margin(15)
            .x_label_area_size(self.names_h + 26)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..n as f64, self.range.clone())
            .map_err(plot_err)?;
        // One gridline and label per decade, no minor lines.
        let decades = (self.range.end - self.range.start).round() as usize + 1;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_labels(decades)
            .max_light_lines(0)
            .y_label_formatter(&|v| format!("1e{:.0}", v))
            .x_desc(match self.names.iter().any(|n| n.ends_with('*')) {
                true => "material (*: built-in analytic material; errors under the axis written at its foot)",
                false => "material",
            })
            .y_desc("normalized error (Eq. 1 error / max albedo), log scale")
            .draw()
            .map_err(plot_err)?;
        let lo = self.range.start;
        let xs: Vec<i32> = (0..n)
            .map(|i| chart.backend_coord(&(i as f64 + 0.5, lo)).0)
            .collect();
        let axis_y = chart.backend_coord(&(0.0, lo)).1;
        let (x0, y0) = area.get_base_pixel();
        let xs_local: Vec<i32> = xs.iter().map(|x| x - x0).collect();
        draw_axis_names(&area, self.names, &xs_local, axis_y - y0 + 8)?;
        let mut below_axis: std::collections::HashMap<u64, i32> = Default::default();
        for &m in self.models {
            let st = style(m);
            let lo = self.range.start;
            let pts: Vec<(f64, f64, f64)> = self
                .order
                .iter()
                .enumerate()
                .filter_map(|(i, r)| (self.error)(r, m).map(|e| (i as f64 + 0.5, e.log10())))
                .map(|(x, y)| (x, y.max(lo), y))
                .collect();
            let below = ("sans-serif", 11).into_font().color(&st.color);
            for &(x, y, e) in pts.iter().filter(|p| p.2 < lo) {
                // Values below the axis at one material stack upwards, one line each.
                let k = below_axis.entry(x.to_bits()).or_insert(0);
                let (px, py) = chart.backend_coord(&(x, y));
                area.draw(&Text::new(
                    format!("\u{2193}{:.0e}", 10f64.powf(e)),
                    (px - x0 + 6, py - y0 - 14 - 12 * *k),
                    below.clone(),
                ))
                .map_err(plot_err)?;
                *k += 1;
            }
            let pts: Vec<(f64, f64)> = pts.into_iter().map(|p| (p.0, p.1)).collect();
            draw_line(&mut chart, pts.clone(), st, 2)?;
            for p in pts {
                let (px, py) = chart.backend_coord(&p);
                draw_marker(&area, (px - x0, py - y0), 4, st)?;
            }
        }
        Ok(())
    }
}

/// An axis tick value with one decimal (zero without a sign).
fn tick(v: &f64) -> String {
    format!("{:.1}", if v.abs() < 1e-9 { 0.0 } else { *v })
}

/// The name of colour channel `c` (0, 1, 2).
pub fn channel_name(c: usize) -> &'static str {
    ["red", "green", "blue"].get(c).copied().unwrap_or("?")
}

/// Figure 4: the incidence-plane BRDF (cube root, colour `channel`) of the measured
/// `material` (`data`) and of fitted models at incidence `theta_i` degrees, on equal axis
/// scales, each model in its [`style`], the legend beside the plot.
pub fn polar(
    material: &str,
    data: &dyn Bsdf,
    fits: &[NamedMaterial],
    theta_i: f64,
    channel: usize,
) -> Result<Figure, Error> {
    if !(0.0..90.0).contains(&theta_i) || channel > 2 {
        return Err(Error::Other(format!(
            "--theta-i must be in [0, 90) and --channel in 0..=2; found {theta_i} and {channel}"
        )));
    }
    let ti = theta_i.to_radians();
    let wi = glam::Vec3::new(ti.sin() as f32, 0.0, ti.cos() as f32);
    // Outgoing directions in the incidence plane, from -90 (behind) to +90 degrees (mirror side).
    let curve = |m: &dyn Bsdf| -> Vec<(f64, f64)> {
        // Stop 1 degree short of grazing: models with a 1/sqrt(cos) factor (Ward) are
        // unbounded there and would flatten every other curve.
        (0..=356)
            .map(|k| {
                let a = (-89.0 + k as f64 * 0.5).to_radians();
                let wo = glam::Vec3::new(-(a.sin()) as f32, 0.0, a.cos() as f32);
                let v = (m.eval(wo, wi).to_array()[channel].max(0.0) as f64).cbrt();
                (v * a.sin(), v * a.cos())
            })
            .collect()
    };
    let mut curves = vec![("measured".to_string(), curve(data))];
    for (name, m) in fits {
        curves.push((name.clone(), curve(m.as_ref())));
    }
    // The curves' bounding box (with the normal, x = 0), padded: the plot spends its area
    // on the lobes, not on an empty half disk; its height follows the box's shape.
    let (mut x0, mut x1, mut y1) = (0.0f64, 0.0f64, 1e-6f64);
    for (x, y) in curves.iter().flat_map(|(_, c)| c.iter()) {
        (x0, x1, y1) = (x0.min(*x), x1.max(*x), y1.max(*y));
    }
    let pad = 0.06 * (x1 - x0).max(y1);
    let bounds = (x0 - pad..x1 + pad, 0.0..y1 + pad);
    let title = format!(
        "{material}: incidence plane, \u{3b8}i = {theta_i}\u{b0}, {} channel, cube root of f_r",
        channel_name(channel)
    );
    let legend: Vec<(String, Style)> = curves.iter().map(|(n, _)| (n.clone(), style(n))).collect();
    let plot_w = W - LEGEND_W + 60;
    let data_w = (plot_w - 80) as f64;
    let aspect = (bounds.1.end - bounds.1.start) / (bounds.0.end - bounds.0.start);
    let plot_h = (data_w * aspect).clamp(280.0, 760.0) as u32 + 120;
    Ok(vector_figure!((plot_w + LEGEND_W, plot_h), |root| {
        let (plot, side) = root.split_horizontally(plot_w);
        draw_polar(&plot, &title, &curves, (bounds.clone(), ti))?;
        draw_legend(&side, "series", &legend)?
    }))
}

/// The polar plot's axes, incident direction and curves (see [`polar`]) over `bounds`.
fn draw_polar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    curves: &[(String, Vec<(f64, f64)>)],
    (bounds, ti): ((std::ops::Range<f64>, std::ops::Range<f64>), f64),
) -> Result<(), Error> {
    let area = area.titled(title, ("sans-serif", 18)).map_err(plot_err)?;
    let mut chart = equal_chart(&area, (45, 65), bounds.clone(), true)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc("f_r^(1/3) sin \u{3b8}o  (sr^-1/3; negative: the incident side)")
        .y_desc("f_r^(1/3) cos \u{3b8}o  (sr^-1/3)")
        .draw()
        .map_err(plot_err)?;
    // The incident direction, to the edge of the plotted box.
    let (dx, dy) = (-ti.sin(), ti.cos());
    let reach = [
        (dx < 0.0).then(|| bounds.0.start / dx),
        (dx > 0.0).then(|| bounds.0.end / dx),
        (dy > 0.0).then(|| bounds.1.end / dy),
    ]
    .into_iter()
    .flatten()
    .fold(f64::MAX, f64::min);
    chart
        .draw_series(LineSeries::new(
            vec![(0.0, 0.0), (reach * dx, reach * dy)],
            BLACK.mix(0.5).stroke_width(1),
        ))
        .map_err(plot_err)?;
    let (x0, y0) = area.get_base_pixel();
    for (name, c) in curves {
        let st = style(name);
        let width = if MEASURED.contains(&name.as_str()) {
            3
        } else {
            2
        };
        draw_line(&mut chart, c.clone(), st, width)?;
        for p in c.iter().step_by(40) {
            let (px, py) = chart.backend_coord(p);
            draw_marker(&area, (px - x0, py - y0), 4, st)?;
        }
    }
    Ok(())
}

/// Figures 3 and 6 with their errors: the unit sphere of [`crate::sphere_errors::Stage`]
/// under the map `env` (a file or builtin:studio), one column per item (`items[0]` the
/// measured data): its name centred, its picture (`tile` pixels, the exposure at which
/// under 1 % of the data's pixels clip, plus `exposure` stops), and under it the FLIP map
/// against the data's image with the RMSE, its 95 % interval and the mean FLIP. The data's
/// column shows the FLIP between the halves of its samples and its own noise instead. The
/// images come from [`crate::sphere_errors::estimate`] (common random numbers, noise bias
/// removed) with at most `spp` samples per pixel; the caption gives the noise floor and a
/// FLIP colour bar.
pub fn spheres(
    items: &[NamedMaterial],
    env: &str,
    spp: u32,
    tile: u32,
    exposure: f32,
) -> Result<Figure, Error> {
    use crate::sphere_errors::{ErrorSettings, Stage, estimate};
    register_font();
    if !(32..=1024).contains(&tile) || spp == 0 || items.is_empty() {
        return Err(Error::Other(format!(
            "--tile {tile} / --spp {spp}: expected 32 to 1024 pixels, at least one sample and one material"
        )));
    }
    let map = crate::fit_images::FitEnvironment::load(env)?;
    let stage = Stage::sphere(&map.0, tile);
    let reps: Vec<&dyn Bsdf> = items.iter().map(|(_, m)| m.as_ref()).collect();
    let settings = ErrorSettings {
        pilot_spp: (spp as usize).min(64),
        max_spp: spp as usize,
        ..ErrorSettings::default()
    };
    let est = estimate(&stage, &reps, &settings)?;
    let (cols, rows, cell) = sphere_grid(items.len(), tile);
    let (w, h) = sphere_grid_size(items.len(), tile);
    let name_h = SPHERE_NAME_H;
    let mut fig = Figure::white(w, h);
    let origin = |k: usize| ((k as u32 % cols) * cell.0 + 6, (k as u32 / cols) * cell.1);
    for k in 0..items.len() {
        let (x, y) = origin(k);
        let picture = lobe_renderer::film::tonemap(&est.images[k].pixels, est.exposure + exposure);
        paste(&mut fig, &picture, tile, (x, y + name_h));
        let heat = lobe_renderer::compare::flip_heatmap(&est.flip_maps[k], tile, tile);
        paste(&mut fig, &heat, tile, (x, y + name_h + tile + 4));
    }
    {
        let root = BitMapBackend::with_buffer(&mut fig.rgb, (w, h)).into_drawing_area();
        let centred = |size: f64| {
            TextStyle::from(("sans-serif", size).into_font()).pos(Pos::new(HPos::Center, VPos::Top))
        };
        for (k, (name, _)) in items.iter().enumerate() {
            let (x, y) = origin(k);
            let mid = (x + tile / 2) as i32;
            root.draw(&Text::new(name.clone(), (mid, y as i32 + 5), centred(16.0)))
                .map_err(plot_err)?;
            let e = &est.errors[k];
            let lines = match k {
                0 => [
                    format!("noise {:.2e} (reference)", e.rmse),
                    format!("FLIP of its halves {:.3}", e.flip),
                ],
                _ => [
                    format!("RMSE {:.2e} [{:.2e}, {:.2e}]", e.rmse, e.ci95[0], e.ci95[1]),
                    format!("FLIP {:.3}", e.flip),
                ],
            };
            let ty = (y + name_h + 2 * tile + 8) as i32;
            for (i, line) in lines.iter().enumerate() {
                root.draw(&Text::new(
                    line.clone(),
                    (mid, ty + 17 * i as i32),
                    centred(12.5),
                ))
                .map_err(plot_err)?;
            }
        }
        let foot = (rows * cell.1) as i32;
        let scale = lobe_renderer::compare::flip_colour_scale(200);
        for (i, c) in scale.iter().enumerate() {
            let x = 10 + i as i32;
            root.draw(&Rectangle::new(
                [(x, foot + 6), (x + 1, foot + 18)],
                RGBColor(c[0], c[1], c[2]).filled(),
            ))
            .map_err(plot_err)?;
        }
        let small = ("sans-serif", 12).into_font().color(&BLACK);
        for (t, label) in [(0, "FLIP 0"), (199, "1")] {
            root.draw(&Text::new(label, (10 + t, foot + 22), small.clone()))
                .map_err(plot_err)?;
        }
        root.draw(&Text::new(
            format!(
                "{} spp on average (up to {}) in {} batches in the last pass; noise floor {:.2e} (the RMS noise of the closest fit's difference image)",
                est.spp, est.spp_max, est.batches, est.noise_floor
            ),
            (10, foot + 40),
            small,
        ))
        .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(fig)
}

/// Pixels of a sphere cell's name row, of its two text lines and of the figure's caption.
const SPHERE_NAME_H: u32 = 26;
const SPHERE_TEXT_H: u32 = 40;
const SPHERE_FOOT_H: u32 = 60;

/// The grid of [`spheres`] for `n` items: (columns, rows, cell size): at most 4 columns,
/// a cell the name, the picture, the FLIP map and two lines of numbers.
fn sphere_grid(n: usize, tile: u32) -> (u32, u32, (u32, u32)) {
    let cols = n.clamp(1, 4) as u32;
    let rows = (n.max(1) as u32).div_ceil(cols);
    let cell = (tile + 12, SPHERE_NAME_H + 2 * tile + 4 + SPHERE_TEXT_H);
    (cols, rows, cell)
}

/// The pixel size of [`spheres`]' figure of `n` items in `tile`-pixel pictures.
pub fn sphere_grid_size(n: usize, tile: u32) -> (u32, u32) {
    let (cols, rows, cell) = sphere_grid(n, tile);
    ((cols * cell.0).max(360), rows * cell.1 + SPHERE_FOOT_H)
}

/// Copies a `size` x `size` RGB picture into `fig` with its top-left corner at `at`.
fn paste(fig: &mut Figure, rgb: &[u8], size: u32, at: (u32, u32)) {
    let row = (size * 3) as usize;
    for y in 0..size {
        let (src, dst) = (
            (y as usize) * row,
            (((at.1 + y) * fig.width + at.0) * 3) as usize,
        );
        if dst + row <= fig.rgb.len() {
            fig.rgb[dst..dst + row].copy_from_slice(&rgb[src..src + row]);
        }
    }
}

/// The colour of the hemisphere's rim in lobe plots.
pub const RIM: RGBColor = RGBColor(70, 70, 150);

/// Contour levels of lobe plots (fractions of each panel's peak) and their colours.
const LEVELS: [(f64, RGBColor); 5] = [
    (0.1, RGBColor(68, 1, 84)),
    (0.3, RGBColor(59, 82, 139)),
    (0.5, RGBColor(33, 145, 140)),
    (0.7, RGBColor(60, 170, 70)),
    (0.9, RGBColor(200, 160, 0)),
];

/// Grid cells per side of a lobe plot's contour grid over [-1, 1]^2.
const GRID: usize = 240;

/// A scalar field over the projected outgoing hemisphere, (x, y) = (sin θo cos φo,
/// sin θo sin φo); negative outside the disk.
type Field<'a> = &'a (dyn Fn(f64, f64) -> f64 + Sync);

/// The values of `f` at the (n + 1)^2 nodes of a grid over [-1, 1]^2, row by row.
fn sample_grid(f: Field<'_>, n: usize) -> Vec<f64> {
    use rayon::prelude::*;
    let at = |i: usize| -1.0 + 2.0 * i as f64 / n as f64;
    (0..(n + 1) * (n + 1))
        .into_par_iter()
        .map(|k| f(at(k % (n + 1)), at(k / (n + 1))))
        .collect()
}

/// Line segments where the grid values `v` ([`sample_grid`]) cross `level` (marching
/// squares).
fn contour(v: &[f64], n: usize, level: f64) -> Vec<[(f64, f64); 2]> {
    let at = |i: usize| -1.0 + 2.0 * i as f64 / n as f64;
    let mut segs = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let c = [
                (at(i), at(j), v[j * (n + 1) + i]),
                (at(i + 1), at(j), v[j * (n + 1) + i + 1]),
                (at(i + 1), at(j + 1), v[(j + 1) * (n + 1) + i + 1]),
                (at(i), at(j + 1), v[(j + 1) * (n + 1) + i]),
            ];
            let mut pts = Vec::new();
            for e in 0..4 {
                let (a, b) = (c[e], c[(e + 1) % 4]);
                if (a.2 >= level) != (b.2 >= level) {
                    let t = (level - a.2) / (b.2 - a.2);
                    pts.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
                }
            }
            for p in pts.chunks_exact(2) {
                segs.push([p[0], p[1]]);
            }
        }
    }
    segs
}

/// Pixels per lobe-plot panel (width) and of the figure's height.
const PANEL: (u32, u32) = (430, 500);

/// What the contour levels of a lobe plot are fractions of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Levels {
    /// Each panel's own peak: shapes compare, magnitudes do not.
    OwnPeak,
    /// The first panel's peak (the measured data) in every panel: a fit too bright or too
    /// dark shows as contours too many or too few, and each panel names its peak.
    FirstPanel,
}

/// Lobe plots: one panel per named field, each with iso-contours at 10 % to 90 % of a
/// peak ([`Levels`]) over the projected hemisphere (equal axis scales: the disk is a
/// circle, its rim the horizon), the mirror direction `mirror` marked, the levels' legend
/// beside the panels.
fn contour_figure(
    title: &str,
    panels: &[(String, Field<'_>)],
    mirror: (f64, f64),
    levels: Levels,
) -> Result<Figure, Error> {
    let grids: Vec<(String, Vec<f64>)> = panels
        .iter()
        .map(|(name, f)| (name.clone(), sample_grid(*f, GRID)))
        .collect();
    let peak_of = |g: &[f64]| g.iter().cloned().fold(0.0f64, f64::max);
    let first = grids.first().map_or(0.0, |g| peak_of(&g.1));
    let k = grids.len().max(1) as u32;
    let of = match levels {
        Levels::OwnPeak => "the panel's peak",
        Levels::FirstPanel => "the first panel's peak",
    };
    let legend: Vec<(String, Style)> = LEVELS
        .iter()
        .map(|(l, c)| {
            let st = Style {
                color: *c,
                marker: crate::plot::Marker::Circle,
                dashed: false,
            };
            (format!("{:.0} % of {of}", l * 100.0), st)
        })
        .collect();
    Ok(vector_figure!((k * PANEL.0 + LEGEND_W, PANEL.1), |root| {
        let root = root.titled(title, ("sans-serif", 18)).map_err(plot_err)?;
        let (left, side) = root.split_horizontally(k * PANEL.0);
        for (i, (area, (name, grid))) in left
            .split_evenly((1, k as usize))
            .iter()
            .zip(&grids)
            .enumerate()
        {
            let peak = peak_of(grid);
            let (reference, caption) = match levels {
                Levels::OwnPeak => (peak, name.clone()),
                Levels::FirstPanel if i == 0 => (first, format!("{name} (peak {peak:.3})")),
                Levels::FirstPanel => (
                    first,
                    format!("{name} (peak {:.2} x the first)", peak / first.max(1e-300)),
                ),
            };
            draw_contour_panel(area, &caption, grid, reference, mirror)?;
        }
        draw_legend(&side, "contour level", &legend)?
    }))
}

/// One panel of [`contour_figure`]: contours at the [`LEVELS`] of `reference`.
fn draw_contour_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    name: &str,
    grid: &[f64],
    reference: f64,
    mirror: (f64, f64),
) -> Result<(), Error> {
    let area = area.titled(name, ("sans-serif", 16)).map_err(plot_err)?;
    let mut chart = equal_chart(&area, (40, 50), (-1.05..1.05, -1.05..1.05), false)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc("sin \u{3b8}o cos \u{3c6}o")
        .y_desc("sin \u{3b8}o sin \u{3c6}o")
        .draw()
        .map_err(plot_err)?;
    if reference > 0.0 {
        for (level, c) in LEVELS {
            let segs = contour(grid, GRID, level * reference);
            chart
                .draw_series(
                    segs.into_iter()
                        .map(|s| PathElement::new(vec![s[0], s[1]], c.stroke_width(2))),
                )
                .map_err(plot_err)?;
        }
    }
    // The horizon and the mirror direction over the contours.
    let circle: Vec<(f64, f64)> = (0..=360)
        .map(|k| {
            let a = (k as f64).to_radians();
            (a.cos(), a.sin())
        })
        .collect();
    chart
        .draw_series(LineSeries::new(circle, RIM.stroke_width(1)))
        .map_err(plot_err)?;
    chart
        .draw_series(std::iter::once(Cross::new(mirror, 5, BLACK)))
        .map_err(plot_err)?;
    Ok(())
}

/// The outgoing direction at a point of the projected hemisphere, if inside it.
fn hemisphere(x: f64, y: f64) -> Option<glam::DVec3> {
    let z2 = 1.0 - x * x - y * y;
    (z2 > 0.0).then(|| glam::DVec3::new(x, y, z2.sqrt()))
}

/// The incident direction at `theta_i` degrees in the xz plane (light from -x), and its
/// mirror direction.
fn incidence(theta_i: f64) -> (glam::DVec3, glam::DVec3) {
    let ti = theta_i.to_radians();
    let wi = glam::DVec3::new(-ti.sin(), 0.0, ti.cos());
    (wi, glam::DVec3::new(-wi.x, -wi.y, wi.z))
}

/// Figures 7 and 8: iso-contours (10 % to 90 % of the peak) of a half-vector lobe
/// cos^n(h.n) and a mirror lobe cos^n(v.r) over the outgoing hemisphere (projected disk)
/// at incidence `theta_i` degrees.
pub fn lobes(theta_i: f64, n: f64) -> Result<Figure, Error> {
    if !((0.0..90.0).contains(&theta_i) && (1.0..=1e5).contains(&n)) {
        return Err(Error::Other(format!(
            "--theta-i must be in [0, 90) and --exponent in [1, 1e5]; found {theta_i} and {n}"
        )));
    }
    let (wi, r) = incidence(theta_i);
    let hn = move |x: f64, y: f64| {
        hemisphere(x, y).map_or(-1.0, |o| (o + wi).normalize().z.max(0.0).powf(n))
    };
    let vr = move |x: f64, y: f64| hemisphere(x, y).map_or(-1.0, |o| o.dot(r).max(0.0).powf(n));
    contour_figure(
        &format!(
            "Half-vector and mirror lobes of exponent n = {n} at \u{3b8}i = {theta_i}\u{b0} (x: the mirror direction)"
        ),
        &[
            ("H.N lobe: cos^n(h\u{b7}n)".to_string(), &hn),
            ("V.R lobe: cos^n(v\u{b7}r)".to_string(), &vr),
        ],
        (r.x, r.y),
        Levels::OwnPeak,
    )
}

/// Lobe plots of measured data: iso-contours of f_r (colour `channel`) over the outgoing
/// hemisphere at incidence `theta_i` degrees, one panel per item (the measured material
/// first, then its fits), all at 10 % to 90 % of the first item's peak, so that a fit's
/// magnitude error shows as well as its shape's.
pub fn lobe_contours(
    material: &str,
    items: &[NamedMaterial],
    theta_i: f64,
    channel: usize,
) -> Result<Figure, Error> {
    if !(0.0..90.0).contains(&theta_i) || channel > 2 || items.is_empty() {
        return Err(Error::Other(format!(
            "lobe plot: expected theta_i in [0, 90), a channel in 0..=2 and at least one material; found {theta_i}, {channel} and {} materials",
            items.len()
        )));
    }
    let (wi, r) = incidence(theta_i);
    let wi32 = wi.as_vec3();
    let fields: Vec<Box<dyn Fn(f64, f64) -> f64 + Sync>> = items
        .iter()
        .map(|(_, m)| {
            let m = m.clone();
            Box::new(move |x: f64, y: f64| {
                hemisphere(x, y).map_or(-1.0, |o| {
                    (m.eval(o.as_vec3(), wi32).to_array()[channel].max(0.0) as f64).max(0.0)
                })
            }) as Box<dyn Fn(f64, f64) -> f64 + Sync>
        })
        .collect();
    let panels: Vec<(String, Field<'_>)> = items
        .iter()
        .zip(&fields)
        .map(|((name, _), f)| (name.clone(), f.as_ref() as Field<'_>))
        .collect();
    contour_figure(
        &format!(
            "{material}: f_r over the outgoing hemisphere at \u{3b8}i = {theta_i}\u{b0}, {} channel (x: the mirror direction)",
            channel_name(channel)
        ),
        &panels,
        (r.x, r.y),
        Levels::FirstPanel,
    )
}

/// The decades below the top of a map of p that [`distribution`] colours.
pub const DISTRIBUTION_DECADES: f64 = 4.0;

/// The top of a shared colour range for maps of p: the largest node of any of `tables`
/// (so that a truth and its estimate drawn with it compare colour for colour).
pub fn distribution_top(tables: &[&Table]) -> f64 {
    tables
        .iter()
        .flat_map(|t| t.nodes().iter())
        .fold(0.0f32, |a, &b| a.max(b))
        .max(1e-30) as f64
}

/// A perceptually ordered ramp (dark blue, teal, green, yellow) at `t` in [0, 1].
fn ramp(t: f64) -> RGBColor {
    let stops = [
        [0.07, 0.04, 0.33],
        [0.13, 0.45, 0.55],
        [0.35, 0.75, 0.35],
        [0.99, 0.91, 0.15],
    ];
    let s = t.clamp(0.0, 1.0) * 3.0;
    let i = (s as usize).min(2);
    let f = s - i as f64;
    let c = |k: usize| ((stops[i][k] * (1.0 - f) + stops[i + 1][k] * f) * 255.0).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

/// Figures 11 to 13: the APS2000 distribution `table` as log10 p over the projected
/// hemisphere (h_x, h_y) on axes, titled `title`, with a colour bar: the ramp spans
/// [`DISTRIBUTION_DECADES`] decades below `top` (p per unit projected area; give a truth
/// and its estimate the same [`distribution_top`]), lower values take its darkest colour.
pub fn distribution(title: &str, table: &Table, top: f64) -> Result<Figure, Error> {
    const SIZE: (u32, u32) = (470, 420);
    crate::plot::register_font();
    let top = top.max(1e-30);
    let mut fig = Figure::white(SIZE.0, SIZE.1);
    {
        let root = BitMapBackend::with_buffer(&mut fig.rgb, SIZE).into_drawing_area();
        let root = root.titled(title, ("sans-serif", 16)).map_err(plot_err)?;
        let (plot, bar) = root.split_horizontally(SIZE.0 - 90);
        let mut chart = equal_chart(&plot, (40, 50), (-1.0..1.0, -1.0..1.0), false)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .x_desc("h_x (tangent)")
            .y_desc("h_y (bitangent)")
            .draw()
            .map_err(plot_err)?;
        let colour = |hx: f64, hy: f64| {
            let v = table.p(hx, hy).max(1e-300) / top;
            ramp(v.log10() / DISTRIBUTION_DECADES + 1.0)
        };
        let (a, b) = (
            chart.backend_coord(&(-1.0, 1.0)),
            chart.backend_coord(&(1.0, -1.0)),
        );
        let (x0, y0) = plot.get_base_pixel();
        for py in a.1..=b.1 {
            for px in a.0..=b.0 {
                let hx = -1.0 + 2.0 * (px - a.0) as f64 / (b.0 - a.0).max(1) as f64;
                let hy = 1.0 - 2.0 * (py - a.1) as f64 / (b.1 - a.1).max(1) as f64;
                if hx * hx + hy * hy < 1.0 {
                    plot.draw_pixel((px - x0, py - y0), &colour(hx, hy))
                        .map_err(plot_err)?;
                }
            }
        }
        let rim: Vec<(f64, f64)> = (0..=360)
            .map(|k| (k as f64).to_radians())
            .map(|a| (a.cos(), a.sin()))
            .collect();
        chart
            .draw_series(LineSeries::new(rim, BLACK.mix(0.6).stroke_width(1)))
            .map_err(plot_err)?;
        draw_decade_bar(&bar, top.log10(), (a.1 - y0, b.1 - y0))?;
        root.present().map_err(plot_err)?;
    }
    Ok(fig)
}

/// The colour bar of [`distribution`]: the ramp from `log_top` - decades (bottom) to
/// `log_top` (top) between pixel rows `rows`, a tick and label per whole decade.
fn draw_decade_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    log_top: f64,
    rows: (i32, i32),
) -> Result<(), Error> {
    let (x0, x1) = (8i32, 26i32);
    let (top, bottom) = rows;
    let span = (bottom - top).max(1) as f64;
    for y in top..=bottom {
        let t = 1.0 - (y - top) as f64 / span;
        area.draw(&Rectangle::new([(x0, y), (x1, y + 1)], ramp(t).filled()))
            .map_err(plot_err)?;
    }
    let font = ("sans-serif", 12).into_font().color(&BLACK);
    let lo = log_top - DISTRIBUTION_DECADES;
    for d in (lo.ceil() as i64)..=(log_top.floor() as i64) {
        let y = top + ((log_top - d as f64) / DISTRIBUTION_DECADES * span).round() as i32;
        area.draw(&PathElement::new([(x1 - 6, y), (x1, y)], WHITE))
            .map_err(plot_err)?;
        let style = font.clone().pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(format!("1e{d}"), (x1 + 4, y), style))
            .map_err(plot_err)?;
    }
    let style = font.pos(Pos::new(HPos::Left, VPos::Bottom));
    area.draw(&Text::new("p (log)", (x0 - 4, top - 6), style))
        .map_err(plot_err)
}

/// A FLIP error map (`rgb`, `width` x `height`, as [`lobe_renderer::compare::flip_heatmap`]
/// colours it) with its colour bar and scale under it: the bar spans FLIP 0 to 1 with
/// ticks at 0, 0.25, 0.5, 0.75 and 1, and `caption` (e.g. the mean FLIP) beside the title.
pub fn flip_map_with_bar(
    rgb: &[u8],
    width: u32,
    height: u32,
    caption: &str,
) -> Result<Figure, Error> {
    const BAR: u32 = 48;
    let w = width.max(220);
    let h = height + BAR;
    crate::plot::register_font();
    let mut fig = Figure::white(w, h);
    for y in 0..height as usize {
        let src = &rgb[y * width as usize * 3..(y + 1) * width as usize * 3];
        let dst = y * w as usize * 3;
        fig.rgb[dst..dst + src.len()].copy_from_slice(src);
    }
    {
        let root = BitMapBackend::with_buffer(&mut fig.rgb, (w, h)).into_drawing_area();
        let (x0, x1) = (12i32, w as i32 - 14);
        let (y0, y1) = (height as i32 + 6, height as i32 + 18);
        let scale = lobe_renderer::compare::flip_colour_scale((x1 - x0) as usize);
        for (i, c) in scale.iter().enumerate() {
            let x = x0 + i as i32;
            root.draw(&Rectangle::new(
                [(x, y0), (x + 1, y1)],
                RGBColor(c[0], c[1], c[2]).filled(),
            ))
            .map_err(plot_err)?;
        }
        let font = ("sans-serif", 12).into_font().color(&BLACK);
        for k in 0..=4 {
            let t = k as f64 / 4.0;
            let x = x0 + ((x1 - x0 - 1) as f64 * t).round() as i32;
            root.draw(&PathElement::new([(x, y1), (x, y1 + 4)], BLACK))
                .map_err(plot_err)?;
            let style = font.clone().pos(Pos::new(HPos::Center, VPos::Top));
            root.draw(&Text::new(format!("{t}"), (x, y1 + 5), style))
                .map_err(plot_err)?;
        }
        let title = font.pos(Pos::new(HPos::Left, VPos::Top));
        root.draw(&Text::new(
            format!("FLIP {caption}"),
            (x0, height as i32 + 34),
            title,
        ))
        .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(fig)
}
