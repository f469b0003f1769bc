#!/usr/bin/env python3
"""Render a lobe scene with Mitsuba 3.

    tools/mitsuba/.venv/bin/python tools/mitsuba/render.py SCENE.json OUT.exr [--spp N] [--runs K] [--seed S]

With --runs K > 1 the image is the mean of K independent renders (seeds S..S+K-1) and
OUT.var.exr holds the variance of that mean per pixel. EXRs are written synchronously
(write_async=False: Mitsuba's asynchronous writer corrupts files in scalar mode) to a
temporary name and renamed into place.
"""

import argparse
import os
import time

import lobe.mitsuba as lobe_mitsuba  # noqa: E402  (the lobe package, tools/python)

variant = lobe_mitsuba.set_variant()

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

from lobe.mitsuba.convert import Converter  # noqa: E402

lobe_mitsuba.register()


def write_exr(path, array):
    tmp = path + ".tmp.exr"
    mi.util.write_bitmap(tmp, np.ascontiguousarray(array, dtype=np.float32), write_async=False)
    os.replace(tmp, path)


def render(scene_path, spp, runs, seed):
    scene = mi.load_dict(Converter(scene_path).convert(spp))
    images = []
    for k in range(runs):
        img = mi.render(scene, spp=spp, seed=seed + k)
        dr.eval(img)
        images.append(np.array(img, dtype=np.float64)[..., :3])
    stack = np.stack(images)
    mean = stack.mean(axis=0)
    var = stack.var(axis=0, ddof=1) / runs if runs > 1 else np.zeros_like(mean)
    return mean, var


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, default=None, help="samples per pixel per run (default: the scene's)")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    t = time.time()
    mean, var = render(a.scene, a.spp, a.runs, a.seed)
    write_exr(a.out, mean)
    if a.runs > 1:
        write_exr(a.out[:-4] + ".var.exr" if a.out.endswith(".exr") else a.out + ".var.exr", var)
    print(f"{a.scene}: {mean.shape[1]}x{mean.shape[0]}, {a.runs} x {a.spp or 'scene'} spp with {variant} in {time.time() - t:.1f} s -> {a.out}")


if __name__ == "__main__":
    main()
