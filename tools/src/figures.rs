//! `lobe figure`: the study's plots as PNG (plotters, bitmap backend, with an embedded
//! DejaVu Sans so no system font library is needed):
//! - `errors`: Figure 14, the normalized fitting error (log scale) of every model for every
//!   material, materials sorted by the Lafortune error;
//! - `multilobe`: Figure 5, one against two lobes for Cook-Torrance and Lafortune on the 30
//!   materials whose error the second lobe improves most;
//! - `polar`: Figure 4, the incidence-plane BRDF of the data and of fitted models, cube root.

use crate::eval::{MaterialArgs, load_material};
use lobe_materials::Bsdf;
use lobe_renderer::Error;
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
        /// Fit reports or folders of them.
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figure 5: one against two lobes (cook-torrance / -2, lafortune / -2).
    Multilobe {
        #[arg(required = true)]
        reports: Vec<PathBuf>,
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
        #[arg(long)]
        models: Option<String>,
        /// Incident angle in degrees.
        #[arg(long, default_value_t = 45.0)]
        theta_i: f64,
        /// Colour channel: 0, 1 or 2 (red, green, blue).
        #[arg(long, default_value_t = 1)]
        channel: usize,
        #[arg(long, short)]
        output: PathBuf,
    },
}

pub(crate) fn plot_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Other(format!("cannot draw the figure: {e:?}"))
}

pub(crate) fn save(path: &Path, buf: &[u8]) -> Result<(), Error> {
    lobe_renderer::film::write_png_rgb8(path, W, H, buf)
}

pub(crate) fn register_font() {
    let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
}

fn read_reports(inputs: &[PathBuf]) -> Result<Vec<Value>, Error> {
    Ok(crate::fit::read_reports(inputs)?
        .into_iter()
        .map(|(_, v)| v)
        .collect())
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

pub fn cmd_figure(cmd: FigureCmd, quiet: bool) -> Result<(), Error> {
    register_font();
    let out = match cmd {
        FigureCmd::Errors { reports, output } => {
            errors(&read_reports(&reports)?, &output)?;
            output
        }
        FigureCmd::Multilobe { reports, output } => {
            multilobe(&read_reports(&reports)?, &output)?;
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
            let data = load_material(&material)?;
            let mut fits = Vec::new();
            if let Some(rp) = &report {
                let r = read_reports(std::slice::from_ref(rp))?.remove(0);
                let wanted: Option<Vec<String>> =
                    models.map(|m| m.split(',').map(|s| s.trim().to_string()).collect());
                let reg = lobe_materials::registry::Registry::builtin();
                for (name, v) in r["models"].as_object().expect("checked") {
                    if wanted.as_ref().is_some_and(|w| !w.contains(name)) {
                        continue;
                    }
                    let m = reg
                        .create(&v["material"], &format!("models.{name}"))
                        .map_err(|e| Error::file(rp.display(), e.to_string()))?;
                    fits.push((name.clone(), m));
                }
            }
            polar(data, fits, theta_i, channel, &output)?;
            output
        }
    };
    if !quiet {
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
