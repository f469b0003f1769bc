"""lobe on a Dask cluster (``pip install "lobe[distributed]"``, docs/distributed.md):
renders, batch fits and the study as Dask tasks, giving the one-machine results.

Each function takes a ``dask.distributed.Client`` (a ``LocalCluster`` on a laptop,
``dask_jobqueue.SLURMCluster`` on a university cluster) and submits module-level task
functions whose arguments are paths, JSON text and numbers and whose results are bytes
or JSON text: nothing bound to one process crosses, and workers keep no state between
tasks; each task runs on one thread, as Dask expects (a worker runs as many tasks at
once as it has threads), so that a machine is never oversubscribed. Every process
must see the same files at the same paths (a shared filesystem, as
on any HPC cluster); paths are made absolute on the client.

- ``render``: the sample range of every pixel is cut into ``chunks`` tasks, each a
  partial render (per-pixel sums, ``lobe render --samples A:B``); the client adds them up
  in range order. ``chunks=1`` is ``lobe.render`` bit for bit; more chunks agree to
  within one float32 step per pixel (the f64 sums are added in another order).
- ``fit``: one task per file, each ``lobe.fit`` of it (fits are deterministic: equal to
  ``lobe.fit`` to the last bit, timings aside); with ``out=`` each report is written by
  content key as ``lobe fit FOLDER -o OUT`` writes it (kept when complete, completed with
  missing models, redone for other data or settings).
- ``study``: one task per step of each material, each waiting for the steps whose files
  it reads (renders and plots after the fits); the report is built on the client at the
  end. The folder is the one ``lobe study`` writes.

A task that fails on its input (a corrupt file) is an error of that material, reported
on the client and not retried; a worker that dies is Dask's business: the task is run
again elsewhere (``distributed.scheduler.allowed-failures``), and since every output is
written by temp file and rename, nothing partial is ever visible. Ctrl-C on the client
cancels the futures and raises ``KeyboardInterrupt``. Progress: Dask's dashboard
(``client.dashboard_link``) and a tqdm bar on the client.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lobe
from ._fit import FitReport, fit_options
from ._progress import Progress
from ._study import study_config

PathLike = Union[str, "os.PathLike[str]"]
Scene = Union[Mapping[str, Any], PathLike]

__all__ = ["render", "fit", "study"]


def _dask() -> Any:
    try:
        import distributed
    except ImportError as e:  # pragma: no cover - the message is the point
        raise ImportError('lobe.distributed needs Dask: pip install "lobe[distributed]" (dask[distributed])') from e
    return distributed


def _gather(client: Any, futures: Sequence[Any], what: str, unit: str, progress: bool) -> List[Any]:
    """The futures' results in order, with a bar over them; Ctrl-C cancels them all. A
    task's exception is raised here, on the client, after the others are cancelled."""
    distributed = _dask()
    bar = Progress(what, len(futures), unit) if progress else None
    try:
        for k, f in enumerate(distributed.as_completed(futures), 1):
            if f.status == "error":
                f.result()  # raises the task's exception
            if bar is not None:
                bar.update_to(k)
        return client.gather(list(futures))
    except BaseException:
        client.cancel(list(futures))
        raise
    finally:
        if bar is not None:
            bar.close()


def _task_threads() -> int:
    """The threads a task's parallel work runs on: one, as Dask expects of its tasks (it
    runs as many at once as a worker has threads, and sets ``OMP_NUM_THREADS=1`` in its
    workers for the same reason). A worker of 2 threads running two 2-thread fits made
    a 100-material batch 15 % slower than two 1-thread fits (docs/distributed.md)."""
    return 1


# --- render ---------------------------------------------------------------------------


def _render_task(path: Optional[str], text: Optional[str], base: str, spp: int, seed: Optional[int], first: int, last: int) -> bytes:
    """Task: the partial render of samples first..last (its .lobepart bytes)."""
    return _lobe.render_samples(path, text, base, spp, seed, first, last, _task_threads())


def sample_ranges(spp: int, chunks: int) -> List[Tuple[int, int]]:
    """``spp`` samples cut into ``chunks`` consecutive ranges of nearly equal size."""
    if not (1 <= chunks <= spp):
        raise ValueError(f"chunks: expected 1 to spp = {spp} tasks, found {chunks}")
    cuts = [spp * k // chunks for k in range(chunks + 1)]
    return [(cuts[k], cuts[k + 1]) for k in range(chunks)]


def render(
    scene: Scene,
    spp: int,
    client: Any,
    chunks: Optional[int] = None,
    seed: Optional[int] = None,
    base: Optional[PathLike] = None,
    variance: bool = False,
    progress: bool = True,
) -> Union[np.ndarray, Tuple[np.ndarray, np.ndarray]]:
    """Renders ``scene`` (a scene file, or a dict whose relative paths resolve against
    ``base``, default the current folder) at ``spp`` samples per pixel as ``chunks`` tasks
    (default: two per worker thread, at most ``spp``) and returns the image, (H, W, 3) float32,
    or with ``variance=True`` ``(image, variance of each pixel's mean)``: what
    ``lobe.render(scene, spp=spp, seed=seed)`` returns (see the module doc for how
    exactly)."""
    if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
        raise ValueError(f"spp: expected a positive number of samples per pixel, found {spp!r}")
    if chunks is None:
        workers = client.scheduler_info().get("workers", {}).values()
        slots = max(1, sum(int(w.get("nthreads", 1)) for w in workers))
        chunks = min(spp, 2 * slots)
    ranges = sample_ranges(spp, chunks)
    if isinstance(scene, Mapping):
        path, text = None, json.dumps(scene, allow_nan=False)
    else:
        path, text = os.path.abspath(os.fspath(scene)), None
    folder = os.path.abspath(os.fspath(base) if base is not None else os.getcwd())
    futures = [
        client.submit(_render_task, path, text, folder, spp, seed, a, b, pure=False)
        for a, b in ranges
    ]
    parts = _gather(client, futures, "rendering", "part", progress)
    image, var, _ = _lobe.merge_renders(parts)
    return (image, var) if variance else image


# --- fit ------------------------------------------------------------------------------


def _fit_task(path: str, out: Optional[str], models: Optional[str], resolution: float, max_evals: int, select: Optional[float], metric: str, envs: List[str]) -> str:
    """Task: the fit report of one file as JSON text (written by content key to ``out``
    when given)."""
    threads = _task_threads()
    if out is None:
        return _lobe.fit(path, models, resolution, max_evals, select, None, metric, envs, threads)
    text, _written = _lobe.fit_into(path, out, models, resolution, max_evals, select, metric, envs, threads)
    return text


def fit(
    files: Iterable[PathLike],
    client: Any,
    models: Union[str, Iterable[str], None] = None,
    metric: str = "eq1",
    resolution: float = 1.0,
    max_evals: int = 300,
    select: Optional[float] = None,
    envs: Iterable[PathLike] = (),
    out: Optional[PathLike] = None,
    progress: bool = True,
) -> List[FitReport]:
    """Fits every measured file of ``files`` (one task each) and returns their reports in
    order: each equal to ``lobe.fit(file, models=..., ...)`` (the same options; timings
    aside). With ``out`` (a folder), each report is also written to
    ``out/<stem>.fit.json`` by content key, as ``lobe fit FOLDER -o OUT`` does, so a rerun
    computes only what is missing or changed. A file that fails raises ``ValueError`` on
    the client naming it, once the other tasks are cancelled."""
    models, env_list = fit_options(models, metric, resolution, select, envs)
    env_list = [e if e.startswith("builtin:") else os.path.abspath(e) for e in env_list]
    paths = [os.path.abspath(os.fspath(f)) for f in files]
    if not paths:
        raise ValueError("files: expected at least one measured data file")
    reports: List[Optional[str]] = [None] * len(paths)
    if out is not None:
        folder = os.path.abspath(os.fspath(out))
        os.makedirs(folder, exist_ok=True)
        stems = [os.path.splitext(os.path.basename(p))[0] for p in paths]
        if len(set(stems)) != len(stems):
            raise ValueError("files: two files of one name would share a report; expected distinct file names")
        reports = [os.path.join(folder, f"{s}.fit.json") for s in stems]
        clash = set(map(os.path.realpath, reports)) & set(map(os.path.realpath, paths))
        if clash:
            raise ValueError(f"out: the report {sorted(clash)[0]} would overwrite an input; expected a folder of reports apart from the data")
    futures = [
        client.submit(_fit_task, p, r, models, float(resolution), int(max_evals), select, metric, env_list, pure=False)
        for p, r in zip(paths, reports)
    ]
    texts = _gather(client, futures, "fitting", "file", progress)
    return [FitReport.from_json(json.loads(t)) for t in texts]


# --- study ----------------------------------------------------------------------------


def _study_step_task(config: str, material: str, step: str, *after: Dict[str, str]) -> Dict[str, str]:
    """Task: one step of one material, once the steps it reads (``after``) are done.
    Returns ``{"status": "computed" | "done" | "failed" | "skipped", "error": ...}``: a
    material's failure is a result, not an exception, so that Dask does not retry it and
    the material's later steps are skipped as ``lobe study`` skips them."""
    failed = [a for a in after if a["status"] in ("failed", "skipped")]
    if failed:
        return {"status": "skipped", "error": failed[0]["error"]}
    try:
        return {"status": _lobe.study_step(config, material, step, _task_threads()), "error": ""}
    except (ValueError, FileNotFoundError) as e:
        return {"status": "failed", "error": str(e)}


def study(
    data: Iterable[PathLike],
    out: PathLike,
    client: Any,
    quick: bool = False,
    envs: Iterable[str] = (),
    progress: bool = True,
    error_spp: Optional[int] = None,
) -> Dict[str, Any]:
    """The study of ``data`` (measured files and folders of them; empty: the built-in
    set) as Dask tasks, writing the folder ``out`` as ``lobe study`` and ``lobe.study``
    write it (the same files and ``results.json``, timed values aside). Returns the same
    summary as ``lobe.study``; ``error_spp`` is ``lobe study --error-spp``."""
    config = study_config(data, out, quick, envs, error_spp=error_spp)
    plan = json.loads(_lobe.study_plan(config))
    futures: Dict[Tuple[str, str], Any] = {}
    for s in plan["steps"]:
        m = s["material"]
        deps = [futures[(m, a)] for a in s["after"]]
        futures[(m, s["step"])] = client.submit(_study_step_task, config, m, s["step"], *deps, pure=False)
    order = list(futures)
    results = _gather(client, [futures[k] for k in order], "study", "step", progress)
    failures: List[List[str]] = []
    summary = {"materials": len(plan["materials"]), "computed": 0, "skipped": 0}
    for (material, _), r in zip(order, results):
        if r["status"] == "computed":
            summary["computed"] += 1
        elif r["status"] == "done":
            summary["skipped"] += 1
        elif r["status"] == "failed" and all(f[0] != material for f in failures):
            failures.append([material, r["error"]])
    end = json.loads(_lobe.study_finish(config, json.dumps(failures)))
    return {**summary, "pending": end["pending"], "index": end["index"], "failures": failures}
