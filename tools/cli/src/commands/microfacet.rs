//! `lobe microfacet`: the Ashikhmin-Premože-Shirley generator's distribution estimated from
//! measured data (Ngan et al. 2005, section 5, Eq. 4), written as the EXR table the
//! `sampled-microfacet` material loads, a material description and the study's log-scale
//! spherical plot (Figures 11 to 13); `synth` runs the section 5.1 experiment on a synthetic
//! brushed metal, satin or velvet (lobe_analysis::microfacet) and prints the comparison
//! with the anisotropic fits.

use crate::args::finite;
use lobe_analysis::microfacet::{Synth, SynthConfig, synth};
use lobe_materials::fit::dataset::Dataset;
use lobe_materials::microfacet_gen::{Estimate, Shape, Table, estimate};
use lobe_renderer::Error;
use lobe_renderer::outputs::FilePlan;
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum MicrofacetCmd {
    /// Estimate p(h) from measured data (MERL, binned or RGL, told apart by content): writes
    /// STEM.exr (the table), STEM.png (log10 p over the projected hemisphere) and
    /// STEM.json (the material description, error and per-iteration changes).
    Estimate {
        data: PathBuf,
        /// Output stem.
        #[arg(long, short)]
        output: PathBuf,
        #[command(flatten)]
        opts: EstimateOpts,
        /// Bin size in degrees for isotropic data.
        #[arg(long, default_value_t = 1.0, value_parser = finite::<f64>)]
        resolution: f64,
    },
    /// Section 5.1 on a synthetic structure (brushed, satin or velvet): tabulate it through
    /// the forward model as sparse 4D data, recover p, fit anisotropic Ward,
    /// Ashikhmin-Shirley and Poulin-Fournier, print the Eq. (1) errors; writes the truth's
    /// and the estimate's tables and plots into the output folder.
    Synth {
        structure: String,
        /// Output folder.
        #[arg(long, short)]
        output: PathBuf,
        #[command(flatten)]
        opts: EstimateOpts,
        /// 4D bin size in degrees (the study: 2; 2 degrees makes 13 M bins and needs ~1 GB).
        #[arg(long, default_value_t = 4.0, value_parser = finite::<f64>)]
        resolution: f64,
        /// Fraction of non-empty bins (the study: about a quarter).
        #[arg(long, default_value_t = 0.25, value_parser = finite::<f64>)]
        filled: f64,
    },
}

#[derive(clap::Args)]
pub struct EstimateOpts {
    /// Nodes per side of the table (its spacing at the pole is 360 / (pi (N - 1)) degrees).
    #[arg(long, default_value_t = 129)]
    nodes: usize,
    /// Schlick's f0; without it, found by a golden-section search on the Eq. (1) error.
    #[arg(long, value_parser = finite::<f64>)]
    f0: Option<f64>,
    /// Alternations of the p and g estimates (at most 5 in the study).
    #[arg(long, default_value_t = 5)]
    iterations: usize,
}

impl EstimateOpts {
    fn check(&self) -> Result<(), Error> {
        if !(9..=1025).contains(&self.nodes) {
            return Err(Error::Other(format!(
                "--nodes: expected 9 to 1025, found {}",
                self.nodes
            )));
        }
        if let Some(f) = self.f0
            && !(0.0..=1.0).contains(&f)
        {
            return Err(Error::Other(format!("--f0: expected 0 to 1, found {f}")));
        }
        if !(1..=10).contains(&self.iterations) {
            return Err(Error::Other(format!(
                "--iterations: expected 1 to 10, found {}",
                self.iterations
            )));
        }
        Ok(())
    }
}

/// The table and plot files of a stem.
fn table_files(stem: &Path) -> (PathBuf, PathBuf) {
    (stem.with_extension("exr"), stem.with_extension("png"))
}

/// Writes `table` as EXR and its map (titled `title`, colours up to `top`: see
/// [`lobe_analysis::figures::distribution`]) as PNG.
fn write_table(
    table: &Table,
    stem: &Path,
    title: &str,
    top: f64,
) -> Result<(PathBuf, PathBuf), Error> {
    let (exr, png) = table_files(stem);
    table.write_exr(&exr)?;
    lobe_analysis::figures::distribution(title, table, top)?.save(&png)?;
    Ok((exr, png))
}

/// Refuses outputs of the stems over the inputs or each other.
fn check_outputs(inputs: &[&Path], stems: &[PathBuf], json: Option<&Path>) -> Result<(), Error> {
    let mut plan = FilePlan::new();
    for i in inputs {
        plan.input(i, "the measured data");
    }
    for s in stems {
        let (exr, png) = table_files(s);
        plan.output(exr, "distribution table").output(png, "plot");
    }
    if let Some(j) = json {
        plan.output(j, "material description");
    }
    plan.check()
}

fn run_estimate(data: &Dataset, source: &str, opts: &EstimateOpts) -> Result<Estimate, Error> {
    estimate(data, opts.nodes, opts.f0, opts.iterations).map_err(|e| Error::file(source, e))
}

pub fn cmd_microfacet(cmd: MicrofacetCmd, quiet: bool) -> Result<(), Error> {
    match cmd {
        MicrofacetCmd::Estimate {
            data,
            output,
            opts,
            resolution,
        } => estimate_from_data(&data, &output, &opts, resolution, quiet),
        MicrofacetCmd::Synth {
            structure,
            output,
            opts,
            resolution,
            filled,
        } => synthetic_round_trip(&structure, &output, &opts, (resolution, filled), quiet),
    }
}

/// `lobe microfacet estimate`: the distribution of normals estimated from measured data,
/// written as a table (EXR, PNG) and a material (JSON).
fn estimate_from_data(
    data: &Path,
    output: &Path,
    opts: &EstimateOpts,
    resolution: f64,
    quiet: bool,
) -> Result<(), Error> {
    opts.check()?;
    let json_path = output.with_extension("json");
    check_outputs(&[data], &[output.to_path_buf()], Some(&json_path))?;
    let d = Dataset::read(data, resolution)?;
    let source = data.display().to_string();
    let est = run_estimate(&d, &source, opts)?;
    let name = data.file_stem().unwrap_or_default().to_string_lossy();
    let top = lobe_analysis::figures::distribution_top(&[&est.table]);
    let title = format!("{name}: estimated distribution of normals");
    let (exr, png) = write_table(&est.table, output, &title, top)?;
    let file = exr
        .file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_default();
    lobe_renderer::film::write_json(
        &json_path,
        &json!({
            "source": source,
            "material": est.material(&file),
            "error": est.error,
            "error_normalized": est.error / d.max_albedo.max(1e-300),
            "changes": est.changes,
            "nodes": opts.nodes,
        }),
    )?;
    if !quiet {
        eprintln!(
            "{source}: f0 {:.3}, Eq. (1) error {:.4e}, p change per iteration {:?}",
            est.f0, est.error, est.changes
        );
        eprintln!(
            "wrote {}, {}, {}",
            exr.display(),
            png.display(),
            json_path.display()
        );
    }
    Ok(())
}

/// `lobe microfacet synth`: a synthetic structure's true distribution, its BRDF binned as
/// measured data, the distribution estimated back from it and every model's fit.
fn synthetic_round_trip(
    structure: &str,
    output: &Path,
    opts: &EstimateOpts,
    (resolution, filled): (f64, f64),
    quiet: bool,
) -> Result<(), Error> {
    opts.check()?;
    let shape = Shape::synthetic(structure).ok_or_else(|| {
        Error::Other(format!(
            "structure: unknown \"{structure}\"; expected brushed, satin or velvet"
        ))
    })?;
    if !(1.0..=15.0).contains(&resolution) || !(0.01..=1.0).contains(&filled) {
        return Err(Error::Other(format!(
            "--resolution {resolution} / --filled {filled}: expected 1 to 15 degrees and a fraction in (0, 1]"
        )));
    }
    let stems = ["truth", "estimate"].map(|k| output.join(format!("{structure}-{k}")));
    std::fs::create_dir_all(output)
        .map_err(|e| Error::file(output.display(), format!("cannot create the folder: {e}")))?;
    check_outputs(&[], &stems, None)?;
    let config = SynthConfig {
        nodes: opts.nodes,
        f0: opts.f0,
        iterations: opts.iterations,
        resolution,
        filled,
    };
    let Synth {
        data,
        truth,
        estimate: est,
        correlation,
        rows,
    } = synth(
        &lobe_materials::registry::Registry::builtin(),
        &shape,
        structure,
        &config,
    )?;
    // Truth and estimate on one colour range, so that they compare colour for colour.
    let top = lobe_analysis::figures::distribution_top(&[&truth, &est.table]);
    write_table(&truth, &stems[0], &format!("{structure}: true p(h)"), top)?;
    write_table(
        &est.table,
        &stems[1],
        &format!("{structure}: p(h) estimated from the data"),
        top,
    )?;
    let mut text = format!(
        "{structure}: {} bins ({resolution} degree 4D bins, {:.0} % filled), table {} x {}, correlation of p with the truth {:.4}, p change per iteration {:?}\n",
        data.samples.len(),
        filled * 100.0,
        opts.nodes,
        opts.nodes,
        correlation,
        est.changes
            .iter()
            .map(|c| format!("{c:.2e}"))
            .collect::<Vec<_>>()
    );
    text += "\n| model | Eq. (1) error | normalized | fitted lobe |\n|---|---|---|---|\n";
    for (label, e, _, note) in &rows {
        text += &format!(
            "| {label} | {e:.4e} | {:.4e} | {note} |\n",
            e / data.max_albedo.max(1e-300)
        );
    }
    print!("{text}");
    let table = output.join(format!("{structure}.md"));
    lobe_renderer::film::atomic_write(&table, |w| w.write_all(text.as_bytes()))?;
    if !quiet {
        eprintln!(
            "wrote the tables, plots and {} into {}",
            table.display(),
            output.display()
        );
    }
    Ok(())
}
