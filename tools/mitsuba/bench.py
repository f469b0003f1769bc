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

The machine may be shared and its speed drift over a run, so lobe and each `llvm_ad_rgb`
configuration run in rounds: each round renders once with lobe and once with Mitsuba, one
after the other, and the speed and equal-error ratios against lobe are the medians of the
per-round ratios (paired), not ratios of medians taken minutes apart. One Mitsuba scene is
alive at a time, as when a user renders a scene: with a second copy of the scene loaded
in the same process, Dr.Jit compiles a different kernel for it that runs 1.3-1.4x faster
on sphere-envmap (measured: 15-17 against 20-24 Msamples/s), a state no single-scene
render reaches. `scalar_rgb`, tens of
times slower, runs after the rounds.
"""

import argparse
import gc
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


class MitsubaScene:
    """A scene converted and loaded for one Mitsuba variant and sampler, its LLVM kernel
    compiled by an untimed render; `render` times one more render."""

    def __init__(self, variant, scene, spp, sampler="independent"):
        mi.set_variant(variant)
        from lobe_mitsuba import bsdfs
        from lobe_mitsuba.convert import Converter
        bsdfs.register()
        self.variant, self.spp = variant, spp
        self.scene = mi.load_dict(Converter(scene).convert(spp, sampler))
        if variant.startswith("llvm"):
            dr.eval(mi.render(self.scene, spp=spp, seed=99))  # compile the kernel (untimed)

    def render(self, seed):
        mi.set_variant(self.variant)
        t = time.perf_counter()
        img = mi.render(self.scene, spp=self.spp, seed=seed)
        dr.eval(img)
        arr = np.array(img, dtype=np.float64)[..., :3]
        # Reading the image waits for the (asynchronous) kernel: it is in the timed span.
        return arr, time.perf_counter() - t


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
             f"Mitsuba {mi.__version__}; {a.spp} spp, median of {a.runs} runs (lobe and llvm_ad_rgb "
             f"alternating, ratios paired per round), reference: lobe at "
             f"{a.reference_spp} spp with another seed; {time.strftime('%Y-%m-%d')}.", "",
             "| scene | renderer | seconds | Msamples/s | RMSE | speed vs lobe | equal-error time vs lobe |",
             "|---|---|---|---|---|---|---|"]
    for scene in scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        ref, _ = lobe_render(exe, scene, a.reference_spp, 1000, os.path.join(tmp, "ref.exr"))
        h, w = ref.shape[:2]
        samples = w * h * a.spp
        # lobe and each LLVM configuration in rounds (see the module docs); one Mitsuba
        # scene alive at a time, as when a user renders one scene.
        lobe_times, lobe_img = [], None
        rows = []
        for smp in ("independent", "ldsampler"):
            try:
                ms = MitsubaScene("llvm_ad_rgb", scene, a.spp, smp)
            except Exception as e:  # noqa: BLE001 - a missing variant (no libLLVM) is reported, not fatal
                print(f"{name}: Mitsuba llvm_ad_rgb unavailable: {e}", file=sys.stderr)
                break
            pairs, img = [], None
            for k in range(a.runs):
                lobe_img, tl = lobe_render(exe, scene, a.spp, k, os.path.join(tmp, f"lobe{k}.exr"))
                img, tm = ms.render(k)
                lobe_times.append(tl)
                pairs.append((tl, tm))
            rows.append((f"Mitsuba llvm_ad_rgb ({smp})", pairs, rmse(img, ref)))
            del ms
            gc.collect()
        if not lobe_times:
            for k in range(a.runs):
                lobe_img, tl = lobe_render(exe, scene, a.spp, k, os.path.join(tmp, f"lobe{k}.exr"))
                lobe_times.append(tl)
        rows.insert(0, ("lobe", [(t, t) for t in lobe_times], rmse(lobe_img, ref)))
        try:
            ms = MitsubaScene("scalar_rgb", scene, a.spp)
            ts, img = [], None
            for k in range(min(a.runs, 3)):
                img, t = ms.render(k)
                ts.append(t)
            m = statistics.median(lobe_times)
            rows.append(("Mitsuba scalar_rgb (independent)", [(m, t) for t in ts], rmse(img, ref)))
        except Exception as e:  # noqa: BLE001
            print(f"{name}: Mitsuba scalar_rgb unavailable: {e}", file=sys.stderr)
        e0 = rows[0][2]
        for r, pairs, e in rows:
            # Paired: the median over rounds of lobe's time over this renderer's (scalar_rgb,
            # not run in rounds: lobe's median time over its).
            t = statistics.median(tm for _, tm in pairs)
            speed = statistics.median(tl / tm for tl, tm in pairs)
            lines.append(f"| {name} | {r} | {t:.3f} | {samples / t / 1e6:.2f} | {e:.4e} | "
                         f"{speed:.2f} | {(e * e) / (speed * e0 * e0):.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        with open(a.out + ".tmp", "w") as f:
            f.write(text)
        os.replace(a.out + ".tmp", a.out)


if __name__ == "__main__":
    main()
