//! `lobe tradeoff`: the speed/accuracy/memory trade between the representations of one
//! measured material (lobe_analysis::tradeoff: the measured table, the estimated
//! microfacet distribution and every analytic fit); writes Markdown, CSV and a Pareto plot
//! and prints the Markdown table.

use crate::args::finite;
use lobe_analysis::tradeoff::{TradeoffConfig, study, write};
use lobe_renderer::Error;
use std::path::PathBuf;

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
    /// Output stem: STEM.md, STEM.csv, STEM.png and .svg, STEM-microfacet.exr.
    #[arg(long, short)]
    output: PathBuf,
}

pub fn cmd_tradeoff(args: TradeoffArgs, quiet: bool) -> Result<(), Error> {
    let config = TradeoffConfig {
        data: args.data,
        scene: args.scene,
        reference_spp: crate::args::check_spp("--reference-spp", args.reference_spp)?,
        spp: crate::args::check_spp("--spp", args.spp)?,
        size: args.size,
        resolution: args.resolution,
        models: args.models,
        output: args.output,
    };
    let say = |m: String| {
        if !quiet {
            eprintln!("{m}");
        }
    };
    let s = study(
        &lobe_materials::registry::Registry::builtin(),
        &config,
        &say,
    )?;
    write(&s, &config.output)?;
    print!("{}", lobe_analysis::tradeoff::markdown(&s));
    Ok(())
}
