#!/usr/bin/env python3
"""lobe against Mitsuba 3 on the same scenes, in the same run (issue 8 benchmark).

    tools/mitsuba/bench.sh [SCENE.json ...] [--spp 64] [--reference-spp 2048] [--runs 3]

For each scene (default: scenes/sphere-envmap.json and scenes/spheres-envmap.json) it
renders with lobe (`lobe render`, release build), Mitsuba `llvm_ad_rgb` (after one
untimed run that compiles the kernel) and Mitsuba `scalar_rgb`, all at the same spp on all
cores, and reports the median time of --runs renders, Msamples/s, the RMSE against a
high-spp lobe reference rendered with another seed, and the equal-error time ratio

    (t_X RMSE_X^2) / (t_lobe RMSE_lobe^2)

i.e. how much longer renderer X needs than lobe to reach the same error (RMSE^2 falls as
1/spp for these unbiased renderers, and about so for the low-discrepancy samplers at these
spp). lobe's padded, XOR-scrambled Sobol' sampler has less variance per sample than
Mitsuba's default `independent` sampler, so `llvm_ad_rgb` is also run with Mitsuba's
`ldsampler` (the same construction: XOR-scrambled (0,2)-sequences per dimension pair):
that row is the like-for-like equal-error comparison. Prints a Markdown table (with the
machine) and writes it to --out if given.
"""

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(os.path.join(here, "..", ".."))
sys.path.insert(0, here)

import mitsuba as mi  # noqa: E402
import drjit as dr  # noqa: E402
import numpy as np  # noqa: E402


def lobe_bin():
    exe = os.path.join(root, "target", "release", "lobe")
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "lobe-tools"], cwd=root, check=True)
    return exe


def read_exr(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def lobe_render(exe, scene, spp, seed, out):
    subprocess.run([exe, "render", scene, "--spp", str(spp), "--seed", str(seed), "-o", out, "--no-png", "-q"],
                   check=True)
    stats = out[:-4] + ".stats.json"
    with open(stats) as f:
        s = json.load(f)
    return read_exr(out), float(s["seconds"])


def mitsuba_renders(variant, scene, spp, runs, sampler="independent"):
    mi.set_variant(variant)
    from lobe_mitsuba import bsdfs
    from lobe_mitsuba.convert import Converter
    bsdfs.register()
    sc = mi.load_dict(Converter(scene).convert(spp, sampler))
    times, img = [], None
    if variant.startswith("llvm"):
        dr.eval(mi.render(sc, spp=spp, seed=99))  # compile the kernel (untimed)
    for k in range(runs):
        t = time.perf_counter()
        img = mi.render(sc, spp=spp, seed=k)
        dr.eval(img)
        arr = np.array(img, dtype=np.float64)[..., :3]
        times.append(time.perf_counter() - t)
    return arr, statistics.median(times)


def rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--reference-spp", type=int, default=2048)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    scenes = a.scenes or [os.path.join(root, "scenes", "sphere-envmap.json"),
                          os.path.join(root, "scenes", "spheres-envmap.json")]
    exe = lobe_bin()
    tmp = tempfile.mkdtemp(prefix="lobe-bench-")
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    lines = [f"Machine: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
             f"Mitsuba {mi.__version__}; {a.spp} spp, median of {a.runs} runs, reference: lobe at "
             f"{a.reference_spp} spp with another seed; {time.strftime('%Y-%m-%d')}.", "",
             "| scene | renderer | seconds | Msamples/s | RMSE | speed vs lobe | equal-error time vs lobe |",
             "|---|---|---|---|---|---|---|"]
    for scene in scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        ref, _ = lobe_render(exe, scene, a.reference_spp, 1000, os.path.join(tmp, "ref.exr"))
        h, w = ref.shape[:2]
        samples = w * h * a.spp
        rows = []
        times, img = [], None
        for k in range(a.runs):
            img, t = lobe_render(exe, scene, a.spp, k, os.path.join(tmp, f"lobe{k}.exr"))
            times.append(t)
        rows.append(("lobe", statistics.median(times), rmse(img, ref)))
        for v, smp in (("llvm_ad_rgb", "independent"), ("llvm_ad_rgb", "ldsampler"),
                       ("scalar_rgb", "independent")):
            try:
                img, t = mitsuba_renders(v, scene, a.spp, a.runs, smp)
            except Exception as e:  # noqa: BLE001 - a missing variant (no libLLVM) is reported, not fatal
                print(f"{name}: Mitsuba {v} unavailable: {e}", file=sys.stderr)
                continue
            rows.append((f"Mitsuba {v} ({smp})", t, rmse(img, ref)))
        t0, e0 = rows[0][1], rows[0][2]
        for r, t, e in rows:
            lines.append(f"| {name} | {r} | {t:.3f} | {samples / t / 1e6:.2f} | {e:.4e} | "
                         f"{t0 / t:.2f} | {(t * e * e) / (t0 * e0 * e0):.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        with open(a.out + ".tmp", "w") as f:
            f.write(text)
        os.replace(a.out + ".tmp", a.out)


if __name__ == "__main__":
    main()
