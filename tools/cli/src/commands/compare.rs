//! `lobe compare TEST.exr REFERENCE.exr`: RMSE, relative MSE, PSNR, SSIM and mean FLIP of a
//! test image against a reference, a FLIP heat map, thresholds for scripts, JSON output.

use crate::args::finite;
use lobe_renderer::Error;
use lobe_renderer::compare::{
    NoiseAwareRmse, ZTest, check_finite, flip_heatmap, metrics, noise_aware_rmse, z_test,
};
use lobe_renderer::film::Image;
use lobe_renderer::image_io::{ImageWindows, read_exr_windows};
use lobe_renderer::outputs::FilePlan;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CompareArgs {
    /// The image under test (EXR or HDR).
    test: PathBuf,
    /// The reference image (EXR or HDR).
    reference: PathBuf,
    /// Exposure in stops applied before tonemapping for SSIM and FLIP.
    #[arg(long, default_value_t = 0.0, value_parser = finite::<f32>)]
    exposure: f32,
    /// Write the FLIP error map as a colour PNG, with its colour bar and scale (0 to 1)
    /// and the mean FLIP under it.
    #[arg(long)]
    heatmap: Option<PathBuf>,
    /// Print the metrics as JSON.
    #[arg(long)]
    json: bool,
    /// Exit with failure when an error metric exceeds a value: NAME=VALUE with NAME one of
    /// rmse, relmse, flip (repeatable).
    #[arg(long, value_name = "NAME=VALUE")]
    fail_above: Vec<String>,
    /// Exit with failure when a similarity metric is below a value: psnr=VALUE or
    /// ssim=VALUE (repeatable).
    #[arg(long, value_name = "NAME=VALUE")]
    fail_below: Vec<String>,
    /// Noise-aware test: read each image's variance of the mean from NAME.var.exr next to
    /// it, z-test every pixel and channel, and fail if any is significant at this
    /// family-wise false-alarm rate (Sidak-corrected), e.g. 0.01. Also prints the RMSE
    /// with the noise taken out, its 95 % interval and the noise floor (an upper bound
    /// when a variance is a Sobol' render's own, exact from independent runs).
    #[arg(long, value_name = "ALPHA", value_parser = finite::<f64>)]
    z_test: Option<f64>,
    /// Degrees of freedom of the test image's variances (its spp - 1; default: normal).
    #[arg(long, value_parser = finite::<f64>)]
    test_dof: Option<f64>,
    /// Degrees of freedom of the reference's variances (e.g. runs - 1 of a Mitsuba
    /// reference; default: normal).
    #[arg(long, value_parser = finite::<f64>)]
    reference_dof: Option<f64>,
}

fn threshold(spec: &str, flag: &str, allowed: &[&str]) -> Result<(String, f64), Error> {
    let bad = || {
        Error::Other(format!(
            "--{flag} {spec}: expected NAME=VALUE with NAME one of {}",
            allowed.join(", ")
        ))
    };
    let (name, value) = spec.split_once('=').ok_or_else(bad)?;
    let name = name.trim().to_ascii_lowercase();
    if !allowed.contains(&name.as_str()) {
        return Err(bad());
    }
    let v: f64 = value.trim().parse().map_err(|_| bad())?;
    if !v.is_finite() {
        return Err(bad());
    }
    Ok((name, v))
}

/// Reads an image, refusing non-finite pixels with their count and the file's name.
fn load(path: &Path) -> Result<(lobe_renderer::film::Image, ImageWindows), Error> {
    if !path.exists() {
        return Err(Error::file(
            path.display(),
            "does not exist; expected an EXR or HDR image",
        ));
    }
    let (img, windows) = read_exr_windows(path)?;
    check_finite(&img.pixels, &path.display().to_string())?;
    Ok((img, windows))
}

/// Refuses two images whose pixels lie in different places (OpenEXR data or display
/// windows differ), as OpenImageIO's idiff tells them apart: compared pixel by pixel they
/// would match where they should not.
fn same_windows(a: (&Path, &ImageWindows), b: (&Path, &ImageWindows)) -> Result<(), Error> {
    for (what, wa, wb) in [
        ("data window", a.1.data, b.1.data),
        ("display window", a.1.display, b.1.display),
    ] {
        if wa != wb {
            return Err(Error::file(
                a.0.display(),
                format!(
                    "{what} {wa} differs from {}'s {wb}; expected images over the same pixels",
                    b.0.display()
                ),
            ));
        }
    }
    Ok(())
}

/// The variance image next to `image` (NAME.var.exr), as `lobe render --variance` writes.
fn variance_path(image: &Path) -> PathBuf {
    image.with_extension("var.exr")
}

/// The variance image of `image` (read from `path`): refused unless it has the image's
/// size, pixel for pixel.
fn load_variance(
    path: &Path,
    image: &lobe_renderer::film::Image,
    image_windows: &ImageWindows,
) -> Result<Vec<lobe_renderer::Rgb>, Error> {
    let vpath = variance_path(path);
    let (v, windows) = load(&vpath)?;
    if windows.data.width == image.width as usize && windows.data.height == image.height as usize {
        same_windows((&vpath, &windows), (path, image_windows))?;
    }
    if (v.width, v.height) != (image.width, image.height) {
        return Err(Error::file(
            vpath.display(),
            format!(
                "the variance image is {}x{}; expected the size of {}, {}x{}",
                v.width,
                v.height,
                path.display(),
                image.width,
                image.height
            ),
        ));
    }
    Ok(v.pixels)
}

fn plan(args: &CompareArgs) -> FilePlan {
    let mut plan = FilePlan::new();
    plan.input(&args.test, "the test image")
        .input(&args.reference, "the reference image");
    if args.z_test.is_some() {
        plan.input(variance_path(&args.test), "the test image's variance")
            .input(variance_path(&args.reference), "the reference's variance");
    }
    if let Some(h) = &args.heatmap {
        plan.output(h, "heat map");
    }
    plan
}

/// `--z-test`: the per-pixel and per-block z-test of the two images at false-alarm rate
/// `alpha`, and the RMSE with the noise taken out, each image with the variance its file
/// holds (or a sidecar gives).
fn noise_tests(
    args: &CompareArgs,
    (test, test_windows): (&Image, &ImageWindows),
    (reference, reference_windows): (&Image, &ImageWindows),
    alpha: f64,
) -> Result<(ZTest, NoiseAwareRmse), Error> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(Error::Other(format!(
            "--z-test: expected a false-alarm rate in (0, 1), found {alpha}"
        )));
    }
    let mut t = test.clone();
    let mut r = reference.clone();
    t.variance = load_variance(&args.test, test, test_windows)?;
    r.variance = load_variance(&args.reference, reference, reference_windows)?;
    t.variance_dof = args.test_dof.unwrap_or(f64::INFINITY);
    r.variance_dof = args.reference_dof.unwrap_or(f64::INFINITY);
    Ok((z_test(&t, &r, alpha)?, noise_aware_rmse(&t, &r)?))
}

pub fn cmd_compare(args: CompareArgs, quiet: bool) -> Result<(), Error> {
    let above: Vec<_> = args
        .fail_above
        .iter()
        .map(|s| threshold(s, "fail-above", &["rmse", "relmse", "flip"]))
        .collect::<Result<_, _>>()?;
    let below: Vec<_> = args
        .fail_below
        .iter()
        .map(|s| threshold(s, "fail-below", &["psnr", "ssim"]))
        .collect::<Result<_, _>>()?;
    plan(&args).check()?;
    let (test, test_windows) = load(&args.test)?;
    let (reference, reference_windows) = load(&args.reference)?;
    same_windows(
        (&args.test, &test_windows),
        (&args.reference, &reference_windows),
    )?;
    let (m, err) = metrics(&test, &reference, args.exposure)?;
    let z = match args.z_test {
        None => None,
        Some(alpha) => Some(noise_tests(
            &args,
            (&test, &test_windows),
            (&reference, &reference_windows),
            alpha,
        )?),
    };
    let noise = z.as_ref().map(|z| z.1);
    let z = z.map(|z| z.0);
    if let Some(h) = &args.heatmap {
        let map = flip_heatmap(&err, test.width, test.height);
        let caption = format!("(mean {:.4}; 0: no visible difference)", m.flip);
        lobe_analysis::figures::flip_map_with_bar(&map, test.width, test.height, &caption)?
            .save(h)?;
    }
    if args.json {
        let v = serde_json::json!({
            "test": args.test.display().to_string(),
            "reference": args.reference.display().to_string(),
            "width": test.width, "height": test.height, "exposure": args.exposure,
            "rmse": m.rmse, "relmse": m.rel_mse, "psnr": m.psnr, "ssim": m.ssim, "flip": m.flip,
            "noise": noise.map(|e| serde_json::json!({
                "rmse_without_noise": e.rmse, "ci95": e.ci95, "noise_floor": e.noise_floor,
            })),
            "z_test": z.as_ref().map(|z| serde_json::json!({
                "min_p": z.min_p, "threshold": z.threshold, "failures": z.failures,
                "tests": z.tests, "worst_block": [z.worst.0, z.worst.1], "worst_block_size": z.worst.2, "worst_z": z.worst.3,
            })),
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&v).expect("serializable")
        );
    } else if !quiet {
        println!(
            "RMSE    {:.6e}\nrelMSE  {:.6e}\nPSNR    {:.3} dB\nSSIM    {:.5}\nFLIP    {:.5}",
            m.rmse, m.rel_mse, m.psnr, m.ssim, m.flip
        );
        if let Some(e) = &noise {
            println!(
                "RMSE without noise {:.6e} (95 % interval [{:.6e}, {:.6e}]), noise floor {:.6e}",
                e.rmse, e.ci95[0], e.ci95[1], e.noise_floor
            );
        }
        if let Some(z) = &z {
            println!(
                "z-test  min p {:.3e} (threshold {:.3e} over {} tests), {} significant, worst z {:.2} for the {}x{} block at ({}, {})",
                z.min_p,
                z.threshold,
                z.tests,
                z.failures,
                z.worst.3,
                z.worst.2,
                z.worst.2,
                z.worst.0,
                z.worst.1
            );
        }
    }
    let failed = threshold_failures(&m, &above, &below);
    if !args.json && (z.is_some() || !above.is_empty() || !below.is_empty()) {
        println!(
            "{}",
            verdict(z.as_ref(), args.z_test, &failed, above.len() + below.len())
        );
    }
    if let Some(z) = &z
        && !z.passed()
    {
        return Err(Error::Other(format!(
            "{} against {}: z-test fails: {} of {} tests significant, worst z {:.2} for the {}x{} block at ({}, {})",
            args.test.display(),
            args.reference.display(),
            z.failures,
            z.tests,
            z.worst.3,
            z.worst.2,
            z.worst.2,
            z.worst.0,
            z.worst.1
        )));
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Error::Other(format!(
            "{} against {}: {}",
            args.test.display(),
            args.reference.display(),
            failed.join(", ")
        )))
    }
}

/// The one line that ends a checking comparison: PASS or FAIL, with the z-test's count
/// and the thresholds missed.
fn verdict(
    z: Option<&lobe_renderer::compare::ZTest>,
    alpha: Option<f64>,
    failed: &[String],
    thresholds: usize,
) -> String {
    let mut parts = Vec::new();
    if let Some(z) = z {
        parts.push(format!(
            "{} of {} z-tests significant at a family-wise false-alarm rate of {}",
            z.failures,
            z.tests,
            alpha.unwrap_or_default()
        ));
    }
    if thresholds > 0 {
        parts.push(match failed.is_empty() {
            true => format!("all {thresholds} thresholds met"),
            false => format!("missed: {}", failed.join(", ")),
        });
    }
    let pass = z.is_none_or(|z| z.passed()) && failed.is_empty();
    format!(
        "{}: {}",
        if pass { "PASS" } else { "FAIL" },
        parts.join("; ")
    )
}

/// The thresholds a metric misses; a metric that is NaN (SSIM of an image under 8x8
/// pixels) misses every threshold on it.
fn threshold_failures(
    m: &lobe_renderer::compare::Metrics,
    above: &[(String, f64)],
    below: &[(String, f64)],
) -> Vec<String> {
    let undefined = |name: &str| format!("{name} is undefined (NaN; SSIM needs 8x8 pixels)");
    let mut failed = Vec::new();
    for (name, v) in above {
        let got = m.get(name).expect("known");
        if got.is_nan() {
            failed.push(undefined(name));
        } else if got > *v {
            failed.push(format!("{name} {got:.6e} > {v}"));
        }
    }
    for (name, v) in below {
        let got = m.get(name).expect("known");
        if got.is_nan() {
            failed.push(undefined(name));
        } else if got < *v {
            failed.push(format!("{name} {got:.6e} < {v}"));
        }
    }
    failed
}
