//! `lobe figure`: the study's plots as PNG (plotters, bitmap backend, with an embedded
//! DejaVu Sans so no system font library is needed):
//! - `errors`: Figure 14, the normalized fitting error (log scale) of every model for every
//!   material, materials sorted by the Lafortune error;
//! - `multilobe`: Figure 5, one against two lobes for Cook-Torrance and Lafortune on the 30
//!   materials whose error the second lobe improves most;
//! - `polar`: Figure 4, the incidence-plane BRDF of the data and of fitted models, cube root;
//! - `spheres`: Figures 3 and 6, the measured material and each model's fit as labelled
//!   spheres under an environment map;
//! - `lobes`: Figures 7 and 8, iso-contours of a half-vector (H.N) and of a mirror (V.R)
//!   lobe of the same exponent over the outgoing hemisphere at a chosen incidence.

use crate::args::finite;
use crate::eval::{MaterialArgs, MaterialSource};
use crate::fit::{read_reports, report_files};
use lobe_materials::Bsdf;
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use plotters::prelude::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(crate) const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
pub(crate) const W: u32 = 1000;
pub(crate) const H: u32 = 600;
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

#[derive(clap::Subcommand)]
pub enum FigureCmd {
    /// Figure 14: normalized error per material for every model (log scale).
    Errors {
        /// Fit reports or folders of them (their *.fit.json files).
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        /// Output PNG file.
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figure 5: one against two lobes (cook-torrance / -2, lafortune / -2).
    Multilobe {
        /// Fit reports or folders of them (their *.fit.json files).
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        /// Output PNG file.
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figure 4: incidence-plane polar plot (cube root) of a material and of fitted models.
    Polar {
        #[command(flatten)]
        material: MaterialArgs,
        /// A fit report whose models are drawn beside the material.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Comma-separated models of the report (default: all).
        #[arg(long, requires = "report")]
        models: Option<String>,
        /// Incident angle in degrees.
        #[arg(long, default_value_t = 45.0, value_parser = finite::<f64>)]
        theta_i: f64,
        /// Colour channel: 0, 1 or 2 (red, green, blue).
        #[arg(long, default_value_t = 1)]
        channel: usize,
        /// Output PNG file.
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figures 3 and 6: the material and each fitted model as labelled spheres under an
    /// environment map, one PNG.
    Spheres {
        #[command(flatten)]
        material: MaterialArgs,
        /// A fit report whose models are drawn after the material.
        #[arg(long)]
        report: PathBuf,
        /// Comma-separated models of the report (default: all).
        #[arg(long)]
        models: Option<String>,
        /// Environment map (EXR or .hdr) or builtin:studio.
        #[arg(long, default_value = "builtin:studio")]
        env: String,
        /// Samples per pixel.
        #[arg(long, default_value_t = 64)]
        spp: u32,
        /// Pixels per sphere tile.
        #[arg(long, default_value_t = 192)]
        tile: u32,
        /// Exposure in stops.
        #[arg(long, default_value_t = 0.0, value_parser = finite::<f32>)]
        exposure: f32,
        /// Output PNG file.
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figures 7 and 8: iso-contours (10 % to 90 % of the peak) of cos^n(h.n) and cos^n(v.r)
    /// over the outgoing hemisphere (projected disk) for incidence theta_i.
    Lobes {
        /// Incident angle in degrees.
        #[arg(long, default_value_t = 60.0, value_parser = finite::<f64>)]
        theta_i: f64,
        /// Lobe exponent n.
        #[arg(long, default_value_t = 30.0, value_parser = finite::<f64>)]
        exponent: f64,
        /// Output PNG file.
        #[arg(long, short)]
        output: PathBuf,
    },
}

pub(crate) fn plot_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Other(format!("cannot draw the figure: {e:?}"))
}

pub(crate) fn save(path: &Path, buf: &[u8]) -> Result<(), Error> {
    lobe_renderer::image_io::write_png_rgb8(path, W, H, buf)
}

pub(crate) fn register_font() {
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
}

/// Writes each label centred at its pixel position (its top edge there) onto an 8-bit RGB
/// image: white text on a translucent dark box, so it reads on any background, at a size
/// that keeps neighbouring labels apart.
pub(crate) fn draw_labels(
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

/// Reads the reports of `inputs` (files or folders), after checking that `output` is
/// none of them.
fn reports_for(inputs: &[PathBuf], output: &Path) -> Result<Vec<Value>, Error> {
    let files = report_files(inputs)?;
    let mut plan = FilePlan::new();
    for f in &files {
        plan.input(f, "a fit report");
    }
    plan.output(output, "figure").check()?;
    Ok(read_reports(&files)?.into_iter().map(|(_, v)| v).collect())
}

fn err_of(r: &Value, model: &str) -> Option<f64> {
    r["models"][model]["error_normalized"]
        .as_f64()
        .filter(|x| x.is_finite() && *x > 0.0)
}

fn errors(reports: &[Value], output: &Path) -> Result<(), Error> {
    let mut models: Vec<&str> = Vec::new();
    for r in reports {
        for k in r["models"].as_object().expect("checked").keys() {
            if !models.contains(&k.as_str()) {
                models.push(k);
            }
        }
    }
    let mut order: Vec<&Value> = reports.iter().collect();
    order.sort_by(|a, b| {
        err_of(a, "lafortune")
            .unwrap_or(0.0)
            .total_cmp(&err_of(b, "lafortune").unwrap_or(0.0))
    });
    error_chart(
        "Normalized fitting error (log10), materials sorted by the Lafortune error",
        &order,
        &models,
        true,
        output,
    )
}

fn multilobe(reports: &[Value], output: &Path) -> Result<(), Error> {
    let pairs = [
        ("cook-torrance", "cook-torrance-2"),
        ("lafortune", "lafortune-2"),
    ];
    let mut rows: Vec<(&Value, f64)> = reports
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
    rows.sort_by(|a, b| b.1.total_cmp(&a.1));
    rows.truncate(30);
    let order: Vec<&Value> = rows.into_iter().map(|(r, _)| r).collect();
    error_chart(
        "One lobe against two: the 30 most improved materials",
        &order,
        &[
            "cook-torrance",
            "cook-torrance-2",
            "lafortune",
            "lafortune-2",
        ],
        false,
        output,
    )
}

/// One line per model of log10 normalized error over the materials in `order`
/// (optionally with a marker per material), y range from the data in whole decades.
fn error_chart(
    title: &str,
    order: &[&Value],
    models: &[&str],
    markers: bool,
    output: &Path,
) -> Result<(), Error> {
    let (lo, hi) = order
        .iter()
        .flat_map(|r| models.iter().filter_map(move |m| err_of(r, m)))
        .fold((f64::MAX, f64::MIN), |(a, b), x| {
            (a.min(x.log10()), b.max(x.log10()))
        });
    let (lo, hi) = if lo <= hi {
        (lo.floor(), hi.ceil().max(lo.floor() + 1.0))
    } else {
        (-4.0, 0.0)
    };
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(0f64..order.len() as f64, lo..hi)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("material")
            .y_desc("log10 error / max albedo")
            .draw()
            .map_err(plot_err)?;
        for (k, &m) in models.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            let pts: Vec<(f64, f64)> = order
                .iter()
                .enumerate()
                .filter_map(|(i, r)| err_of(r, m).map(|e| (i as f64 + 0.5, e.log10())))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                .map_err(plot_err)?
                .label(m)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            if markers {
                chart
                    .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, c.filled())))
                    .map_err(plot_err)?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    save(output, &buf)
}

#[allow(clippy::too_many_arguments)]
fn polar(
    data: Arc<dyn Bsdf>,
    fits: Vec<(String, Arc<dyn Bsdf>)>,
    theta_i: f64,
    channel: usize,
    output: &Path,
) -> Result<(), Error> {
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
    let mut curves = vec![("data".to_string(), curve(data.as_ref()))];
    for (name, m) in &fits {
        curves.push((name.clone(), curve(m.as_ref())));
    }
    let r = curves
        .iter()
        .flat_map(|(_, c)| c.iter().map(|(x, y)| x.hypot(*y)))
        .fold(1e-6f64, f64::max)
        * 1.05;
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("Incidence plane, theta_i = {theta_i} deg, cube root of f_r"),
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(-r * 1.1..r * 1.1, 0.0..r)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .draw()
            .map_err(plot_err)?;
        // Incident direction.
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, 0.0), (-r * ti.sin(), r * ti.cos())],
                BLACK.stroke_width(1),
            ))
            .map_err(plot_err)?;
        for (k, (name, c)) in curves.into_iter().enumerate() {
            let col = if k == 0 {
                BLACK
            } else {
                PALETTE[(k - 1) % PALETTE.len()]
            };
            chart
                .draw_series(LineSeries::new(
                    c,
                    col.stroke_width(if k == 0 { 3 } else { 2 }),
                ))
                .map_err(plot_err)?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    save(output, &buf)
}

/// Renders each material on a sphere under `env` and tiles the images with labels.
#[allow(clippy::too_many_arguments)]
fn spheres(
    items: &[Named],
    env: &str,
    spp: u32,
    tile: u32,
    exposure: f32,
    output: &Path,
) -> Result<(), Error> {
    if !(32..=1024).contains(&tile) || spp == 0 {
        return Err(Error::Other(format!(
            "--tile {tile} / --spp {spp}: expected 32 to 1024 pixels and at least one sample"
        )));
    }
    let here = std::env::current_dir().unwrap_or_default();
    let scene_v = serde_json::json!({
        "camera": {"type": "perspective", "fov": 30, "origin": [0, 0, 4.5], "target": [0, 0, 0], "up": [0, 1, 0]},
        "film": {"width": tile, "height": tile},
        "sampler": {"spp": spp, "seed": 0},
        "integrator": {"type": "path", "max_depth": 3},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}],
        "lights": [{"type": "envmap", "file": env}]
    });
    let cols = items.len().clamp(1, 4) as u32;
    let rows = (items.len() as u32).div_ceil(cols);
    let label_h = 30u32;
    let (w, h) = (cols * tile, rows * (tile + label_h));
    let mut buf = vec![255u8; (w * h * 3) as usize];
    // One scene (camera, environment map and its sampling tables); only the sphere's
    // material changes between tiles.
    let mut scene = lobe_renderer::scene::from_value(
        &scene_v,
        "spheres",
        &here,
        &lobe_renderer::scene::LoadOptions::with_builtins(),
    )?;
    for (k, (_, m)) in items.iter().enumerate() {
        scene.shapes[0].material = m.clone();
        let (img, _) = lobe_renderer::render::render(
            &scene,
            &lobe_renderer::render::RenderOptions::default(),
        )?;
        let rgb = lobe_renderer::film::tonemap(&img.pixels, exposure);
        let (cx, cy) = (
            (k as u32 % cols) * tile,
            (k as u32 / cols) * (tile + label_h),
        );
        for y in 0..tile {
            let src = (y * tile * 3) as usize;
            let dst = (((cy + y) * w + cx) * 3) as usize;
            buf[dst..dst + (tile * 3) as usize]
                .copy_from_slice(&rgb[src..src + (tile * 3) as usize]);
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        for (k, (name, _)) in items.iter().enumerate() {
            let (cx, cy) = (
                (k as u32 % cols) * tile,
                (k as u32 / cols) * (tile + label_h),
            );
            root.draw(&Text::new(
                name.clone(),
                (cx as i32 + 6, (cy + tile + 6) as i32),
                ("sans-serif", 16),
            ))
            .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    lobe_renderer::image_io::write_png_rgb8(output, w, h, &buf)
}

/// Line segments where `f` crosses `level` on a grid over [-1, 1]^2 (marching squares).
fn contour(f: &dyn Fn(f64, f64) -> f64, level: f64, n: usize) -> Vec<[(f64, f64); 2]> {
    let at = |i: usize| -1.0 + 2.0 * i as f64 / n as f64;
    let v: Vec<f64> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| (at(i), at(j))))
        .map(|(x, y)| f(x, y))
        .collect();
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

fn lobes(theta_i: f64, n: f64, output: &Path) -> Result<(), Error> {
    if !((0.0..90.0).contains(&theta_i) && (1.0..=1e5).contains(&n)) {
        return Err(Error::Other(format!(
            "--theta-i must be in [0, 90) and --exponent in [1, 1e5]; found {theta_i} and {n}"
        )));
    }
    let ti = theta_i.to_radians();
    let wi = glam::DVec3::new(-ti.sin(), 0.0, ti.cos());
    let r = glam::DVec3::new(-wi.x, -wi.y, wi.z);
    let wo = |x: f64, y: f64| {
        let z2 = 1.0 - x * x - y * y;
        (z2 > 0.0).then(|| glam::DVec3::new(x, y, z2.sqrt()))
    };
    let hn =
        move |x: f64, y: f64| wo(x, y).map_or(-1.0, |o| (o + wi).normalize().z.max(0.0).powf(n));
    let vr = move |x: f64, y: f64| wo(x, y).map_or(-1.0, |o| o.dot(r).max(0.0).powf(n));
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let panels = root.split_evenly((1, 2));
        type Field<'a> = &'a dyn Fn(f64, f64) -> f64;
        let lobes: [(&str, Field); 2] = [("H.N lobe", &hn), ("V.R lobe", &vr)];
        for (panel, (name, f)) in panels.iter().zip(lobes) {
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    format!("{name}, n = {n}, theta_i = {theta_i} deg"),
                    ("sans-serif", 18),
                )
                .margin(20)
                .build_cartesian_2d(-1.05f64..1.05, -1.05f64..1.05)
                .map_err(plot_err)?;
            let circle: Vec<(f64, f64)> = (0..=360)
                .map(|k| {
                    let a = (k as f64).to_radians();
                    (a.cos(), a.sin())
                })
                .collect();
            chart
                .draw_series(LineSeries::new(circle, BLACK.stroke_width(1)))
                .map_err(plot_err)?;
            // The mirror direction.
            chart
                .draw_series(std::iter::once(Cross::new((r.x, r.y), 5, BLACK)))
                .map_err(plot_err)?;
            for (k, level) in [0.1, 0.3, 0.5, 0.7, 0.9].iter().enumerate() {
                let c = PALETTE[k % PALETTE.len()];
                let segs = contour(f, *level, 240);
                chart
                    .draw_series(
                        segs.into_iter()
                            .map(|s| PathElement::new(vec![s[0], s[1]], c.stroke_width(2))),
                    )
                    .map_err(plot_err)?;
            }
        }
        root.present().map_err(plot_err)?;
    }
    save(output, &buf)
}

/// A labelled material.
type Named = (String, Arc<dyn Bsdf>);

/// The fitted models of a report (those of the comma-separated `models`, or all), built;
/// a name the report does not have is an error listing those it has.
fn report_models(report: &Path, models: Option<String>) -> Result<Vec<Named>, Error> {
    let (_, r) = read_reports(&[report.to_path_buf()])?.remove(0);
    let fitted = r["models"].as_object().expect("checked");
    let wanted: Vec<String> = match models {
        Some(m) => m.split(',').map(|s| s.trim().to_string()).collect(),
        None => fitted.keys().cloned().collect(),
    };
    let reg = lobe_materials::registry::Registry::builtin();
    let mut out = Vec::new();
    for name in wanted {
        let v = fitted.get(&name).ok_or_else(|| {
            Error::Other(format!(
                "--models: no model \"{name}\" in {}; expected one of: {}",
                report.display(),
                fitted.keys().cloned().collect::<Vec<_>>().join(", ")
            ))
        })?;
        let m = reg
            .create(&v["material"], &format!("models.{name}"))
            .map_err(|e| Error::file(report.display(), e.to_string()))?;
        out.push((name, m));
    }
    Ok(out)
}

/// The material and report of a polar or spheres figure (and an environment map file),
/// checked against the output.
fn material_figure_inputs(
    material: &MaterialArgs,
    report: Option<&Path>,
    env: Option<&str>,
    output: &Path,
) -> Result<MaterialSource, Error> {
    let source = MaterialSource::new(material)?;
    let mut plan = FilePlan::new();
    source.plan_inputs(&mut plan);
    if let Some(r) = report {
        plan.input(r, "the fit report");
    }
    if let Some(e) = env.filter(|e| !e.starts_with("builtin:")) {
        plan.input(e, "the environment map");
    }
    plan.output(output, "figure").check()?;
    Ok(source)
}

pub fn cmd_figure(cmd: FigureCmd, quiet: bool) -> Result<(), Error> {
    register_font();
    let out = match cmd {
        FigureCmd::Errors { reports, output } => {
            errors(&reports_for(&reports, &output)?, &output)?;
            output
        }
        FigureCmd::Multilobe { reports, output } => {
            multilobe(&reports_for(&reports, &output)?, &output)?;
            output
        }
        FigureCmd::Polar {
            material,
            report,
            models,
            theta_i,
            channel,
            output,
        } => {
            let source = material_figure_inputs(&material, report.as_deref(), None, &output)?;
            let fits = match &report {
                Some(rp) => report_models(rp, models)?,
                None => Vec::new(),
            };
            polar(source.build()?, fits, theta_i, channel, &output)?;
            output
        }
        FigureCmd::Spheres {
            material,
            report,
            models,
            env,
            spp,
            tile,
            exposure,
            output,
        } => {
            let source = material_figure_inputs(&material, Some(&report), Some(&env), &output)?;
            let mut items = vec![("measured".to_string(), source.build()?)];
            items.extend(report_models(&report, models)?);
            spheres(&items, &env, spp, tile, exposure, &output)?;
            output
        }
        FigureCmd::Lobes {
            theta_i,
            exponent,
            output,
        } => {
            lobes(theta_i, exponent, &output)?;
            output
        }
    };
    if !quiet {
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
