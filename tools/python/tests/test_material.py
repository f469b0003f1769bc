"""lobe.Material against the `lobe eval` command: bit for bit on a grid for every model,
and its sampling and albedo against what they must satisfy."""

import json
import os

import numpy as np
import pytest

import lobe
from conftest import MODELS, record_skip, run

GRID = "0..80..20,0..300..60,5..85..20,10..350..85"


def cli_grid(lobe_bin, desc):
    out = run([lobe_bin, "eval", "--material", json.dumps(desc), "--grid", GRID])
    rows = [line.split(",") for line in out.strip().splitlines()[1:]]
    angles = np.array([[float(x) for x in r[:4]] for r in rows])
    # `lobe eval` prints f32 in shortest round-trip form: parsing gives the exact value.
    values = np.array([[np.float32(x) for x in r[4:]] for r in rows], dtype=np.float32)
    return angles, values


def python_grid(m, angles, batched=True):
    """f and pdf at the grid's pairs: through the batched eval_pdf, or eval and pdf."""
    wi = lobe.directions(angles[:, 0], angles[:, 1])
    wo = lobe.directions(angles[:, 2], angles[:, 3])
    f, pdf = m.eval_pdf(wo, wi) if batched else (m.eval(wo, wi), m.pdf(wo, wi))
    return np.concatenate([f, pdf[:, None]], axis=1)


def same_bits(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))


def measured_and_fits(data_dir):
    """Descriptions that read files: an RGL table, a published Ngan fit."""
    out = {}
    if data_dir:
        out["rgl"] = {"type": "rgl", "file": os.path.join(data_dir, "rgl", "paper_white_rgb.bsdf")}
        out["ngan-fit"] = {"type": "ngan-fit", "material": "nickel", "model": "he", "fits": os.path.join(data_dir, "ngan-fits")}
    else:
        record_skip("no shared data: the rgl and ngan-fit cases of test_files_models_equal_cli")
    return out


@pytest.mark.parametrize("name", sorted(MODELS))
def test_eval_equals_cli_bit_for_bit(lobe_bin, name):
    angles, expected = cli_grid(lobe_bin, MODELS[name])
    m = lobe.Material(MODELS[name])
    assert len(expected) == 5 * 6 * 5 * 5
    for batched in (False, True):
        got = python_grid(m, angles, batched)
        assert same_bits(got, expected), f"{name} (batched {batched}): first differing row {np.argwhere(got != expected)[:1]}"
    assert np.any(expected[:, :3] > 0), f"{name}: the grid sees no reflection at all"


def test_files_models_equal_cli(lobe_bin, data_dir, tmp_path):
    descs = measured_and_fits(data_dir)
    table = tmp_path / "ward.binary"
    run([lobe_bin, "tabulate", "--material", json.dumps(MODELS["ward"]), "-o", str(table)])
    descs["merl"] = {"type": "merl", "file": str(table)}
    for name, d in descs.items():
        angles, expected = cli_grid(lobe_bin, d)
        for batched in (False, True):
            assert same_bits(python_grid(lobe.Material(d), angles, batched), expected), (name, batched)


def test_results_do_not_depend_on_chunking():
    m = lobe.Material(MODELS["he"])
    rng = np.random.default_rng(1)
    n = 20000  # several chunks of the parallel loop
    wo = lobe.directions(rng.uniform(0, 89, n), rng.uniform(0, 360, n))
    wi = lobe.directions(rng.uniform(0, 89, n), rng.uniform(0, 360, n))
    f, pdf = m.eval_pdf(wo, wi)
    f1, pdf1 = m.eval_pdf(wo[12345:12346], wi[12345:12346])
    assert np.array_equal(f[12345:12346], f1) and np.array_equal(pdf[12345:12346], pdf1)


def test_sample_weights_match_eval_and_pdf():
    m = lobe.Material(MODELS["ward"])
    rng = np.random.default_rng(2)
    n = 5000
    wo = lobe.directions(np.full(n, 40.0), np.zeros(n))
    wi, weight, pdf, valid = m.sample(wo, rng.random((n, 2)), rng.random(n))
    assert valid.mean() > 0.9
    f, p = m.eval_pdf(wo[valid], wi[valid])
    np.testing.assert_allclose(p, pdf[valid], rtol=1e-4)
    np.testing.assert_allclose(weight[valid], f * (wi[valid][:, 2] / pdf[valid])[:, None], rtol=1e-4)
    assert np.all(weight[~valid] == 0) and np.all(pdf[~valid] == 0)


def test_albedo_of_lambert_is_its_reflectance():
    a = lobe.Material({"type": "lambert", "reflectance": [0.6, 0.4, 0.2]}).albedo([0.0, 60.0])
    np.testing.assert_allclose(a, [[0.6, 0.4, 0.2]] * 2, rtol=2e-3)
    w = lobe.Material({"type": "ward", "specular": 1.0, "alpha": 0.3}).albedo(30.0)
    assert w.shape == (3,) and 0.5 < w[0] < 1.0
