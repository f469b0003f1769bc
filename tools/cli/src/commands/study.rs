//! `lobe study`: the whole experiment of Ngan et al. 2005 on measured files and folders
//! (or the built-in set), resumable and shardable, with its report as a static site
//! (lobe_analysis::study); progress bar, Ctrl-C and `--open`.

use crate::args::parse_shard;
use lobe_analysis::study::{StudyConfig, StudyProgress, run};
use lobe_renderer::Error;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct StudyArgs {
    /// Measured data (MERL, binned, RGL; isotropic or anisotropic) files or folders of
    /// them. Without any: the built-in set (analytic materials tabulated in memory, and
    /// the RGL files of ../shared/data/rgl or $LOBE_DATA/rgl when present).
    data: Vec<PathBuf>,
    /// The study folder: every step's files and the report (index.html).
    #[arg(long, short, default_value = "lobe-study")]
    output: PathBuf,
    /// The small version: five models, 6-degree bins, 64-pixel sphere images.
    #[arg(long)]
    quick: bool,
    /// Only the materials whose index (in order) is i modulo n, e.g. 2/8 for the third
    /// task of an 8-way job array; the report is built once every material is done.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// An environment map (EXR, HDR or builtin:studio) to render under; repeatable
    /// (default: builtin:studio and the embedded sunset map).
    #[arg(long)]
    env: Vec<String>,
    /// Open the report in the platform's browser when it is built.
    #[arg(long)]
    open: bool,
    /// The image-error estimate's budget, a cap on its mean samples per pixel (32 to
    /// 16384, rounded up to a multiple of 16; default 4096, 128 with --quick): each map
    /// takes what its noise target needs within it. A smaller cap finishes sooner with
    /// noisier errors; results.json says per map whether the targets hold.
    #[arg(long, value_name = "SPP")]
    error_spp: Option<usize>,
}

/// Progress: a bar over steps on a terminal, else one line per computed step.
struct Display {
    bar: Option<indicatif::ProgressBar>,
    lines: bool,
}

impl StudyProgress for Display {
    fn planned(&self, total: usize) {
        self.bar.as_ref().inspect(|b| b.set_length(total as u64));
    }

    fn began(&self, what: &str) {
        if let Some(b) = &self.bar {
            b.set_message(what.to_string());
        } else if self.lines {
            eprintln!("{what}");
        }
    }

    fn finished(&self, _what: &str) {
        self.bar.as_ref().inspect(|b| b.inc(1));
    }
}

/// Starts the platform's browser on `page` (without waiting for it).
fn open(page: &Path) -> Result<(), Error> {
    let (cmd, pre): (&str, &[&str]) = if cfg!(target_os = "macos") {
        ("open", &[])
    } else if cfg!(windows) {
        ("cmd", &["/C", "start", ""])
    } else {
        ("xdg-open", &[])
    };
    std::process::Command::new(cmd)
        .args(pre)
        .arg(page)
        .spawn()
        .map(|_| ())
        .map_err(|e| {
            Error::Other(format!(
                "--open: cannot start {cmd}: {e}; open {} by hand",
                page.display()
            ))
        })
}

pub fn cmd_study(args: StudyArgs, quiet: bool) -> Result<(), Error> {
    let shard = match &args.shard {
        Some(s) => parse_shard(s)?,
        None => (0, 1),
    };
    let config = StudyConfig {
        inputs: args.data.clone(),
        out: args.output.clone(),
        quick: args.quick,
        shard,
        envs: args.env.clone(),
        error_spp: args.error_spp,
    };
    let flag = crate::args::ctrl_c(
        "interrupted: stopping after the running step (finished steps are kept, no partial file is written); Ctrl-C again to abort",
    );
    let stop = move || flag.load(std::sync::atomic::Ordering::Relaxed);
    let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
        let pb = indicatif::ProgressBar::new(0);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "study [{bar:40}] {pos}/{len} steps {elapsed_precise} ETA {eta} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb
    });
    let display = Display {
        lines: !quiet && bar.is_none(),
        bar,
    };
    let summary = run(
        &lobe_materials::registry::Registry::builtin(),
        &config,
        &stop,
        &display,
    );
    if let Some(b) = &display.bar {
        b.finish_and_clear();
    }
    let summary = summary?;
    if !quiet {
        eprintln!(
            "{} materials: {} steps computed, {} already done",
            summary.materials, summary.computed, summary.skipped
        );
    }
    match &summary.index {
        Some(index) => {
            if !quiet {
                eprintln!("report: {}", index.display());
            }
            if args.open {
                open(index)?;
            }
        }
        None if !quiet => eprintln!(
            "{} materials are not complete yet (other shards): rerun without --shard once they are, to build the report",
            summary.pending
        ),
        None => {}
    }
    // As `lobe fit DIR`: every other material is done, and the exit status says that
    // some failed (1, after the report is written).
    if !summary.failures.is_empty() {
        for (name, error) in &summary.failures {
            eprintln!("lobe: {name} failed: {error}");
        }
        eprintln!("{}", summary.verdict());
        return Err(Error::Other(format!(
            "{} of {} materials failed (listed above{}); the others are done",
            summary.failures.len(),
            summary.materials,
            if summary.index.is_some() {
                " and in the report"
            } else {
                ""
            }
        )));
    }
    if !quiet {
        eprintln!("{}", summary.verdict());
    }
    Ok(())
}
