"""Measured BRDF data to and from numpy, through lobe's own readers and writers (the
same checks and error messages as the ``lobe`` command)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Dict, List, Tuple, Union

import numpy as np

from . import _lobe

PathLike = Union[str, "os.PathLike[str]"]

# Type codes of Mitsuba's tensor files (u8, i8, u16, i16, u32, i32, u64, i64, f16, f32, f64).
_TENSOR_DTYPES = {1: "<u1", 2: "<i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8", 9: "<f2", 10: "<f4", 11: "<f8"}


def read_merl(path: PathLike) -> np.ndarray:
    """A MERL ``.binary`` table (Matusik et al. 2003) as a float32 array of shape
    (90, 90, 180, 3): BRDF values in 1/sr (the file's values times 1/1500, 1.15/1500 and
    1.66/1500 for red, green, blue), -1 where a sample is missing.

    Axes are Rusinkiewicz's half/difference angles: index ``i`` of theta_h covers
    theta_h = (i / 90)^2 * 90 degrees up to ((i + 1) / 90)^2 * 90 (non-linear, finer near
    the specular peak); ``j`` of theta_d covers [j, j + 1) degrees; ``k`` of phi_d covers
    [k, k + 1) degrees of [0, 180) (phi_d and phi_d + 180 are the same by reciprocity).
    Values are f32, equal to what lobe's reader holds (materials/src/measured/merl.rs)."""
    return _lobe.read_merl(os.fspath(path))


def write_merl(path: PathLike, values: np.ndarray) -> None:
    """Writes a (90, 90, 180, 3) array in 1/sr (``read_merl``'s layout; negative or NaN
    marks a missing sample) as a MERL ``.binary`` file, atomically."""
    _lobe.write_merl(os.fspath(path), np.ascontiguousarray(values, dtype=np.float32))


@dataclass
class Binned:
    """The study's binned data (Ngan et al. 2005 section 2.4; docs/binned-format.md).

    ``values``: float32, one axis per binned angle then RGB (1/sr), NaN in empty bins;
    isotropic data bins (theta_i, theta_o, phi_d), anisotropic data (theta_i, theta_o,
    phi_i, phi_o). ``axes``: per angle (bin count, lower bound, upper bound) in degrees,
    bins uniform over [lower, upper)."""

    values: np.ndarray
    axes: List[Tuple[int, float, float]]
    anisotropic: bool


def read_binned(path: PathLike) -> Binned:
    """Reads a binned file (``LOBEBIN1``)."""
    values, axes, anisotropic = _lobe.read_binned(os.fspath(path))
    return Binned(values, [tuple(a) for a in axes], anisotropic)


def write_binned(path: PathLike, data: Binned) -> None:
    """Writes binned data atomically (checked by the reader first)."""
    axes = [(int(n), float(lo), float(hi)) for n, lo, hi in data.axes]
    _lobe.write_binned(os.fspath(path), np.ascontiguousarray(data.values, dtype=np.float32), axes, bool(data.anisotropic))


def read_rgl(path: PathLike) -> Dict[str, np.ndarray]:
    """An RGL measured BSDF (Dupuy and Jakob 2018, a ``*_rgb.bsdf`` tensor file) as its
    fields, name -> numpy array, after lobe's RGL reader has accepted the file.

    The fields are those of the format: ``theta_i`` and ``phi_i`` (radians) the measured
    incident directions; ``ndf`` and ``sigma`` over the unit square of the half vector /
    the viewer (u = sqrt(theta / 90 degrees), v = (phi + 180 degrees) / 360 degrees);
    ``vndf`` and ``luminance`` (phi_i, theta_i, 2D sample space), the warps of the
    visible-normal distribution; ``rgb`` (phi_i, theta_i, channel, 2D sample space) the
    BRDF times cos(theta_i) at the warped points; ``description`` (bytes) and
    ``jacobian``. To evaluate it use ``Material({"type": "rgl", "file": path})``. lobe has
    no RGL writer."""
    fields = _lobe.read_rgl_fields(os.fspath(path))
    return {name: np.frombuffer(data, dtype=_TENSOR_DTYPES[code]).reshape(shape)
            for name, (code, shape, data) in sorted(fields.items())}
