//! The study's figures (Ngan et al. 2005), each drawn as a [`Figure`] (plotters' bitmap
//! backend):
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
//! - [`distribution`]: Figures 11 to 13, an estimated microfacet distribution, log scale.

use crate::NamedMaterial;
use crate::plot::{Figure, H, PALETTE, W, plot_err, register_font};
use crate::reports::model_labels;
use lobe_materials::Bsdf;
use lobe_materials::fit::report::FitReport;
use lobe_materials::microfacet_gen::Table;
use lobe_renderer::Error;
use plotters::prelude::*;

/// The normalized error of `model` in a report, if it has a positive finite one.
pub fn err_of(r: &FitReport, model: &str) -> Option<f64> {
    r.models
        .get(model)
        .map(|m| m.error_normalized)
        .filter(|x| x.is_finite() && *x > 0.0)
}

/// Figure 14: the normalized error (log10) of every model of the reports for every
/// material, materials sorted by the Lafortune error.
pub fn errors(reports: &[FitReport]) -> Result<Figure, Error> {
    let mut order: Vec<&FitReport> = reports.iter().collect();
    let labels = model_labels(&order);
    let models: Vec<&str> = labels.iter().map(String::as_str).collect();
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
    )
}

/// Figure 5: one lobe against two (Cook-Torrance, Lafortune) on the 30 materials whose
/// error the second lobe improves most.
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
    rows.sort_by(|a, b| b.1.total_cmp(&a.1));
    rows.truncate(30);
    let order: Vec<&FitReport> = rows.into_iter().map(|(r, _)| r).collect();
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
    )
}

/// One line per model of log10 normalized error over the materials in `order`
/// (optionally with a marker per material), y range from the data in whole decades.
fn error_chart(
    title: &str,
    order: &[&FitReport],
    models: &[&str],
    markers: bool,
) -> Result<Figure, Error> {
    register_font();
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
    let mut fig = Figure::chart();
    {
        let root = BitMapBackend::with_buffer(&mut fig.rgb, (W, H)).into_drawing_area();
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
    Ok(fig)
}

/// Figure 4: the incidence-plane BRDF (cube root, colour `channel`) of `data` and of
/// fitted models at incidence `theta_i` degrees.
pub fn polar(
    data: &dyn Bsdf,
    fits: &[NamedMaterial],
    theta_i: f64,
    channel: usize,
) -> Result<Figure, Error> {
    register_font();
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
    let mut curves = vec![("data".to_string(), curve(data))];
    for (name, m) in fits {
        curves.push((name.clone(), curve(m.as_ref())));
    }
    let r = curves
        .iter()
        .flat_map(|(_, c)| c.iter().map(|(x, y)| x.hypot(*y)))
        .fold(1e-6f64, f64::max)
        * 1.05;
    let mut fig = Figure::chart();
    {
        let root = BitMapBackend::with_buffer(&mut fig.rgb, (W, H)).into_drawing_area();
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
    Ok(fig)
}

/// Figures 3 and 6: renders each material on a sphere under `env` (an environment map file
/// or builtin:studio) at `spp` samples per pixel, `tile` pixels square, and tiles the
/// images (at most 4 per row) with a label under each.
pub fn spheres(
    items: &[NamedMaterial],
    env: &str,
    spp: u32,
    tile: u32,
    exposure: f32,
) -> Result<Figure, Error> {
    register_font();
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
    let mut fig = Figure::white(w, h);
    let buf = &mut fig.rgb;
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
        let root = BitMapBackend::with_buffer(buf, (w, h)).into_drawing_area();
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
    Ok(fig)
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

/// Figures 7 and 8: iso-contours (10 % to 90 % of the peak) of a half-vector lobe
/// cos^n(h.n) and a mirror lobe cos^n(v.r) over the outgoing hemisphere (projected disk)
/// at incidence `theta_i` degrees.
pub fn lobes(theta_i: f64, n: f64) -> Result<Figure, Error> {
    register_font();
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
    let mut fig = Figure::chart();
    {
        let root = BitMapBackend::with_buffer(&mut fig.rgb, (W, H)).into_drawing_area();
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
    Ok(fig)
}

/// log10 p over the projected hemisphere (a disk; white outside), 320 x 320 pixels, on a
/// blue-to-yellow ramp over four decades below the maximum.
/// Figures 11 to 13: the APS2000 distribution `table` as log10 p over the projected
/// hemisphere.
pub fn distribution(table: &Table) -> Figure {
    let size = 320usize;
    let max = table
        .nodes()
        .iter()
        .cloned()
        .fold(0.0f32, f32::max)
        .max(1e-30) as f64;
    let mut rgb = vec![255u8; size * size * 3];
    for y in 0..size {
        for x in 0..size {
            let hx = (x as f64 + 0.5) / size as f64 * 2.0 - 1.0;
            // Image rows go down; h_y goes up.
            let hy = 1.0 - (y as f64 + 0.5) / size as f64 * 2.0;
            if hx * hx + hy * hy >= 1.0 {
                continue;
            }
            let v = table.p(hx, hy);
            let t = ((v.max(1e-300) / max).log10() / 4.0 + 1.0).clamp(0.0, 1.0);
            // A perceptually ordered ramp: dark blue, teal, green, yellow.
            let stops = [
                [0.07, 0.04, 0.33],
                [0.13, 0.45, 0.55],
                [0.35, 0.75, 0.35],
                [0.99, 0.91, 0.15],
            ];
            let s = t * 3.0;
            let i = (s as usize).min(2);
            let f = s - i as f64;
            let k = (y * size + x) * 3;
            for c in 0..3 {
                rgb[k + c] =
                    ((stops[i][c] * (1.0 - f) + stops[i + 1][c] * f) * 255.0).round() as u8;
            }
        }
    }
    Figure {
        width: size as u32,
        height: size as u32,
        rgb,
    }
}
