//! `lobe stability`: numerical stability at the extremes (lobe_analysis::stability: every
//! model swept over its parameter box and extreme directions); prints a Markdown table of
//! the counts per model and exits non-zero on any non-finite or negative value.

use lobe_analysis::stability::{StabilityConfig, StabilityReport, sweep};
use lobe_renderer::Error;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct StabilityArgs {
    /// Comma-separated models (default: every analytic model, sampled-microfacet, merl,
    /// measured-extremes, rgl).
    #[arg(long)]
    models: Option<String>,
    /// Fewer parameter values and directions (for CI).
    #[arg(long)]
    quick: bool,
    /// Print the first case of each kind (non-finite or negative, reciprocity, energy,
    /// f32/f64) per model, on stderr.
    #[arg(long)]
    verbose: bool,
    /// Folder of RGL .bsdf files to sweep (default: ../shared/data/rgl or $LOBE_DATA/rgl).
    #[arg(long)]
    rgl: Option<PathBuf>,
}

pub fn cmd_stability(args: StabilityArgs, quiet: bool) -> Result<(), Error> {
    let config = StabilityConfig {
        models: args
            .models
            .as_ref()
            .map(|m| m.split(',').map(|s| s.trim().to_string()).collect()),
        quick: args.quick,
        rgl: args.rgl.clone(),
    };
    let report = sweep(&lobe_materials::registry::Registry::builtin(), &config)?;
    if report.rgl_skipped && !quiet {
        eprintln!("rgl: skipped (no ../shared/data/rgl, $LOBE_DATA/rgl or --rgl folder)");
    }
    println!("{}", StabilityReport::HEADER);
    for (name, c) in &report.rows {
        println!("{}", StabilityReport::row(name, c));
        if args.verbose {
            for e in c.examples() {
                eprintln!("  {e}");
            }
        }
    }
    println!("{}", report.verdict());
    let failed = report.failures();
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Error::Other(format!(
            "non-finite or negative values, or nothing swept, in: {}",
            failed.join("; ")
        )))
    }
}
