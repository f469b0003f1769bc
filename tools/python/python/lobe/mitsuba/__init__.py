"""lobe's models in Mitsuba 3: ``lobe.mitsuba.register()`` registers the BSDF plugin
``lobe`` (plugin.py) for the current variant, so that a scene says

    {"type": "lobe", "model": "ward", "diffuse": [0.3, 0.1, 0.05], "specular": 0.15, "alpha": 0.15}

with any of lobe's analytic models (docs/models.md), a published Ngan et al. fit
(``"ngan": "nickel"``) or a model of a lobe fit report (``"report": "x.fit.json"``). The
models are Dr.Jit twins written from the papers (models/, one file per model), independent of lobe's Rust
code; they run in ``scalar_rgb`` and ``llvm_ad_rgb`` (tested) and ``cuda_ad_rgb`` (the
same code as ``llvm_ad_rgb``; untested, lobe's test machine has no GPU).

``convert.Converter`` turns a lobe scene file into a Mitsuba scene dict (the validation
tools of tools/mitsuba use it); ``set_variant()`` picks the first usable variant."""

import mitsuba as mi

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


def set_variant(variants=VARIANTS):
    """The first available of ``variants`` (llvm_ad_rgb needs libLLVM), now set."""
    for v in variants:
        try:
            mi.set_variant(v)
            return v
        except Exception:  # noqa: BLE001 - Mitsuba raises generic errors for missing LLVM
            continue
    raise RuntimeError("no usable Mitsuba variant among " + ", ".join(variants))


def register():
    """Registers the ``lobe`` BSDF plugin for the current Mitsuba variant (call it after
    ``mi.set_variant``, and again after changing the variant)."""
    from .plugin import bsdf_class

    cls = bsdf_class()
    mi.register_bsdf("lobe", lambda props: cls(props))
