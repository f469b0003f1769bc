//! `lobe._lobe.Material`: a material built by lobe-materials' registry from the JSON of
//! scene files, fit reports and Ngan fits, evaluated, its density and its importance
//! sampling computed on numpy arrays of directions (the `Bsdf` interface of
//! materials/src/bsdf.rs: local shading frame, z the normal, `wo` toward the viewer, `wi`
//! toward the light, f_r without the cosine), and its directional albedo.
//!
//! The arrays are cut into fixed chunks evaluated on rayon's pool with the GIL released:
//! `eval` and `pdf` call the one-pair methods (what `lobe eval` calls), `eval_pdf` and
//! `sample` the batched `eval_pdf_many` / `sample_many`, which must equal the one-pair
//! calls bit for bit; results do not depend on the thread count.

use crate::{guarded, to_py};
use glam::{Vec2, Vec3};
use lobe_materials::frame::spherical_direction;
use lobe_materials::registry::{BuildContext, Registry};
use lobe_materials::sampling::warp::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use lobe_materials::{Bsdf, BsdfSamples, Rgb, Vec2s, Vec3s};
use lobe_renderer::Error;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

/// Direction pairs per task: large enough to amortize scheduling, small enough to balance.
const CHUNK: usize = 4096;

/// A BRDF built from a material description.
#[pyclass(module = "lobe._lobe", frozen)]
pub struct Material {
    bsdf: Arc<dyn Bsdf>,
}

/// The rows of an (N, `width`) float32 array as a contiguous slice, or a ValueError
/// naming the argument and the shape found.
fn rows<'a>(a: &'a PyReadonlyArray2<'_, f32>, name: &str, width: usize) -> PyResult<&'a [f32]> {
    let shape = a.shape();
    if shape[1] != width {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape (N, {width}), found {shape:?}"
        )));
    }
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a C-contiguous array")))
}

fn same_length(a: (&str, usize), b: (&str, usize)) -> PyResult<()> {
    if a.1 != b.1 {
        return Err(PyValueError::new_err(format!(
            "{} has {} rows but {} has {}; expected one row each per query",
            a.0, a.1, b.0, b.1
        )));
    }
    Ok(())
}

/// The two (N, 3) direction arrays of a query, checked.
fn pairs<'a>(
    wo: &'a PyReadonlyArray2<'_, f32>,
    wi: &'a PyReadonlyArray2<'_, f32>,
) -> PyResult<(&'a [f32], &'a [f32])> {
    let (o, i) = (rows(wo, "wo", 3)?, rows(wi, "wi", 3)?);
    same_length(("wo", o.len() / 3), ("wi", i.len() / 3))?;
    Ok((o, i))
}

/// Rows of 3 floats as the batched calls' columns.
fn vec3s(s: &[f32]) -> Vec3s {
    s.chunks_exact(3).map(Vec3::from_slice).collect()
}

/// f (3 floats per pair) and pdf of every pair of `wo` and `wi` (3 floats per direction).
fn eval_pdf(b: &dyn Bsdf, wo: &[f32], wi: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let n = wo.len() / 3;
    let (mut f, mut pdf) = (vec![0.0f32; 3 * n], vec![0.0f32; n]);
    f.par_chunks_mut(3 * CHUNK)
        .zip(pdf.par_chunks_mut(CHUNK))
        .zip(wo.par_chunks(3 * CHUNK).zip(wi.par_chunks(3 * CHUNK)))
        .for_each(|((f, pdf), (wo, wi))| {
            let mut rgb = vec![Rgb::ZERO; pdf.len()];
            b.eval_pdf_many(vec3s(wo).cols(), vec3s(wi).cols(), &mut rgb, pdf);
            for (o, c) in f.chunks_exact_mut(3).zip(&rgb) {
                o.copy_from_slice(&c.to_array());
            }
        });
    (f, pdf)
}

/// `W` floats per pair of `wo` and `wi` (3 floats per direction) from one-pair calls of
/// `f`: the path of `eval` and `pdf` alone (a batched call would compute both).
fn per_pair<const W: usize>(
    wo: &[f32],
    wi: &[f32],
    f: impl Fn(Vec3, Vec3) -> [f32; W] + Sync,
) -> Vec<f32> {
    let mut out = vec![0.0f32; wo.len() / 3 * W];
    out.par_chunks_mut(W * CHUNK)
        .zip(wo.par_chunks(3 * CHUNK).zip(wi.par_chunks(3 * CHUNK)))
        .for_each(|(out, (wo, wi))| {
            for ((o, a), b) in out
                .chunks_exact_mut(W)
                .zip(wo.chunks_exact(3))
                .zip(wi.chunks_exact(3))
            {
                o.copy_from_slice(&f(Vec3::from_slice(a), Vec3::from_slice(b)));
            }
        });
    out
}

/// Samples of every query: wi and weight (3 floats each, zero where no sample), pdf
/// (zero where none) and whether a sample was produced.
struct Samples {
    wi: Vec<f32>,
    weight: Vec<f32>,
    pdf: Vec<f32>,
    valid: Vec<bool>,
}

fn sample(b: &dyn Bsdf, wo: &[f32], u: &[f32], uc: &[f32]) -> Samples {
    let n = uc.len();
    let mut s = Samples {
        wi: vec![0.0; 3 * n],
        weight: vec![0.0; 3 * n],
        pdf: vec![0.0; n],
        valid: vec![false; n],
    };
    s.wi.par_chunks_mut(3 * CHUNK)
        .zip(s.weight.par_chunks_mut(3 * CHUNK))
        .zip(
            s.pdf
                .par_chunks_mut(CHUNK)
                .zip(s.valid.par_chunks_mut(CHUNK)),
        )
        .zip(wo.par_chunks(3 * CHUNK).zip(u.par_chunks(2 * CHUNK)))
        .zip(uc.par_chunks(CHUNK))
        .for_each(|((((wi, weight), (pdf, valid)), (wo, u)), uc)| {
            let u: Vec2s = u.chunks_exact(2).map(Vec2::from_slice).collect();
            let mut out = BsdfSamples::new(uc.len());
            b.sample_many(vec3s(wo).cols(), u.cols(), uc, out.cols_mut());
            for (k, o) in out.iter().enumerate() {
                if let Some(o) = o {
                    wi[3 * k..3 * k + 3].copy_from_slice(&o.wi.to_array());
                    weight[3 * k..3 * k + 3].copy_from_slice(&o.weight.to_array());
                    pdf[k] = o.pdf;
                    valid[k] = true;
                }
            }
        });
    s
}

/// Directional albedo int f(wo, wi) cos(theta_i) dwi per channel, from n x n stratified
/// draws of each of two strategies (cosine-weighted and the material's own sampling)
/// combined with the balance heuristic: unbiased even where the material's sampler misses
/// part of the lobe.
fn albedo(b: &dyn Bsdf, wo: Vec3, n: usize) -> [f64; 3] {
    let row = |i: usize| {
        let mut acc = [0.0f64; 3];
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let uc = ((i * n + j) as f32 * 0.618_034).fract();
            let drawn = b.sample(wo, u, uc).map(|s| s.wi);
            for wi in [Some(square_to_cosine_hemisphere(u)), drawn]
                .into_iter()
                .flatten()
            {
                let pdf = 0.5 * cosine_hemisphere_pdf(wi.z) + 0.5 * b.pdf(wo, wi);
                if wi.z > 0.0 && pdf > 0.0 {
                    let v = b.eval(wo, wi) * (wi.z / pdf);
                    for (a, x) in acc.iter_mut().zip(v.to_array()) {
                        *a += x as f64;
                    }
                }
            }
        }
        acc
    };
    let sum = (0..n).into_par_iter().map(row).collect::<Vec<_>>();
    let total = sum
        .iter()
        .fold([0.0f64; 3], |a, r| [a[0] + r[0], a[1] + r[1], a[2] + r[2]]);
    total.map(|t| t / (2 * n * n) as f64)
}

fn flat_array<'py>(py: Python<'py>, v: Vec<f32>, width: usize) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len() / width;
    Ok(PyArray1::from_vec(py, v).reshape([n, width])?.into_any())
}

impl Material {
    /// The built BRDF.
    pub(crate) fn bsdf(&self) -> Arc<dyn Bsdf> {
        self.bsdf.clone()
    }

    fn build(desc: &serde_json::Value, shown: &str, base: PathBuf) -> PyResult<Self> {
        let registry = Registry::builtin();
        let bsdf = registry
            .create_with(desc, "material", &BuildContext::new(&base, &registry))
            .map_err(|e| to_py(Error::scene(shown, e.path, e.message)))?;
        Ok(Self { bsdf })
    }
}

#[pymethods]
impl Material {
    /// A material from JSON text; `shown` names it in errors, relative files resolve
    /// against `base` (default: the current folder).
    #[staticmethod]
    #[pyo3(signature = (text, shown, base=None))]
    fn from_json(text: &str, shown: &str, base: Option<PathBuf>) -> PyResult<Self> {
        guarded(|| {
            let desc = lobe_materials::json::parse(text, shown)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
            let here = std::env::current_dir().unwrap_or_default();
            Self::build(&desc, shown, base.unwrap_or(here))
        })
    }

    /// A material from a JSON file (the CLI's `--material @FILE`).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        guarded(|| {
            let desc = lobe_materials::json::read(&path).map_err(crate::file_err)?;
            let base = path.parent().map(PathBuf::from).unwrap_or_default();
            Self::build(&desc, &path.display().to_string(), base)
        })
    }

    /// The registry name of the model.
    #[getter]
    fn name(&self) -> String {
        self.bsdf.name().to_string()
    }

    fn eval<'py>(
        &self,
        py: Python<'py>,
        wo: PyReadonlyArray2<'py, f32>,
        wi: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let ((o, i), b) = (pairs(&wo, &wi)?, self.bsdf.as_ref());
            let f = py.detach(|| per_pair(o, i, |wo, wi| b.eval(wo, wi).to_array()));
            flat_array(py, f, 3)
        })
    }

    fn pdf<'py>(
        &self,
        py: Python<'py>,
        wo: PyReadonlyArray2<'py, f32>,
        wi: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let ((o, i), b) = (pairs(&wo, &wi)?, self.bsdf.as_ref());
            let p = py.detach(|| per_pair(o, i, |wo, wi| [b.pdf(wo, wi)]));
            Ok(PyArray1::from_vec(py, p).into_any())
        })
    }

    fn eval_pdf<'py>(
        &self,
        py: Python<'py>,
        wo: PyReadonlyArray2<'py, f32>,
        wi: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        guarded(|| {
            let ((o, i), b) = (pairs(&wo, &wi)?, self.bsdf.as_ref());
            let (f, pdf) = py.detach(|| eval_pdf(b, o, i));
            Ok((
                flat_array(py, f, 3)?,
                PyArray1::from_vec(py, pdf).into_any(),
            ))
        })
    }

    fn sample<'py>(
        &self,
        py: Python<'py>,
        wo: PyReadonlyArray2<'py, f32>,
        u: PyReadonlyArray2<'py, f32>,
        uc: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            let (o, u) = (rows(&wo, "wo", 3)?, rows(&u, "u", 2)?);
            let uc = uc
                .as_slice()
                .map_err(|_| PyValueError::new_err("uc: expected a C-contiguous array"))?;
            same_length(("wo", o.len() / 3), ("u", u.len() / 2))?;
            same_length(("wo", o.len() / 3), ("uc", uc.len()))?;
            let b = self.bsdf.as_ref();
            let s = py.detach(|| sample(b, o, u, uc));
            let out = (
                flat_array(py, s.wi, 3)?,
                flat_array(py, s.weight, 3)?,
                PyArray1::from_vec(py, s.pdf),
                PyArray1::from_vec(py, s.valid),
            );
            Ok(out.into_pyobject(py)?.into_any())
        })
    }

    /// Directional albedo per channel for each viewer elevation in `theta_o` (degrees) at
    /// azimuth `phi_o` (degrees), from 2 n^2 stratified samples each.
    fn albedo<'py>(
        &self,
        py: Python<'py>,
        theta_o: Vec<f64>,
        phi_o: f64,
        n: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        guarded(|| {
            if n == 0 || n > 4096 {
                return Err(PyValueError::new_err(format!(
                    "n: expected 1 to 4096 strata per axis, found {n}"
                )));
            }
            if let Some(t) = theta_o.iter().find(|t| !(**t >= 0.0 && **t < 90.0)) {
                return Err(PyValueError::new_err(format!(
                    "theta_o: expected elevations in [0, 90) degrees, found {t}"
                )));
            }
            let b = self.bsdf.as_ref();
            let rgb: Vec<f32> = py.detach(|| {
                theta_o
                    .iter()
                    .flat_map(|t| {
                        let wo =
                            spherical_direction(t.to_radians() as f32, phi_o.to_radians() as f32);
                        albedo(b, wo, n).map(|x| x as f32)
                    })
                    .collect()
            });
            flat_array(py, rgb, 3)
        })
    }

    fn __repr__(&self) -> String {
        format!("lobe.Material({})", self.bsdf.name())
    }
}

/// lobe's direction convention: the unit vector at elevation `theta` and azimuth `phi`
/// (degrees), computed as `lobe eval` computes it (radians in f64, then f32).
#[pyfunction]
fn directions<'py>(
    py: Python<'py>,
    theta: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    guarded(|| {
        let (t, p) = (theta.as_array(), phi.as_array());
        same_length(("theta", t.len()), ("phi", p.len()))?;
        let v: Vec<f32> = t
            .iter()
            .zip(p.iter())
            .flat_map(|(t, p)| {
                spherical_direction(t.to_radians() as f32, p.to_radians() as f32).to_array()
            })
            .collect();
        flat_array(py, v, 3)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Material>()?;
    m.add_function(wrap_pyfunction!(directions, m)?)?;
    Ok(())
}
