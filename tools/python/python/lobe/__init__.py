"""lobe from Python: the BRDF models of Ngan, Durand and Matusik 2005 ("Experimental
Analysis of BRDF Models") and lobe's measured data, fitting and renderer on numpy arrays.

Conventions (lobe's, docs/models.md): directions are unit vectors in the local shading
frame, z is the surface normal, ``wo`` points toward the viewer and ``wi`` toward the
light, both away from the surface; f_r is in 1/sr without the cosine factor, linear
Rec.709 RGB; angles are in degrees. Errors are ``ValueError`` (bad input; the message is
the one the ``lobe`` command prints) or ``FileNotFoundError`` (a named file does not
exist); lobe never lets a panic reach Python (it would be a ``RuntimeError`` naming it a
bug).

    import lobe, numpy as np
    m = lobe.Material({"type": "ward", "specular": 0.1, "alpha": 0.2})
    wo = lobe.directions([30.0], [180.0]); wi = lobe.directions([30.0], [0.0])
    f, pdf = m.eval(wo, wi), m.pdf(wo, wi)

``lobe.distributed`` runs renders, batch fits and the study as Dask tasks
(docs/distributed.md). ``lobe.mitsuba`` registers lobe's models as Mitsuba 3 plugins (``{"type": "lobe",
"model": "ward", ...}``).
"""

from ._lobe import __version__
from ._data import Binned, read_binned, read_merl, read_rgl, write_binned, write_merl
from ._fit import BoundHit, FitReport, ModelCost, ModelFit, Selection, StartedFrom, fit, fit_models, read_fit_report
from ._images import compare, read_image, render, write_image
from ._material import Material, directions
from ._study import study

__all__ = [
    "__version__",
    "Binned",
    "FitReport",
    "Material",
    "ModelCost",
    "ModelFit",
    "BoundHit",
    "StartedFrom",
    "Selection",
    "compare",
    "directions",
    "fit",
    "fit_models",
    "read_binned",
    "read_fit_report",
    "read_image",
    "read_merl",
    "read_rgl",
    "render",
    "study",
    "write_binned",
    "write_image",
    "write_merl",
]
