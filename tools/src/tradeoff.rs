//! `lobe tradeoff`: the speed/accuracy/memory trade between the representations of one
//! measured material (Ngan et al. 2005 compare fits in BRDF space, Eq. 1, and in renderings,
//! Figures 3 and 6): the measured table itself, the APS2000 generator with a distribution
//! estimated from it (section 5), and every analytic fit (section 4). For each it measures
//! the Eq. (1) error, the image error against a high-spp render of the measured table (RMSE
//! and FLIP), eval and sample cost per call, memory, render time at a fixed spp, and the
//! image error at equal render time (from a convergence curve over spp); each image error
//! also as the median-of-means RMSE with its outlier pixels (lobe_renderer::error_stats), so
//! that a firefly cannot decide a published number; writes Markdown, CSV and a Pareto plot
//! (render time against median-of-means image error).

use crate::args::finite;
use crate::figures::{H, PALETTE, W, plot_err, register_font, save};
use lobe_materials::Bsdf;
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::{builtin_specs, fit};
use lobe_materials::measured::format;
use lobe_materials::microfacet_gen::estimate;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_materials::sampling::warp;
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

#[derive(clap::Args)]
pub struct TradeoffArgs {
    /// Measured data: a MERL table, binned data or an RGL file (told apart by content).
    data: PathBuf,
    /// A scene whose `materials` has an entry named "subject", replaced by each
    /// representation (default: a sphere under the built-in studio environment).
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Samples per pixel of the reference render of the measured table.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Samples per pixel of the compared renders (the convergence curve also renders at
    /// 1/16 and 1/4 of it).
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Image size of the default scene.
    #[arg(long, default_value_t = 128)]
    size: u32,
    /// Bin size in degrees of the fitted data (the study: 1).
    #[arg(long, default_value_t = 2.0, value_parser = finite::<f64>)]
    resolution: f64,
    /// Comma-separated fitted models (default: the study's seven, or the three anisotropic
    /// ones for anisotropic data).
    #[arg(long)]
    models: Option<String>,
    /// Output stem: STEM.md, STEM.csv, STEM.png, STEM-microfacet.exr.
    #[arg(long, short)]
    output: PathBuf,
}

struct Row {
    name: String,
    desc: Value,
    brdf_error: f64,
    eval_ns: f64,
    sample_ns: f64,
    memory: usize,
    seconds: f64,
    rmse: f64,
    /// Median-of-means RMSE and outlier pixels (lobe_renderer::error_stats).
    robust_rmse: f64,
    outliers: usize,
    flip: f64,
    curve: Vec<(f64, f64)>,
    robust_curve: Vec<(f64, f64)>,
    equal_time_rmse: f64,
    equal_time_robust_rmse: f64,
}

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

/// Nanoseconds per eval and per sample over a fixed set of direction pairs.
/// One timing case: wo, wi, the 2D and 1D sample.
type Case = (glam::Vec3, glam::Vec3, glam::Vec2, f32);

pub(crate) fn cost(b: &dyn Bsdf) -> (f64, f64) {
    let n = 1 << 15;
    let mut state = 0x853c49e6748fea9bu64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 + 0.5) / (1u64 << 24) as f32
    };
    let dirs: Vec<Case> = (0..n)
        .map(|_| {
            let a = warp::square_to_cosine_hemisphere(glam::Vec2::new(next(), next()));
            let b = warp::square_to_cosine_hemisphere(glam::Vec2::new(next(), next()));
            (a, b, glam::Vec2::new(next(), next()), next())
        })
        .collect();
    let time = |f: &dyn Fn(&Case) -> f32| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let mut acc = 0.0f32;
            for d in &dirs {
                acc += f(d);
            }
            std::hint::black_box(acc);
            best = best.min(t.elapsed().as_secs_f64() * 1e9 / n as f64);
        }
        best
    };
    (
        time(&|d| b.eval(d.0, d.1).r),
        time(&|d| b.sample(d.0, d.2, d.3).map_or(0.0, |s| s.pdf)),
    )
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
fn output_files(stem: &Path) -> [(PathBuf, &'static str); 4] {
    let at = |suffix: &str| PathBuf::from(format!("{}{suffix}", stem.display()));
    [
        (at(".md"), "Markdown table"),
        (at(".csv"), "CSV table"),
        (at(".png"), "Pareto plot"),
        (at("-microfacet.exr"), "estimated distribution"),
    ]
}

/// What the trade-off reads (the data, the scene and what it refers to) and writes.
fn plan(args: &TradeoffArgs) -> Result<FilePlan, Error> {
    let mut plan = FilePlan::new();
    plan.input(&args.data, "the measured data");
    if let Some(scene) = &args.scene {
        plan.scene(scene)?;
    }
    for (p, role) in output_files(&args.output) {
        plan.output(p, role);
    }
    Ok(plan)
}

/// The scene (JSON), its name and its folder: --scene, which must have a material named
/// "subject", or a sphere under the built-in studio environment.
fn scene(args: &TradeoffArgs) -> Result<(Value, String, PathBuf), Error> {
    let Some(p) = &args.scene else {
        return Ok((
            default_scene(args.size),
            "tradeoff-sphere".to_string(),
            PathBuf::from("."),
        ));
    };
    let v = lobe_renderer::scene::read_json(p)?;
    if v.pointer("/materials/subject").is_none() {
        return Err(Error::file(
            p.display(),
            "materials.subject: missing; expected the material the representations replace",
        ));
    }
    let base = p.parent().map(Path::to_path_buf).unwrap_or_default();
    Ok((v, p.display().to_string(), base))
}

pub fn cmd_tradeoff(args: TradeoffArgs, quiet: bool) -> Result<(), Error> {
    if args.spp < 16 || args.reference_spp < args.spp {
        return Err(Error::Other(format!(
            "--spp {} / --reference-spp {}: expected spp >= 16 and reference-spp >= spp",
            args.spp, args.reference_spp
        )));
    }
    let data_path = std::fs::canonicalize(&args.data).map_err(|e| {
        Error::file(
            args.data.display(),
            format!("cannot open: {e}; expected a MERL, binned or RGL file"),
        )
    })?;
    plan(&args)?.check()?;
    let kind = format::detect(&data_path)?.material_type();
    let measured_desc = json!({"type": kind, "file": data_path.display().to_string()});
    let say = |m: String| {
        if !quiet {
            eprintln!("{m}");
        }
    };
    let (scene_v, scene_file, base) = scene(&args)?;
    let render_with = |desc: &Value, spp: u32| -> Result<(Image, f64), Error> {
        let mut v = scene_v.clone();
        v["materials"]["subject"] = desc.clone();
        let mut scene = from_value(&v, &scene_file, &base, &LoadOptions::with_builtins())?;
        scene.spp = spp;
        let (img, stats) = render(&scene, &RenderOptions::default())?;
        Ok((img, stats.seconds))
    };
    // Fits and the estimated distribution.
    let data = Dataset::read(&data_path, args.resolution)?;
    let source = data_path.display().to_string();
    data.check().map_err(|m| Error::file(&source, m))?;
    let specs = builtin_specs();
    let chosen = crate::fit::choose(&specs, &args.models, data.anisotropic)?;
    let mut reps: Vec<(String, Value, f64)> = vec![("measured".into(), measured_desc.clone(), 0.0)];
    say(format!(
        "{source}: {} bins; estimating the microfacet distribution",
        data.samples.len()
    ));
    let est = estimate(&data, 129, None, 5).map_err(|m| Error::file(&source, m))?;
    let [.., (exr, _)] = output_files(&args.output);
    est.table.write_exr(&exr)?;
    let exr_abs = std::fs::canonicalize(&exr).unwrap_or(exr.clone());
    reps.push((
        "sampled-microfacet".into(),
        est.material(&exr_abs.display().to_string()),
        est.error,
    ));
    let registry = Registry::builtin();
    for spec in chosen {
        let r = fit(&registry, &data, spec, 300).map_err(|m| Error::file(&source, m))?;
        say(format!(
            "  fitted {}: Eq. (1) error {:.4e}",
            spec.label, r.error
        ));
        reps.push((spec.label.to_string(), r.material, r.error));
    }
    // The reference.
    say(format!(
        "rendering the reference at {} spp",
        args.reference_spp
    ));
    let (reference, _) = render_with(&measured_desc, args.reference_spp)?;
    let ctx = BuildContext::new(&base, &registry);
    let spps = [args.spp / 16, args.spp / 4, args.spp];
    let mut rows = Vec::new();
    for (name, desc, brdf_error) in reps {
        let b = registry
            .create_with(&desc, &name, &ctx)
            .map_err(|e| Error::Other(e.to_string()))?;
        let (eval_ns, sample_ns) = cost(b.as_ref());
        let mut curve = Vec::new();
        let mut robust_curve = Vec::new();
        let mut last = None;
        for &spp in &spps {
            let (img, secs) = render_with(&desc, spp)?;
            let (m, _) = metrics(&img, &reference, 0.0)?;
            let r = robust_error(&img, &reference)?;
            curve.push((secs, m.rmse));
            robust_curve.push((secs, r.median_of_means_rmse));
            last = Some((secs, m, r));
        }
        let (seconds, m, r) = last.expect("three renders");
        say(format!(
            "  {name}: {seconds:.2} s at {} spp, RMSE {:.4e} (median of means {:.4e}), FLIP {:.4}",
            args.spp, m.rmse, r.median_of_means_rmse, m.flip
        ));
        if r.outliers > 0 {
            say(format!(
                "  warning: {name}: {} outlier pixel(s) (worst at ({}, {}), squared error {:.3e}) decide its RMSE; compare the median-of-means column",
                r.outliers, r.worst.1, r.worst.2, r.worst.0
            ));
        }
        rows.push(Row {
            name,
            desc,
            brdf_error,
            eval_ns,
            sample_ns,
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
        });
    }
    // Equal time: each representation rendered again with the spp that fits the measured
    // table's render time (from its own measured rate), up to 16x the fixed spp; the error
    // at exactly the budget is then interpolated on its curve.
    let budget = rows[0].seconds;
    for r in rows.iter_mut() {
        let spp_eq = ((args.spp as f64 * budget / r.seconds.max(1e-6)).round() as u32)
            .clamp(1, 16 * args.spp);
        if spp_eq != args.spp {
            let (img, secs) = render_with(&r.desc, spp_eq)?;
            let (m, _) = metrics(&img, &reference, 0.0)?;
            r.curve.push((secs, m.rmse));
            r.curve.sort_by(|a, b| a.0.total_cmp(&b.0));
            let e = robust_error(&img, &reference)?;
            r.robust_curve.push((secs, e.median_of_means_rmse));
            r.robust_curve.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        r.equal_time_rmse = at_time(&r.curve, budget);
        r.equal_time_robust_rmse = at_time(&r.robust_curve, budget);
    }
    write_outputs(&rows, &args, budget, data.max_albedo, &source)?;
    Ok(())
}

fn write_outputs(
    rows: &[Row],
    args: &TradeoffArgs,
    budget: f64,
    max_albedo: f64,
    source: &str,
) -> Result<(), Error> {
    let mut md = format!(
        "# Trade-off for {source}\n\nReference: the measured table at {} spp. Renders at {} spp; \
         equal-time error at the measured table's render time ({budget:.2} s): each \
         representation is rendered again with the spp its rate allows in that time (at most \
         16x), and the error interpolated on its convergence curve ({}, {}, {} spp and that \
         one). The reference's own noise is part of every image error. Next to each RMSE, the \
         median-of-means RMSE (median of 16 pixel groups' mean squared errors, \
         lobe_renderer::error_stats), which a few firefly pixels cannot decide; outliers are \
         pixels whose squared error exceeds 1000x that median.\n\n\
         | representation | Eq. (1) error (normalized) | image RMSE | median-of-means RMSE | outlier pixels | FLIP | eval ns | sample ns | memory | render s | RMSE at equal time | median-of-means RMSE at equal time |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
        args.reference_spp,
        args.spp,
        args.spp / 16,
        args.spp / 4,
        args.spp
    );
    let mut csv = String::from(
        "representation,eq1_error,eq1_error_normalized,image_rmse,median_of_means_rmse,outlier_pixels,flip,eval_ns,sample_ns,memory_bytes,render_seconds,equal_time_rmse,equal_time_median_of_means_rmse,material\n",
    );
    for r in rows {
        let mem = if r.memory >= 1 << 20 {
            format!("{:.1} MiB", r.memory as f64 / (1 << 20) as f64)
        } else {
            format!("{:.1} KiB", r.memory as f64 / 1024.0)
        };
        md.push_str(&format!(
            "| {} | {:.3e} ({:.3e}) | {:.3e} | {:.3e} | {} | {:.4} | {:.0} | {:.0} | {mem} | {:.2} | {:.3e} | {:.3e} |\n",
            r.name,
            r.brdf_error,
            r.brdf_error / max_albedo.max(1e-300),
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
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"\n",
            r.name,
            r.brdf_error,
            r.brdf_error / max_albedo.max(1e-300),
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
    let [(md_path, _), (csv_path, _), (png_path, _), _] = output_files(&args.output);
    let write = |p: &Path, text: &str| {
        lobe_renderer::film::atomic_write(p, |w| std::io::Write::write_all(w, text.as_bytes()))
    };
    write(&md_path, &md)?;
    write(&csv_path, &csv)?;
    pareto(rows, &png_path)?;
    print!("{md}");
    Ok(())
}

/// Render time against image RMSE (log-log), one labelled point per representation.
fn pareto(rows: &[Row], path: &Path) -> Result<(), Error> {
    register_font();
    let xs = rows.iter().map(|r| r.seconds.max(1e-4).log10());
    let ys = rows.iter().map(|r| r.robust_rmse.max(1e-9).log10());
    let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "render time against image error (lower left is better)",
                ("sans-serif", 20),
            )
            .margin(20)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0 - 0.2..x1 + 0.3, y0 - 0.2..y1 + 0.2)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("log10 render seconds at fixed spp")
            .y_desc("log10 median-of-means image RMSE")
            .draw()
            .map_err(plot_err)?;
        for (k, r) in rows.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            let p = (r.seconds.max(1e-4).log10(), r.robust_rmse.max(1e-9).log10());
            chart
                .draw_series(std::iter::once(Circle::new(p, 6, c.filled())))
                .map_err(plot_err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    r.name.clone(),
                    (p.0 + 0.02, p.1 + 0.02),
                    ("sans-serif", 14),
                )))
                .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    save(path, &buf)
}
