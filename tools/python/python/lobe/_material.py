"""``lobe.Material``: a BRDF built by lobe's registry from the JSON of scene files, fit
reports and Ngan fits, evaluated on numpy arrays on all cores (the GIL released)."""

from __future__ import annotations

import json
import os
from typing import Any, Mapping, Tuple, Union

import numpy as np

from . import _lobe

Spec = Union[Mapping[str, Any], str, "os.PathLike[str]"]


def _f32(a: Any, width: int, name: str) -> np.ndarray:
    arr = np.ascontiguousarray(a, dtype=np.float32)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name}: expected an array of shape (N, {width}), found {arr.shape}")
    return arr


def directions(theta: Any, phi: Any) -> np.ndarray:
    """Unit vectors (N, 3) float32 at elevations ``theta`` and azimuths ``phi`` (degrees),
    computed exactly as ``lobe eval`` computes them (so results compare bit for bit)."""
    t = np.ascontiguousarray(np.atleast_1d(theta), dtype=np.float64)
    p = np.ascontiguousarray(np.atleast_1d(phi), dtype=np.float64)
    return _lobe.directions(t, p)


class Material:
    """A material: ``Material(spec)`` with ``spec`` a dict or JSON text as in scene files
    (``{"type": "ward", "specular": 0.1, "alpha": 0.2}``, ``{"type": "ngan-fit",
    "material": "nickel", "model": "he"}``, ``{"type": "fit", "file": "r.fit.json",
    "model": "ward"}``, ``{"type": "rgl", "file": "x.bsdf"}``, ...), or a path
    (``pathlib.Path``) to a JSON file holding one. Relative files in the description resolve
    against ``base`` (default: the current folder; for a JSON file, its folder).

    Raises ``ValueError`` for an invalid description (the CLI's message, with the JSON path
    of the value) and ``FileNotFoundError`` when a file it names does not exist.
    """

    def __init__(self, spec: Spec, base: Union[str, "os.PathLike[str]", None] = None):
        if isinstance(spec, os.PathLike):
            self._m = _lobe.Material.from_file(os.fspath(spec))
            return
        if isinstance(spec, Mapping):
            text = json.dumps(spec, allow_nan=False)
        elif isinstance(spec, str):
            text = spec
        else:
            raise ValueError(f"spec: expected a dict, JSON text or a path, found {type(spec).__name__}")
        self._m = _lobe.Material.from_json(text, "lobe.Material", None if base is None else os.fspath(base))

    @property
    def name(self) -> str:
        """The model's registry name (e.g. ``"ward"``)."""
        return self._m.name

    def eval(self, wo: Any, wi: Any) -> np.ndarray:
        """f_r(wo, wi) in 1/sr, RGB, without the cosine: (N, 3) float32 for (N, 3) arrays of
        unit directions (zero where either is below the surface)."""
        return self._m.eval(_f32(wo, 3, "wo"), _f32(wi, 3, "wi"))

    def pdf(self, wo: Any, wi: Any) -> np.ndarray:
        """The solid-angle density (N,) float32 with which ``sample`` draws ``wi`` given ``wo``."""
        return self._m.pdf(_f32(wo, 3, "wo"), _f32(wi, 3, "wi"))

    def eval_pdf(self, wo: Any, wi: Any) -> Tuple[np.ndarray, np.ndarray]:
        """``(eval(wo, wi), pdf(wo, wi))`` in one pass, through the material's batched
        (SIMD) evaluation."""
        return self._m.eval_pdf(_f32(wo, 3, "wo"), _f32(wi, 3, "wi"))

    def sample(self, wo: Any, u: Any, uc: Any) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Importance sampling: for each ``wo`` (N, 3), 2D uniform sample ``u`` (N, 2) and 1D
        component sample ``uc`` (N,), returns ``(wi, weight, pdf, valid)``: the drawn light
        direction (N, 3), the weight f cos(theta_i) / pdf (N, 3), the density (N,) and
        whether a sample was produced (N,) bool; wi, weight and pdf are zero where not."""
        uc = np.ascontiguousarray(np.reshape(uc, -1), dtype=np.float32)
        return self._m.sample(_f32(wo, 3, "wo"), _f32(u, 2, "u"), uc)

    def albedo(self, theta_o: Any, phi_o: float = 0.0, n: int = 64) -> np.ndarray:
        """Directional albedo, int f_r(wo, wi) cos(theta_i) dwi per RGB channel, for the
        viewer at elevation(s) ``theta_o`` in [0, 90) degrees and azimuth ``phi_o``: (3,) for
        a number, (M, 3) for M elevations. A deterministic estimate from 2 n^2 stratified
        samples (cosine-weighted and the material's own sampling, balance heuristic)."""
        t = np.atleast_1d(np.asarray(theta_o, dtype=np.float64))
        out = self._m.albedo([float(x) for x in t.reshape(-1)], float(phi_o), int(n))
        return out[0] if np.ndim(theta_o) == 0 else out

    def __repr__(self) -> str:
        return repr(self._m)
