"""``lobe.study``: the whole experiment of Ngan, Durand and Matusik 2005 (fits with model
selection, the microfacet estimate, sphere renders with image errors and intervals,
plots and the browsable report) on one machine, exactly as ``lobe study``; see
``lobe.distributed.study`` for the same steps as Dask tasks."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Iterable, Optional, Tuple, Union

from . import _lobe
from ._progress import Progress

PathLike = Union[str, "os.PathLike[str]"]


def study_config(
    data: Iterable[PathLike],
    out: PathLike,
    quick: bool = False,
    envs: Iterable[str] = (),
    shard: Optional[Tuple[int, int]] = None,
    error_spp: Optional[int] = None,
) -> str:
    """The JSON configuration the compiled study functions take (absolute paths, so that
    every process of a cluster reads the same files)."""
    if isinstance(data, (str, os.PathLike)):
        data = [data]
    env_list = [e if str(e).startswith("builtin:") else os.path.abspath(os.fspath(e)) for e in envs]
    return json.dumps(
        {
            "inputs": [os.path.abspath(os.fspath(d)) for d in data],
            "out": os.path.abspath(os.fspath(out)),
            "quick": bool(quick),
            "envs": env_list,
            "shard": list(shard) if shard is not None else None,
            "error_spp": error_spp,
        }
    )


def study(
    data: Iterable[PathLike],
    out: PathLike,
    quick: bool = False,
    envs: Iterable[str] = (),
    shard: Optional[Tuple[int, int]] = None,
    progress: bool = True,
    error_spp: Optional[int] = None,
) -> Dict[str, Any]:
    """Runs the study of ``data`` (measured files and folders of them; empty: the built-in
    set) into the folder ``out``, as ``lobe study DATA -o OUT [--quick] [--env MAP]
    [--shard I/N] [--error-spp SPP]``: steps done for the same data, maps and settings
    are kept, the rest computed. Returns the summary: ``materials``, ``computed``,
    ``skipped``, ``pending`` (materials of other shards not yet complete), ``index`` (the
    report's index page, once every material is complete) and ``failures`` (``[material,
    error]`` pairs; the others go on). ``progress`` shows a bar over the steps. Ctrl-C
    stops at the next step or fit evaluation, keeping every finished file, and raises
    ``KeyboardInterrupt``."""
    config = study_config(data, out, quick, envs, shard, error_spp)
    if not progress:
        return json.loads(_lobe.study_run(config, None))
    bar: Optional[Progress] = None

    def step(done: int, total: int) -> None:
        nonlocal bar
        if bar is None:
            bar = Progress("study", total, "step")
        bar.update_to(done)

    try:
        return json.loads(_lobe.study_run(config, step))
    finally:
        if bar is not None:
            bar.close()
