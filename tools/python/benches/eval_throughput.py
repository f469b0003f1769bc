#!/usr/bin/env python3
"""Throughput of ``lobe.Material.eval`` from Python against its Rust peer, measured in
one run: N direction pairs (default 10^7, both directions cosine-distributed, as in
materials/benches/bsdf.rs) of the criterion benchmark's Ward material
(``{"type": "ward", "diffuse": 0.2, "specular": 0.1, "alpha": 0.1}``), median of 5 calls,
then ``cargo bench -p lobe-materials --bench bsdf -- bsdf/ward/`` (single-threaded
``eval`` and ``eval_pdf_many``, ns per pair), and the ratio.

    tools/mitsuba/.venv/bin/python tools/python/benches/eval_throughput.py [--pairs N] [--no-cargo]

Set RAYON_NUM_THREADS=1 for a single-threaded Python figure."""

import argparse
import os
import re
import subprocess
import time

import numpy as np

import lobe

WARD = {"type": "ward", "diffuse": 0.2, "specular": 0.1, "alpha": 0.1}
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))


def cosine_directions(rng, n):
    u1, u2 = rng.random(n), rng.random(n)
    r = np.sqrt(u1)
    return np.stack([r * np.cos(2 * np.pi * u2), r * np.sin(2 * np.pi * u2), np.sqrt(1 - u1)], 1).astype(np.float32)


def python_ns_per_pair(n):
    m = lobe.Material(WARD)
    rng = np.random.default_rng(0)
    wo, wi = cosine_directions(rng, n), cosine_directions(rng, n)
    m.eval(wo[:4096], wi[:4096])
    times = []
    for _ in range(5):
        t = time.perf_counter()
        m.eval(wo, wi)
        times.append(time.perf_counter() - t)
    return sorted(times)[2] / n * 1e9


def rust_ns_per_pair():
    p = subprocess.run(["cargo", "bench", "-p", "lobe-materials", "--bench", "bsdf", "--", "bsdf/ward/"],
                       cwd=ROOT, capture_output=True, text=True, check=True)
    row = re.search(r"^\| ward \| ([0-9.]+) \| ([0-9.]+) \| ([0-9.]+) \|", p.stdout, re.M)
    return {"eval": float(row.group(1)), "eval_pdf_many": float(row.group(3))}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=10**7)
    ap.add_argument("--no-cargo", action="store_true", help="only the Python figure")
    a = ap.parse_args()
    threads = os.environ.get("RAYON_NUM_THREADS", f"all ({os.cpu_count()})")
    py = python_ns_per_pair(a.pairs)
    print(f"Python lobe.Material.eval, {a.pairs} pairs, threads {threads}: {py:.1f} ns/pair")
    if not a.no_cargo:
        rs = rust_ns_per_pair()
        for k, v in rs.items():
            print(f"Rust criterion bsdf/ward/{k} (1 thread): {v:.1f} ns/pair; Python / Rust = {py / v:.2f}")


if __name__ == "__main__":
    main()
