//! The speed/accuracy/memory trade between the representations of one
//! measured material (Ngan et al. 2005 compare fits in BRDF space, Eq. 1, and in renderings,
//! Figures 3 and 6): the measured table itself, the APS2000 generator with a distribution
//! estimated from it (section 5), and every analytic fit (section 4). For each it measures
//! the Eq. (1) error, the image error against a high-spp render of the measured table (RMSE
//! and FLIP), eval and sample cost per call, memory, render time at a fixed spp, and the
//! image error at equal render time (from a convergence curve over spp); each image error
//! also as the median-of-means RMSE with its outlier pixels (lobe_renderer::error_stats), so
//! that a firefly cannot decide a published number; writes Markdown, CSV and a Pareto plot
//! (render time against median-of-means image error).
//! The study runs in stages: the representations (estimate and fits), the reference render,
//! each representation's measurements, then the equal-time renders.

use crate::cost::measure;
use crate::models::choose;
use crate::plot::{Figure, H, W, draw_marker, plot_err, register_font, style};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::{builtin_specs, fit};
use lobe_materials::measured::format;
use lobe_materials::microfacet_gen::estimate;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_renderer::Error;
use lobe_renderer::compare::metrics;
use lobe_renderer::error_stats::robust_error;
use lobe_renderer::film::Image;
use lobe_renderer::outputs::FilePlan;
use lobe_renderer::render::{RenderOptions, render};
use lobe_renderer::scene::{LoadOptions, from_value};
use plotters::prelude::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// What a trade-off study measures and how.
#[derive(Clone, Debug)]
pub struct TradeoffConfig {
    /// Measured data: a MERL table, binned data or an RGL file (told apart by content).
    pub data: PathBuf,
    /// A scene whose `materials` has an entry named "subject", replaced by each
    /// representation (default: a sphere under the built-in studio environment).
    pub scene: Option<PathBuf>,
    /// Samples per pixel of the reference render of the measured table.
    pub reference_spp: u32,
    /// Samples per pixel of the compared renders (the convergence curve also renders at
    /// 1/16 and 1/4 of it).
    pub spp: u32,
    /// Image size of the default scene.
    pub size: u32,
    /// Bin size in degrees of the fitted data.
    pub resolution: f64,
    /// Comma-separated fitted models (default: the study's defaults for the data).
    pub models: Option<String>,
    /// Output stem: STEM.md, STEM.csv, STEM.png, STEM-microfacet.exr.
    pub output: PathBuf,
}

/// The measurements of one representation.
#[derive(Clone, Debug)]
pub struct Row {
    pub name: String,
    /// Its material description.
    pub desc: Value,
    /// Eq. (1) error against the data (0 for the measured table itself).
    pub brdf_error: f64,
    pub eval_ns: f64,
    pub sample_ns: f64,
    pub memory: usize,
    /// Render time at the fixed spp.
    pub seconds: f64,
    pub rmse: f64,
    /// Median-of-means RMSE and outlier pixels (lobe_renderer::error_stats).
    pub robust_rmse: f64,
    pub outliers: usize,
    pub flip: f64,
    /// (render seconds, RMSE) over spp.
    pub curve: Vec<(f64, f64)>,
    /// (render seconds, median-of-means RMSE) over spp.
    pub robust_curve: Vec<(f64, f64)>,
    pub equal_time_rmse: f64,
    pub equal_time_robust_rmse: f64,
}

/// A finished study: one row per representation, the measured table's first.
#[derive(Clone, Debug)]
pub struct Study {
    pub rows: Vec<Row>,
    /// The measured table's render time: the equal-time budget.
    pub budget: f64,
    /// The data's largest directional albedo (normalizes Eq. (1) errors).
    pub max_albedo: f64,
    /// The data file.
    pub source: String,
    pub spp: u32,
    pub reference_spp: u32,
}

/// A representation to measure: its name, description and Eq. (1) error.
type Representation = (String, Value, f64);

fn default_scene(size: u32) -> Value {
    json!({
        "camera": {"type": "perspective", "fov": 30, "origin": [0, 0, 4.5], "target": [0, 0, 0], "up": [0, 1, 0]},
        "film": {"width": size, "height": size},
        "sampler": {"spp": 16, "seed": 0},
        "integrator": {"type": "path", "max_depth": 3},
        "materials": {"subject": {"type": "lambert"}},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "subject"}],
        "lights": [{"type": "envmap", "file": "builtin:studio"}]
    })
}

/// log-log interpolation (linear extrapolation at the ends) of a curve at `t`.
fn at_time(curve: &[(f64, f64)], t: f64) -> f64 {
    let pts: Vec<(f64, f64)> = curve
        .iter()
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .map(|p| (p.0.ln(), p.1.ln()))
        .collect();
    if pts.len() < 2 {
        return curve.last().map_or(f64::NAN, |p| p.1);
    }
    let x = t.ln();
    let k = pts
        .windows(2)
        .position(|w| x <= w[1].0)
        .unwrap_or(pts.len() - 2);
    let (a, b) = (pts[k], pts[k + 1]);
    let f = if b.0 > a.0 {
        (x - a.0) / (b.0 - a.0)
    } else {
        0.0
    };
    (a.1 + f * (b.1 - a.1)).exp()
}

/// The output files of a stem.
fn output_files(stem: &Path) -> [(PathBuf, &'static str); 5] {
    let at = |suffix: &str| PathBuf::from(format!("{}{suffix}", stem.display()));
    [
        (at(".md"), "Markdown table"),
        (at(".csv"), "CSV table"),
        (at(".png"), "Pareto plot"),
        (at(".svg"), "Pareto plot (SVG)"),
        (at("-microfacet.exr"), "estimated distribution"),
    ]
}

/// What the trade-off reads (the data, the scene and what it refers to) and writes.
fn plan(config: &TradeoffConfig) -> Result<FilePlan, Error> {
    let mut plan = FilePlan::new();
    plan.input(&config.data, "the measured data");
    if let Some(scene) = &config.scene {
        plan.scene(scene)?;
    }
    for (p, role) in output_files(&config.output) {
        plan.output(p, role);
    }
    Ok(plan)
}

/// The scene the representations are rendered in, with each one as its "subject".
struct Stage {
    scene: Value,
    file: String,
    base: PathBuf,
}

impl Stage {
    /// --scene, which must have a material named "subject", or a sphere under the built-in
    /// studio environment.
    fn new(config: &TradeoffConfig) -> Result<Self, Error> {
        let Some(p) = &config.scene else {
            return Ok(Self {
                scene: default_scene(config.size),
                file: "tradeoff-sphere".to_string(),
                base: PathBuf::from("."),
            });
        };
        let v = lobe_renderer::scene::read_json(p)?;
        if v.pointer("/materials/subject").is_none() {
            return Err(Error::file(
                p.display(),
                "materials.subject: missing; expected the material the representations replace",
            ));
        }
        let base = p.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(Self {
            scene: v,
            file: p.display().to_string(),
            base,
        })
    }

    /// The image and render seconds of the scene with `desc` as its subject.
    fn render(&self, desc: &Value, spp: u32) -> Result<(Image, f64), Error> {
        let mut v = self.scene.clone();
        v["materials"]["subject"] = desc.clone();
        let mut scene = from_value(&v, &self.file, &self.base, &LoadOptions::with_builtins())?;
        scene.settings.spp = spp;
        let (img, stats) = render(&scene, &RenderOptions::default())?;
        Ok((img, stats.seconds))
    }
}

/// Refuses spp settings the study cannot use.
fn check(config: &TradeoffConfig) -> Result<(), Error> {
    if config.spp < 16 || config.reference_spp < config.spp {
        return Err(Error::Other(format!(
            "--spp {} / --reference-spp {}: expected spp >= 16 and reference-spp >= spp",
            config.spp, config.reference_spp
        )));
    }
    Ok(())
}

/// Runs the study (see the module doc) and writes the estimated distribution's table
/// (STEM-microfacet.exr); `say` receives progress lines and warnings.
pub fn study(
    registry: &Registry,
    config: &TradeoffConfig,
    say: &dyn Fn(String),
) -> Result<Study, Error> {
    check(config)?;
    let data_path = std::fs::canonicalize(&config.data).map_err(|e| {
        Error::file(
            config.data.display(),
            format!("cannot open: {e}; expected a MERL, binned or RGL file"),
        )
    })?;
    plan(config)?.check()?;
    let kind = format::detect(&data_path)?.material_type();
    let measured_desc = json!({"type": kind, "file": data_path.display().to_string()});
    let stage = Stage::new(config)?;
    let data = Dataset::read(&data_path, config.resolution)?;
    let source = data_path.display().to_string();
    data.check().map_err(|m| Error::file(&source, m))?;
    let mut reps: Vec<Representation> = vec![("measured".into(), measured_desc.clone(), 0.0)];
    reps.extend(fitted(registry, &data, &source, config, say)?);
    say(format!(
        "rendering the reference at {} spp",
        config.reference_spp
    ));
    let (reference, _) = stage.render(&measured_desc, config.reference_spp)?;
    let ctx = BuildContext::new(&stage.base, registry);
    let mut rows = Vec::new();
    for rep in reps {
        let b = registry
            .create_with(&rep.1, &rep.0, &ctx)
            .map_err(|e| Error::Other(e.to_string()))?;
        rows.push(measure_one(
            rep,
            b.as_ref(),
            &stage,
            &reference,
            config.spp,
            say,
        )?);
    }
    let budget = rows[0].seconds;
    for r in rows.iter_mut() {
        equal_time(r, &stage, &reference, config.spp, budget)?;
    }
    Ok(Study {
        rows,
        budget,
        max_albedo: data.max_albedo,
        source,
        spp: config.spp,
        reference_spp: config.reference_spp,
    })
}

/// The representations made from the data: the estimated microfacet distribution (its
/// table written to STEM-microfacet.exr) and every chosen analytic fit.
fn fitted(
    registry: &Registry,
    data: &Dataset,
    source: &str,
    config: &TradeoffConfig,
    say: &dyn Fn(String),
) -> Result<Vec<Representation>, Error> {
    let specs = builtin_specs();
    let chosen = choose(&specs, config.models.as_deref(), data.anisotropic)?;
    say(format!(
        "{source}: {} bins; estimating the microfacet distribution",
        data.samples.len()
    ));
    let est = estimate(data, 129, None, 5).map_err(|m| Error::file(source, m))?;
    let [.., (exr, _)] = output_files(&config.output);
    est.table.write_exr(&exr)?;
    let exr_abs = std::fs::canonicalize(&exr).unwrap_or(exr.clone());
    let mut reps = vec![(
        "sampled-microfacet".into(),
        est.material(&exr_abs.display().to_string()),
        est.error,
    )];
    for spec in chosen {
        let r = fit(registry, data, spec, 300).map_err(|m| Error::file(source, m))?;
        say(format!(
            "  fitted {}: Eq. (1) error {:.4e}",
            spec.label, r.error
        ));
        reps.push((spec.label.to_string(), r.material, r.error));
    }
    Ok(reps)
}

/// One representation's costs, memory and image errors at 1/16, 1/4 and all of `spp`
/// (the convergence curve); its equal-time errors are left NaN for [`equal_time`].
fn measure_one(
    (name, desc, brdf_error): Representation,
    b: &dyn lobe_materials::Bsdf,
    stage: &Stage,
    reference: &Image,
    spp: u32,
    say: &dyn Fn(String),
) -> Result<Row, Error> {
    let cost = measure(b);
    let mut curve = Vec::new();
    let mut robust_curve = Vec::new();
    let mut last = None;
    for s in [spp / 16, spp / 4, spp] {
        let (img, secs) = stage.render(&desc, s)?;
        let (m, _) = metrics(&img, reference, 0.0)?;
        let r = robust_error(&img, reference)?;
        curve.push((secs, m.rmse));
        robust_curve.push((secs, r.median_of_means_rmse));
        last = Some((secs, m, r));
    }
    let (seconds, m, r) = last.expect("three renders");
    say(format!(
        "  {name}: {seconds:.2} s at {spp} spp, RMSE {:.4e} (median of means {:.4e}), FLIP {:.4}",
        m.rmse, r.median_of_means_rmse, m.flip
    ));
    if r.outliers > 0 {
        say(format!(
            "  warning: {name}: {} outlier pixel(s) (worst at ({}, {}), squared error {:.3e}) decide its RMSE; compare the median-of-means column",
            r.outliers, r.worst.1, r.worst.2, r.worst.0
        ));
    }
    Ok(Row {
        name,
        desc,
        brdf_error,
        eval_ns: cost.eval_ns,
        sample_ns: cost.sample_ns,
        memory: b.memory_bytes(),
        seconds,
        rmse: m.rmse,
        robust_rmse: r.median_of_means_rmse,
        outliers: r.outliers,
        flip: m.flip,
        curve,
        robust_curve,
        equal_time_rmse: f64::NAN,
        equal_time_robust_rmse: f64::NAN,
    })
}

/// Equal time: the representation rendered again with the spp that fits the measured
/// table's render time `budget` (from its own measured rate), up to 16x the fixed spp; the
/// error at exactly the budget is then interpolated on its curve.
fn equal_time(
    r: &mut Row,
    stage: &Stage,
    reference: &Image,
    spp: u32,
    budget: f64,
) -> Result<(), Error> {
    let spp_eq = ((spp as f64 * budget / r.seconds.max(1e-6)).round() as u32).clamp(1, 16 * spp);
    if spp_eq != spp {
        let (img, secs) = stage.render(&r.desc, spp_eq)?;
        let (m, _) = metrics(&img, reference, 0.0)?;
        r.curve.push((secs, m.rmse));
        r.curve.sort_by(|a, b| a.0.total_cmp(&b.0));
        let e = robust_error(&img, reference)?;
        r.robust_curve.push((secs, e.median_of_means_rmse));
        r.robust_curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    r.equal_time_rmse = at_time(&r.curve, budget);
    r.equal_time_robust_rmse = at_time(&r.robust_curve, budget);
    Ok(())
}

/// The study as a Markdown table, with how it was measured.
pub fn markdown(study: &Study) -> String {
    let mut md = format!(
        "# Trade-off for {}\n\nReference: the measured table at {} spp. Renders at {} spp; \
         equal-time error at the measured table's render time ({:.2} s): each \
         representation is rendered again with the spp its rate allows in that time (at most \
         16x), and the error interpolated on its convergence curve ({}, {}, {} spp and that \
         one). The reference's own noise is part of every image error. Next to each RMSE, the \
         median-of-means RMSE (median of 16 pixel groups' mean squared errors, \
         lobe_renderer::error_stats), which a few firefly pixels cannot decide; outliers are \
         pixels whose squared error exceeds 1000x that median.\n\n\
         | representation | Eq. (1) error (normalized) | image RMSE | median-of-means RMSE | outlier pixels | FLIP | eval ns | sample ns | memory | render s | RMSE at equal time | median-of-means RMSE at equal time |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
        study.source,
        study.reference_spp,
        study.spp,
        study.budget,
        study.spp / 16,
        study.spp / 4,
        study.spp
    );
    for r in &study.rows {
        let mem = if r.memory >= 1 << 20 {
            format!("{:.1} MiB", r.memory as f64 / (1 << 20) as f64)
        } else {
            format!("{:.1} KiB", r.memory as f64 / 1024.0)
        };
        md.push_str(&format!(
            "| {} | {:.3e} ({:.3e}) | {:.3e} | {:.3e} | {} | {:.4} | {:.0} | {:.0} | {mem} | {:.2} | {:.3e} | {:.3e} |\n",
            r.name,
            r.brdf_error,
            r.brdf_error / study.max_albedo.max(1e-300),
            r.rmse,
            r.robust_rmse,
            r.outliers,
            r.flip,
            r.eval_ns,
            r.sample_ns,
            r.seconds,
            r.equal_time_rmse,
            r.equal_time_robust_rmse
        ));
    }
    md
}

/// The study as CSV, one row per representation with its material description.
pub fn csv(study: &Study) -> String {
    let mut csv = String::from(
        "representation,eq1_error,eq1_error_normalized,image_rmse,median_of_means_rmse,outlier_pixels,flip,eval_ns,sample_ns,memory_bytes,render_seconds,equal_time_rmse,equal_time_median_of_means_rmse,material\n",
    );
    for r in &study.rows {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
            r.name,
            r.brdf_error,
            r.brdf_error / study.max_albedo.max(1e-300),
            r.rmse,
            r.robust_rmse,
            r.outliers,
            r.flip,
            r.eval_ns,
            r.sample_ns,
            r.memory,
            r.seconds,
            r.equal_time_rmse,
            r.equal_time_robust_rmse,
            r.desc.to_string().replace('"', "\"\"")
        ));
    }
    csv
}

/// Writes STEM.md, STEM.csv and the Pareto plot STEM.png (and .svg) of a study (STEM from
/// [`TradeoffConfig::output`]).
pub fn write(study: &Study, stem: &Path) -> Result<(), Error> {
    let [(md_path, _), (csv_path, _), (png_path, _), _, _] = output_files(stem);
    let write = |p: &Path, text: &str| {
        lobe_renderer::film::atomic_write(p, |w| std::io::Write::write_all(w, text.as_bytes()))
    };
    write(&md_path, &markdown(study))?;
    write(&csv_path, &csv(study))?;
    pareto(&study.rows)?.save(&png_path)
}

/// The Pareto front of (time, error) points: the indices of the points no other point
/// beats in both (none faster and at most as wrong, or as fast and less wrong), by time.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for k in order {
        if points[k].1 < best {
            best = points[k].1;
            front.push(k);
        }
    }
    front
}

/// Render time against image RMSE (log-log): one point per representation in its
/// model's style, labels placed so that none overprints another or a point
/// ([`crate::plot::place_labels`]), and the Pareto front drawn as a staircase.
pub fn pareto(rows: &[Row]) -> Result<Figure, Error> {
    register_font();
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.seconds.max(1e-4).log10(), r.robust_rmse.max(1e-9).log10()))
        .collect();
    let (x0, x1) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let front = pareto_front(&pts);
    // Margins of a tenth of the spans (at least a twentieth of a decade): the points fill
    // the plot, with room for labels.
    let (px, py) = ((0.1 * (x1 - x0)).max(0.05), (0.1 * (y1 - y0)).max(0.05));
    let font = ("sans-serif", 14).into_font();
    let sizes: Vec<(u32, u32)> = rows
        .iter()
        .map(|r| {
            font.box_size(&r.name)
                .unwrap_or((8 * r.name.len() as u32, 14))
        })
        .collect();
    Ok(crate::vector_figure!((W, H), |root| {
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "render time against image error (lower left is better; dashed: the Pareto front)",
                ("sans-serif", 20),
            )
            .margin(20)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0 - px..x1 + 2.0 * px, y0 - py..y1 + py)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .max_light_lines(4)
            .x_desc("log10 render seconds at fixed spp")
            .y_desc("log10 median-of-means image RMSE")
            .draw()
            .map_err(plot_err)?;
        // The front: from each front point right to the next one's time, then down.
        let mut stairs = Vec::new();
        for (i, &k) in front.iter().enumerate() {
            stairs.push(pts[k]);
            let next = front.get(i + 1).map_or(x1 + 2.0 * px, |&n| pts[n].0);
            stairs.push((next, pts[k].1));
        }
        // The staircase's segments, as boxes that labels keep off.
        let lines: Vec<crate::plot::PixelBox> = stairs
            .windows(2)
            .map(|w| {
                let (a, b) = (chart.backend_coord(&w[0]), chart.backend_coord(&w[1]));
                (
                    a.0.min(b.0) - 2,
                    a.1.min(b.1) - 2,
                    a.0.max(b.0) + 3,
                    a.1.max(b.1) + 3,
                )
            })
            .collect();
        chart
            .draw_series(DashedLineSeries::new(
                stairs,
                6,
                4,
                RGBColor(90, 90, 90).stroke_width(2),
            ))
            .map_err(plot_err)?;
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let at: Vec<(i32, i32)> = pts.iter().map(|p| chart.backend_coord(p)).collect();
        let bounds = (xr.start, yr.start, xr.end, yr.end);
        let boxes = crate::plot::place_labels(&at, &sizes, 7, bounds, &lines);
        for ((r, &p), b) in rows.iter().zip(&at).zip(&boxes) {
            // A leader line to a label pushed away from its point.
            let end = (p.0.clamp(b.0, b.2 - 1), p.1.clamp(b.1, b.3 - 1));
            if (end.0 - p.0).abs().max((end.1 - p.1).abs()) > 14 {
                root.draw(&PathElement::new(vec![p, end], RGBColor(150, 150, 150)))
                    .map_err(plot_err)?;
            }
            draw_marker(&root, p, 6, style(&r.name))?;
            root.draw(&Text::new(r.name.clone(), (b.0, b.1), font.clone()))
                .map_err(plot_err)?;
        }
    }))
}

#[cfg(test)]
mod header_tests {
    use super::*;

    #[test]
    fn the_header_puts_each_setting_in_its_place() {
        let study = Study {
            rows: Vec::new(),
            budget: 0.262,
            max_albedo: 1.0,
            source: "paper.bsdf".into(),
            spp: 64,
            reference_spp: 1024,
        };
        let md = markdown(&study);
        assert!(md.contains("measured table at 1024 spp"), "{md}");
        assert!(md.contains("Renders at 64 spp"), "{md}");
        assert!(md.contains("render time (0.26 s)"), "{md}");
        assert!(md.contains("(4, 16, 64 spp and that one)"), "{md}");
    }

    #[test]
    fn the_pareto_front_keeps_what_nothing_beats() {
        let pts = [
            (1.0, 5.0),
            (2.0, 3.0),
            (2.0, 4.0),
            (3.0, 3.0),
            (0.5, 9.0),
            (4.0, 1.0),
        ];
        assert_eq!(pareto_front(&pts), vec![4, 0, 1, 5]);
        assert!(pareto_front(&[]).is_empty());
    }
}
