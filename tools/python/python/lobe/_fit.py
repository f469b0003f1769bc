"""``lobe.fit``: the study's fitting (Ngan et al. 2005 section 4: the Eq. 1 metric, NNLS
colours, SLSQP from several starts) of measured data or of a material, exactly as
``lobe fit`` does it, returning the typed fit report."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple, Union

from . import _lobe
from ._material import Material
from ._progress import Progress

PathLike = Union[str, "os.PathLike[str]"]

# The metrics `lobe fit --metric` accepts (docs/fitting.md, "Metrics"): the study's Eq. 1
# (cosine-weighted RMS, sum-of-weights normalized; "ngan2005" is an alias), Eq. 1 on
# ln(1 + f cos) (Löw et al. 2012), on (f cos)^(1/3), and the image error of renders of a
# sphere under environment maps.
METRICS = ("eq1", "ngan2005", "log", "cube-root", "image")


@dataclass
class BoundHit:
    """A fitted parameter that ended at a bound of its fit range (the optimum may lie
    beyond it): ``side`` is ``"lower"`` or ``"upper"``."""

    param: str
    value: float
    bound: float
    side: str


@dataclass
class StartedFrom:
    """The contained model whose optimum an anisotropic fit started from, and its error."""

    model: str
    error: float


@dataclass
class ModelFit:
    """One fitted model: ``material`` is the description ``lobe.Material`` builds;
    ``error`` the Eq. 1 metric (whatever metric the fit minimized), ``error_normalized``
    that over the data's maximum albedo, ``metric_error`` the value of the report's
    ``metric`` when it is not Eq. 1.
    ``at_bounds`` lists parameters that ended at a bound of their fit range,
    ``start_errors`` every start's coarse-stage error (ascending: their spread shows how
    many basins the starts fell into), ``started_from`` the contained model an anisotropic
    fit started from, ``isotropic_data`` whether an anisotropic model met isotropic data
    (``lobe fit`` prints a warning line for each)."""

    material: Dict[str, Any]
    error: float
    error_normalized: float
    starts: int
    starts_agreeing: int
    evaluations: int
    seconds: float
    at_bounds: List[BoundHit] = field(default_factory=list)
    start_errors: List[float] = field(default_factory=list)
    started_from: Optional[StartedFrom] = None
    isotropic_data: bool = False
    metric_error: Optional[float] = None

    @classmethod
    def from_json(cls, v: Dict[str, Any]) -> "ModelFit":
        v = dict(v)
        v["at_bounds"] = [BoundHit(**b) for b in v.get("at_bounds", [])]
        if v.get("started_from") is not None:
            v["started_from"] = StartedFrom(**v["started_from"])
        return cls(**v)

    def to_json(self) -> Dict[str, Any]:
        d = vars(self).copy()
        d["at_bounds"] = [vars(b).copy() for b in self.at_bounds]
        if self.metric_error is None:
            del d["metric_error"]
        if self.started_from is None:
            del d["started_from"]
        else:
            d["started_from"] = vars(self.started_from).copy()
        return d


@dataclass
class ModelCost:
    eval_ns: float
    sample_ns: float
    error: float


@dataclass
class Selection:
    """The cheapest model within ``tolerance`` of the best error (``select=``)."""

    model: str
    tolerance: float
    best_error: float
    costs: Dict[str, ModelCost]


@dataclass
class FitReport:
    """The typed fit report (materials/src/fit/report.rs; the same fields and JSON as
    ``lobe fit -o report.fit.json``)."""

    format_version: int
    material: str
    source: str
    resolution_deg: float
    samples: int
    max_albedo: float
    models: Dict[str, ModelFit]
    selected: Optional[Selection] = None
    # The metric the fits minimized ("eq1" for reports written before the field existed).
    metric: str = "eq1"
    extra: Dict[str, Any] = field(default_factory=dict, repr=False)

    @classmethod
    def from_json(cls, v: Dict[str, Any]) -> "FitReport":
        v = dict(v)
        models = {k: ModelFit.from_json(m) for k, m in v.pop("models").items()}
        sel = v.pop("selected", None)
        if sel is not None:
            sel = Selection(**{**sel, "costs": {k: ModelCost(**c) for k, c in sel["costs"].items()}})
        known = {k: v.pop(k) for k in ("format_version", "material", "source", "resolution_deg", "samples", "max_albedo")}
        metric = v.pop("metric", "eq1")
        return cls(models=models, selected=sel, metric=metric, extra=v, **known)

    def to_json(self) -> Dict[str, Any]:
        """The report as the JSON object ``lobe fit`` writes."""
        d: Dict[str, Any] = {k: getattr(self, k) for k in ("format_version", "material", "source", "resolution_deg", "samples", "max_albedo", "metric")}
        d["models"] = {k: m.to_json() for k, m in self.models.items()}
        if self.selected is not None:
            s = vars(self.selected).copy()
            s["costs"] = {k: vars(c).copy() for k, c in s["costs"].items()}
            d["selected"] = s
        d.update(self.extra)
        return d

    @property
    def key(self) -> Optional[Dict[str, str]]:
        """The report's content key (``{"data", "settings"}``: the digests of the data's
        bytes and of the settings that shape each fit), or None for data given as a
        material and reports written before keys."""
        return self.extra.get("key")

    def material_of(self, model: str) -> Material:
        """The fitted model ``model`` as a ``lobe.Material``."""
        if model not in self.models:
            raise ValueError(f"model: {model!r} is not in this report; expected one of: {', '.join(self.models)}")
        return Material(self.models[model].material)

    def save(self, path: PathLike) -> None:
        """Writes the report (checked by lobe's report reader first), atomically."""
        _lobe.write_fit_report(os.fspath(path), json.dumps(self.to_json(), allow_nan=False))


def read_fit_report(path: PathLike) -> FitReport:
    """Reads a ``*.fit.json`` report written by ``lobe fit`` or ``FitReport.save``."""
    return FitReport.from_json(json.loads(_lobe.read_fit_report(os.fspath(path))))


def fit_models() -> List[str]:
    """The model labels ``fit(models=...)`` accepts (``lobe fit --list``)."""
    return list(_lobe.fit_models())


def fit_options(
    models: Union[str, Iterable[str], None],
    metric: str,
    resolution: float,
    select: Optional[float],
    envs: Iterable[PathLike],
) -> Tuple[Optional[str], List[str]]:
    """Checks ``fit``'s options as ``lobe fit`` does; returns the models as one
    comma-separated string (or None) and the maps as strings."""
    if metric not in METRICS:
        raise ValueError(f"metric: expected one of {', '.join(METRICS)}, found {metric!r}")
    env_list = [os.fspath(e) for e in envs]
    if env_list and metric != "image":
        raise ValueError(f"envs: only for metric='image'; found metric={metric!r}")
    if not (0.25 <= resolution <= 20.0):
        raise ValueError(f"resolution: expected a bin size in [0.25, 20] degrees, found {resolution}")
    if select is not None and not (select >= 0.0):
        raise ValueError(f"select: expected a non-negative relative tolerance, found {select}")
    if models is not None and not isinstance(models, str):
        models = ",".join(models)
    return models, env_list


def fit(
    data: Union[PathLike, Material],
    models: Union[str, Iterable[str], None] = None,
    metric: str = "eq1",
    resolution: float = 1.0,
    max_evals: int = 300,
    select: Optional[float] = None,
    progress: Union[bool, Callable[[str, float, float], Any]] = True,
    envs: Iterable[PathLike] = (),
) -> FitReport:
    """Fits models to ``data``, a measured file (MERL, binned or RGL, told apart by content)
    or a ``lobe.Material`` (its values binned, as ``lobe fit --material``).

    ``models``: labels (``fit_models()``), a list or comma-separated; default the study's
    seven isotropic models (or, for anisotropic binned data, anisotropic Ward,
    Ashikhmin-Shirley and Poulin-Fournier). ``metric``: what the fits minimize, as
    ``lobe fit --metric``: ``"eq1"`` (the study's Eq. 1; ``"ngan2005"`` is an alias),
    ``"log"`` (Eq. 1 on ln(1 + f cos)), ``"cube-root"`` (on (f cos)^(1/3)) or ``"image"``
    (renders of a sphere under the ``envs`` maps: ``"builtin:studio"``,
    ``"builtin:sunset"`` or image files; default both built-in ones); every fit's ``error``
    stays its Eq. 1 error. ``resolution``: bin size in degrees of isotropic data.
    ``max_evals``: objective evaluations per SLSQP start. ``select``: also pick the
    cheapest model whose normalized error is within this relative tolerance of the best.
    ``progress``: ``True`` shows a bar advancing per fitted model (tqdm: a widget in
    notebooks, text in terminals; a line per model without tqdm), ``False`` nothing, a
    callable is called as ``progress(label, error_normalized, seconds)`` after each model.
    Ctrl-C (a notebook's interrupt) stops the fit within an objective evaluation and
    raises ``KeyboardInterrupt``; an exception from the callable stops it and is raised.

    The result equals ``lobe fit DATA --models ... -o r.fit.json`` (timings aside)."""
    models, env_list = fit_options(models, metric, resolution, select, envs)
    if isinstance(data, Material):
        target: Any = data._m
        name = "synthetic"
    else:
        target = os.fspath(data)
        if os.path.isdir(target):
            raise ValueError(f"{target}: is a folder; lobe.fit fits one file (`lobe fit FOLDER -o OUT` fits a folder)")
        name = os.path.basename(target)
    if callable(progress) or not progress:
        text = _lobe.fit(target, models, float(resolution), int(max_evals), select, progress or None, metric, env_list)
    else:
        with Progress(f"fitting {name}", len(models.split(",")) if models else None, "model") as bar:

            def fitted(label: str, error_normalized: float, seconds: float) -> None:
                bar.update_to(bar.n + 1, f"{label:28} normalized error {error_normalized:.4e} ({seconds:.1f} s)")

            text = _lobe.fit(target, models, float(resolution), int(max_evals), select, fitted, metric, env_list)
    return FitReport.from_json(json.loads(text))
