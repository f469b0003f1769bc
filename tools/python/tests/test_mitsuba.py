"""lobe.mitsuba against lobe's renderer: a sphere with each model of the ``lobe`` Mitsuba
plugin, rendered by Mitsuba (scalar_rgb and llvm_ad_rgb) and by lobe.render, passes
lobe's noise-aware z-test (renderer/src/compare.rs, through lobe.compare)."""

import json

import numpy as np
import pytest

import lobe
from conftest import MODELS

mi = pytest.importorskip("mitsuba")
import lobe.mitsuba  # noqa: E402
from lobe.mitsuba.convert import Converter  # noqa: E402

# Lambert and composite are Mitsuba's diffuse / not plugin models; the sampled-microfacet
# twin tabulates g(k) by quadrature when it is built (tens of seconds), too slow for a
# render here: test_sampled_microfacet_twin_builds_and_agrees_with_lobe checks it on a
# coarse grid.
PLUGIN_MODELS = sorted(set(MODELS) - {"lambert", "composite", "sampled-microfacet"})

# Per variant: film side, Mitsuba's spp per run and runs, lobe's spp. The scalar variant
# calls the Python plugin once per sample: a smaller film keeps it to seconds per model.
SETUP = {"llvm_ad_rgb": (24, 16, 16, 256), "scalar_rgb": (8, 16, 8, 256)}


def sphere_scene(material, side):
    return {
        "camera": {"type": "perspective", "fov": 32, "origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]},
        "film": {"width": side, "height": side},
        "sampler": {"spp": 16},
        "integrator": {"type": "path", "max_depth": 3},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": material}],
        "lights": [
            {"type": "constant", "radiance": [0.6, 0.7, 0.8]},
            {"type": "directional", "direction": [-0.5, -0.4, -1.0], "irradiance": [3.0, 2.8, 2.5]},
        ],
    }


def mitsuba_render(scene_file, variant, spp, runs):
    mi.set_variant(variant)
    lobe.mitsuba.register()
    scene = mi.load_dict(Converter(str(scene_file)).convert(spp))
    imgs = np.stack([np.array(mi.render(scene, spp=spp, seed=7 + k), dtype=np.float64)[..., :3] for k in range(runs)])
    return imgs.mean(0).astype(np.float32), (imgs.var(0, ddof=1) / runs).astype(np.float32)


def variant_available(v):
    try:
        mi.set_variant(v)
        return True
    except Exception:  # noqa: BLE001 - Mitsuba raises generic errors for a missing LLVM
        return False


@pytest.mark.parametrize("variant", list(SETUP))
@pytest.mark.parametrize("model", PLUGIN_MODELS)
def test_mitsuba_plugin_matches_lobe(model, variant, tmp_path):
    if not variant_available(variant):
        pytest.skip(f"Mitsuba variant {variant} unavailable here (llvm_ad_rgb needs libLLVM: tools/mitsuba/setup.sh installs it)")
    side, spp, runs, lobe_spp = SETUP[variant]
    scene = sphere_scene(MODELS[model], side)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    ref, ref_var = mitsuba_render(path, variant, spp, runs)
    img, var = lobe.render(scene, spp=lobe_spp, seed=3, variance=True, progress=False)
    z = lobe.compare(img, ref, variances=(var, lobe_spp - 1, ref_var, runs - 1), alpha=0.01)["z_test"]
    assert z["passed"], f"{model} in {variant}: {z}"
    assert ref.mean() > 0.01 and np.isfinite(ref).all()


def test_plugin_takes_model_parameters_and_ngan_fits(data_dir):
    if not variant_available("scalar_rgb"):
        pytest.skip("no scalar_rgb")
    lobe.mitsuba.register()
    b = mi.load_dict({"type": "lobe", "model": "ward", "diffuse": [0.3, 0.1, 0.05], "specular": 0.15, "alpha": 0.15})
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(0.0, 0.0, 1.0)
    wo = mi.Vector3f(0.0, 0.6, 0.8)
    f = b.eval(mi.BSDFContext(), si, wo)
    want = lobe.Material({"type": "ward", "diffuse": [0.3, 0.1, 0.05], "specular": 0.15, "alpha": 0.15}).eval(np.array([[0, 0, 1.0]]), np.array([[0, 0.6, 0.8]]))[0] * 0.8
    np.testing.assert_allclose([f[0], f[1], f[2]], want, rtol=1e-4)
    if data_dir:
        n = mi.load_dict({"type": "lobe", "model": "cook-torrance", "ngan": "nickel"})
        assert "cook-torrance" in str(n)


def test_sampled_microfacet_twin_builds_and_agrees_with_lobe(monkeypatch):
    """The sampled-microfacet twin (left out of the render test for its build time),
    built on a coarse quadrature grid: it loads in scalar_rgb and its value at a few
    direction pairs is within 5 % of lobe's generator."""
    from lobe.mitsuba.models import MicrofacetGenerator

    monkeypatch.setattr(MicrofacetGenerator, "QUADRATURE", (90, 180))
    mi.set_variant("scalar_rgb")
    lobe.mitsuba.register()
    desc = {"type": "sampled-microfacet", "diffuse": 0.0, "specular": 1.0, "distribution": "beckmann",
            "alpha_x": 0.3, "alpha_y": 0.3, "f0": 1.0}
    bsdf = mi.load_dict({"type": "lobe", "desc": json.dumps(desc)})
    ref = lobe.Material(desc)
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(0.0, 0.0, 1.0)
    ctx = mi.BSDFContext()
    for wo, wi in [((0.3, 0.1, 0.948683), (-0.2, 0.0, 0.979796)), ((0.5, 0.0, 0.866025), (-0.4, 0.1, 0.911043))]:
        si.wi = mi.Vector3f(*wo)
        value = np.array(bsdf.eval(ctx, si, mi.Vector3f(*wi)))[:3] / wi[2]
        expected = ref.eval(np.array([wo], np.float32), np.array([wi], np.float32))[0]
        assert np.all(np.isfinite(value)) and np.allclose(value, expected, rtol=0.05), (wo, wi, value, expected)
