//! Measured data to and from numpy: MERL tables and the study's binned files through
//! lobe-materials' readers and writers (materials/src/measured/merl.rs, binned.rs), RGL
//! tensor files through its tensor reader (measured/tensor.rs), after the RGL reader has
//! accepted the file. A writer checks what it is about to write with the reader first, so
//! it never leaves a file lobe would refuse.

use crate::{file_err, guarded};
use lobe_materials::FileError;
use lobe_materials::measured::binned::{Axis, Binned};
use lobe_materials::measured::merl::{self, Merl};
use lobe_materials::measured::rgl::Rgl;
use lobe_materials::measured::tensor::TensorFile;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;

const MERL_SHAPE: [usize; 4] = [merl::RES_THETA_H, merl::RES_THETA_D, merl::RES_PHI_D, 3];

/// The MERL table as (theta_h, theta_d, phi_d, rgb) float32 in 1/sr, -1 where missing.
#[pyfunction]
fn read_merl(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    guarded(|| {
        let m = py.detach(|| Merl::read(&path)).map_err(file_err)?;
        let mut v = Vec::with_capacity(merl::SAMPLES * 3);
        for ith in 0..merl::RES_THETA_H {
            for itd in 0..merl::RES_THETA_D {
                for ipd in 0..merl::RES_PHI_D {
                    v.extend_from_slice(&m.bin(ith, itd, ipd));
                }
            }
        }
        Ok(PyArray1::from_vec(py, v).reshape(MERL_SHAPE)?.into_any())
    })
}

/// Writes a MERL table from a (90, 90, 180, 3) array in 1/sr; negative or NaN = missing.
#[pyfunction]
fn write_merl(path: PathBuf, values: PyReadonlyArrayDyn<'_, f32>) -> PyResult<()> {
    guarded(|| {
        if values.shape() != MERL_SHAPE {
            return Err(PyValueError::new_err(format!(
                "values: expected an array of shape (90, 90, 180, 3) (theta_h, theta_d, phi_d, rgb), found {:?}",
                values.shape()
            )));
        }
        let a = values.as_array();
        let m = Merl::from_fn(|_, _, (i, j, k)| {
            let c = [a[[i, j, k, 0]], a[[i, j, k, 1]], a[[i, j, k, 2]]];
            c.iter().all(|x| *x >= 0.0).then(|| c.map(f64::from))
        });
        let shown = path.display().to_string();
        Merl::from_bytes(&m.to_bytes(), &shown).map_err(file_err)?;
        m.write(&path).map_err(file_err)
    })
}

/// A binned file: values (one axis per binned angle, then rgb; NaN where empty), the axes
/// as (count, min, max) in degrees, and whether it is anisotropic.
#[pyfunction]
fn read_binned(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    guarded(|| {
        let b = py.detach(|| Binned::read(&path)).map_err(file_err)?;
        let mut shape: Vec<usize> = b.axes.iter().map(|a| a.count).collect();
        shape.push(3);
        let v: Vec<f32> = b
            .values
            .iter()
            .flat_map(|v| v.unwrap_or([f32::NAN; 3]))
            .collect();
        let axes: Vec<(usize, f64, f64)> = b.axes.iter().map(|a| (a.count, a.min, a.max)).collect();
        let values = PyArray1::from_vec(py, v).reshape(shape)?;
        Ok((values, axes, b.anisotropic).into_pyobject(py)?.into_any())
    })
}

/// Writes a binned file (the layout `read_binned` returns).
#[pyfunction]
fn write_binned(
    path: PathBuf,
    values: PyReadonlyArrayDyn<'_, f32>,
    axes: Vec<(usize, f64, f64)>,
    anisotropic: bool,
) -> PyResult<()> {
    guarded(|| {
        let mut shape: Vec<usize> = axes.iter().map(|a| a.0).collect();
        shape.push(3);
        if values.shape() != shape.as_slice() {
            return Err(PyValueError::new_err(format!(
                "values: expected an array of shape {shape:?} (the axes' bin counts, then rgb), found {:?}",
                values.shape()
            )));
        }
        let flat: Vec<f32> = values.as_array().iter().copied().collect();
        let b = Binned {
            anisotropic,
            axes: axes
                .iter()
                .map(|&(n, lo, hi)| Axis::new(n, lo, hi))
                .collect(),
            values: flat
                .chunks_exact(3)
                .map(|c| c.iter().all(|x| !x.is_nan()).then(|| [c[0], c[1], c[2]]))
                .collect(),
        };
        let shown = path.display().to_string();
        Binned::from_bytes(&b.to_bytes(), &shown).map_err(file_err)?;
        b.write(&path).map_err(file_err)
    })
}

/// An RGL tensor file's fields as name -> (type code, shape, little-endian bytes), once
/// the RGL reader has accepted the file.
#[pyfunction]
fn read_rgl_fields(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyDict>> {
    guarded(|| {
        let t = py
            .detach(|| Rgl::read(&path).and_then(|_| TensorFile::read(&path)))
            .map_err(|e: FileError| file_err(e))?;
        let d = PyDict::new(py);
        for (name, f) in &t.fields {
            d.set_item(name, (f.dtype, f.shape.clone(), PyBytes::new(py, &f.bytes)))?;
        }
        Ok(d)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_merl, m)?)?;
    m.add_function(wrap_pyfunction!(write_merl, m)?)?;
    m.add_function(wrap_pyfunction!(read_binned, m)?)?;
    m.add_function(wrap_pyfunction!(write_binned, m)?)?;
    m.add_function(wrap_pyfunction!(read_rgl_fields, m)?)?;
    Ok(())
}
