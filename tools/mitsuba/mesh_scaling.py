#!/usr/bin/env python3
"""Big meshes, lobe against Mitsuba 3: from process start to the image, with peak memory.

    tools/mitsuba/.venv/bin/python tools/mitsuba/mesh_scaling.py [--sizes 1,4,16] [--rounds 2]
        [--format obj|ply] [--out docs-table.md]

For each size (millions of triangles) it generates the displaced sphere of
bench_assets.py at that size (an ASCII OBJ, or a binary little-endian PLY, in out/meshes/,
never committed; kept for reruns), then renders it under the studio map with the RGL
`colodur_napoli_4f` measurement (256x256, 64 spp, path tracer of depth 8), in rounds: in each
round once with `lobe render` and once with a fresh Python process that loads the same
file with Mitsuba's own reader (`llvm_ad_rgb`, `ldsampler`) and renders it. Every run is
its own process under GNU time, so the peak resident memory is the whole process's (an
untimed Mitsuba run first fills Dr.Jit's kernel cache, as a user's earlier render would).
lobe's
stats JSON splits its time into mesh reading, BVH build and rendering; Mitsuba's into
`load_dict` (reading and the Embree build) and `render`.

Prints a Markdown table: per size, each renderer's median wall time and peak RSS, lobe's
breakdown, Mitsuba's, and the per-round paired ratios lobe/Mitsuba of wall time and of peak
memory (below 1: lobe is faster or smaller). Needs numpy and mitsuba (this venv), GNU time
(/usr/bin/time) and ../shared/data/rgl (or $LOBE_DATA/rgl).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(os.path.join(here, "..", ".."))
sys.path.insert(0, here)
from bench_assets import displaced_sphere  # noqa: E402

DATA = os.environ.get("LOBE_DATA", os.path.join(root, "..", "shared", "data"))
RGL = os.path.join(DATA, "rgl", "colodur_napoli_4f_rgb.bsdf")
ENV = os.path.join(root, "scenes", "envmaps", "studio-512.exr")
CAMERA = {"type": "perspective", "fov": 30, "origin": [0, 0.6, 4.6], "target": [0, 0, 0], "up": [0, 1, 0]}
SPP = 64


def rings_segments(millions):
    """Rings and segments of a displaced sphere of about `millions` M triangles (2 r s)."""
    segments = int(round((millions * 1e6) ** 0.5 * 1.0))
    segments += segments % 2
    rings = max(4, int(round(millions * 1e6 / (2 * segments))))
    return rings, segments


def write_obj(path, pos, tris):
    with open(path + ".tmp", "w") as f:
        f.write("# displaced sphere (tools/mitsuba/mesh_scaling.py)\n")
        for block in range(0, len(pos), 1 << 20):
            np.savetxt(f, pos[block:block + (1 << 20)], fmt="v %.6f %.6f %.6f")
        for block in range(0, len(tris), 1 << 20):
            np.savetxt(f, tris[block:block + (1 << 20)].astype(np.int64) + 1, fmt="f %d %d %d")
    os.replace(path + ".tmp", path)


def write_ply(path, pos, tris):
    with open(path + ".tmp", "wb") as f:
        f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(pos)}\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n").encode())
        f.write(pos.astype("<f4").tobytes())
        rec = np.zeros(len(tris), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"], rec["i"] = 3, tris
        f.write(rec.tobytes())
    os.replace(path + ".tmp", path)


def mesh_file(millions, fmt):
    folder = os.path.join(root, "out", "meshes")
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, f"displaced-{millions}m.{fmt}")
    if not os.path.exists(path):
        pos, tris = displaced_sphere(*rings_segments(millions))
        (write_obj if fmt == "obj" else write_ply)(path, pos, tris)
        print(f"wrote {path} ({len(tris)} triangles)", file=sys.stderr)
    return path


def timed(cmd):
    """Runs `cmd` under GNU time: (its stdout, wall seconds, peak RSS in MB)."""
    with tempfile.NamedTemporaryFile(suffix=".time") as t:
        p = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", t.name] + cmd,
                           capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(f"{cmd[0]} failed: {p.stderr[-2000:]}")
        wall, kb = open(t.name).read().split()[-2:]
    return p.stdout, float(wall), int(kb) / 1024


def lobe_run(exe, mesh, tmp):
    scene = {
        "camera": CAMERA, "film": {"width": 256, "height": 256}, "sampler": {"spp": SPP, "seed": 0},
        "integrator": {"type": "path", "max_depth": 8},
        "shapes": [{"type": os.path.splitext(mesh)[1][1:], "file": mesh, "material": {"type": "rgl", "file": RGL}}],
        "lights": [{"type": "envmap", "file": ENV}],
    }
    path = os.path.join(tmp, "scene.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    out = os.path.join(tmp, "lobe.exr")
    _, wall, rss = timed([exe, "render", path, "-o", out, "--no-png", "-q"])
    stats = json.load(open(os.path.join(tmp, "lobe.stats.json")))
    g = stats["geometry"]
    return {"wall": wall, "rss": rss, "read": g["mesh_read_seconds"], "build": g["bvh_build_seconds"],
            "load": stats["load_seconds"], "render": stats["seconds"], "triangles": g["primitives"]}


MITSUBA = r"""
import json, sys, time
t0 = time.perf_counter()
import mitsuba as mi, drjit as dr
mi.set_variant("llvm_ad_rgb")
mesh, rgl, env, spp = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
kind = mesh.rsplit(".", 1)[1]
t1 = time.perf_counter()
scene = mi.load_dict({
    "type": "scene",
    "integrator": {"type": "path", "max_depth": 8},
    "mesh": {"type": kind, "filename": mesh, "bsdf": {"type": "measured", "filename": rgl}},
    "env": {"type": "envmap", "filename": env},
    "sensor": {"type": "perspective", "fov": 30,
               "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0.6, 4.6], target=[0, 0, 0], up=[0, 1, 0]),
               "sampler": {"type": "ldsampler", "sample_count": spp},
               "film": {"type": "hdrfilm", "width": 256, "height": 256, "rfilter": {"type": "box"}}},
})
t2 = time.perf_counter()
img = mi.render(scene, spp=spp)
dr.eval(img)
dr.sync_thread()
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "load": t2 - t1, "render": t3 - t2}))
"""


def mitsuba_run(mesh):
    out, wall, rss = timed([sys.executable, "-c", MITSUBA, mesh, RGL, ENV, str(SPP)])
    m = json.loads(out.strip().splitlines()[-1])
    return {"wall": wall, "rss": rss, **m}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="1,4,16", help="millions of triangles, comma-separated")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--format", choices=["obj", "ply"], default="obj")
    ap.add_argument("--lobe", default=os.path.join(root, "target", "release", "lobe"))
    ap.add_argument("--out")
    a = ap.parse_args()
    if not os.path.exists(RGL):
        sys.exit(f"mesh_scaling: {RGL} not found (set LOBE_DATA)")
    lines = ["| triangles | renderer | wall s | peak RSS MB | bytes/triangle | breakdown s |", "|---|---|---|---|---|---|"]
    ratios = []
    for millions in [int(s) for s in a.sizes.split(",")]:
        mesh = mesh_file(millions, a.format)
        runs = {"lobe": [], "mitsuba": []}
        # An untimed Mitsuba run first: Dr.Jit compiles the kernels and caches them on disk,
        # as for a user's second render of the scene.
        mitsuba_run(mesh)
        with tempfile.TemporaryDirectory() as tmp:
            for _ in range(a.rounds):
                runs["lobe"].append(lobe_run(a.lobe, mesh, tmp))
                runs["mitsuba"].append(mitsuba_run(mesh))
                print(f"{millions}M: lobe {runs['lobe'][-1]}, mitsuba {runs['mitsuba'][-1]}", file=sys.stderr)
        n = runs["lobe"][0]["triangles"]
        med = {k: {f: statistics.median(r[f] for r in v) for f in v[0]} for k, v in runs.items()}
        wall = statistics.median(l["wall"] / m["wall"] for l, m in zip(runs["lobe"], runs["mitsuba"]))
        rss = statistics.median(l["rss"] / m["rss"] for l, m in zip(runs["lobe"], runs["mitsuba"]))
        ratios.append(f"| {n / 1e6:.1f} M | {wall:.2f} | {rss:.2f} |")
        lo, mi_ = med["lobe"], med["mitsuba"]
        lines.append(f"| {n / 1e6:.1f} M | lobe | {lo['wall']:.2f} | {lo['rss']:.0f} | {lo['rss'] * 2**20 / n:.0f} | "
                     f"read {lo['read']:.2f}, BVH build {lo['build']:.2f}, render {lo['render']:.2f} |")
        lines.append(f"| | Mitsuba | {mi_['wall']:.2f} | {mi_['rss']:.0f} | {mi_['rss'] * 2**20 / n:.0f} | "
                     f"import {mi_['import']:.2f}, load + Embree {mi_['load']:.2f}, render {mi_['render']:.2f} |")
    table = "\n".join(lines + ["", "| triangles | lobe/Mitsuba wall (paired median) | lobe/Mitsuba peak RSS |",
                               "|---|---|---|"] + ratios) + "\n"
    print(table)
    if a.out:
        with open(a.out, "w") as f:
            f.write(table)


if __name__ == "__main__":
    main()
