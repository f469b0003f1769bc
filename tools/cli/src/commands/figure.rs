//! `lobe figure`: the study's plots as PNG, the charts also as SVG next to it (drawn by
//! lobe_analysis::figures):
//! - `errors`: Figure 14, the normalized fitting error (log scale) of every model for every
//!   material, materials sorted by the Lafortune error;
//! - `multilobe`: Figure 5, one against two lobes for Cook-Torrance and Lafortune on the 30
//!   materials whose error the second lobe improves most;
//! - `polar`: Figure 4, the incidence-plane BRDF of the data and of fitted models, cube root;
//! - `spheres`: Figures 3 and 6, the measured material and each model's fit as labelled
//!   spheres under an environment map;
//! - `lobes`: Figures 7 and 8, iso-contours of a half-vector (H.N) and of a mirror (V.R)
//!   lobe of the same exponent over the outgoing hemisphere at a chosen incidence.

use crate::args::finite;
use crate::material::{MaterialArgs, MaterialSource};
use lobe_analysis::figures;
use lobe_analysis::plot::Figure;
use lobe_analysis::reports::{read_reports, report_files, report_models};
use lobe_materials::fit::report::FitReport;
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum FigureCmd {
    /// Figure 14: normalized error per material for every model (log scale).
    Errors {
        /// Fit reports or folders of them (their *.fit.json files).
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        /// Output PNG file (a chart also writes an SVG of the same name beside it).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figure 5: one against two lobes (cook-torrance / -2, lafortune / -2).
    Multilobe {
        /// Fit reports or folders of them (their *.fit.json files).
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        /// Output PNG file (a chart also writes an SVG of the same name beside it).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figure 4: incidence-plane polar plot (cube root) of a material and of fitted models.
    Polar {
        #[command(flatten)]
        material: MaterialArgs,
        /// A fit report whose models are drawn beside the material.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Comma-separated models of the report (default: all).
        #[arg(long, requires = "report")]
        models: Option<String>,
        /// Incident angle in degrees.
        #[arg(long, default_value_t = 45.0, value_parser = finite::<f64>)]
        theta_i: f64,
        /// Colour channel: 0, 1 or 2 (red, green, blue).
        #[arg(long, default_value_t = 1)]
        channel: usize,
        /// Output PNG file (a chart also writes an SVG of the same name beside it).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figures 3 and 6: the material and each fitted model as labelled spheres under an
    /// environment map, each fit with its FLIP map, RMSE (95 % interval) and FLIP against
    /// the material, one PNG.
    Spheres {
        #[command(flatten)]
        material: MaterialArgs,
        /// A fit report whose models are drawn after the material.
        #[arg(long)]
        report: PathBuf,
        /// Comma-separated models of the report (default: all).
        #[arg(long)]
        models: Option<String>,
        /// Environment map (EXR or .hdr) or builtin:studio.
        #[arg(long, default_value = "builtin:studio")]
        env: String,
        /// At most this many samples per pixel: the images of all materials share their
        /// samples, and the estimate stops sooner once every fit's noise is under a tenth
        /// of its own error.
        #[arg(long, default_value_t = 256)]
        spp: u32,
        /// Pixels per sphere tile.
        #[arg(long, default_value_t = 192)]
        tile: u32,
        /// Exposure in stops, added to the automatic one (under 1 % of the data's pixels
        /// clip).
        #[arg(long, default_value_t = 0.0, value_parser = finite::<f32>)]
        exposure: f32,
        /// Output PNG file (a chart also writes an SVG of the same name beside it).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Figures 7 and 8: iso-contours (10 % to 90 % of the peak) of cos^n(h.n) and cos^n(v.r)
    /// over the outgoing hemisphere (projected disk) for incidence theta_i.
    Lobes {
        /// Incident angle in degrees.
        #[arg(long, default_value_t = 60.0, value_parser = finite::<f64>)]
        theta_i: f64,
        /// Lobe exponent n.
        #[arg(long, default_value_t = 30.0, value_parser = finite::<f64>)]
        exponent: f64,
        /// Output PNG file (a chart also writes an SVG of the same name beside it).
        #[arg(long, short)]
        output: PathBuf,
    },
}

/// Adds a figure's PNG `output` and the SVG written next to it to `plan`.
fn plan_figure<'a>(plan: &'a mut FilePlan, output: &Path) -> &'a mut FilePlan {
    plan.output(output, "figure")
        .output(Figure::svg_path(output), "figure (SVG)")
}

/// Reads the reports of `inputs` (files or folders), after checking that `output` is
/// none of them.
fn reports_for(inputs: &[PathBuf], output: &Path) -> Result<Vec<FitReport>, Error> {
    let files = report_files(inputs)?;
    let mut plan = FilePlan::new();
    for f in &files {
        plan.input(f, "a fit report");
    }
    plan_figure(&mut plan, output).check()?;
    read_reports(&files)
}

/// The material and report of a polar or spheres figure (and an environment map file),
/// checked against the output.
fn material_figure_inputs(
    material: &MaterialArgs,
    report: Option<&Path>,
    env: Option<&str>,
    output: &Path,
) -> Result<MaterialSource, Error> {
    let source = MaterialSource::new(material)?;
    let mut plan = FilePlan::new();
    source.plan_inputs(&mut plan);
    if let Some(r) = report {
        plan.input(r, "the fit report");
    }
    if let Some(e) = env.filter(|e| !e.starts_with("builtin:")) {
        plan.input(e, "the environment map");
    }
    plan_figure(&mut plan, output).check()?;
    Ok(source)
}

pub fn cmd_figure(cmd: FigureCmd, quiet: bool) -> Result<(), Error> {
    let out = match cmd {
        FigureCmd::Errors { reports, output } => {
            figures::errors(&reports_for(&reports, &output)?)?.save(&output)?;
            output
        }
        FigureCmd::Multilobe { reports, output } => {
            figures::multilobe(&reports_for(&reports, &output)?)?.save(&output)?;
            output
        }
        FigureCmd::Polar {
            material,
            report,
            models,
            theta_i,
            channel,
            output,
        } => {
            let source = material_figure_inputs(&material, report.as_deref(), None, &output)?;
            let fits = match &report {
                Some(rp) => report_models(
                    &lobe_materials::registry::Registry::builtin(),
                    rp,
                    models.as_deref(),
                )?,
                None => Vec::new(),
            };
            let fig = figures::polar(
                &source.label(),
                source.build()?.as_ref(),
                &fits,
                theta_i,
                channel,
            )?;
            fig.save(&output)?;
            output
        }
        FigureCmd::Spheres {
            material,
            report,
            models,
            env,
            spp,
            tile,
            exposure,
            output,
        } => {
            crate::args::check_spp("--spp", spp)?;
            let source = material_figure_inputs(&material, Some(&report), Some(&env), &output)?;
            let mut items = vec![("measured".to_string(), source.build()?)];
            items.extend(report_models(
                &lobe_materials::registry::Registry::builtin(),
                &report,
                models.as_deref(),
            )?);
            figures::spheres(&items, &env, spp, tile, exposure)?.save(&output)?;
            output
        }
        FigureCmd::Lobes {
            theta_i,
            exponent,
            output,
        } => {
            plan_figure(&mut FilePlan::new(), &output).check()?;
            figures::lobes(theta_i, exponent)?.save(&output)?;
            output
        }
    };
    if !quiet {
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
