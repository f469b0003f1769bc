"""The batch fit of docs/distributed.md: N measured materials (binned tables of random
analytic materials of five models, made here and not kept), every isotropic model
(13), fitted by ``lobe fit FOLDER`` on this machine's cores and by
``lobe.distributed.fit`` on a LocalCluster of 1 worker process of 2 threads and of 2
worker processes of 1 thread; then the engine's
overhead per task (empty tasks) and a simulation of the same batch on 100 workers from
the measured task times. Prints a Markdown table and writes JSON with --json.

    tools/mitsuba/.venv/bin/python tools/python/benches/distributed_fit.py --materials 100
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import lobe
import lobe.distributed as ld

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))


def material(rng: np.random.Generator) -> dict:
    """A random analytic material of one of five models."""
    kind = rng.integers(5)
    d, s = float(rng.uniform(0.02, 0.4)), float(rng.uniform(0.05, 0.6))
    if kind == 0:
        return {"type": "ward", "diffuse": d, "specular": s * 0.3, "alpha": float(rng.uniform(0.05, 0.4))}
    if kind == 1:
        return {"type": "cook-torrance", "diffuse": d, "specular": s, "m": float(rng.uniform(0.08, 0.5)), "f0": float(rng.uniform(0.02, 0.9))}
    if kind == 2:
        return {"type": "blinn-phong", "diffuse": d, "specular": s * 0.2, "n": float(rng.uniform(5, 400))}
    if kind == 3:
        return {"type": "he", "diffuse": d, "specular": s, "sigma0": float(rng.uniform(0.05, 0.5)), "tau": float(rng.uniform(1, 6)), "eta": float(rng.uniform(1.3, 2.5))}
    return {"type": "ashikhmin-shirley", "diffuse": d, "specular": s, "n": float(rng.uniform(10, 1000)), "f0": float(rng.uniform(0.02, 0.9))}


def write_table(path: str, desc: dict, bins: int) -> None:
    """Isotropic binned data (theta_i, theta_o, phi_d) of ``desc``."""
    n, p = bins, 2 * bins
    th = (np.arange(n) + 0.5) * 90.0 / n
    ph = (np.arange(p) + 0.5) * 180.0 / p
    ti, to, pd = np.meshgrid(th, th, ph, indexing="ij")
    wi = lobe.directions(ti.ravel(), np.zeros(ti.size))
    wo = lobe.directions(to.ravel(), pd.ravel())
    v = lobe.Material(desc).eval(wo, wi).reshape(n, n, p, 3).astype(np.float32)
    lobe.write_binned(path, lobe.Binned(v, [(n, 0.0, 90.0), (n, 0.0, 90.0), (p, 0.0, 180.0)], False))


def simulate(times: list, workers: int, overhead: float) -> float:
    """Makespan of the tasks (longest first is not what Dask does; it takes them in
    submission order) on ``workers`` single-task workers, each task paying ``overhead``."""
    free = [0.0] * workers
    heapq.heapify(free)
    end = 0.0
    for t in times:
        start = heapq.heappop(free)
        done = start + overhead + t
        end = max(end, done)
        heapq.heappush(free, done)
    return end


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--materials", type=int, default=100)
    ap.add_argument("--resolution", type=float, default=2.0)
    ap.add_argument("--bins", type=int, default=45)
    ap.add_argument("--max-evals", type=int, default=300)
    ap.add_argument("--json")
    a = ap.parse_args()
    import distributed

    lobe_bin = os.environ.get("LOBE_BIN", os.path.join(ROOT, "target", "release", "lobe"))
    models = ",".join(m for m in lobe.fit_models() if not m.endswith("-anisotropic") and m != "poulin-fournier")
    rng = np.random.default_rng(2005)
    out: dict = {"materials": a.materials, "models": len(models.split(",")), "resolution": a.resolution, "cores": os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "data")
        os.makedirs(data)
        for k in range(a.materials):
            write_table(os.path.join(data, f"m{k:03}.bin"), material(rng), a.bins)
        files = sorted(os.path.join(data, f) for f in os.listdir(data))
        opts = ["--models", models, "--resolution", str(a.resolution), "--max-evals", str(a.max_evals)]
        t0 = time.perf_counter()
        subprocess.run([lobe_bin, "fit", data, "-o", os.path.join(tmp, "cli"), "-q", *opts], check=True)
        out["cli_seconds"] = time.perf_counter() - t0
        print(f"CLI: {out['cli_seconds']:.1f} s", file=sys.stderr)
        cores = os.cpu_count() or 2
        for workers in (1, 2):
            threads = max(1, cores // workers)
            with distributed.LocalCluster(n_workers=workers, threads_per_worker=threads, processes=True, dashboard_address=None) as cluster, distributed.Client(cluster) as client:
                t0 = time.perf_counter()
                reports = ld.fit(files, client, models=models, resolution=a.resolution, max_evals=a.max_evals, progress=False)
                out[f"dask_{workers}_seconds"] = time.perf_counter() - t0
                print(f"Dask, {workers} workers: {out[f'dask_{workers}_seconds']:.1f} s", file=sys.stderr)
                if workers == 2:
                    t0 = time.perf_counter()
                    client.gather(client.map(lambda x: x, range(1000), pure=False))
                    out["overhead_per_task_seconds"] = (time.perf_counter() - t0) / 1000
        task_times = [sum(m.seconds for m in r.models.values()) for r in reports]
    # The fit seconds of each material as measured with 2 workers on this machine's cores
    # (about a core each): the simulation's workers are such one-core workers.
    lone = task_times
    out["task_seconds"] = {"median": statistics.median(lone), "max": max(lone), "sum": sum(lone)}
    for w in (2, 10, 100):
        out[f"simulated_{w}_workers_seconds"] = simulate(lone, w, out["overhead_per_task_seconds"])
    print(json.dumps(out, indent=1))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
