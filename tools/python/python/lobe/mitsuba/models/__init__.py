"""The Dr.Jit twins of lobe's analytic models (Ngan et al. 2005 section 3.1 and the
anisotropic models, docs/models.md), one file per model as in lobe's
``materials/src/analytic/``, written from the papers' formulas independently of lobe's Rust
code. ``Lobe(desc, T)`` is the specular lobe of a description: ``value(v, l)`` for unit
local directions above the surface and ``widths()``, two Beckmann widths for the
half-vector proposals, over the backend ``T`` (backend.py), so that the same code runs
vectorized in the JIT variants and on one-element arrays in ``scalar_rgb``.

A new model is one file with a class having ``TYPES``, ``__init__(d, T)``, ``widths()`` and
``value(v, l)``, and its line in ``MODELS``.
"""

from .ashikhmin_shirley import AshikhminShirley
from .blinn_phong import BlinnPhong
from .cook_torrance import CookTorrance
from .he import He
from .lafortune import Lafortune
from .poulin_fournier import PoulinFournier
from .sampled_microfacet import MicrofacetGenerator, SampledMicrofacet
from .ward import Ward

MODELS = (AshikhminShirley, BlinnPhong, CookTorrance, He, Lafortune, PoulinFournier, SampledMicrofacet, Ward)
BY_TYPE = {t: m for m in MODELS for t in m.TYPES}


def Lobe(d, T):  # noqa: N802 (a factory standing for the model classes)
    """The twin of the lobe that description ``d`` names (its ``type``), over backend ``T``."""
    t = d["type"]
    if t not in BY_TYPE:
        raise ValueError(f"unknown model {t}")
    lobe = BY_TYPE[t](d, T)
    lobe.t = t
    return lobe


__all__ = ["BY_TYPE", "MODELS", "Lobe", "MicrofacetGenerator"]
