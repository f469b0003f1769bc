//! Renders and images: `lobe.render` loads a scene (a file, or a dict given as JSON text
//! with the folder its relative paths resolve against) with lobe-renderer's loader and
//! renders it with the path tracer the CLI runs; `lobe.compare` computes
//! `lobe compare`'s metrics (RMSE, relative MSE, PSNR, SSIM, FLIP) and its noise-aware
//! z-test (renderer/src/compare.rs); images are (H, W, 3) float32 arrays of linear RGB.
//! A render reports its progress to a Python callable and stops on Ctrl-C ([`interrupt`]).

use crate::{guarded, interrupt, to_py};
use lobe_materials::Rgb;
use lobe_renderer::Error;
use lobe_renderer::compare::{check_finite, metrics, z_test};
use lobe_renderer::film::Image;
use lobe_renderer::image_io::{read_exr, write_exr};
use lobe_renderer::partial::PartialRender;
use lobe_renderer::render::{
    Progress, RenderOptions, render as render_scene, render_samples as render_samples_of,
};
use lobe_renderer::scene::{self, LoadOptions};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;

fn to_array<'py>(py: Python<'py>, img: &Image, px: &[Rgb]) -> PyResult<Bound<'py, PyAny>> {
    let v: Vec<f32> = px.iter().flat_map(|p| p.to_array()).collect();
    let shape = [img.height as usize, img.width as usize, 3];
    Ok(PyArray1::from_vec(py, v).reshape(shape)?.into_any())
}

/// The pixels of an (H, W, 3) array, refusing other shapes and non-finite values.
fn pixels(a: &PyReadonlyArray3<'_, f32>, what: &str) -> PyResult<(u32, u32, Vec<Rgb>)> {
    let s = a.shape();
    if s[2] != 3 || s[0] == 0 || s[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected an image array of shape (H, W, 3), found {s:?}"
        )));
    }
    let px: Vec<Rgb> = a
        .as_array()
        .as_standard_layout()
        .as_slice()
        .expect("standard layout")
        .chunks_exact(3)
        .map(|c| Rgb::new(c[0], c[1], c[2]))
        .collect();
    check_finite(&px, what).map_err(to_py)?;
    Ok((s[1] as u32, s[0] as u32, px))
}

/// Renders a scene; returns (image, variance of each pixel's mean, statistics JSON).
/// `progress(done, total)` (pixels) is called on the calling thread as tiles finish, with
/// `done` increasing and last equal to `total`; Ctrl-C or an exception from `progress`
/// stops the render and is raised.
#[pyfunction]
#[pyo3(signature = (path, text, base, spp, seed, threads, progress))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    path: Option<PathBuf>,
    text: Option<String>,
    base: PathBuf,
    spp: Option<u32>,
    seed: Option<u64>,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    guarded(|| {
        check_counts(spp, threads)?;
        let work = |events: &interrupt::Events<(u64, u64)>| {
            let sc = load_scene((&path, &text, &base), spp, seed)?;
            let (cancel, events) = (events.cancel.clone(), events.clone());
            let ro = RenderOptions {
                threads,
                progress: progress
                    .is_some()
                    .then(|| Progress::new(move |done, total| events.post((done, total)))),
                cancel: Some(cancel),
            };
            render_scene(&sc, &ro)
        };
        let show = |py: Python<'_>, batch: Vec<(u64, u64)>| match (&progress, batch.last()) {
            (Some(cb), Some(&(done, total))) => cb.call1(py, (done, total)).map(drop),
            _ => Ok(()),
        };
        let (img, stats) = interrupt::run(py, work, show)?.map_err(to_py)?;
        let out = (
            to_array(py, &img, &img.pixels)?,
            to_array(py, &img, &img.variance)?,
            stats.to_json().to_string(),
        );
        Ok(out.into_pyobject(py)?.into_any())
    })
}

/// Refuses a sample count or a thread count of 0.
fn check_counts(spp: Option<u32>, threads: Option<usize>) -> PyResult<()> {
    if spp == Some(0) {
        return Err(PyValueError::new_err(
            "spp: expected a positive number of samples per pixel, found 0",
        ));
    }
    if threads == Some(0) {
        return Err(PyValueError::new_err(
            "threads: expected at least 1 thread, found 0",
        ));
    }
    Ok(())
}

/// The scene of a file, or of JSON text whose paths resolve against `base`, with its
/// samples per pixel and seed overridden when given.
fn load_scene(
    (path, text, base): (&Option<PathBuf>, &Option<String>, &PathBuf),
    spp: Option<u32>,
    seed: Option<u64>,
) -> Result<scene::Scene, Error> {
    let opts = LoadOptions::with_builtins();
    let mut sc = match (path, text) {
        (Some(p), _) => scene::load_with(p, &opts)?,
        (None, Some(t)) => {
            let v = lobe_materials::json::parse(t, "<scene dict>")?;
            scene::from_value(&v, "<scene dict>", base, &opts)?
        }
        (None, None) => {
            return Err(Error::Other("scene: expected a file or a dict".into()));
        }
    };
    sc.settings.spp = spp.unwrap_or(sc.settings.spp);
    sc.settings.seed = seed.unwrap_or(sc.settings.seed);
    Ok(sc)
}

/// Renders the samples `first..last` of every pixel and returns the partial render's bytes
/// (the `.lobepart` format, `lobe_renderer::partial`), which `merge_renders` joins. Ctrl-C
/// stops it and is raised.
#[pyfunction]
#[pyo3(signature = (path, text, base, spp, seed, first, last, threads=None))]
#[allow(clippy::too_many_arguments)]
fn render_samples<'py>(
    py: Python<'py>,
    path: Option<PathBuf>,
    text: Option<String>,
    base: PathBuf,
    spp: Option<u32>,
    seed: Option<u64>,
    first: u32,
    last: u32,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyBytes>> {
    guarded(|| {
        check_counts(spp, threads)?;
        let work = |events: &interrupt::Events<()>| {
            let sc = load_scene((&path, &text, &base), spp, seed)?;
            let ro = RenderOptions {
                threads,
                progress: None,
                cancel: Some(events.cancel.clone()),
            };
            render_samples_of(&sc, (first, last), &ro)
        };
        let (part, _) = interrupt::run(py, work, |_, _| Ok(()))?.map_err(to_py)?;
        Ok(PyBytes::new(py, &part.to_bytes()))
    })
}

/// Joins partial renders (their bytes, in any order) whose ranges cover every sample:
/// returns (image, variance of each pixel's mean, header JSON: size, spp, key, dropped).
#[pyfunction]
fn merge_renders<'py>(py: Python<'py>, parts: Vec<Vec<u8>>) -> PyResult<Bound<'py, PyAny>> {
    guarded(|| {
        let parts = parts
            .iter()
            .enumerate()
            .map(|(k, b)| PartialRender::from_bytes(b, &format!("part {k}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(to_py)?;
        let merged = PartialRender::merge(parts).map_err(to_py)?;
        let img = merged.image().map_err(to_py)?;
        let header = serde_json::json!({"width": merged.width, "height": merged.height,
            "spp": merged.spp, "key": merged.key, "nonfinite_dropped": merged.dropped});
        let out = (
            to_array(py, &img, &img.pixels)?,
            to_array(py, &img, &img.variance)?,
            header.to_string(),
        );
        Ok(out.into_pyobject(py)?.into_any())
    })
}

/// `lobe compare`'s metrics of `test` against `reference`, and with both variances (of
/// the pixel means, with their degrees of freedom) the z-test at false-alarm rate `alpha`.
#[pyfunction]
#[pyo3(signature = (test, reference, exposure, variances, alpha))]
fn compare<'py>(
    py: Python<'py>,
    test: PyReadonlyArray3<'py, f32>,
    reference: PyReadonlyArray3<'py, f32>,
    exposure: f32,
    variances: Option<(
        PyReadonlyArray3<'py, f32>,
        f64,
        PyReadonlyArray3<'py, f32>,
        f64,
    )>,
    alpha: f64,
) -> PyResult<Bound<'py, PyDict>> {
    guarded(|| {
        let image = |a: &PyReadonlyArray3<'_, f32>, what: &str| -> PyResult<Image> {
            let (w, h, px) = pixels(a, what)?;
            let mut img = Image::new(w, h);
            img.pixels = px;
            Ok(img)
        };
        let (mut t, mut r) = (image(&test, "test")?, image(&reference, "reference")?);
        let (m, _) = metrics(&t, &r, exposure).map_err(to_py)?;
        let d = PyDict::new(py);
        for name in lobe_renderer::compare::Metrics::NAMES {
            d.set_item(*name, m.get(name))?;
        }
        if let Some((tv, tdof, rv, rdof)) = variances {
            t.variance = pixels(&tv, "test variance")?.2;
            r.variance = pixels(&rv, "reference variance")?.2;
            (t.variance_dof, r.variance_dof) = (tdof, rdof);
            let z = z_test(&t, &r, alpha).map_err(to_py)?;
            let zd = PyDict::new(py);
            zd.set_item("passed", z.passed())?;
            zd.set_item("min_p", z.min_p)?;
            zd.set_item("threshold", z.threshold)?;
            zd.set_item("failures", z.failures)?;
            zd.set_item("tests", z.tests)?;
            zd.set_item("worst_block", (z.worst.0, z.worst.1))?;
            zd.set_item("worst_block_size", z.worst.2)?;
            zd.set_item("worst_z", z.worst.3)?;
            d.set_item("z_test", zd)?;
        }
        Ok(d)
    })
}

/// Reads an EXR or Radiance HDR image as (H, W, 3) float32, refusing non-finite pixels.
#[pyfunction]
fn read_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    guarded(|| {
        if !path.exists() {
            return Err(to_py(Error::file(
                path.display(),
                "does not exist; expected an EXR or HDR image",
            )));
        }
        let img = read_exr(&path).map_err(to_py)?;
        check_finite(&img.pixels, &path.display().to_string()).map_err(to_py)?;
        to_array(py, &img, &img.pixels)
    })
}

/// Writes an (H, W, 3) array as a float32 OpenEXR file, atomically.
#[pyfunction]
fn write_image(path: PathBuf, image: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    guarded(|| {
        let (w, h, px) = pixels(&image, "image")?;
        write_exr(&path, w, h, &px).map_err(to_py)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(render_samples, m)?)?;
    m.add_function(wrap_pyfunction!(merge_renders, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    Ok(())
}
