"""The published fits of Ngan et al. 2005 (bbm's `ngan_<model>.fit` files) mapped onto
model descriptions, following docs/models.md; independent of lobe's Rust reader."""

import os
import re

FILES = {
    "ward": "ngan_ward.fit",
    "ward-duer": "ngan_wardduer.fit",
    "blinn-phong": "ngan_blinnphong.fit",
    "lafortune": "ngan_lafortune.fit",
    "cook-torrance": "ngan_cooktorrance.fit",
    "ashikhmin-shirley": "ngan_ashikhminshirley.fit",
    "he": "ngan_he.fit",
}
MERL_SCALE = (1.0, 1.15, 1.66)


def _vec(s):
    return [float(x) for x in s.split(",")]


def locate(explicit, base):
    if explicit:
        return explicit if os.path.isabs(explicit) else os.path.join(base, explicit)
    if os.environ.get("LOBE_DATA"):
        p = os.path.join(os.environ["LOBE_DATA"], "ngan-fits")
        if os.path.isdir(p):
            return p
    for start in (os.path.abspath(base), os.getcwd()):
        d = start
        while True:
            p = os.path.join(d, "shared", "data", "ngan-fits")
            if os.path.isdir(p):
                return p
            parent = os.path.dirname(d)
            if parent == d:
                break
            d = parent
    raise FileNotFoundError("cannot find the Ngan et al. fits (shared/data/ngan-fits or $LOBE_DATA)")


def fit(material, model, folder):
    path = os.path.join(folder, FILES[model])
    with open(path) as f:
        for line in f:
            if not line.strip() or line.startswith("#"):
                continue
            name, expr = line.split("=", 1)
            if name.strip() != material:
                continue
            lam = re.search(r"Lambertian\(albedo = \[([^\]]*)\]\)", expr)
            spec = re.search(r"Ngan\w+\(albedo = \[([^\]]*)\](.*)\)\)", expr)
            params = dict((k, float(v)) for k, v in re.findall(r"(\w+) = ([-0-9.e+]+)", spec.group(2)))
            return _vec(lam.group(1)), _vec(spec.group(1)), params
    raise KeyError(f"{path}: no fit named {material}")


def description(material, model, folder, channel_scale="merl"):
    diffuse, specular, p = fit(material, model, folder)
    s = MERL_SCALE if channel_scale == "merl" else (1.0, 1.0, 1.0)
    d = {"type": model, "diffuse": [diffuse[c] * s[c] for c in range(3)], "specular": [specular[c] * s[c] for c in range(3)]}
    if model in ("ward", "ward-duer"):
        d["alpha"] = p["roughness"]
    elif model == "blinn-phong":
        d["n"] = p["sharpness"]
    elif model == "lafortune":
        d.update(cx=p["Cxy"], cy=p["Cxy"], cz=p["Cz"], n=p["sharpness"])
    elif model == "cook-torrance":
        d.update(m=p["roughness"], distribution="beckmann", fresnel="schlick", f0=p["eta"])
    elif model == "ashikhmin-shirley":
        d.update(n=p["sharpness"], f0=p["fresnelReflectance"])
    elif model == "he":
        d.update(sigma0=p["roughness"], tau=p["autocorrelation"], eta=p["eta"])
    return d
