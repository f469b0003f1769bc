#!/usr/bin/env python3
"""Render the Mitsuba 3 reference of one scene of reference-images/scenes/ and record it.

    tools/mitsuba/reference.sh NAME            # = setup.sh, then this script
    tools/mitsuba/.venv/bin/python tools/mitsuba/reference.py NAME [--spp 64] [--runs 16] [--seed 0]

Writes reference-images/NAME.exr (mean of RUNS independent renders of SPP samples per
pixel) and reference-images/NAME.var.exr (variance of that mean per pixel), and records in
reference-images/manifest.json how they were made: scene file and SHA-256, Mitsuba
version and variant, spp, runs, seed, command, and the spp the lobe test renders with
(a quarter of the reference's total, so that lobe's well-estimated variance dominates).
"""

import argparse
import datetime
import hashlib
import json
import os
import sys
import time

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
root = os.path.abspath(os.path.join(here, "..", ".."))

import render as mrender  # noqa: E402  (sets the variant, registers the plugins)
import mitsuba as mi  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("name")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of each run")
    ap.add_argument("--runs", type=int, default=16, help="independent runs (for the variance)")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    refdir = os.path.join(root, "reference-images")
    scene = os.path.join(refdir, "scenes", a.name + ".json")
    if not os.path.isfile(scene):
        sys.exit(f"reference.py: {scene} does not exist; expected a lobe scene file there")
    t = time.time()
    mean, var = mrender.render(scene, a.spp, a.runs, a.seed)
    h, w = mean.shape[:2]
    if w > 256 or h > 256:
        sys.exit(f"reference.py: {scene}: {w}x{h} pixels; references are at most 256x256")
    mrender.write_exr(os.path.join(refdir, a.name + ".exr"), mean)
    mrender.write_exr(os.path.join(refdir, a.name + ".var.exr"), var)
    with open(scene, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    manifest_path = os.path.join(refdir, "manifest.json")
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f)
    manifest[a.name] = {
        "scene": f"reference-images/scenes/{a.name}.json",
        "scene_sha256": digest,
        "image": f"reference-images/{a.name}.exr",
        "variance": f"reference-images/{a.name}.var.exr",
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "spp_per_run": a.spp,
        "runs": a.runs,
        "seed": a.seed,
        "lobe_spp": max(1, a.spp * a.runs // 4),
        "command": f"tools/mitsuba/reference.sh {a.name} --spp {a.spp} --runs {a.runs} --seed {a.seed}",
        "date": datetime.date.today().isoformat(),
        "seconds": round(time.time() - t, 1),
    }
    tmp = manifest_path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(dict(sorted(manifest.items())), f, indent=2)
        f.write("\n")
    os.replace(tmp, manifest_path)
    print(f"{a.name}: {w}x{h}, {a.runs} x {a.spp} spp with {mi.variant()} in {time.time() - t:.1f} s")


if __name__ == "__main__":
    main()
