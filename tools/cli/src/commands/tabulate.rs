//! `lobe tabulate`: write any material as a MERL table or as the study's binned data, with
//! options that emulate a real acquisition.

use crate::args::finite;
use crate::material::{MaterialArgs, MaterialSource};
use lobe_materials::measured::tabulate::{Acquisition, binned_from, merl_from};
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct TabulateArgs {
    #[command(flatten)]
    material: MaterialArgs,
    /// Output format: merl (.binary) or binned (docs/binned-format.md).
    #[arg(long, value_parser = ["merl", "binned"], default_value = "merl")]
    format: String,
    /// For --format binned: the anisotropic layout (2-degree bins of theta_i, theta_o, phi_i, phi_o)
    /// instead of the isotropic one (1-degree bins of theta_i, theta_o, phi_d).
    #[arg(long)]
    anisotropic: bool,
    /// Output file.
    #[arg(long, short)]
    output: PathBuf,
    /// Relative standard deviation of multiplicative Gaussian noise.
    #[arg(long, default_value_t = 0.0, value_parser = finite::<f64>)]
    noise: f64,
    /// No samples within this many degrees of retro-reflection (MERL: 3).
    #[arg(long, default_value_t = 0.0, value_parser = finite::<f64>)]
    retro_exclusion: f64,
    /// No samples with theta_i or theta_o above this many degrees.
    #[arg(long, default_value_t = 90.0, value_parser = finite::<f64>)]
    grazing_cutoff: f64,
    /// Fraction of bins left empty at random.
    #[arg(long, default_value_t = 0.0, value_parser = finite::<f64>)]
    empty_fraction: f64,
    /// Seed of the noise and of the empty bins.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn check(name: &str, v: f64, lo: f64, hi: f64) -> Result<(), Error> {
    if !(v >= lo && v <= hi) {
        return Err(Error::Other(format!(
            "--{name}: expected a value in [{lo}, {hi}], found {v}"
        )));
    }
    Ok(())
}

pub fn cmd_tabulate(args: TabulateArgs, quiet: bool) -> Result<(), Error> {
    check("noise", args.noise, 0.0, 10.0)?;
    check("retro-exclusion", args.retro_exclusion, 0.0, 180.0)?;
    check("grazing-cutoff", args.grazing_cutoff, 0.0, 90.0)?;
    check("empty-fraction", args.empty_fraction, 0.0, 1.0)?;
    if args.anisotropic && args.format != "binned" {
        return Err(Error::Other(
            "--anisotropic: only the binned format has an anisotropic layout".into(),
        ));
    }
    let source = MaterialSource::new(&args.material)?;
    let mut plan = FilePlan::new();
    source.plan_inputs(&mut plan);
    plan.output(&args.output, "table").check()?;
    let m = source.build()?;
    let acq = Acquisition {
        noise: args.noise,
        retro_exclusion_deg: args.retro_exclusion,
        grazing_cutoff_deg: args.grazing_cutoff,
        empty_fraction: args.empty_fraction,
        seed: args.seed,
    };
    let f = |wo: glam::Vec3, wi: glam::Vec3| m.eval(wo, wi);
    // A table without a value cannot be read back (nor fitted, nor rendered): refused
    // before it is written.
    let nothing_left = || {
        Error::Other(format!(
            "{}: no bin would hold a value (--empty-fraction {}, --grazing-cutoff {}, --retro-exclusion {}); expected settings that keep at least one bin",
            args.output.display(),
            args.empty_fraction,
            args.grazing_cutoff,
            args.retro_exclusion
        ))
    };
    let (filled, total) = if args.format == "merl" {
        let t = merl_from(&f, &acq);
        let cov = t.coverage();
        let filled = (cov * lobe_materials::measured::merl::SAMPLES as f64).round() as usize;
        if filled == 0 {
            return Err(nothing_left());
        }
        t.write(&args.output)?;
        (filled, lobe_materials::measured::merl::SAMPLES)
    } else {
        let t = binned_from(&f, args.anisotropic, &acq);
        if t.filled() == 0 {
            return Err(nothing_left());
        }
        t.write(&args.output)?;
        (t.filled(), t.len())
    };
    if !quiet {
        eprintln!(
            "wrote {}: {} format, {filled} of {total} bins hold a value ({:.1} %)",
            args.output.display(),
            args.format,
            100.0 * filled as f64 / total as f64
        );
    }
    Ok(())
}
