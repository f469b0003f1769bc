"""Parts of the Python API that no other test exercised, each checked against lobe's
command line or a property that a wrong implementation would break."""

import json

import numpy as np
import pytest

import lobe
from conftest import MODELS, run


def test_images_round_trip_bit_for_bit_and_agree_with_the_cli(lobe_bin, tmp_path):
    rng = np.random.default_rng(7)
    img = rng.uniform(0.0, 4.0, size=(12, 20, 3)).astype(np.float32)
    img[3, 5] = [0.0, 1e-30, 3.0e38]
    path = tmp_path / "a.exr"
    lobe.write_image(path, img)
    back = lobe.read_image(path)
    assert back.dtype == np.float32 and back.shape == (12, 20, 3)
    assert np.array_equal(back.view(np.uint32), img.view(np.uint32))
    # The CLI reads the same pixels: an image against itself is RMSE 0, and against a
    # copy brighter by 1 in one pixel's green channel the RMSE is sqrt(1 / (3 N)).
    brighter = img.copy()
    brighter[0, 0, 1] += 1.0
    lobe.write_image(tmp_path / "b.exr", brighter)
    out = run([lobe_bin, "compare", str(path), str(tmp_path / "b.exr"), "--json"])
    rmse = json.loads(out)["rmse"]
    assert rmse == pytest.approx(np.sqrt(1.0 / (3 * 12 * 20)), rel=1e-4)
    with pytest.raises(ValueError):
        lobe.write_image(tmp_path / "bad.exr", np.zeros((4, 4)))


def test_fit_models_are_the_labels_fit_accepts(lobe_bin):
    labels = lobe.fit_models()
    assert len(labels) == len(set(labels)) and {"ward", "cook-torrance", "lafortune-2", "he"} <= set(labels)
    with pytest.raises(ValueError, match="ward"):
        lobe.fit(lobe.Material(MODELS["ward"]), models="no-such-model", resolution=10, progress=False)


def test_select_picks_a_model_within_the_tolerance_and_material_of_builds_it():
    data = lobe.Material(MODELS["ward"])
    r = lobe.fit(data, models="ward,cook-torrance,blinn-phong", resolution=6, max_evals=30, select=0.5, progress=False)
    assert r.selected is not None
    chosen = r.selected.model
    best = min(m.error for m in r.models.values())
    assert r.models[chosen].error <= best * 1.5 + 1e-15
    assert set(r.selected.costs) == set(r.models)
    # The selected model, built, evaluates as its report's description does.
    m = r.material_of(chosen)
    direct = lobe.Material(r.models[chosen].material)
    wo = np.array([[0.0, 0.3, 0.95]])
    wi = np.array([[0.2, -0.3, 0.93]])
    assert np.array_equal(m.eval(wo, wi), direct.eval(wo, wi))
    with pytest.raises(ValueError, match="not in this report"):
        r.material_of("he")
    # Without select there is no selection.
    assert lobe.fit(data, models="ward", resolution=6, max_evals=30, progress=False).selected is None
