"""Measured files to numpy: the MERL reader against the file's bytes as lobe's reader
documents them, writers round-tripping through lobe's readers, the RGL fields."""

import json
import os

import numpy as np
import pytest

import lobe
from conftest import MODELS, run

SCALE = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])


@pytest.fixture(scope="module")
def merl_file(lobe_bin, tmp_path_factory):
    p = tmp_path_factory.mktemp("merl") / "he.binary"
    run([lobe_bin, "tabulate", "--material", json.dumps(MODELS["he"]), "--retro-exclusion", "3", "-o", str(p)])
    return p


def test_read_merl_equals_the_file_as_documented(merl_file):
    a = lobe.read_merl(merl_file)
    assert a.shape == (90, 90, 180, 3) and a.dtype == np.float32
    raw = np.fromfile(merl_file, dtype="<f8", offset=12).reshape(3, 90, 90, 180)
    expected = np.where(raw < 0, -1.0, raw * SCALE[:, None, None, None]).astype(np.float32)
    assert np.array_equal(a, np.moveaxis(expected, 0, -1))
    assert np.any(a < 0) and np.any(a > 0)  # missing samples near retro-reflection, and data


def test_read_merl_equals_the_merl_material(merl_file, lobe_bin):
    # lobe's nearest-bin lookup is what the fitter reads: the material and the array agree.
    a = lobe.read_merl(merl_file)
    i, j, k = 40, 30, 60
    th = ((i + 0.5) / 90) ** 2 * 90.0
    td, pd = j + 0.5, k + 0.5
    assert a[i, j, k].min() > 0
    # The directions of bin centre (theta_h, phi_h = 0, theta_d, phi_d), Rusinkiewicz 1998.
    r = np.radians
    d = np.array([np.sin(r(td)) * np.cos(r(pd)), np.sin(r(td)) * np.sin(r(pd)), np.cos(r(td))])
    rot = np.array([[np.cos(r(th)), 0, np.sin(r(th))], [0, 1, 0], [-np.sin(r(th)), 0, np.cos(r(th))]])
    wi = rot @ d
    h = np.array([np.sin(r(th)), 0.0, np.cos(r(th))])
    wo = 2 * np.dot(wi, h) * h - wi
    f = lobe.Material({"type": "merl", "file": str(merl_file)}).eval(wo[None], wi[None])[0]
    np.testing.assert_allclose(f, a[i, j, k], rtol=1e-3)


def test_write_merl_round_trips_bytes(merl_file, tmp_path):
    out = tmp_path / "copy.binary"
    lobe.write_merl(out, lobe.read_merl(merl_file))
    assert out.read_bytes() == merl_file.read_bytes()


def test_binned_round_trip(lobe_bin, tmp_path):
    p = tmp_path / "ward.bin"
    run([lobe_bin, "tabulate", "--material", json.dumps(MODELS["ward"]), "--format", "binned", "--empty-fraction", "0.5", "-o", str(p)])
    b = lobe.read_binned(p)
    assert not b.anisotropic and len(b.axes) == 3 and b.values.shape == tuple(n for n, _, _ in b.axes) + (3,)
    assert 0.3 < np.isnan(b.values[..., 0]).mean() < 0.7
    out = tmp_path / "copy.bin"
    lobe.write_binned(out, b)
    assert out.read_bytes() == p.read_bytes()


def test_read_rgl_fields(data_dir):
    if not data_dir:
        pytest.skip("no shared data folder (../shared/data or $LOBE_DATA)")
    f = lobe.read_rgl(os.path.join(data_dir, "rgl", "paper_white_rgb.bsdf"))
    assert {"theta_i", "phi_i", "ndf", "sigma", "vndf", "luminance", "rgb"} <= set(f)
    assert f["rgb"].ndim == 5 and f["rgb"].shape[2] == 3 and f["theta_i"].dtype == np.float32
