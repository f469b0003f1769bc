//! `lobe`: the command-line front end of lobe (Ngan, Durand and Matusik 2005's system
//! for rendering, fitting and comparing BRDF models).
//!
//! A thin layer: the command line (clap), progress and printing; each subcommand is one
//! file of [`commands`], over the libraries lobe-renderer, lobe-materials and
//! lobe-analysis. Errors are one line on stderr and a non-zero exit.

mod args;
mod commands;
mod material;

use clap::{Parser, Subcommand};
use commands::{
    compare, eval, figure, fit, microfacet, models, render, stability, study, tabulate, tradeoff,
};
use std::process::ExitCode;

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
        after_help = "Examples:\n  lobe render                                  # built-in showcase -> out/showcase.exr, .png, .stats.json\n  lobe render scenes/sphere-envmap.json --spp 256 -o out/sphere.exr\n  lobe render scenes/cornell-box.json --threads 1 --seed 7\n  lobe render --bench                          # Msamples/s on the sphere-under-env-map benchmark"
    )]
    Render(render::RenderArgs),
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
    Figure(figure::FigureCmd),
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
    /// The whole study on measured data (or a built-in set): fits, selection, microfacet
    /// estimate, renders and image errors, plots, figures; a browsable report (index.html).
    #[command(
        after_help = "Examples:\n  lobe study                                   # the built-in set -> lobe-study/index.html\n  lobe study ../shared/data/rgl -o out/rgl-study --open\n  lobe study data/ --quick -o out/quick\n  lobe study data/ --shard 2/8 -o out/s   # one task of a job array; rerun without --shard to build the report\nA rerun computes only what is missing; Ctrl-C keeps every finished step."
    )]
    Study(study::StudyArgs),
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
        after_help = "Examples:\n  lobe render reference-images/scenes/lambert-envmap.json -o out/lambert.exr --variance\n  lobe compare out/lambert.exr reference-images/lambert-envmap.exr --heatmap out/diff.png --json\n  lobe compare out/lambert.exr reference-images/lambert-envmap.exr --fail-above rmse=0.01 --fail-below ssim=0.98\n  lobe compare out/lambert.exr reference-images/lambert-envmap.exr --z-test 0.01   # reads the .var.exr files\nA non-finite pixel in either image is an error: no metric of such an image means anything."
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

fn main() -> ExitCode {
    exit_quietly_on_closed_pipe();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => {
            // Before the reader's and the builder's threads start (a big mesh's peak).
            lobe_renderer::memory::use_one_arena();
            render::cmd_render(args, cli.quiet)
        }
        Command::Eval(args) => eval::cmd_eval(args),
        Command::Compare(args) => compare::cmd_compare(args, cli.quiet),
        Command::Tabulate(args) => tabulate::cmd_tabulate(args, cli.quiet),
        Command::Fit(args) => fit::cmd_fit(args, cli.quiet),
        Command::Figure(cmd) => figure::cmd_figure(cmd, cli.quiet),
        Command::Microfacet(cmd) => microfacet::cmd_microfacet(cmd, cli.quiet),
        Command::Tradeoff(args) => tradeoff::cmd_tradeoff(args, cli.quiet),
        Command::Stability(args) => stability::cmd_stability(args, cli.quiet),
        Command::Study(args) => study::cmd_study(args, cli.quiet),
        Command::Models { names } => models::cmd_models(names),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lobe: error: {e}");
            // The shell's convention for a command stopped by SIGINT.
            if args::cancelled() {
                ExitCode::from(130)
            } else if matches!(e, lobe_renderer::Error::Biased(_)) {
                // Written, but biased (docs/robustness.md).
                ExitCode::from(3)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Output piped into a reader that stops early (`lobe compare A B | head -1`) ends the
/// process quietly, as it does every Unix tool, instead of panicking in `println!`: Rust
/// programs ignore SIGPIPE, so a write to a closed pipe is an error that `println!` turns
/// into a panic; the default disposition restored here makes it end the process.
fn exit_quietly_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to the default has no preconditions; it is
    // done first thing in main, before any other thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use clap::error::ErrorKind;
    use clap::{CommandFactory, Parser};
    use std::any::TypeId;

    /// Every floating-point option of every command (found by walking the command tree,
    /// so a new one is covered too) refuses NaN and infinity as an invalid value, and
    /// accepts a number.
    #[test]
    fn every_float_option_refuses_nan_and_infinity() {
        let mut stack = vec![(vec!["lobe".to_string()], Cli::command())];
        let mut checked = Vec::new();
        while let Some((path, mut cmd)) = stack.pop() {
            cmd.build();
            for arg in cmd.get_arguments() {
                let id = arg.get_value_parser().type_id();
                let Some(long) = arg.get_long() else { continue };
                if id != TypeId::of::<f64>() && id != TypeId::of::<f32>() {
                    continue;
                }
                let run = |value: &str| {
                    let mut argv = path.clone();
                    argv.push(format!("--{long}={value}"));
                    Cli::try_parse_from(argv).err().map(|e| e.kind())
                };
                for bad in ["nan", "NaN", "inf", "-inf", "1e400"] {
                    assert_eq!(
                        run(bad),
                        Some(ErrorKind::ValueValidation),
                        "{path:?} --{long} {bad}"
                    );
                }
                assert_ne!(run("0.5"), Some(ErrorKind::ValueValidation), "{long}");
                checked.push(format!("{} --{long}", path.join(" ")));
            }
            for sub in cmd.get_subcommands() {
                let mut p = path.clone();
                p.push(sub.get_name().to_string());
                stack.push((p, sub.clone()));
            }
        }
        // The exposures, the fit's resolution and tolerance, the tabulation's acquisition,
        // the figures' angles, the microfacet and trade-off options, the compare test.
        assert!(checked.len() >= 20, "{checked:?}");
    }
}
