# %% [markdown]
# # Fit a measured BRDF, plot it, render it in lobe and in Mitsuba 3
#
# Run as a script (`python tools/python/examples/fit_and_render.py [FILE.bsdf]`) or cell by
# cell in Jupyter/VS Code. Needs `pip install "./tools/python[progress,mitsuba]" matplotlib`
# (progress: the fit's and the render's bars); the measured file defaults to
# ../shared/data/rgl/paper_white_rgb.bsdf. Writes its figure and images to
# out/python-example/.

# %%
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import lobe

root = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", ".."))
data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "..", "shared", "data", "rgl", "paper_white_rgb.bsdf")
out = os.path.join(root, "out", "python-example")
os.makedirs(out, exist_ok=True)

# %% Fit two of the study's models to the measurement (2-degree bins to keep it quick).
report = lobe.fit(data, models=["ward", "cook-torrance"], resolution=2.0)
for name, m in report.models.items():
    print(f"{name:14} normalized error {m.error_normalized:.4f}")
best = min(report.models, key=lambda k: report.models[k].error_normalized)
fitted = report.material_of(best)
measured = lobe.Material({"type": "rgl", "file": data})

# %% The incidence plane at theta_i = 45 degrees: the data against the fitted lobes.
theta_o = np.linspace(-85, 85, 171)
wi = lobe.directions(np.full_like(theta_o, 45.0), np.zeros_like(theta_o))
wo = lobe.directions(np.abs(theta_o), np.where(theta_o < 0, 0.0, 180.0))
plt.figure(figsize=(6, 4))
plt.semilogy(theta_o, measured.eval(wo, wi).mean(1) * wo[:, 2], "k.", ms=3, label="measured")
for name in report.models:
    plt.semilogy(theta_o, report.material_of(name).eval(wo, wi).mean(1) * wo[:, 2], label=name)
plt.xlabel("theta_o (degrees; negative = toward the light)")
plt.ylabel("f_r cos(theta_o), mean RGB")
plt.title(f"{report.material}: incidence plane, theta_i = 45")
plt.legend()
plt.savefig(os.path.join(out, "lobes.png"), dpi=120, bbox_inches="tight")
print("wrote", os.path.join(out, "lobes.png"))

# %% One sphere under a sky and a sun, rendered by lobe with the data and with the fit.
def sphere(material, side=64):
    return {
        "camera": {"type": "perspective", "fov": 32, "origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]},
        "film": {"width": side, "height": side},
        "integrator": {"type": "path", "max_depth": 3},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": material}],
        "lights": [{"type": "constant", "radiance": [0.6, 0.7, 0.8]},
                   {"type": "directional", "direction": [-0.5, -0.4, -1.0], "irradiance": [3.0, 2.8, 2.5]}],
    }

fit_desc = report.models[best].material
img_data = lobe.render(sphere({"type": "rgl", "file": data}), spp=256)
img_fit, var_fit = lobe.render(sphere(fit_desc), spp=256, variance=True)
print("lobe, fitted", best, "against the measured data:", lobe.compare(img_fit, img_data))
lobe.write_image(os.path.join(out, "lobe-fit.exr"), img_fit)


def save_png(name, img):
    """Writes a linear image as an sRGB-ish PNG (gamma 2.2, clipped) next to the EXRs."""
    plt.imsave(os.path.join(out, name), np.clip(np.asarray(img)[..., :3], 0, 1) ** (1 / 2.2))
    print("wrote", os.path.join(out, name))


save_png("lobe-data.png", img_data)
save_png("lobe-fit.png", img_fit)

# %% The fitted model in Mitsuba 3 through lobe.mitsuba's plugin, z-tested against lobe.
try:
    import mitsuba as mi
except ImportError:
    mi = None
    print("Mitsuba 3 is not installed: skipping its render (pip install mitsuba)")
if mi is not None:
    import lobe.mitsuba
    from lobe.mitsuba.convert import Converter

    variant = lobe.mitsuba.set_variant()
    lobe.mitsuba.register()
    scene_file = os.path.join(out, "sphere-fit.json")
    with open(scene_file, "w") as f:
        json.dump(sphere(fit_desc), f)
    scene = mi.load_dict(Converter(scene_file).convert(64))
    runs = np.stack([np.array(mi.render(scene, spp=64, seed=s), dtype=np.float64)[..., :3] for s in range(8)])
    ref, ref_var = runs.mean(0).astype(np.float32), (runs.var(0, ddof=1) / 8).astype(np.float32)
    save_png("mitsuba-fit.png", ref)
    m = lobe.compare(img_fit, ref, variances=(var_fit, 255, ref_var, 7))
    print(f"Mitsuba ({variant}) against lobe, the fitted {best}:",
          {k: round(v, 5) for k, v in m.items() if k != "z_test"}, "z-test passed:", m["z_test"]["passed"])
