//! `lobe fit`: fit measured data (MERL, binned, RGL, or any material) to the study's models
//! and write the JSON report, loadable as `{"type": "fit", "file": ..., "model": ...}`.

use crate::eval::{MaterialArgs, load_material};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::fit::{builtin_specs, fit, report_json};
use lobe_materials::measured::binned::Binned;
use lobe_materials::measured::merl::Merl;
use lobe_materials::measured::rgl::Rgl;
use lobe_renderer::Error;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct FitArgs {
    /// Measured data: a MERL table (.binary), binned data (.bin) or an RGL file (.bsdf).
    /// Without it, the material given by --material / --ngan (synthetic data).
    data: Option<PathBuf>,
    #[command(flatten)]
    material: MaterialArgs,
    /// Comma-separated model labels (default: the seven models of the study's section 4, or for
    /// anisotropic binned data anisotropic Ward, Ashikhmin-Shirley and Poulin-Fournier).
    /// `lobe fit --list` shows them all.
    #[arg(long)]
    models: Option<String>,
    /// Bin size in degrees of the isotropic data (the study: 1).
    #[arg(long, default_value_t = 1.0)]
    resolution: f64,
    /// Objective evaluations allowed per SLSQP start.
    #[arg(long, default_value_t = 300)]
    max_evals: usize,
    /// Output report (JSON).
    #[arg(long, short)]
    output: Option<PathBuf>,
    /// List the model labels and exit.
    #[arg(long)]
    list: bool,
}

pub fn cmd_fit(args: FitArgs, quiet: bool) -> Result<(), Error> {
    let specs = builtin_specs();
    if args.list {
        for s in &specs {
            println!("{}", s.label);
        }
        return Ok(());
    }
    if !(args.resolution >= 0.25 && args.resolution <= 20.0) {
        return Err(Error::Other(format!(
            "--resolution: expected a bin size in [0.25, 20] degrees, found {}",
            args.resolution
        )));
    }
    let output = args.output.clone().ok_or_else(|| {
        Error::Other("--output: expected the path of the JSON report to write".into())
    })?;
    let to_err = |e: lobe_materials::FileError| Error::File {
        file: e.file,
        message: e.message,
    };
    let (name, source, data) = match &args.data {
        Some(p) => {
            if !p.exists() {
                return Err(Error::file(
                    p.display(),
                    "does not exist; expected a MERL .binary, binned .bin or RGL .bsdf file",
                ));
            }
            let name = p
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("material")
                .to_string();
            let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
            let data = match ext {
                "binary" => Dataset::from_merl(&Merl::read(p).map_err(to_err)?, args.resolution),
                "bin" => Dataset::from_binned(&Binned::read(p).map_err(to_err)?),
                "bsdf" => {
                    let t = Rgl::read(p).map_err(to_err)?;
                    Dataset::isotropic(&|wi, wo| Some(t.eval(wo, wi)), args.resolution)
                }
                _ => {
                    return Err(Error::file(
                        p.display(),
                        format!(
                            "unknown extension \"{ext}\"; expected .binary (MERL), .bin (binned) or .bsdf (RGL)"
                        ),
                    ));
                }
            };
            (name, p.display().to_string(), data)
        }
        None => {
            let m = load_material(&args.material)?;
            (
                "synthetic".to_string(),
                "material".to_string(),
                Dataset::isotropic(&|wi, wo| Some(m.eval(wo, wi)), args.resolution),
            )
        }
    };
    let default: &[&str] = if data.anisotropic {
        &[
            "ward-anisotropic",
            "ashikhmin-shirley-anisotropic",
            "poulin-fournier",
        ]
    } else {
        lobe_materials::fit::ISOTROPIC_DEFAULT
    };
    let chosen: Vec<_> = match &args.models {
        None => specs
            .iter()
            .filter(|s| default.contains(&s.label))
            .collect(),
        Some(list) => list
            .split(',')
            .map(|l| {
                specs.iter().find(|s| s.label == l.trim()).ok_or_else(|| {
                    Error::Other(format!(
                        "--models: unknown model \"{}\"; expected one of: {}",
                        l.trim(),
                        specs.iter().map(|s| s.label).collect::<Vec<_>>().join(", ")
                    ))
                })
            })
            .collect::<Result<_, _>>()?,
    };
    if data.samples.is_empty() {
        return Err(Error::Other(format!(
            "{source}: no measured values below 80 degrees to fit"
        )));
    }
    let mut results = Vec::new();
    for spec in chosen {
        let r = fit(&data, spec, args.max_evals);
        if !quiet {
            eprintln!(
                "{:28} error {:.4e}  normalized {:.4e}  ({} of {} starts agree, {:.1} s)",
                r.label, r.error, r.error_normalized, r.starts_agreeing, r.starts, r.seconds
            );
        }
        results.push(r);
    }
    let report = report_json(&name, &source, args.resolution, &data, &results);
    lobe_renderer::film::write_json(&output, &report)?;
    if !quiet {
        eprintln!("wrote {}", output.display());
    }
    Ok(())
}
