//! `lobe`: the command-line front end of lobe (Ngan, Durand and Matusik 2005's system
//! for rendering, fitting and comparing BRDF models).
//!
//! Subcommands: `render` (this step); fit, tabulate, compare, figure, tradeoff and
//! stability arrive with later steps. Errors are one line on stderr and a non-zero exit.

mod compare;
mod eval;
mod figures;
mod fit;
mod microfacet;
mod stability;
mod tabulate;
mod tradeoff;

use clap::{Parser, Subcommand};
use lobe_renderer::render::{RenderOptions, RenderStats, render};
use lobe_renderer::scene::Scene;
use lobe_renderer::{Error, film};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

#[derive(Parser)]
#[command(
    name = "lobe",
    version,
    about = "Render, fit and compare BRDF models (Ngan et al. 2005)"
)]
struct Cli {
    /// Print nothing but errors.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file (or the built-in showcase) to EXR, PNG and a statistics JSON.
    #[command(
        after_help = "Examples:\n  lobe render                                  # built-in showcase -> out/showcase.{exr,png,json}\n  lobe render scenes/sphere-envmap.json --spp 256 -o out/sphere.exr\n  lobe render scenes/cornell-box.json --threads 1 --seed 7\n  lobe render --bench                          # Msamples/s on the sphere-under-env-map benchmark"
    )]
    Render(RenderArgs),
    /// Evaluate f_r (RGB, 1/sr) and the sampling pdf of a material at direction pairs, as CSV.
    #[command(
        after_help = "Direction pairs are theta_i phi_i theta_o phi_o in degrees (wi toward the light, wo toward\nthe viewer, z the normal), one pair per line on stdin, or a --grid. The pdf is the density\nwith which the material samples wi given wo.\n\nExamples:\n  echo '30 0 30 180' | lobe eval --material '{\"type\": \"ward\", \"specular\": 0.1, \"alpha\": 0.2}'\n  lobe eval --ngan green-metallic-paint --model cook-torrance --grid 45,0,0..89..1,180\n  lobe eval --scene scenes/cornell-box.json --name white --grid 0,0,30,0"
    )]
    Eval(eval::EvalArgs),
    /// Fit measured data to the study's models (Eq. 1 metric, NNLS colours, SLSQP multi-start).
    #[command(
        after_help = "Examples:\n  lobe fit nickel.binary -o nickel.fit.json\n  lobe fit data.bin --models ward-anisotropic -o data.fit.json\n  lobe fit ../shared/data/rgl/paper_white_rgb.bsdf --models cook-torrance,lafortune --resolution 2 -o paper.fit.json\n  lobe fit --list\nThe report loads as a material: {\"type\": \"fit\", \"file\": \"nickel.fit.json\", \"model\": \"cook-torrance\"}"
    )]
    Fit(fit::FitArgs),
    /// Draw the study's figures: error plots from fit reports, incidence-plane polar plots.
    #[command(
        subcommand,
        after_help = "Examples:\n  lobe figure errors reports/ -o figure14.png\n  lobe figure multilobe reports/ -o figure5.png\n  lobe figure polar --material '{\"type\": \"merl\", \"file\": \"gmp.binary\"}' --report gmp.fit.json --models ward,cook-torrance,lafortune --theta-i 45 -o figure4.png"
    )]
    Figure(figures::FigureCmd),
    /// The APS2000 microfacet generator: estimate its distribution from measured data, or run
    /// the study's section 5.1 experiment on a synthetic structure.
    #[command(
        subcommand,
        after_help = "Examples:\n  lobe microfacet estimate brushed.bin -o brushed-p    # brushed-p.{exr,png,json}\n  lobe microfacet synth satin -o out/satin             # prints the comparison table\nThe table loads as a material: {\"type\": \"sampled-microfacet\", \"distribution\": \"brushed-p.exr\", \"specular\": 0.5}"
    )]
    Microfacet(microfacet::MicrofacetCmd),
    /// Measure the speed/accuracy/memory trade between a measured table, the estimated
    /// microfacet distribution and every analytic fit (Markdown, CSV, Pareto plot).
    #[command(
        after_help = "Examples:\n  lobe tradeoff ../shared/data/rgl/paper_white_rgb.bsdf -o out/paper\n  lobe tradeoff nickel.binary --scene my-scene.json --spp 256 --reference-spp 4096 -o out/nickel\nA --scene must name the material to replace \"subject\" in its \"materials\"."
    )]
    Tradeoff(tradeoff::TradeoffArgs),
    /// Sweep every model over its parameter box and extreme directions; count non-finite,
    /// negative, non-reciprocal, energy-gaining and f32/f64-disagreeing values.
    #[command(
        after_help = "Examples:\n  lobe stability                 # every model, full sweep\n  lobe stability --quick         # the CI sweep\n  lobe stability --models he,lafortune\nExits non-zero on any non-finite or negative value."
    )]
    Stability(stability::StabilityArgs),
    /// Write a material as a MERL table or as binned 4D data, emulating an acquisition.
    #[command(
        after_help = "Examples:\n  lobe tabulate --material '{\"type\": \"cook-torrance\", \"diffuse\": 0.1, \"specular\": 0.5, \"m\": 0.1}' -o ct.binary\n  lobe tabulate --ngan nickel --model he --retro-exclusion 3 --noise 0.02 -o nickel-he.binary\n  lobe tabulate --material @brushed.json --format binned --anisotropic --empty-fraction 0.75 --grazing-cutoff 80 -o brushed.bin"
    )]
    Tabulate(tabulate::TabulateArgs),
    /// Compare a test image with a reference: RMSE, relative MSE, PSNR, SSIM, mean FLIP.
    #[command(
        after_help = "Examples:\n  lobe compare out/sphere.exr reference-images/sphere-envmap/mitsuba.exr\n  lobe compare a.exr b.exr --heatmap diff.png --json\n  lobe compare a.exr b.exr --fail-above rmse=0.01 --fail-below ssim=0.98"
    )]
    Compare(compare::CompareArgs),
    /// List the material models and their parameters (Markdown, as in docs/models.md).
    #[command(
        after_help = "Examples:\n  lobe models             # every model's parameters, ranges and defaults\n  lobe models --names     # one model name per line"
    )]
    Models {
        /// Print only the names.
        #[arg(long)]
        names: bool,
    },
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (JSON, see docs/scene-format.md). Without it, the built-in showcase.
    scene: Option<PathBuf>,
    /// Output EXR path; the PNG (.png) and the statistics (.stats.json) go next to it with
    /// the same stem.
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
    #[arg(long)]
    exposure: Option<f32>,
    /// Do not write the PNG.
    #[arg(long)]
    no_png: bool,
    /// Also write the per-pixel variance of the mean as NAME.var.exr (for `lobe compare
    /// --z-test` and noise-aware comparisons).
    #[arg(long)]
    variance: bool,
    /// Benchmark: render several times without writing anything and report Msamples/s.
    /// Without a scene, renders the built-in benchmark (one diffuse sphere under a
    /// 512x256 environment map, 256x256 pixels, path tracer of depth 8).
    #[arg(long)]
    bench: bool,
    /// Number of timed runs for --bench.
    #[arg(long, default_value_t = 3)]
    runs: u32,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => cmd_render(args, cli.quiet),
        Command::Eval(args) => eval::cmd_eval(args),
        Command::Compare(args) => compare::cmd_compare(args, cli.quiet),
        Command::Tabulate(args) => tabulate::cmd_tabulate(args, cli.quiet),
        Command::Fit(args) => fit::cmd_fit(args, cli.quiet),
        Command::Figure(cmd) => figures::cmd_figure(cmd, cli.quiet),
        Command::Microfacet(cmd) => microfacet::cmd_microfacet(cmd, cli.quiet),
        Command::Tradeoff(args) => tradeoff::cmd_tradeoff(args, cli.quiet),
        Command::Stability(args) => stability::cmd_stability(args, cli.quiet),
        Command::Models { names } => {
            let reg = lobe_materials::registry::Registry::builtin();
            if names {
                for n in reg.names() {
                    println!("{n}");
                }
            } else {
                print!("{}", reg.reference_markdown());
            }
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lobe: error: {e}");
            ExitCode::FAILURE
        }
    }
}

pub(crate) fn install_ctrlc() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    // If a handler cannot be installed (already set), rendering simply cannot be cancelled.
    let _ = ctrlc::set_handler(move || f.store(true, Ordering::SeqCst));
    flag
}

fn load_scene(args: &RenderArgs) -> Result<(Scene, String), Error> {
    let (mut scene, name) = match &args.scene {
        Some(p) => {
            if !p.exists() {
                return Err(Error::file(
                    p.display(),
                    "does not exist; expected a scene JSON file",
                ));
            }
            let name = p
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("render")
                .to_string();
            (lobe_renderer::scene::load(p)?, name)
        }
        None if args.bench => (lobe_renderer::showcase::bench_scene()?, "bench".to_string()),
        None => (lobe_renderer::showcase::showcase()?, "showcase".to_string()),
    };
    if let Some(spp) = args.spp {
        if spp == 0 {
            return Err(Error::Other(
                "--spp: expected a positive number of samples per pixel, found 0".into(),
            ));
        }
        scene.spp = spp;
    }
    if let Some(seed) = args.seed {
        scene.seed = seed;
    }
    if let Some(e) = args.exposure {
        scene.exposure = e;
    }
    Ok((scene, name))
}

fn cmd_render(args: RenderArgs, quiet: bool) -> Result<(), Error> {
    if args.threads == Some(0) {
        return Err(Error::Other(
            "--threads: expected at least 1 thread, found 0".into(),
        ));
    }
    let (scene, name) = load_scene(&args)?;
    let cancel = install_ctrlc();
    let opts = RenderOptions {
        threads: args.threads,
        progress: !quiet && !args.bench && std::io::stderr().is_terminal(),
        cancel: Some(cancel),
    };
    if args.bench {
        return bench(&scene, &opts, args.runs.max(1), quiet);
    }
    let exr_path = match &args.output {
        Some(p) => p.clone(),
        None => {
            let dir = PathBuf::from("out");
            std::fs::create_dir_all(&dir).map_err(|e| {
                Error::file(
                    dir.display(),
                    format!("cannot create the output folder: {e}"),
                )
            })?;
            dir.join(format!("{name}.exr"))
        }
    };
    check_output_folder(&exr_path)?;
    let (img, stats) = render(&scene, &opts)?;
    let png_path = exr_path.with_extension("png");
    let json_path = exr_path.with_extension("stats.json");
    // Never write over the scene being rendered (e.g. `-o scenes/x.exr` for scenes/x.json).
    if let Some(scene_path) = &args.scene {
        let same = |p: &Path| match (p.canonicalize(), scene_path.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        for out in [&exr_path, &png_path, &json_path] {
            if same(out) {
                return Err(Error::file(
                    out.display(),
                    "is the scene file itself; expected a different output path",
                ));
            }
        }
    }
    film::write_exr(&exr_path, img.width, img.height, &img.pixels)?;
    if args.variance {
        film::write_exr(
            &exr_path.with_extension("var.exr"),
            img.width,
            img.height,
            &img.variance,
        )?;
    }
    if !args.no_png {
        film::write_png(
            &png_path,
            img.width,
            img.height,
            &img.pixels,
            scene.exposure,
        )?;
    }
    film::write_json(
        &json_path,
        &stats_json(
            &scene,
            &stats,
            &exr_path,
            (!args.no_png).then_some(&png_path),
        ),
    )?;
    if !quiet {
        eprintln!("{}", stats.summary());
        eprintln!("wrote {}", exr_path.display());
    }
    Ok(())
}

fn check_output_folder(path: &Path) -> Result<(), Error> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::file(
            path.display(),
            format!("output folder {} does not exist", dir.display()),
        ));
    }
    if path.is_dir() {
        return Err(Error::file(
            path.display(),
            "is a directory; expected an output file path",
        ));
    }
    Ok(())
}

fn stats_json(
    scene: &Scene,
    stats: &RenderStats,
    exr: &Path,
    png: Option<&PathBuf>,
) -> serde_json::Value {
    let mut v = stats.to_json();
    let o = v.as_object_mut().expect("object");
    o.insert("scene".into(), scene.file.clone().into());
    o.insert("seed".into(), scene.seed.into());
    o.insert("scramble".into(), scene.scramble.name().into());
    o.insert("integrator".into(), scene.integrator.describe().into());
    o.insert("exr".into(), exr.display().to_string().into());
    if let Some(p) = png {
        o.insert("png".into(), p.display().to_string().into());
        o.insert("exposure".into(), scene.exposure.into());
    }
    o.insert("lobe_version".into(), env!("CARGO_PKG_VERSION").into());
    v
}

fn bench(scene: &Scene, opts: &RenderOptions, runs: u32, quiet: bool) -> Result<(), Error> {
    // One untimed warm-up run (page faults, thread pool start-up).
    let _ = render(scene, opts)?;
    let mut rates = Vec::new();
    for i in 0..runs {
        let (_, stats) = render(scene, opts)?;
        if !quiet {
            eprintln!("run {}: {}", i + 1, stats.summary());
        }
        rates.push(stats.msamples_per_second());
    }
    rates.sort_by(f64::total_cmp);
    let median = rates[rates.len() / 2];
    println!(
        "bench {}: {}x{} at {} spp, {}: median {:.2} Msamples/s over {} runs",
        scene.file,
        scene.width,
        scene.height,
        scene.spp,
        scene.integrator.describe(),
        median,
        runs
    );
    Ok(())
}
