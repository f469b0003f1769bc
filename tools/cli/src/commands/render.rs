//! `lobe render`: render a scene file (or the built-in showcase) to EXR, a tonemapped PNG
//! and a statistics JSON, or benchmark the renderer (`--bench`, Msamples/s); render a range
//! of the samples to a partial render (`--samples A:B`, [`lobe_renderer::partial`]) and
//! join partial renders into the image (`lobe render merge`).

use crate::args::{self, finite};
use lobe_analysis::plot::draw_labels;
use lobe_materials::io::OutputSet;
use lobe_renderer::film::Image;
use lobe_renderer::outputs::{FilePlan, RenderFiles};
use lobe_renderer::partial::PartialRender;
use lobe_renderer::render::{Progress, RenderOptions, RenderStats, render, render_samples};
use lobe_renderer::scene::Scene;
use lobe_renderer::{Error, film, image_io};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct RenderArgs {
    #[command(subcommand)]
    sub: Option<RenderSub>,
    /// Scene file (JSON, see docs/scene-format.md). Without it, the built-in showcase.
    scene: Option<PathBuf>,
    /// Output path, NAME.exr or NAME.png: the render writes NAME.exr (linear), NAME.png
    /// (tonemapped) and NAME.stats.json side by side.
    /// Default: out/<scene name>.exr
    #[arg(long, short)]
    output: Option<PathBuf>,
    /// Samples per pixel (overrides the scene's sampler.spp).
    #[arg(long)]
    spp: Option<u32>,
    /// Sampler seed (overrides the scene's sampler.seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// PNG exposure in stops (overrides the scene's film.exposure).
    #[arg(long, value_parser = finite::<f32>)]
    exposure: Option<f32>,
    /// Do not write the PNG.
    #[arg(long)]
    no_png: bool,
    /// Also write the per-pixel variance of the mean as NAME.var.exr (for `lobe compare
    /// --z-test` and noise-aware comparisons).
    #[arg(long)]
    variance: bool,
    /// Benchmark: render several times without writing anything and report Msamples/s and
    /// where the scene's loading went (mesh reading, BVH build). Without a scene, renders the built-in benchmark (one diffuse sphere under a
    /// 512x256 environment map, 256x256 pixels, path tracer of depth 8).
    #[arg(long)]
    bench: bool,
    /// Number of timed runs for --bench.
    #[arg(long, default_value_t = 3, requires = "bench")]
    runs: u32,
    /// Render only the samples FIRST to LAST-1 of every pixel (of the scene's spp) to a
    /// partial render, -o NAME.lobepart; `lobe render merge` joins the parts of disjoint
    /// ranges into the whole render's image.
    #[arg(long, value_name = "FIRST:LAST", conflicts_with = "bench")]
    samples: Option<String>,
}

#[derive(clap::Subcommand)]
enum RenderSub {
    /// Join partial renders (`lobe render --samples A:B`) of one scene whose ranges cover
    /// every sample into the image, NAME.exr with NAME.png and NAME.stats.json.
    Merge {
        /// The partial renders (.lobepart), in any order.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Output path, NAME.exr or NAME.png.
        #[arg(long, short)]
        output: PathBuf,
        /// PNG exposure in stops.
        #[arg(long, default_value_t = 0.0, value_parser = finite::<f32>)]
        exposure: f32,
        /// Do not write the PNG.
        #[arg(long)]
        no_png: bool,
        /// Also write the variance of each pixel's mean as NAME.var.exr.
        #[arg(long)]
        variance: bool,
    },
}

fn load_scene(args: &RenderArgs) -> Result<Scene, Error> {
    let mut scene = match &args.scene {
        Some(p) => lobe_renderer::scene::load(p)?,
        None if args.bench => lobe_renderer::showcase::bench_scene()?,
        None => lobe_renderer::showcase::showcase()?,
    };
    if let Some(spp) = args.spp {
        scene.settings.spp = args::check_spp("--spp", spp)?;
    }
    if let Some(seed) = args.seed {
        scene.settings.seed = seed;
    }
    if let Some(e) = args.exposure {
        scene.settings.exposure = e;
    }
    Ok(scene)
}

/// The files a render writes: from -o, or out/<scene name>.exr.
fn render_files(args: &RenderArgs) -> Result<RenderFiles, Error> {
    let output = match (&args.output, &args.scene) {
        (Some(p), _) => p.clone(),
        (None, Some(scene)) => {
            let stem = scene
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("render");
            Path::new("out").join(format!("{stem}.exr"))
        }
        (None, None) => PathBuf::from("out/showcase.exr"),
    };
    RenderFiles::new(&output, !args.no_png, args.variance)
}

pub fn cmd_render(args: RenderArgs, quiet: bool) -> Result<(), Error> {
    if let Some(RenderSub::Merge {
        inputs,
        output,
        exposure,
        no_png,
        variance,
    }) = &args.sub
    {
        let files = RenderFiles::new(output, !no_png, *variance)?;
        return merge_parts(inputs, &files, *exposure, quiet);
    }
    if args.threads == Some(0) {
        return Err(Error::Other(
            "--threads: expected at least 1 thread, found 0".into(),
        ));
    }
    let show_bar = !quiet && !args.bench && std::io::stderr().is_terminal();
    let opts = |scene_kind: &'static str, bar: Option<&indicatif::ProgressBar>| RenderOptions {
        threads: args.threads,
        progress: bar.map(|b| {
            let b = b.clone();
            Progress::new(move |done, total| {
                b.set_length(total);
                b.set_position(done);
            })
        }),
        cancel: Some(args::ctrl_c(scene_kind)),
    };
    if args.runs == 0 {
        return Err(Error::Other(
            "--runs: expected at least 1 timed run, found 0".into(),
        ));
    }
    if args.bench {
        let ack = "interrupted: stopping the benchmark; Ctrl-C again to abort";
        return bench(&load_scene(&args)?, &opts(ack, None), args.runs, quiet);
    }
    if let Some(range) = &args.samples {
        return render_part(&args, range, &opts, quiet);
    }
    let files = render_files(&args)?;
    let mut plan = FilePlan::new();
    if let Some(scene) = &args.scene {
        plan.scene(scene)?;
    }
    files.plan(&mut plan);
    plan.check_overlaps()?;
    if args.output.is_none() {
        std::fs::create_dir_all("out")
            .map_err(|e| Error::file("out", format!("cannot create the output folder: {e}")))?;
    }
    plan.check()?;
    let scene = load_scene(&args)?;
    let ack = "interrupted: stopping the render, nothing is written; Ctrl-C again to abort";
    // Made once the scene is loaded, so that its clock and ETA are the render's.
    let bar = show_bar.then(progress_bar);
    let rendered = render(&scene, &opts(ack, bar.as_ref()));
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let (img, stats) = rendered?;
    if args::cancelled() {
        return Err(Error::Other(
            "interrupted after the render: nothing is written".into(),
        ));
    }
    let labels = match args.scene {
        Some(_) => Vec::new(),
        None => lobe_renderer::showcase::labels(&scene),
    };
    write_render(&files, &img, &scene, &stats, &labels)?;
    if !quiet {
        eprintln!("{}", stats.summary());
        eprintln!("{}", stats.load_summary());
        if !labels.is_empty() {
            let names: Vec<&str> = labels.iter().map(|l| l.0.as_str()).collect();
            eprintln!("showcase spheres, left to right: {}", names.join(", "));
        }
        let all: Vec<String> = files
            .all()
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        eprintln!("wrote {}", all.join(", "));
    }
    stats.check_dropped(&scene.file)
}

/// The range of `--samples FIRST:LAST`.
fn parse_range(s: &str) -> Result<(u32, u32), Error> {
    let bad = || {
        Error::Other(format!(
            "--samples: expected FIRST:LAST (sample indices, FIRST < LAST), found \"{s}\""
        ))
    };
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let (a, b) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a >= b {
        return Err(bad());
    }
    Ok((a, b))
}

/// `--samples FIRST:LAST`: renders that range of every pixel's samples to -o NAME.lobepart.
fn render_part(
    args: &RenderArgs,
    range: &str,
    opts: &dyn Fn(&'static str, Option<&indicatif::ProgressBar>) -> RenderOptions,
    quiet: bool,
) -> Result<(), Error> {
    let range = parse_range(range)?;
    let output = args
        .output
        .clone()
        .filter(|o| o.extension().is_some_and(|e| e == "lobepart"))
        .ok_or_else(|| {
            Error::Other("--samples: expected -o NAME.lobepart, the partial render to write".into())
        })?;
    let mut plan = FilePlan::new();
    if let Some(scene) = &args.scene {
        plan.scene(scene)?;
    }
    plan.output(&output, "partial render").check()?;
    let scene = load_scene(args)?;
    let ack = "interrupted: stopping the render, nothing is written; Ctrl-C again to abort";
    let (part, stats) = render_samples(&scene, range, &opts(ack, None))?;
    if args::cancelled() {
        return Err(Error::Other(
            "interrupted after the render: nothing is written".into(),
        ));
    }
    let bytes = part.to_bytes();
    film::atomic_write(&output, |w| std::io::Write::write_all(w, &bytes))?;
    if !quiet {
        eprintln!(
            "samples {}:{} of {}: {}",
            range.0,
            range.1,
            scene.settings.spp,
            stats.summary()
        );
        eprintln!("wrote {}", output.display());
    }
    stats.check_dropped(&scene.file)
}

/// `lobe render merge`: joins partial renders into the image files.
fn merge_parts(
    inputs: &[PathBuf],
    files: &RenderFiles,
    exposure: f32,
    quiet: bool,
) -> Result<(), Error> {
    let mut plan = FilePlan::new();
    for p in inputs {
        plan.input(p, "a partial render");
    }
    files.plan(&mut plan);
    plan.check()?;
    let mut parts = Vec::new();
    for p in inputs {
        let bytes = lobe_materials::io::read_regular(
            p,
            lobe_materials::io::MAX_DATA_BYTES,
            "a partial render (.lobepart)",
        )?;
        parts.push(PartialRender::from_bytes(&bytes, &p.display().to_string())?);
    }
    let merged = PartialRender::merge(parts)?;
    let img = merged.image()?;
    let mut set = OutputSet::new();
    let (w, h) = (img.width, img.height);
    stage_images(&mut set, files, &img, (exposure, &[]))?;
    let stats = serde_json::json!({
        "width": w, "height": h, "spp": merged.spp, "key": merged.key,
        "nonfinite_dropped": merged.dropped,
        "parts": inputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "lobe_version": env!("CARGO_PKG_VERSION"),
    });
    set.stage(&files.stats, |out| film::encode_json(out, &stats))?;
    set.commit()?;
    if !quiet {
        eprintln!(
            "merged {} partial renders ({w}x{h} at {} spp) into {}",
            inputs.len(),
            merged.spp,
            files.exr.display()
        );
    }
    Ok(())
}

/// The bar on stderr that the render's progress reports drive (pixels done, with ETA).
fn progress_bar() -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(0);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} ETA {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb
}

/// Stages a render's images: the EXR, the variance EXR and the PNG at `exposure` stops
/// with `labels` drawn on it, as `files` asks.
fn stage_images(
    set: &mut OutputSet,
    files: &RenderFiles,
    img: &Image,
    (exposure, labels): (f32, &[(String, glam::Vec2)]),
) -> Result<(), Error> {
    let (w, h) = (img.width, img.height);
    set.stage(&files.exr, |out| {
        image_io::encode_exr(out, w, h, &img.pixels)
    })?;
    if let Some(v) = &files.variance {
        set.stage(v, |out| image_io::encode_exr(out, w, h, &img.variance))?;
    }
    if let Some(png) = &files.png {
        let mut rgb = film::tonemap(&img.pixels, exposure);
        draw_labels(&mut rgb, (w, h), labels)?;
        set.stage(png, |out| image_io::encode_png_rgb8(out, w, h, &rgb))?;
    }
    Ok(())
}

/// Writes every file of a render; the PNG carries `labels` (text at pixel positions).
fn write_render(
    files: &RenderFiles,
    img: &Image,
    scene: &Scene,
    stats: &RenderStats,
    labels: &[(String, glam::Vec2)],
) -> Result<(), Error> {
    // All or none: each file is staged, then the set is moved into place together.
    let mut set = OutputSet::new();
    stage_images(&mut set, files, img, (scene.settings.exposure, labels))?;
    let stats = stats_json(scene, stats, files);
    set.stage(&files.stats, |out| film::encode_json(out, &stats))?;
    Ok(set.commit()?)
}

fn stats_json(scene: &Scene, stats: &RenderStats, files: &RenderFiles) -> serde_json::Value {
    let mut v = stats.to_json();
    let o = v.as_object_mut().expect("object");
    o.insert("scene".into(), scene.file.clone().into());
    o.insert("seed".into(), scene.settings.seed.into());
    o.insert("scramble".into(), scene.settings.scramble.name().into());
    o.insert(
        "integrator".into(),
        scene.settings.integrator.describe().into(),
    );
    o.insert("exr".into(), files.exr.display().to_string().into());
    if let Some(p) = &files.png {
        o.insert("png".into(), p.display().to_string().into());
        o.insert("exposure".into(), scene.settings.exposure.into());
    }
    o.insert("lobe_version".into(), env!("CARGO_PKG_VERSION").into());
    v
}

fn bench(scene: &Scene, opts: &RenderOptions, runs: u32, quiet: bool) -> Result<(), Error> {
    // One untimed warm-up run (page faults, thread pool start-up).
    let _ = render(scene, opts)?;
    let mut rates = Vec::new();
    let mut last = None;
    for i in 0..runs {
        let (_, stats) = render(scene, opts)?;
        if !quiet {
            eprintln!("run {}: {}", i + 1, stats.summary());
        }
        rates.push((stats.msamples_per_second(), stats.seconds));
        last = Some(stats);
    }
    rates.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (median, seconds) = rates[rates.len() / 2];
    println!(
        "bench {}: {}x{} at {} spp, {}: median {:.2} Msamples/s ({:.2} s) over {} runs",
        scene.file,
        scene.settings.width,
        scene.settings.height,
        scene.settings.spp,
        scene.settings.integrator.describe(),
        median,
        seconds,
        runs
    );
    if let Some(stats) = last {
        println!("{}", stats.load_summary());
    }
    Ok(())
}
