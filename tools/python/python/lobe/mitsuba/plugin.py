"""The ``lobe`` Mitsuba 3 BSDF: diffuse / pi + specular * lobe, with the lobe one of
lobe's analytic models (models/), the parameters given as in a lobe description:

    {"type": "lobe", "model": "ward", "diffuse": [0.3, 0.1, 0.05], "specular": 0.15, "alpha": 0.15}
    {"type": "lobe", "model": "he", "ngan": "nickel"}                  # a published Ngan et al. fit
    {"type": "lobe", "model": "cook-torrance", "report": "x.fit.json"}  # a model of a lobe fit report
    {"type": "lobe", "desc": "<a lobe material description as JSON text>"}

Importance sampling is deliberately simple and independent of lobe's: a mixture of
cosine sampling and two Beckmann half-vector proposals whose widths come from the
model's parameters; unbiased for every model (cosine sampling covers the hemisphere).
The evaluation runs over the variant's backend (backend.py): vectorized in the JIT
variants, on one-lane arrays in ``scalar_rgb``.
"""

import json
import math
import os

import drjit as dr
import mitsuba as mi

from . import backend, ngan
from .models import Lobe
from .models.common import rgb as _rgb

ANISOTROPIC = ("ward-anisotropic", "ashikhmin-shirley-anisotropic", "poulin-fournier", "sampled-microfacet")


def _prop(v):
    """A Mitsuba property value as JSON: numbers, strings, and 3-vectors or RGB colours."""
    if isinstance(v, (bool, int, float, str)):
        return v
    try:
        return [float(x) for x in v]
    except TypeError:
        raise ValueError(f"lobe plugin: a parameter must be a number, a string or a constant RGB colour, found {type(v).__name__}") from None


def description(props):
    """The lobe material description a plugin's properties give (docs/models.md)."""
    keys = [k for k in props.keys() if k not in ("type", "id")]
    if "desc" in keys:
        d = json.loads(props["desc"])
    else:
        d = {k: _prop(props[k]) for k in keys}
        if "model" not in d:
            raise ValueError("lobe plugin: expected \"model\" (ward, cook-torrance, ...) or \"desc\"")
        model = d.pop("model")
        if "ngan" in d:
            d = {"type": "ngan-fit", "material": d.pop("ngan"), "model": model, **d}
        elif "report" in d:
            d = {"type": "fit", "file": d.pop("report"), "model": model}
        else:
            d = {"type": model, **d}
    return resolve(d, os.getcwd())


def resolve(d, base):
    """An analytic description from a published Ngan fit or a fit report's model."""
    if d["type"] == "ngan-fit":
        folder = ngan.locate(d.get("fits", ""), base)
        return ngan.description(d["material"], d.get("model", "cook-torrance"), folder, d.get("channel_scale", "merl"))
    if d["type"] == "fit":
        from .. import read_fit_report  # lobe's own report reader (the compiled module)

        path = d["file"] if os.path.isabs(d["file"]) else os.path.join(base, d["file"])
        report = read_fit_report(path)
        return report.models[d["model"]].material if d["model"] in report.models else report.material_of(d["model"])
    return d


def _beckmann_sample(T, alpha, u1, u2):
    phi = 2 * math.pi * u1
    tan2 = -alpha * alpha * dr.log(dr.maximum(1.0 - u2, 1e-30))
    c = dr.rsqrt(1 + tan2)
    s = dr.sqrt(dr.maximum(1 - c * c, 0.0))
    return T.vec(s * dr.cos(phi), s * dr.sin(phi), c)


def _beckmann_pdf_h(alpha, h):
    c2 = h.z * h.z
    d = dr.exp(-(1 - c2) / c2 / (alpha * alpha)) / (math.pi * alpha * alpha * c2 * h.z)
    return dr.select(h.z > 0, d, 0.0)


_CLASSES = {}


def bsdf_class():
    """The plugin class of the current variant. Each variant has its own ``mi.BSDF``, so
    the class is made per variant: a class derived from another variant's ``mi.BSDF``
    fails in ``__init__`` with "incompatible function arguments" (what the old
    ``lobe_analytic`` plugin did in ``scalar_rgb`` once defined under ``llvm_ad_rgb``)."""
    v = mi.variant()
    if v not in _CLASSES:
        _CLASSES[v] = _make_class()
    return _CLASSES[v]


def _make_class():
    class LobeBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            d = description(props)
            self.T = T = backend.for_variant(mi)
            self.diffuse = T.color(_rgb(d.get("diffuse", 0.0)))
            self.specular = T.color(_rgb(d.get("specular", 0.04)))
            self.lobe = Lobe(d, T)
            self.a1, self.a2 = self.lobe.widths()
            lum = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
            self.p_cos = 0.5 if lum(_rgb(d.get("diffuse", 0.0))) > 0 else 0.2
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            if d["type"] in ANISOTROPIC:
                flags = flags | mi.BSDFFlags.Anisotropic
            self.m_flags = flags
            self.m_components = [flags]

        # The model over the backend's types: v toward the viewer, l toward the light.
        def _f(self, v, l):
            ok = (v.z > 0) & (l.z > 0)
            f = self.diffuse / math.pi + self.specular * self.lobe.value(v, l)
            return self.T.select(ok, f, 0.0)

        def _pdf(self, v, l):
            h = backend.normalize(v + l)
            vh = backend.dot(v, h)
            jac = dr.select(vh > 0, 1.0 / (4 * vh), 0.0)
            p_half = 0.5 * (_beckmann_pdf_h(self.a1, h) + _beckmann_pdf_h(self.a2, h)) * jac
            p = self.p_cos * dr.maximum(l.z, 0.0) / math.pi + (1 - self.p_cos) * p_half
            return dr.select((v.z > 0) & (l.z > 0), p, 0.0)

        def _sample(self, v, s1, u1, u2):
            T = self.T
            use_cos = s1 < self.p_cos
            u_rest = dr.select(use_cos, 0.0, (s1 - self.p_cos) / (1 - self.p_cos))
            r, phi = dr.sqrt(u1), 2 * math.pi * u2
            wcos = T.vec(r * dr.cos(phi), r * dr.sin(phi), dr.sqrt(dr.maximum(1 - u1, 0.0)))
            h = T.select(u_rest < 0.5, _beckmann_sample(T, self.a1, u1, u2), _beckmann_sample(T, self.a2, u1, u2))
            wref = h * (2 * backend.dot(v, h)) - v
            l = T.select(use_cos, wcos, wref)
            pdf = self._pdf(v, l)
            ok = (pdf > 0) & (v.z > 0) & (l.z > 0)
            weight = T.select(ok, self._f(v, l) * (l.z / dr.maximum(pdf, 1e-30)), 0.0)
            return l, pdf, weight, ok

        def sample(self, ctx, si, sample1, sample2, active=True):
            T = self.T
            l, pdf, weight, ok = self._sample(T.wrap_vec(si.wi), T.wrap(sample1), T.wrap(sample2[0]), T.wrap(sample2[1]))
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = mi.Vector3f(T.out(l.x), T.out(l.y), T.out(l.z))
            bs.pdf = T.out(pdf)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            w = T.out_color(weight)
            return (bs, dr.select(active & T.out_mask(ok), w, 0.0))

        def eval(self, ctx, si, wo, active=True):
            T = self.T
            l = T.wrap_vec(wo)
            f = self._f(T.wrap_vec(si.wi), l) * dr.maximum(l.z, 0.0)
            return dr.select(active, T.out_color(f), 0.0)

        def pdf(self, ctx, si, wo, active=True):
            T = self.T
            return dr.select(active, T.out(self._pdf(T.wrap_vec(si.wi), T.wrap_vec(wo))), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"LobeBSDF[{self.lobe.t}]"

    return LobeBSDF
