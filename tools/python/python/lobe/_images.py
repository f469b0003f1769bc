"""Rendering and image comparison: ``lobe.render`` (lobe's path tracer on a scene file
or dict, docs/scene-format.md) and ``lobe.compare`` (``lobe compare``'s metrics and its
noise-aware z-test); images are (H, W, 3) float32 arrays of linear RGB."""

from __future__ import annotations

import json
import os
import sys
from typing import Any, Callable, Dict, Mapping, Optional, Tuple, Union

import numpy as np

from . import _lobe
from ._progress import Progress

PathLike = Union[str, "os.PathLike[str]"]
Scene = Union[Mapping[str, Any], PathLike]
Image = Union[np.ndarray, PathLike]


def render(
    scene: Scene,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    base: Optional[PathLike] = None,
    variance: bool = False,
    progress: Union[bool, Callable[[int, int], Any]] = True,
) -> Union[np.ndarray, Tuple[np.ndarray, np.ndarray]]:
    """Renders ``scene`` (a scene file, or a dict in the scene-file format whose relative
    paths resolve against ``base``, default the current folder) and returns the image,
    (H, W, 3) float32, or with ``variance=True`` ``(image, variance)``, the variance of
    each pixel's mean (for ``compare(..., variances=...)``). ``spp`` and ``seed``
    override the scene's; the image depends on the seed only, not on ``threads``
    (default: all cores).

    ``progress``: ``True`` shows a bar over the film's pixels as tiles finish (tqdm: a
    widget in notebooks, text in terminals; a line per tenth without tqdm) and then one
    summary line on stderr, ``False`` nothing, a callable is called as
    ``progress(done, total)`` (pixels; ``done`` increasing, last equal to ``total``; tiles
    that finish while the calling thread is busy are reported together, by the last) on
    the calling thread. Ctrl-C (a notebook's interrupt) stops the render within a
    wavefront (at most 512 samples) and raises ``KeyboardInterrupt``; an exception from the callable stops it and is
    raised. Rendering runs without the GIL on all cores either way."""
    if isinstance(scene, Mapping):
        path, text = None, json.dumps(scene, allow_nan=False)
    else:
        path, text = os.fspath(scene), None
    folder = os.fspath(base) if base is not None else os.getcwd()
    if callable(progress) or not progress:
        image, var, stats = _lobe.render(path, text, folder, spp, seed, threads, progress or None)
    else:
        bar: Optional[Progress] = None

        def rendered(done: int, total: int) -> None:
            nonlocal bar
            if bar is None:  # made at the first report, which knows the film's size
                bar = Progress("rendering", total, "px", unit_scale=True)
            bar.update_to(done)

        try:
            image, var, stats = _lobe.render(path, text, folder, spp, seed, threads, rendered)
        finally:
            if bar is not None:
                bar.close()
        s = json.loads(stats)
        print(f"lobe.render: {s['width']}x{s['height']} at {s['spp']} spp in {s['seconds']:.2f} s on {s['threads']} threads", file=sys.stderr)
    return (image, var) if variance else image


def read_image(path: PathLike) -> np.ndarray:
    """An EXR or Radiance HDR image as (H, W, 3) float32 (non-finite pixels refused)."""
    return _lobe.read_image(os.fspath(path))


def write_image(path: PathLike, image: np.ndarray) -> None:
    """Writes (H, W, 3) linear RGB as a float32 OpenEXR file, atomically."""
    if isinstance(image, (str, os.PathLike)):
        raise ValueError(f"image: expected an image array of shape (H, W, 3), found the path {os.fspath(image)!r}")
    _lobe.write_image(os.fspath(path), _image(image, "image"))


def _image(a: Image, what: str) -> np.ndarray:
    if isinstance(a, (str, os.PathLike)):
        return read_image(a)
    arr = np.ascontiguousarray(a, dtype=np.float32)
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"{what}: expected an image array of shape (H, W, 3), found {arr.shape}")
    return arr


def compare(
    test: Image,
    reference: Image,
    exposure: float = 0.0,
    variances: Optional[Tuple[Image, float, Image, float]] = None,
    alpha: float = 0.01,
) -> Dict[str, Any]:
    """``lobe compare``'s metrics of ``test`` against ``reference`` (arrays or EXR/HDR
    files): ``{"rmse", "relmse", "psnr", "ssim", "flip"}`` (SSIM and FLIP after
    tonemapping at ``exposure`` stops; SSIM is NaN under 8x8 pixels).

    With ``variances=(test_variance, test_dof, reference_variance, reference_dof)`` (the
    variances of the pixel means and their degrees of freedom, e.g. spp - 1 of a render,
    runs - 1 of a mean of runs; ``float("inf")`` when unknown) it adds ``"z_test"``, the
    noise-aware multi-scale z-test at family-wise false-alarm rate ``alpha``:
    ``{"passed", "min_p", "threshold", "failures", "tests", "worst_block",
    "worst_block_size", "worst_z"}``."""
    t, r = _image(test, "test"), _image(reference, "reference")
    v = None
    if variances is not None:
        tv, tdof, rv, rdof = variances
        v = (_image(tv, "test variance"), float(tdof), _image(rv, "reference variance"), float(rdof))
    if not (0.0 < alpha < 1.0):
        raise ValueError(f"alpha: expected a false-alarm rate in (0, 1), found {alpha}")
    return _lobe.compare(t, r, float(exposure), v, float(alpha))
